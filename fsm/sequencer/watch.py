"""The runtime side of the step-common keys (EEROS): monitors, the timeout monitor, the precondition and the
exception sequences they run, and what their behaviours do to a state (abort, restart, resume).

A state with monitors, a timeout or a precondition has a :class:`Watcher`; ``Region.step`` asks it first
(``state._watch``), before the state's preemptive transitions and its tick, so monitors are checked outermost
first, each tick, while the owner or anything inside it is active. The watcher answers

- ``None``: nothing to do, tick the state as usual;
- ``1``: this tick is used up (a monitor fired, an exception sequence ran a tick, the owner was restarted);
- ``0``: the owner is halted (aborted or skipped by its precondition): not ticked, but its transitions are
  checked (so a sequence goes on with its next step in the same tick).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fsm.state import State

if TYPE_CHECKING:
    from fsm.context import Context
    from fsm.region import Region

#: Slack for timeouts computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10


class Monitor:
    """One compiled monitor: its condition (``holds(ctx)``), behaviour and exception sequence."""

    __slots__ = ("holds", "behavior", "exception", "exception_id", "label", "kind", "conditions", "fired")

    def __init__(self, holds: Any, behavior: str, exception_id: str | None, label: str, kind: str = "monitor",
                 conditions: tuple[Any, ...] = ()) -> None:
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


class Restart:
    """What a listener sees as the transition when a monitor restarts a state (source and target are the state)."""

    __slots__ = ("source", "target", "type_name", "monitor")

    def __init__(self, state: State, monitor: Monitor | None) -> None:
        self.source = state
        self.target = state
        self.type_name = "restart"
        self.monitor = monitor

    def describe(self) -> str:
        return f"restart {self.source.id}" + (f" ({self.monitor.label})" if self.monitor else "")


class Watcher:
    """Monitors, timeout and precondition of one state."""

    __slots__ = ("owner", "monitors", "precondition", "pre_conditions", "timeout", "reset_at", "running",
                 "machine", "halted")

    def __init__(self, owner: State, monitors: list[Monitor], precondition: Any = None,
                 pre_conditions: tuple[Any, ...] = (), timeout: float | None = None) -> None:
        self.owner = owner
        self.monitors = tuple(monitors)
        self.precondition = precondition
        self.pre_conditions = pre_conditions
        self.timeout = timeout
        #: the owner's time in state at which its timeout clock was last (re)started
        self.reset_at = 0.0
        #: (monitor, exception region) while an exception sequence runs for this owner
        self.running: tuple[Monitor, Region] | None = None
        self.machine: Any = None
        self.halted = False

    # -- entry -------------------------------------------------------------------------------------
    def arm(self, ctx: Context) -> bool:
        """Called on each entry of the owner: fresh timeout, conditions reset. Returns False when the
        precondition is false (the owner is then skipped: finished with ``precondition_failed``)."""
        self.halted = False
        self.running = None
        self.reset_at = 0.0
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
        return self.owner.time_in_state(ctx) - self.reset_at >= self.timeout - _EPS  # type: ignore[operator]

    def reset_timeout(self, ctx: Context) -> None:
        self.reset_at = self.owner.time_in_state(ctx)

    # -- each tick ---------------------------------------------------------------------------------
    def check(self, ctx: Context) -> int | None:
        if self.halted:
            return 0
        running = self.running
        if running is not None:
            monitor, region = running
            region.step(ctx)
            if self.running is not running:
                return 1  # the owner was left or restarted from inside (an outer behaviour)
            exc = region.active
            if exc.finished:
                region.stop(ctx)
                self.running = None
                return self.apply(monitor, ctx)
            return 1
        for m in self.monitors:
            if m.holds(ctx):
                exc = m.exception
                if exc is not None and exc.started:
                    continue  # its exception sequence is busy for another owner: checked again next tick
                m.fired += 1
                owner = self.owner
                machine = self.machine
                if machine.listeners:
                    machine._notify_monitor(owner, m)
                if exc is None:
                    return self.apply(m, ctx)
                suspend(owner, ctx)
                self.running = (m, exc)
                exc.start(ctx)
                return 1
        return None

    def apply(self, m: Monitor, ctx: Context) -> int | None:
        """The monitor's behaviour, after its exception sequence (if any) has finished."""
        owner = self.owner
        behavior = m.behavior
        if behavior == "nothing":
            unsuspend(owner, ctx)
            return None if m.exception is None else 1
        outcome = "timeout" if m.kind == "timeout" else "aborted"
        if behavior == "abortOwner":
            abort(owner, outcome, ctx)
            return 0
        if behavior == "restartOwner":
            restart(owner, ctx, m)
            return 1
        caller = owner.region.owner if owner.region is not None else None
        unsuspend(owner, ctx)
        if caller is None:  # the loader refuses this; a hand-built machine gets the owner's own behaviour
            caller = owner
        if behavior == "abortCallerOfOwner":
            abort(caller, outcome, ctx)
        else:
            restart(caller, ctx, m)
        return 1


# -- what behaviours do to a state ------------------------------------------------------------------------
def suspend(state: State, ctx: Context) -> None:
    """Freeze ``state`` and its active subtree (not ticked, clocks stand still) while an exception sequence runs."""
    now = ctx._now
    todo = [state]
    while todo:
        s = todo.pop()
        if s.frozen_since is None:
            s.frozen_since = now
            s._prepare()
            if type(s).on_pause is not State.on_pause:
                s.on_pause(ctx)
        todo.extend(r.active for r in s.regions if r.started)
        w = s._watcher
        if s is not state and w is not None and w.running is not None:
            todo.append(w.running[1].active)  # an exception sequence running further down stands still too


def unsuspend(state: State, ctx: Context) -> None:
    """Undo :func:`suspend` (states held by a pause stay frozen until resumed)."""
    if state.frozen_since is None:
        return
    s: Any = state
    while s is not None:  # an ancestor's pause keeps the subtree frozen: Machine.resume thaws it later
        if s.paused:
            return
        s = s.region.owner if s.region is not None else None
    ctx.machine._thaw(state, ctx._now)  # type: ignore[union-attr]


def abort(state: State, outcome: str, ctx: Context) -> None:
    """End ``state`` where it is: everything inside it is left (innermost first), it is finished with
    ``outcome`` and halted (no longer ticked) until its own level leaves it by a transition."""
    for region in reversed(state.regions):
        region.stop(ctx)
    w = state._watcher
    if w is not None:
        if w.running is not None:
            w.running[1].stop(ctx)
            w.running = None
        w.halted = True
    state.finished = True
    state.outcome = outcome
    stopped = getattr(state, "on_abort", None)
    if stopped is not None:
        stopped(ctx)


def restart(state: State, ctx: Context, monitor: Monitor | None = None) -> None:
    """Leave ``state`` (its subtree first) and enter it again from its start, with a fresh timeout."""
    w = state._watcher
    if w is not None and w.running is not None:
        w.running[1].stop(ctx)
        w.running = None
    if state._exit is not None:
        state._exit(ctx)
    else:
        for region in reversed(state.regions):
            region.stop(ctx)
    state.entered_at = ctx._now
    region = state.region
    if region is not None and region.listeners:
        marker = Restart(state, monitor)
        for listener in region.listeners:
            listener.on_transition(ctx, state, state, marker)
    if state._enter is not None:
        state._enter(ctx)
    else:
        state.finished = False
        state.outcome = None
