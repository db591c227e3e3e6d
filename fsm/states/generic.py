"""Generic leaf states: ``Idle`` (does nothing, never finishes) and ``Final`` (ends its machine with an outcome)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from fsm.loading.registry import register_state
from fsm.model.params import StateParams
from fsm.runtime.state import State

if TYPE_CHECKING:
    from fsm.runtime.context import Context


@register_state
class Idle(State[StateParams]):
    """Does nothing and never finishes; leave it by a Timeout, Signal, Var or InState transition."""

    __slots__ = ()


class FinalParams(StateParams):
    outcome: str = Field(default="succeeded", min_length=1,
                         description="Outcome the machine finishes with (succeeded, aborted, ...).")


@register_state
class Final(State[FinalParams]):
    """Ends its machine level; the enclosing composite (or the machine) finishes with this outcome."""

    __slots__ = ()
    can_finish = True
    is_final = True
    Params = FinalParams

    @classmethod
    def possible_outcomes(cls, params: FinalParams) -> set[str]:
        return {params.outcome}

    def on_enter(self, ctx: Context) -> None:
        self.finish(self.params.outcome)
