"""The runtime side of the step-common keys (EEROS): monitors, the timeout monitor, the precondition and the
exception sequences they run, and what their behaviours do to a state (abort, restart, resume).

A state with monitors, a timeout or a precondition has a :class:`Supervisor`; ``Region.tick`` asks it first,
before the state's preemptive transitions and its tick, so monitors are checked outermost first, each tick,
while the owner or anything inside it is active. It answers with a :class:`~fsm.runtime.verdict.Verdict`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

from fsm.model.expr import ExprRuntimeError
from fsm.runtime.region import Region, StateWiring, wiring
from fsm.runtime.state import State
from fsm.runtime.verdict import Verdict

if TYPE_CHECKING:
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import Context

#: Slack for timeouts computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10


class Monitor:
    """One compiled monitor: its condition (``holds(ctx)``), behaviour and exception sequence."""

    __slots__ = ("holds", "behavior", "exception", "exception_id", "label", "kind", "conditions", "fired")

    def __init__(self, holds: Callable[[Context], bool], behavior: str, exception_id: str | None, label: str,
                 kind: str = "monitor", conditions: tuple[Condition[Any], ...] = ()) -> None:
        self.holds = holds
        self.behavior = behavior
        self.exception_id = exception_id
        #: the exception sequence's region (bound when the machine is built)
        self.exception: Region | None = None
        self.label = label
        #: "monitor" or "timeout"
        self.kind = kind
        #: condition objects to reset when the owner is entered
        self.conditions = conditions
        #: times this monitor fired
        self.fired = 0


def _seconds(value: Any) -> float:
    """A timeout read from an expression: a finite number of seconds > 0, else a run-time error of the state."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0 < value < float("inf")):
        raise ExprRuntimeError(f"the timeout's expression gave {value!r}; a timeout is a number of seconds > 0")
    return float(value)


class Restart:
    """What a listener sees as the transition when a monitor restarts a state (source and target are the state)."""

    __slots__ = ("source", "target", "type_name", "monitor")

    def __init__(self, state: State[Any], monitor: Monitor | None) -> None:
        self.source = state
        self.target = state
        self.type_name = "restart"
        self.monitor = monitor

    def describe(self) -> str:
        return f"restart {self.source.id}" + (f" ({self.monitor.label})" if self.monitor else "")


class MonitorListeners(Protocol):
    """What a supervisor needs of its machine: to tell the listeners that a monitor fired, and to thaw its owner
    after an exception sequence (a :class:`fsm.runtime.machine.Machine`, above this module, is one)."""

    @property
    def listeners(self) -> Sequence[object]:
        """The attached listeners (empty: nobody to tell)."""
        ...

    def notify_monitor(self, owner: State[Any], monitor: Monitor) -> None:
        """Tell the listeners that a monitor (or a timeout) of ``owner`` fired."""
        ...

    def thaw(self, state: State[Any], now: float) -> None:
        """Unfreeze ``state`` and its subtree after a suspension."""
        ...


class Running(NamedTuple):
    """An exception sequence running for its owner: the monitor that started it and the sequence's region."""

    monitor: Monitor
    region: Region


class Supervisor:
    """Monitors, timeout and precondition of one state (its *owner*)."""

    __slots__ = ("owner", "monitors", "precondition", "pre_conditions", "timeout", "timeout_at_entry", "reset_at",
                 "running", "machine", "halted")

    def __init__(self, owner: State[Any], monitors: list[Monitor],
                 precondition: Callable[[Context], bool] | None = None,
                 pre_conditions: tuple[Condition[Any], ...] = (),
                 timeout: float | Callable[[Context], Any] | None = None) -> None:
        self.owner = owner
        self.monitors = tuple(monitors)
        self.precondition = precondition
        self.pre_conditions = pre_conditions
        #: the timeout in seconds (read at each entry when it comes from an expression)
        self.timeout: float | None = None
        #: the timeout's expression (``"t_grip"``), read at each entry, or None for a fixed number
        self.timeout_at_entry: Callable[[Context], Any] | None = None
        if callable(timeout):
            self.timeout_at_entry = timeout
        else:
            self.timeout = timeout
        #: the owner's time in state at which its timeout clock was last (re)started
        self.reset_at = 0.0
        #: the exception sequence running for this owner, if any
        self.running: Running | None = None
        #: whom to tell when a monitor fires (the machine, bound when it is built)
        self.machine: MonitorListeners | None = None
        self.halted = False

    @property
    def level(self) -> Region | None:
        """The exception sequence's level running for the owner, or None."""
        running = self.running
        return None if running is None else running.region

    # -- entry -------------------------------------------------------------------------------------
    def arm(self, ctx: Context) -> bool:
        """Called on each entry of the owner: fresh timeout, conditions reset. Returns False when the
        precondition is false (the owner is then skipped: finished with ``precondition_failed``)."""
        self.halted = False
        self.running = None
        self.reset_at = 0.0
        if self.timeout_at_entry is not None:
            self.timeout = _seconds(self.timeout_at_entry(ctx))
        for m in self.monitors:
            for c in m.conditions:
                c.reset(ctx)
        if self.precondition is not None:
            for c in self.pre_conditions:
                c.reset(ctx)
            if not self.precondition(ctx):
                self.halted = True
                return False
        return True

    def elapsed(self, ctx: Context) -> float:
        """Seconds counted by the timeout: time in state (paused and suspended time excluded) since the last reset."""
        return self.owner.time_in_state(ctx) - self.reset_at

    def timed_out(self, ctx: Context) -> bool:
        assert self.timeout is not None
        return self.owner.time_in_state(ctx) - self.reset_at >= self.timeout - _EPS

    def reset_timeout(self, ctx: Context) -> None:
        self.reset_at = self.owner.time_in_state(ctx)

    # -- each tick ---------------------------------------------------------------------------------
    def verdict(self, ctx: Context) -> Verdict:
        """Before the owner is ticked: run a running exception sequence, or ask the monitors in order."""
        if self.halted:
            return Verdict.HALTED
        running = self.running
        if running is not None:
            running.region.tick(ctx)
            if self.running is not running:
                return Verdict.CONSUMED  # the owner was left or restarted from inside (an outer behaviour)
            if running.region.active.finished:
                running.region.stop(ctx)
                self.running = None
                return self.apply(running.monitor, ctx)
            return Verdict.CONSUMED
        for m in self.monitors:
            if m.holds(ctx):
                exc = m.exception
                if exc is not None and exc.started:
                    continue  # its exception sequence is busy for another owner: checked again next tick
                m.fired += 1
                owner = self.owner
                machine = self.machine
                if machine is not None and machine.listeners:
                    machine.notify_monitor(owner, m)
                if exc is None:
                    return self.apply(m, ctx)
                suspend(owner, ctx)
                self.running = Running(m, exc)
                exc.start(ctx)
                return Verdict.CONSUMED
        return Verdict.PROCEED

    def apply(self, m: Monitor, ctx: Context) -> Verdict:
        """The monitor's behaviour, after its exception sequence (if any) has finished."""
        owner = self.owner
        behavior = m.behavior
        if behavior == "nothing":
            unsuspend(owner, ctx, self.machine)
            return Verdict.PROCEED if m.exception is None else Verdict.CONSUMED
        outcome = "timeout" if m.kind == "timeout" else "aborted"
        if behavior == "abortOwner":
            abort(owner, outcome, ctx)
            return Verdict.HALTED
        if behavior == "restartOwner":
            restart(owner, ctx, m)
            return Verdict.CONSUMED
        level = wiring(owner).region
        caller = level.owner if level is not None else None
        unsuspend(owner, ctx, self.machine)
        if caller is None:  # the checks refuse this; a hand-built machine gets the owner's own behaviour
            caller = owner
        if behavior == "abortCallerOfOwner":
            abort(caller, outcome, ctx)
        else:
            restart(caller, ctx, m)
        return Verdict.CONSUMED


