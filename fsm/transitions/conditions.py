"""The built-in conditions (signal levels and edges with debounce, expressions, time, state, all/any/not) and
the ``Condition`` transition that fires when one holds."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Literal, TypeVar, cast

from pydantic import Field

from fsm.loading.registry import register_condition, register_transition
from fsm.model.params import ConditionField, ConditionParams, TransitionParams
from fsm.runtime.condition import Condition
from fsm.runtime.debounce import Debounced
from fsm.runtime.region import wiring
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.model.expr import Compiled
    from fsm.runtime.context import Context, MachineView, StateView
    from fsm.runtime.state import State

#: Half a nanosecond of slack for times computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10

# The checks made every tick (holds) read the machine's time slot ctx._now, not the property ctx.now: a property
# costs a call per condition and tick (docs/architecture.md, "Layering": the documented exceptions).


class SignalParams(ConditionParams):
    signal: str = Field(min_length=1, description="Name of the input signal (a button, a switch).")
    debounce: float = Field(default=0.0, ge=0, description="Seconds the level must be stable before a change "
                                                           "counts (0: no debouncing).")


SP = TypeVar("SP", bound=SignalParams)


class _SignalCondition(Condition[SP]):
    __slots__ = ("signal", "debounce", "filter")
    signal_refs = ("signal",)

    def __init__(self, params: SP, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        self.signal: str = params.signal
        self.debounce: float = params.debounce
        self.filter: Debounced | None = None

    def bind(self, machine: MachineView, owner: State[Any]) -> None:
        super().bind(machine, owner)
        if self.debounce > 0:
            self.filter = Debounced(machine.ctx.signal_history(self.signal), self.debounce)


@register_condition
class SignalHigh(_SignalCondition[SignalParams]):
    """Holds while the signal is high (debounced: once it has been high for `debounce` seconds)."""

    __slots__ = ()
    Params = SignalParams

    def holds(self, ctx: Context) -> bool:
        if self.filter is None:
            return ctx.signal(self.signal)
        return self.filter.advance(ctx._now)


@register_condition
class SignalLow(_SignalCondition[SignalParams]):
    """Holds while the signal is low (debounced: once it has been low for `debounce` seconds)."""

    __slots__ = ()
    Params = SignalParams

    def holds(self, ctx: Context) -> bool:
        if self.filter is None:
            return not ctx.signal(self.signal)
        return not self.filter.advance(ctx._now)


class SignalEdgeParams(SignalParams):
    edge: Literal["rising", "falling"] = Field(default="rising", description="Which change counts.")


@register_condition
class SignalEdge(_SignalCondition[SignalEdgeParams]):
    """Holds in the one tick after the signal's (debounced) level changed as `edge` says; each change counts
    once, however the signal bounced."""

    __slots__ = ("rising", "seen")
    Params = SignalEdgeParams

    def __init__(self, params: SignalEdgeParams, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        self.rising = params.edge == "rising"
        self.seen = -1.0  # debounced edges up to this time are consumed

    def reset(self, ctx: Context) -> None:
        if self.filter is not None:
            self.filter.advance(ctx.now)
        self.seen = ctx.now

    def holds(self, ctx: Context) -> bool:
        f = self.filter
        if f is None:
            return ctx.rising(self.signal) if self.rising else ctx.falling(self.signal)
        level = f.advance(ctx._now)
        at = f.edge_at
        if at is None or at <= self.seen + _EPS:
            return False
        self.seen = at  # this change is consumed: it counts once
        return level == self.rising


class ExprParams(ConditionParams):
    expr: str = Field(min_length=1, description="An expression over blackboard variables giving true/false.")


@register_condition
class Expr(Condition[ExprParams]):
    """Holds while the expression over blackboard variables is true (`x > 3 and not busy`)."""

    __slots__ = ("fn",)
    Params = ExprParams
    expr_fields = ("expr",)

    def __init__(self, params: ExprParams, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        # the loader compiled `expr` as a true/false expression, so its closure gives a bool
        self.fn = cast(Callable[[dict[str, Any]], bool], self.exprs["expr"].fn)

    def holds(self, ctx: Context) -> bool:
        return self.fn(ctx.vars)


class TimeSinceParams(ConditionParams):
    seconds: float = Field(gt=0, description="Seconds that must have passed.")
    signal: str | None = Field(default=None, min_length=1,
                               description="Since this signal last rose (machine time); without it, time in the "
                                           "owner state (paused time excluded).")


@register_condition
class TimeSince(Condition[TimeSinceParams]):
    """Holds once `seconds` have passed in the owner state (paused time excluded), or since `signal` last
    rose (false while it never has)."""

    __slots__ = ("seconds", "signal", "history")
    Params = TimeSinceParams
    signal_refs = ("signal",)

    def __init__(self, params: TimeSinceParams, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        self.seconds = params.seconds - _EPS
        self.signal = params.signal
        self.history: list[tuple[float, bool]] | None = None

    def bind(self, machine: MachineView, owner: State[Any]) -> None:
        super().bind(machine, owner)
        if self.signal is not None:
            self.history = machine.ctx.signal_history(self.signal)

    def holds(self, ctx: Context) -> bool:
        h = self.history
        if h is None:
            owner = self.owner
            assert owner is not None
            return owner.time_in_state(ctx) >= self.seconds
        for at, level in reversed(h):
            if level:
                return ctx._now - at >= self.seconds
        return False


class InStateParams(ConditionParams):
    state: str = Field(min_length=1, description="Path of the state, relative to the owner's machine or an "
                                                 "enclosing one ('other/wait'), or absolute ('/a/b').")


IP = TypeVar("IP", bound=InStateParams)


@register_condition(name="InState")
class InStateCondition(Condition[IP]):
    """Holds while the state at path `state` is active."""

    __slots__ = ("other",)
    Params: ClassVar[type[InStateParams]] = InStateParams
    state_refs = ("state",)

    def bind(self, machine: MachineView, owner: State[Any]) -> None:
        super().bind(machine, owner)
        region = wiring(owner).region
        scope = region.path if region is not None else ""
        self.other: StateView = machine.resolve(self.params.state, scope)

    def holds(self, ctx: Context) -> bool:
        return self.other.active


class OutcomeParams(InStateParams):
    outcome: str = Field(min_length=1, description="The outcome (succeeded, aborted, timeout, precondition_failed, "
                                                   "or a Final state's).")


@register_condition(name="Outcome")
class OutcomeCondition(InStateCondition[OutcomeParams]):
    """Holds when the state at path `state` last finished with `outcome` (a sequence's step that was aborted,
    timed out or skipped stays readable until it is entered again)."""

    __slots__ = ("outcome",)
    Params = OutcomeParams

    def bind(self, machine: MachineView, owner: State[Any]) -> None:
        super().bind(machine, owner)
        self.outcome = self.params.outcome

    def holds(self, ctx: Context) -> bool:
        other = self.other
        return other.finished and other.outcome == self.outcome


class ManyParams(ConditionParams):
    conditions: list[ConditionField] = Field(min_length=1, description="The conditions (each a condition object).")


@register_condition(name="All")
class AllOf(Condition[ManyParams]):
    """Holds when every one of `conditions` holds (each is asked every time, so all keep their state)."""

    __slots__ = ()
    Params = ManyParams
    condition_fields = ("conditions",)

    def holds(self, ctx: Context) -> bool:
        result = True
        for c in self.children:
            if not c.holds(ctx):
                result = False
        return result


@register_condition(name="Any")
class AnyOf(Condition[ManyParams]):
    """Holds when at least one of `conditions` holds (each is asked every time, so all keep their state)."""

    __slots__ = ()
    Params = ManyParams
    condition_fields = ("conditions",)

    def holds(self, ctx: Context) -> bool:
        result = False
        for c in self.children:
            if c.holds(ctx):
                result = True
        return result


class NotParams(ConditionParams):
    condition: ConditionField = Field(description="The condition to negate (a condition object).")


@register_condition(name="Not")
class NotOf(Condition[NotParams]):
    """Holds when `condition` does not."""

    __slots__ = ()
    Params = NotParams
    condition_fields = ("condition",)

    def holds(self, ctx: Context) -> bool:
        return not self.children[0].holds(ctx)


class ConditionTransitionParams(TransitionParams):
    condition: ConditionField = Field(description="Fires while this condition holds (a condition object).")


@register_transition(name="Condition")
class ConditionTransition(Transition[ConditionTransitionParams]):
    """Fires when `condition` (a condition object: SignalEdge, Expr, TimeSince, All, ...) holds."""

    __slots__ = ()
    Params = ConditionTransitionParams
    condition_fields = ("condition",)

    def holds(self, ctx: Context) -> bool:
        return self.conditions["condition"].holds(ctx)
