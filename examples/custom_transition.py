"""A custom transition type: a battery-low threshold with hysteresis, written the way a control developer would.

``BatteryLow`` fires when the blackboard variable ``battery`` (volts) has stayed below ``below`` for
``samples`` ticks in a row; it arms only after the level was seen above ``below + hysteresis`` since its
source was entered, so a battery that hovers around the threshold does not make the machine flap between
states. Its ``action`` records when it fired. Run it: ``python examples/custom_transition.py``.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

import fsm
from fsm import Transition, TransitionParams, register_transition


class BatteryLowParams(TransitionParams):
    """The parameters of ``BatteryLow``: a named model, so that ``Transition[BatteryLowParams]`` types them."""

    var: str = Field("battery", description="Blackboard variable holding the battery voltage.")
    below: float = Field(gt=0, description="Voltage under which the battery counts as low.")
    hysteresis: float = Field(0.2, ge=0, description="How far above `below` the level must have been to arm.")
    samples: int = Field(3, ge=1, description="Ticks in a row the level must stay low.")


@register_transition
class BatteryLow(Transition[BatteryLowParams]):
    """Fires when `var` stays below `below` for `samples` ticks, after it was seen above `below + hysteresis`."""

    Params = BatteryLowParams

    # Per-instance state: one transition object exists per document element.
    armed: bool
    low_ticks: int

    def on_source_enter(self, ctx: fsm.Context) -> None:
        """Each time the source is entered, start over: not armed, no low samples yet."""
        self.armed = False
        self.low_ticks = 0

    def holds(self, ctx: fsm.Context) -> bool:
        level = float(ctx.vars.get(self.params.var, 0.0))
        if level >= self.params.below + self.params.hysteresis:
            self.armed = True
        if not self.armed or level >= self.params.below:
            self.low_ticks = 0
            return False
        self.low_ticks += 1
        return self.low_ticks >= self.params.samples

    def action(self, ctx: fsm.Context) -> None:
        """Runs while firing (after the source's exit, before the target's entry)."""
        ctx.vars["low_at"] = round(ctx.now, 4)


MACHINE: dict[str, Any] = {
    "name": "battery_watch",
    "initial": "work",
    "vars": {"battery": 12.6, "low_at": -1.0},
    "states": [
        {"id": "work", "type": "Idle"},
        {"id": "dock", "type": "Final", "outcome": "docked"},
    ],
    "transitions": [
        {"type": "BatteryLow", "from": "work", "to": "dock", "below": 11.0, "hysteresis": 0.3, "samples": 4},
    ],
}


class Battery(fsm.Listener):
    """Plays the plant: the voltage sinks 0.05 V per tick with a ripple of +-0.15 V around the threshold."""

    def on_tick(self, machine: fsm.Machine) -> None:
        tick = machine.ctx.tick
        machine.ctx.vars["battery"] = round(12.6 - 0.05 * tick + (0.15 if tick % 2 else -0.15), 4)


def main() -> None:
    machine = fsm.load(MACHINE)
    machine.add_listener(Battery())
    outcome = fsm.run(machine, duration=5.0).outcome
    ctx = machine.ctx
    print(f"outcome: {outcome}")
    print(f"docked at t={ctx.vars['low_at']:.4f} s (tick {ctx.tick}), battery {ctx.vars['battery']:.2f} V")


if __name__ == "__main__":
    main()
