"""The ``Blink`` state: registered by its decorator when the ``fsm.states`` entry point imports this module.

Its parameters are a named model, and ``State[BlinkParams]`` types ``self.params``: mypy --strict checks
``self.params.period`` as a float and reports a misspelt parameter."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, State, StateParams, register_state


class BlinkParams(StateParams):
    """The parameters of ``Blink``."""

    var: str = Field("led", description="Blackboard variable to toggle.")
    period: float = Field(0.5, gt=0, description="Seconds between toggles.")


@register_state
class Blink(State[BlinkParams]):
    """Toggles blackboard variable `var` every `period` seconds and counts the toggles in `var`_count."""

    #: machine time of the next toggle
    next_toggle: float

    def on_enter(self, ctx: Context) -> None:
        self.next_toggle = ctx.now + self.params.period
        ctx.vars[f"{self.params.var}_count"] = 0

    def tick(self, ctx: Context) -> None:
        if ctx.now >= self.next_toggle - 1e-9:
            ctx.vars[self.params.var] = not ctx.vars.get(self.params.var, False)
            ctx.vars[f"{self.params.var}_count"] += 1
            self.next_toggle += self.params.period
