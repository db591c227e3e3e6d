"""Generic transitions: ``Always``, ``Finished`` (optionally on one outcome) and ``Timeout`` (time in the source)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import Field

from fsm.loading.registry import register_transition
from fsm.model.params import TransitionParams
from fsm.runtime.region import wiring
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.state import State


@register_transition
class Always(Transition[TransitionParams]):
    """Fires at the first check: after one tick of the source (or before it, with preempt)."""

    __slots__ = ()
    unconditional = True

    def holds(self, ctx: Context) -> bool:
        return True


class FinishedParams(TransitionParams):
    outcome: str | None = Field(default=None, min_length=1,
                                description="Only this outcome (succeeded, aborted, ...); any if omitted.")


@register_transition
class Finished(Transition[FinishedParams]):
    """Fires when the source has finished; with `outcome`, only when it finished with that outcome."""

    __slots__ = ("outcome",)
    needs_finishing_source = True
    Params = FinishedParams

    def __init__(self, params: FinishedParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.outcome = params.outcome

    def holds(self, ctx: Context) -> bool:
        source = self.source
        return source.finished and (self.outcome is None or source.outcome == self.outcome)


class TimeoutParams(TransitionParams):
    seconds: float = Field(gt=0, description="Time in the source state, in seconds.")


@register_transition
class Timeout(Transition[TimeoutParams]):
    """Fires when the source has been active for `seconds` (machine time, paused time excluded)."""

    __slots__ = ("seconds", "clock")
    Params = TimeoutParams

    def __init__(self, params: TimeoutParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        # Half a nanosecond of slack: 80 ticks of 0.0125 s are 1 s, however the floats round.
        self.seconds = params.seconds - 5e-10
        #: the source's record, which holds its entry time (read each tick: bound once)
        self.clock = wiring(source)

    def holds(self, ctx: Context) -> bool:
        return ctx._now - self.clock.entered_at >= self.seconds  # the time slot: ctx.now costs a call per tick
