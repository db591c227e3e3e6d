"""The ``Blink`` state: registered by its decorator when the ``fsm.states`` entry point imports this module."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, State, StateParams, register_state


@register_state
class Blink(State):
    """Toggles blackboard variable `var` every `period` seconds and counts the toggles in `var`_count."""

    class Params(StateParams):
        var: str = Field("led", description="Blackboard variable to toggle.")
        period: float = Field(0.5, gt=0, description="Seconds between toggles.")

    def on_enter(self, ctx: Context) -> None:
        self.next = ctx.now + self.params.period
        ctx.vars[f"{self.params.var}_count"] = 0

    def tick(self, ctx: Context) -> None:
        if ctx.now >= self.next - 1e-9:
            ctx.vars[self.params.var] = not ctx.vars.get(self.params.var, False)
            ctx.vars[f"{self.params.var}_count"] += 1
            self.next += self.params.period
