"""Plants and step types for the eight test cases of the EEROS sequencer thesis (section 3.4).

A control developer adds two kinds of things here, both registered like any type:

- **plant models** (``fsm.Plant``): simulated machine parts stepped after every tick. They read what the steps
  commanded, move, and write what their sensors see as input signals (limit switches) or variables (positions,
  counts). An ``Axis`` with two limit switches, a ``Gripper`` that moves between named places and holds parts,
  a ``Conveyor`` that supplies or takes away parts.
- **step types** (``fsm.State``): ``MoveAxis``, ``MoveGripper``, ``Grip``, ``Release``. A step commands its plant
  on entry, finishes when the plant says it is done (``can_finish``), stops it when paused or left.

Use it from a scenario (``"plugins": ["../../examples/eeros/eeros_plant.py"]``) or with ``--plugin``.
The models are simple but strict: an axis driven into its end stop counts a crash, a gripper that opens with
nothing below to take the part drops it, so a wrong sequence fails its scenario.

Every type names its parameter model (``AxisParams``, ``MoveAxisParams``, ...): ``State[MoveAxisParams]`` types
``self.params`` of a step, and a plant declares ``params: AxisParams``, so mypy --strict checks every parameter
read here.
"""

from __future__ import annotations

from typing import Literal, TypeVar

from pydantic import Field

from fsm import Context, Plant, PlantParams, State, StateParams, register_plant, register_state

_EPS = 1e-9


# -- the axis of test cases 1, 4 and 5 ---------------------------------------------------------------------
class AxisParams(PlantParams):
    length: float = Field(default=1.0, gt=0, description="Travel in metres.")
    speed: float = Field(default=0.25, gt=0, description="Speed in m/s.")
    start: float = Field(default=0.5, ge=0, description="Start position in metres.")
    left_switch: str = Field(default="limit_left", min_length=1, description="Signal of the left limit switch.")
    right_switch: str = Field(default="limit_right", min_length=1, description="Signal of the right one.")


@register_plant
class Axis(Plant):
    """A linear axis from 0 to `length` m with a limit switch at each end; moves at `speed` m/s while commanded.
    Writes its position to the variable `<name>_x` and counts `<name>_crashes` (driving on against an end)."""

    signal_refs = ("left_switch", "right_switch")
    Params = AxisParams
    params: AxisParams  # what the registry builds it with (a plant is not generic over its parameters)

    def reset(self, ctx: Context) -> None:
        p = self.params
        self.x = min(p.start, p.length)
        self.direction = 0
        self.crashes = 0
        self.at_end = False
        self._publish(ctx)

    def command(self, direction: int) -> None:
        """-1 left, +1 right, 0 stop."""
        self.direction = direction

    def step(self, ctx: Context, dt: float) -> None:
        p = self.params
        if self.direction:
            x = self.x + self.direction * p.speed * dt
            end = x <= 0 or x >= p.length
            if end and self.at_end:
                self.crashes += 1  # still driving against the end stop a tick after the switch closed
            self.x = min(max(x, 0.0), p.length)
        self._publish(ctx)

    def _publish(self, ctx: Context) -> None:
        p = self.params
        left, right = self.x <= _EPS, self.x >= p.length - _EPS
        self.at_end = left or right
        if ctx.signal(p.left_switch) != left:
            ctx.set_signal(p.left_switch, left)
        if ctx.signal(p.right_switch) != right:
            ctx.set_signal(p.right_switch, right)
        ctx.vars[f"{self.name}_x"] = round(self.x, 6)
        ctx.vars[f"{self.name}_crashes"] = self.crashes


class MoveAxisParams(StateParams):
    axis: str = Field(default="axis", min_length=1, description="Name of the Axis plant.")
    direction: Literal["left", "right"] = Field(description="Which way to drive.")


@register_state
class MoveAxis(State[MoveAxisParams]):
    """Drives an axis plant left or right; finishes when its limit switch on that side is closed. Stops the axis
    when left and while paused."""

    can_finish = True
    Params = MoveAxisParams

    def on_enter(self, ctx: Context) -> None:
        self._drive(ctx)

    def tick(self, ctx: Context) -> None:
        axis = self._axis(ctx)
        p = axis.params
        if ctx.signal(p.left_switch if self.params.direction == "left" else p.right_switch):
            axis.command(0)
            self.finish("succeeded")

    def on_exit(self, ctx: Context) -> None:
        self._axis(ctx).command(0)

    def on_pause(self, ctx: Context) -> None:
        self._axis(ctx).command(0)

    def on_resume(self, ctx: Context) -> None:
        if not self.finished:
            self._drive(ctx)

    def _drive(self, ctx: Context) -> None:
        self._axis(ctx).command(-1 if self.params.direction == "left" else 1)

    def _axis(self, ctx: Context) -> Axis:
        axis: Axis = ctx.plant(self.params.axis)  # the scenario attaches an Axis under this name
        return axis


# -- grippers and conveyors of test cases 3 and 8 --------------------------------------------------------------
class ConveyorParams(PlantParams):
    at: str = Field(min_length=1, description="The place where grippers meet this conveyor.")
    role: Literal["supply", "takeaway"] = Field(description="Brings parts, or carries them off.")
    period: float = Field(default=0.5, ge=0, description="Seconds until the next part is ready (supply).")


