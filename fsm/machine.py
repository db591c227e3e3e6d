"""Machine: the root of a built state machine: its clock, context, tick loop, pause/resume and listeners."""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .clock import SimulatedClock
from .context import Context
from .errors import StateRuntimeError

if TYPE_CHECKING:
    from .region import Region
    from .state import State
    from .transition import Transition


class Listener:
    """Observer of a running machine. Override what you need; the machine calls nothing when none is attached."""

    def on_transition(self, ctx: Context, source: State | None, target: State, transition: Transition | None) -> None:
        """A state was entered; ``source`` and ``transition`` are ``None`` for an initial entry."""

    def on_tick(self, machine: Machine) -> None:
        """A tick has ended."""


class Machine:
    """A runnable machine built by :func:`fsm.load`. Tick it, or ``run`` it to completion.

    The clock is simulated by default (``dt`` = 0.0125 s, 80 Hz as on the TRAL car): tick ``n`` happens
    at ``n * dt``. The first ``tick`` (or ``run``) enters the initial states at time 0.
    """

    def __init__(
        self,
        root: Region,
        *,
        name: str = "",
        clock: Any = None,
        context: Context | None = None,
        all_regions: list[Region] | None = None,
        states_by_path: dict[str, State] | None = None,
    ) -> None:
        self.name = name
        self.root = root
        self.clock = clock if clock is not None else SimulatedClock()
        self.ctx = context if context is not None else Context()
        self.ctx.machine = self
        self.regions: list[Region] = all_regions if all_regions is not None else [root]
        self.states_by_path: dict[str, State] = states_by_path or {}
        self.listeners: list[Any] = []
        self.started = False
        self._sim = not getattr(self.clock, "realtime", False)
        self._dt = self.clock.dt
        self._schedule: list[tuple[float, int, str, bool]] = []
        self._schedule_seq = 0
        for region in self.regions:
            region.listeners = self.listeners

    # -- running --------------------------------------------------------------------------------
    def start(self) -> None:
        """Enter the initial states at the current time (done by the first ``tick`` if not called)."""
        if self.started:
            return
        self.started = True
        ctx = self.ctx
        ctx.now = self.clock.time_at(ctx.tick) if not self._sim else ctx.tick * self._dt
        self._apply_schedule(ctx.now)
        try:
            self.root.start(ctx)
        except StateRuntimeError:
            self._emergency_stop()
            raise

    def tick(self) -> None:
        """Advance the clock by one period and tick the active configuration once."""
        if not self.started:
            self.start()
        ctx = self.ctx
        n = ctx.tick = ctx.tick + 1
        now = n * self._dt if self._sim else self.clock.time_at(n)
        ctx.dt = now - ctx.now
        ctx.now = now
        if self._schedule:
            self._apply_schedule(now)
        if ctx._pending:
            ctx._tick_boundary()
        try:
            self.root.step(ctx)
        except StateRuntimeError:
            self._emergency_stop()
            raise
        if self.listeners:
            for listener in self.listeners:
                listener.on_tick(self)

    def run(
        self,
        until: Callable[[Machine], bool] | None = None,
        max_ticks: int | None = None,
        duration: float | None = None,
    ) -> str | None:
        """Tick until the machine finishes, ``until(machine)`` is true, ``max_ticks`` ticks have run or
        ``duration`` seconds of machine time have passed. Returns the outcome (``None`` if unfinished).

        With a real-time clock, each tick waits for its period.
        """
        if not self.started:
            self.start()
        ctx = self.ctx
        first = ctx.tick
        end_tick = None if max_ticks is None else first + max_ticks
        if duration is not None:
            # the first tick at or after the duration, as with the real-time clock
            ticks_for_duration = math.ceil(duration / self._dt - 1e-9) if self._sim else None
            if ticks_for_duration is not None:
                end_tick = first + ticks_for_duration if end_tick is None else min(end_tick, first + ticks_for_duration)
        end_time = None if (duration is None or self._sim) else ctx.now + duration
        realtime = not self._sim
        tick = self.tick
        while not self.finished:
            if end_tick is not None and ctx.tick >= end_tick:
                break
            if end_time is not None and ctx.now >= end_time:
                break
            if realtime:
                self.clock.wait_for(ctx.tick + 1)
            tick()
            if until is not None and until(self):
                break
        return self.outcome

    # -- inputs ---------------------------------------------------------------------------------
    def schedule_signal(self, name: str, at: float, value: bool = True) -> None:
        """Set signal ``name`` to ``value`` at machine time ``at`` (applied before the first tick at or after it)."""
        self._schedule_seq += 1
        bisect.insort(self._schedule, (float(at), self._schedule_seq, name, bool(value)))

    def _apply_schedule(self, now: float) -> None:
        """Apply the scheduled signal changes due by ``now`` (between ticks: before the tick's boundary)."""
        schedule = self._schedule
        while schedule and schedule[0][0] <= now + 1e-9:
            _, _, name, value = schedule.pop(0)
            self.ctx.set_signal(name, value)

    # -- state of the machine -------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        """True once the root level has reached a ``Final`` state."""
        return self.started and self.root.active.is_final

    @property
    def outcome(self) -> str | None:
        """The outcome of the ``Final`` state reached, or ``None`` while unfinished."""
        if self.finished:
            return self.root.active.outcome or "succeeded"
        return None

    @property
    def active_paths(self) -> list[str]:
        """Paths of all active leaf states (one per parallel region)."""
        return self.root.leaf_paths()

    @property
    def active_path(self) -> str:
        """Path of the active leaf state, e.g. ``"drive/turn/slow"``; under a parallel state the leaf
        paths of its regions, joined by ``", "``."""
        return ", ".join(self.root.leaf_paths())

    @property
    def transition_count(self) -> int:
        """Transitions fired so far, all levels together (initial entries not counted)."""
        return sum(region.fired for region in self.regions)

    @property
    def now(self) -> float:
        return self.ctx.now

    @property
    def ticks(self) -> int:
        return self.ctx.tick

    def state(self, path: str) -> State:
        """The state at ``path`` (ids joined by ``/``; under a ``Parallel``, the region name is a step)."""
        try:
            return self.states_by_path[path.strip("/")]
        except KeyError:
            import difflib

            close = difflib.get_close_matches(path, list(self.states_by_path), n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"no state at path '{path}'{hint}") from None

    def resolve(self, path: str, scope: str = "") -> State:
        """The state ``path`` names when written in the level at ``scope`` (see :func:`fsm.paths.resolve_path`)."""
        from .paths import resolve_path

        full = resolve_path(path, scope, self.states_by_path)
        if full is None:
            raise KeyError(f"no state '{path}' seen from '{scope or '/'}'")
        return self.states_by_path[full]

    # -- pause / resume -------------------------------------------------------------------------
    def pause(self, path: str | None = None) -> None:
        """Suspend the active state at ``path`` and its subtree: not ticked, clocks frozen, no exit/enter.

        Without a path the whole machine pauses (its top-level active state); the clock goes on.
        """
        if not self.started:
            self.start()
        state = self.root.active if not path else self.state(path)
        if not state.active:
            raise ValueError(f"cannot pause '{path}': it is not active")
        if state.paused:
            return
        state.paused = True
        now = self.ctx.now
        for sub in self._active_subtree(state):
            if sub.frozen_since is None:  # already frozen by an earlier pause below: keep that time
                sub.frozen_since = now
                sub._prepare()
        state._prepare()

    def resume(self, path: str | None = None) -> None:
        """Continue a paused state (the whole machine without a path) exactly where it was.

        States below it that are still held by another pause stay frozen until that one is resumed.
        """
        state = self.root.active if not path else self.state(path)
        if not state.paused:
            return
        state.paused = False
        now = self.ctx.now
        held = any(s.paused for s in self._ancestors(state))
        if not held:
            self._thaw(state, now)
        state._prepare()

    def _thaw(self, state: State, now: float) -> None:
        """Unfreeze ``state`` and its subtree, stopping at states that are paused themselves."""
        if state.frozen_since is not None:
            state.entered_at += now - state.frozen_since
            state.frozen_since = None
            state._prepare()
        for region in state.regions:
            if region.started and not region.active.paused:
                self._thaw(region.active, now)

    @staticmethod
    def _ancestors(state: State) -> list[State]:
        out = []
        region = state.region
        while region is not None and region.owner is not None:
            out.append(region.owner)
            region = region.owner.region
        return out

    def _active_subtree(self, state: State) -> list[State]:
        out = [state]
        for region in state.regions:
            if region.started:
                out.extend(self._active_subtree(region.active))
        return out

    # -- listeners ------------------------------------------------------------------------------
    def add_listener(self, listener: Any) -> Any:
        """Attach a listener (see :class:`Listener`); returns it."""
        self.listeners.append(listener)
        return listener

    def remove_listener(self, listener: Any) -> None:
        self.listeners.remove(listener)

    # -- errors ---------------------------------------------------------------------------------
    def _runtime_error(self, state: State, phase: str, exc: BaseException) -> StateRuntimeError:
        if isinstance(exc, StateRuntimeError):
            return exc
        return StateRuntimeError(state.path, phase, self.ctx.tick, self.ctx.now, exc)

    def _emergency_stop(self) -> None:
        """Stop the plant (speed 0) after a state failed, if it can be stopped."""
        car = self.ctx.car
        stop = getattr(car, "emergency_stop", None)
        if stop is not None:
            try:
                stop()
            except Exception:  # noqa: BLE001 - the original error is the one to report
                pass

    def __repr__(self) -> str:
        return f"<Machine {self.name!r} tick={self.ctx.tick} active={self.active_path!r}>"
