"""Generic transitions: ``Always``, ``Finished`` (optionally on one outcome) and ``Timeout`` (time in the source)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import Field

from fsm.params import TransitionParams
from fsm.registry import register_transition
from fsm.transition import Transition

if TYPE_CHECKING:
    from fsm.context import Context


@register_transition
class Always(Transition):
    """Fires at the first check: after one tick of the source (or before it, with preempt)."""

    __slots__ = ()
    unconditional = True

    def check(self, ctx: Context) -> bool:
        return True


@register_transition
class Finished(Transition):
    """Fires when the source has finished; with `outcome`, only when it finished with that outcome."""

    __slots__ = ("outcome",)
    needs_finishing_source = True

    class Params(TransitionParams):
        outcome: str | None = Field(default=None, min_length=1,
                                    description="Only this outcome (succeeded, aborted, ...); any if omitted.")

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self.outcome = params.outcome  # type: ignore[attr-defined]

    def check(self, ctx: Context) -> bool:
        source = self.source
        return source.finished and (self.outcome is None or source.outcome == self.outcome)


@register_transition
class Timeout(Transition):
    """Fires when the source has been active for `seconds` (machine time, paused time excluded)."""

    __slots__ = ("seconds",)

    class Params(TransitionParams):
        seconds: float = Field(gt=0, description="Time in the source state, in seconds.")

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        # Half a nanosecond of slack: 80 ticks of 0.0125 s are 1 s, however the floats round.
        self.seconds = params.seconds - 5e-10  # type: ignore[attr-defined]

    def check(self, ctx: Context) -> bool:
        return ctx._now - self.source.entered_at >= self.seconds