# -- what behaviours do to a state ------------------------------------------------------------------------
def supervisor_of(state: State[Any] | StateWiring) -> Supervisor | None:
    """The supervisor of a state, or of the state of a record (which holds it as what the tick uses of it,
    :class:`fsm.runtime.region.Supervising`), or None."""
    supervisor = (state if isinstance(state, StateWiring) else wiring(state)).supervisor
    assert supervisor is None or isinstance(supervisor, Supervisor)
    return supervisor


def suspend(state: State[Any], ctx: Context) -> None:
    """Freeze ``state`` and its active subtree (not ticked, clocks stand still) while an exception sequence runs."""
    now = ctx.now
    top = wiring(state)
    todo = [top]
    while todo:
        s = todo.pop()
        if s.frozen_since is None:
            s.frozen_since = now
            sub = s.state
            if type(sub).on_pause is not State.on_pause:
                sub.on_pause(ctx)
        todo.extend(r.current for r in s.regions if r.started)
        w = s.supervisor
        running = w.level if w is not None and s is not top else None
        if running is not None:
            todo.append(running.current)  # an exception sequence running further down stands still too


def unsuspend(state: State[Any], ctx: Context, machine: MonitorListeners | None) -> None:
    """Undo :func:`suspend` (states held by a pause stay frozen until resumed); ``machine`` thaws it (the
    supervisor's, bound when the machine is built)."""
    record = wiring(state)
    if record.frozen_since is None:
        return
    s: StateWiring | None = record
    while s is not None:  # an ancestor's pause keeps the subtree frozen: Machine.resume thaws it later
        if s.paused:
            return
        level = s.region
        s = wiring(level.owner) if level is not None and level.owner is not None else None
    assert machine is not None, "a supervisor is bound to its machine when the machine is built"
    machine.thaw(state, ctx.now)


def abort(state: State[Any], outcome: str, ctx: Context) -> None:
    """End ``state`` where it is: everything inside it is left (innermost first), it is finished with
    ``outcome`` and halted (no longer ticked) until its own level leaves it by a transition."""
    record = wiring(state)
    for region in reversed(record.regions):
        region.stop(ctx)
    w = supervisor_of(record)
    if w is not None:
        if w.running is not None:
            w.running.region.stop(ctx)
            w.running = None
        w.halted = True
    state.finished = True
    state.outcome = outcome
    stopped = getattr(state, "on_abort", None)
    if stopped is not None:
        stopped(ctx)


def restart(state: State[Any], ctx: Context, monitor: Monitor | None = None) -> None:
    """Leave ``state`` (its subtree first) and enter it again from its start, with a fresh timeout."""
    record = wiring(state)
    w = supervisor_of(record)
    if w is not None and w.running is not None:
        w.running.region.stop(ctx)
        w.running = None
    if record.exit_hook is not None:
        record.leave(ctx)
    else:
        for sub in reversed(record.regions):
            sub.stop(ctx)
        record.frozen_since = None
        record.paused = False
    record.entered_at = ctx.now
    region = record.region
    if region is not None and region.listeners:
        marker = Restart(state, monitor)
        for listener in region.listeners:
            listener.on_transition(ctx, state, state, marker)
    if record.enter_hook is not None:
        record.enter_hook(ctx)
    else:
        state.finished = False
        state.outcome = None
