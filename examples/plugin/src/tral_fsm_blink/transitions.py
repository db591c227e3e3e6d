"""The ``Counted`` transition: the ``fsm.transitions`` entry point names this class, so the registry adds it
under the entry point's name without importing anything else of the package."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, Transition, TransitionParams


class CountedParams(TransitionParams):
    """The parameters of ``Counted``."""

    var: str = Field(description="Blackboard variable holding a count.")
    count: int = Field(ge=1, description="The count that fires the transition.")


class Counted(Transition[CountedParams]):
    """Fires when blackboard variable `var` has reached `count`."""

    def holds(self, ctx: Context) -> bool:
        count: int = ctx.vars.get(self.params.var, 0)  # the blackboard holds any value: this one is a count
        return count >= self.params.count
