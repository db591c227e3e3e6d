"""The ``Counted`` transition: the ``fsm.transitions`` entry point names this class, so the registry adds it
under the entry point's name without importing anything else of the package."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, Transition, TransitionParams


class Counted(Transition):
    """Fires when blackboard variable `var` has reached `count`."""

    class Params(TransitionParams):
        var: str = Field(description="Blackboard variable holding a count.")
        count: int = Field(ge=1, description="The count that fires the transition.")

    def check(self, ctx: Context) -> bool:
        return ctx.vars.get(self.params.var, 0) >= self.params.count
