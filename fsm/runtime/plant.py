"""Plant: a small simulated machine part behind a machine (an axis with limit switches, a gripper, a
conveyor, a bouncing button) for scenario tests and runs without the car.

A plant is stepped after every tick of the machine, the first time after tick 1 (starting the machine is no
tick; :meth:`Plant.reset` sets what tick 1 sees): it reads what the machine commanded (blackboard
variables, or calls its steps made on it through ``ctx.plant(name)``), advances its model by the tick's
``dt``, and writes what its sensors see as input signals (``ctx.set_signal``: the machine sees them from
the next tick on, as a real input read once per cycle) or variables. Register a plant type with
:func:`fsm.register_plant` (or the entry-point group ``fsm.plants``); a scenario attaches plants with
``"plants": [{"name": "axis", "type": "Axis", ...}]``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

from pydantic import Field

from fsm.model.params import ID_PATTERN, ParamsBase
from fsm.runtime.machine import Listener

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Machine


class PlantParams(ParamsBase):
    """Fields every plant element has; a plant type's own ``Params`` subclasses this."""

    type: str = Field(description="Registered plant type.")
    name: str = Field(min_length=1, pattern=ID_PATTERN, description="The plant's name: states reach it with "
                                                                    "ctx.plant(name).")
    description: str | None = Field(default=None, description="Free text for people.")


class Plant(Listener):
    """Subclass it, declare ``Params`` (a :class:`PlantParams`), override ``reset`` and ``step``, register it."""

    Params: ClassVar[type[PlantParams]] = PlantParams
    #: Input signals the plant writes (``fsmctl test`` then knows who drives them).
    signal_refs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, params: PlantParams) -> None:
        self.params = params
        self.name = params.name
        self.machine: Machine | None = None

    def attach(self, machine: Machine) -> None:
        """Put the plant behind ``machine`` (before it starts): reachable as ``ctx.plant(name)``, stepped each tick."""
        self.machine = machine
        machine.ctx.plants[self.name] = self
        machine.add_listener(self)
        self.reset(machine.ctx)

    @property
    def type_name(self) -> str:
        """The registered type name this plant was built as (its element's ``type``)."""
        return self.params.type

    def signals(self) -> set[str]:
        """The input signals this plant writes (from the parameters named in ``signal_refs``)."""
        return {v for k in self.signal_refs if isinstance(v := getattr(self.params, k, None), str)}

    def reset(self, ctx: Context) -> None:
        """Called once when attached, before the first tick: set the initial sensor signals here."""

    def step(self, ctx: Context, dt: float) -> None:
        """Advance the model by ``dt`` seconds after a tick of the machine."""

    def on_tick(self, machine: Machine) -> None:
        ctx = machine.ctx
        self.step(ctx, ctx.dt)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}>"


__all__ = ["Plant", "PlantParams"]