@register_plant
class Conveyor(Plant):
    """A conveyor end at place `at`: a `supply` conveyor has a new part ready `period` s after the last was taken
    (signal `<name>_ready`); a `takeaway` conveyor carries placed parts off and counts them in `<name>_parts`."""

    Params = ConveyorParams
    params: ConveyorParams

    def reset(self, ctx: Context) -> None:
        self.at = self.params.at
        self.part: int | None = 1 if self.params.role == "supply" else None
        self.next_part = 2
        self.wait = 0.0
        self.parts = 0
        self._publish(ctx)

    def take(self) -> int | None:
        part, self.part = self.part, None
        self.wait = self.params.period
        return part

    def put(self, part: int) -> None:
        self.parts += 1

    def step(self, ctx: Context, dt: float) -> None:
        if self.params.role == "supply" and self.part is None:
            self.wait -= dt
            if self.wait <= _EPS:
                self.part, self.next_part = self.next_part, self.next_part + 1
        self._publish(ctx)

    def _publish(self, ctx: Context) -> None:
        ready = self.part is not None
        name = f"{self.name}_ready"
        if ctx.signal(name) != ready:
            ctx.set_signal(name, ready)
        ctx.vars[f"{self.name}_parts"] = self.parts


class GripperParams(PlantParams):
    places: list[str] = Field(min_length=1, description="The places it can reach; it starts at the first.")
    travel: float = Field(default=0.5, gt=0, description="Seconds from one place to another.")
    close_time: float = Field(default=0.2, ge=0, description="Seconds to open or close.")


@register_plant
class Gripper(Plant):
    """A gripper that travels between named places (`travel` s each way) and opens and closes (`close_time` s).
    Closing over a part (on a supply conveyor, or held by another gripper at the same place) holds it; opening
    hands it to another gripper holding it too, or puts it on a takeaway conveyor; anything else drops it
    (counted in the variable `dropped`). Writes `<name>_at` (its place) and `<name>_holding` (true/false)."""

    Params = GripperParams
    params: GripperParams

    def reset(self, ctx: Context) -> None:
        self.at: str | None = self.params.places[0]
        self.target = self.at
        self.left = 0.0
        self.part: int | None = None
        self.moving_jaws = 0.0
        ctx.vars.setdefault("dropped", 0)
        self._publish(ctx)

    # commands from the steps
    def move(self, place: str) -> None:
        if place not in self.params.places:
            raise ValueError(f"gripper '{self.name}' cannot reach '{place}' (places: {', '.join(self.params.places)})")
        if place != self.at:
            self.target, self.at, self.left = place, None, self.params.travel

    def arrived(self) -> bool:
        return self.at == self.target and self.left <= _EPS

    def close(self, ctx: Context) -> None:
        self.moving_jaws = self.params.close_time
        if self.part is not None or self.at is None:
            return
        for other in ctx.plants.values():
            if other is self or getattr(other, "at", None) != self.at:
                continue
            if isinstance(other, Conveyor) and other.params.role == "supply" and other.part is not None:
                self.part = other.take()
                return
            if isinstance(other, Gripper) and other.part is not None:
                self.part = other.part  # both hold it until one opens
                return

    def open(self, ctx: Context) -> None:
        self.moving_jaws = self.params.close_time
        part, self.part = self.part, None
        if part is None:
            return
        for other in ctx.plants.values():
            if other is self or getattr(other, "at", None) != self.at:
                continue
            if isinstance(other, Gripper) and other.part == part:
                return  # handed over
            if isinstance(other, Conveyor) and other.params.role == "takeaway":
                other.put(part)
                return
        ctx.vars["dropped"] = ctx.vars.get("dropped", 0) + 1

    def jaws_done(self) -> bool:
        return self.moving_jaws <= _EPS

    def step(self, ctx: Context, dt: float) -> None:
        if self.at is None:
            self.left -= dt
            if self.left <= _EPS:
                self.at = self.target
        if self.moving_jaws > 0:
            self.moving_jaws -= dt
        self._publish(ctx)

    def _publish(self, ctx: Context) -> None:
        ctx.vars[f"{self.name}_at"] = self.at or "moving"
        ctx.vars[f"{self.name}_holding"] = self.part is not None


class GripperStepParams(StateParams):
    gripper: str = Field(min_length=1, description="Name of the Gripper plant.")


#: The parameters of a gripper step: a gripper's name, and what the step adds.
GP = TypeVar("GP", bound=GripperStepParams)


class _GripperStep(State[GP]):
    """A step that commands a gripper (generic, so that each step keeps its own parameters typed)."""

    can_finish = True

    def gripper(self, ctx: Context) -> Gripper:
        gripper: Gripper = ctx.plant(self.params.gripper)  # the scenario attaches a Gripper under this name
        return gripper


class MoveGripperParams(GripperStepParams):
    to: str = Field(min_length=1, description="The place to go to.")


@register_state
class MoveGripper(_GripperStep[MoveGripperParams]):
    """Moves a gripper to a place; finishes on arrival."""

    Params = MoveGripperParams

    def on_enter(self, ctx: Context) -> None:
        self.gripper(ctx).move(self.params.to)

    def tick(self, ctx: Context) -> None:
        if self.gripper(ctx).arrived():
            self.finish("succeeded")


@register_state
class Grip(_GripperStep[GripperStepParams]):
    """Closes a gripper; finishes when the jaws are closed (outcome "empty" when there was nothing to hold)."""

    outcomes = ("succeeded", "empty")
    Params = GripperStepParams

    def on_enter(self, ctx: Context) -> None:
        self.gripper(ctx).close(ctx)

    def tick(self, ctx: Context) -> None:
        g = self.gripper(ctx)
        if g.jaws_done():
            self.finish("succeeded" if g.part is not None else "empty")


@register_state
class Release(_GripperStep[GripperStepParams]):
    """Opens a gripper; finishes when the jaws are open."""

    Params = GripperStepParams

    def on_enter(self, ctx: Context) -> None:
        self.gripper(ctx).open(ctx)

    def tick(self, ctx: Context) -> None:
        if self.gripper(ctx).jaws_done():
            self.finish("succeeded")
