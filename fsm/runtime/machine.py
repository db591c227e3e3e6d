"""Machine: the root of a built state machine: its clock, context, tick loop, pause/resume and listeners."""

from __future__ import annotations

import bisect
import difflib
import math
import numbers
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias, TypeVar, runtime_checkable

from fsm.model.errors import StateRuntimeError
from fsm.model.paths import resolve_path
from fsm.runtime.clock import DEFAULT_DURATION, Clock, SimulatedClock
from fsm.runtime.context import Context, StateView, check_signal_name, shown_value, signal_level
from fsm.runtime.debounce import Debounced
from fsm.runtime.region import Region, wiring
from fsm.runtime.state import State
from fsm.runtime.supervisor import Restart
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.runtime.supervisor import Monitor

#: What a listener's ``on_transition`` gets as the ``transition`` that entered a state (``None`` for an initial
#: entry): the transition that fired, or the :class:`~fsm.runtime.supervisor.Restart` record of a monitor that
#: restarted the state (``type_name`` ``"restart"``). Both have ``type_name``, ``source`` and ``target``.
Fired: TypeAlias = Transition[Any] | Restart


@runtime_checkable
class Listener(Protocol):
    """Observer of a running machine: any object with ``on_transition`` and ``on_tick`` is one. Subclass it to
    override only what you need (the others do nothing); the machine calls nothing when no listener is attached.

    Two hooks are optional, called only on listeners that have them (see :class:`MonitorListener` and
    :class:`PauseListener`): ``on_monitor(ctx, owner, monitor)`` and ``on_pause(ctx, state, paused)``.
    """

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        """``target`` was entered: by ``transition`` from ``source``, by a monitor's restart (``transition`` is a
        :class:`~fsm.runtime.supervisor.Restart`; ``source`` and ``target`` are the restarted state), or as an
        initial state (``source`` and ``transition`` are ``None``). ``transition`` is a :data:`Fired` or ``None``."""
        return None

    def on_tick(self, machine: Machine) -> None:
        """A tick has ended."""
        return None


@runtime_checkable
class MonitorListener(Listener, Protocol):
    """A listener that is also told when a monitor (or a timeout) fires."""

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
        """A monitor (or a timeout) of ``owner`` fired; ``monitor.label``, ``.kind``, ``.behavior``,
        ``.exception_id``."""
        return None


@runtime_checkable
class SkipListener(Listener, Protocol):
    """A listener that is also told when a state just entered is skipped because its precondition is false."""

    def on_skipped(self, ctx: Context, state: State[Any]) -> None:
        """``state`` was entered (``on_transition`` told so) and skipped: nothing of it ran, its outcome is
        ``precondition_failed``."""
        return None


@runtime_checkable
class PauseListener(Listener, Protocol):
    """A listener that is also told when a state is paused or resumed."""

    def on_pause(self, ctx: Context, state: State[Any], paused: bool) -> None:
        """``state`` was paused (``paused`` True) or resumed."""
        return None


#: A listener passed to :meth:`Machine.add_listener`, returned as it came.
L = TypeVar("L", bound=Listener)


#: What ``fsm.run`` stops after when given neither ``max_ticks`` nor ``duration`` (machine time, seconds).
DEFAULT_RUN_DURATION = DEFAULT_DURATION
#: ``fsm.run`` refuses a duration of more ticks than this (1e308 s would never end).
MAX_RUN_TICKS = 10**12


class Machine:
    """A runnable machine built by :func:`fsm.load`. Tick it, or ``run`` it to completion.

    The clock is simulated by default (``dt`` = 0.0125 s, 80 Hz as on the TRAL car): tick ``n`` happens
    at ``n * dt``. The first ``tick`` (or ``run``) enters the initial states at time 0.

    Every public method checks its arguments when called: a wrong type raises ``TypeError``, a value out
    of range (negative, NaN, infinite) ``ValueError``, each with a message naming the argument.
    """

    def __init__(
        self,
        root: Region,
        *,
        name: str = "",
        clock: Clock | None = None,
        context: Context | None = None,
        all_regions: list[Region] | None = None,
        states_by_path: dict[str, State[Any]] | None = None,
    ) -> None:
        self.name = name
        self.root = root
        self.clock: Clock = clock if clock is not None else SimulatedClock()
        self.ctx = context if context is not None else Context()
        self.ctx.machine = self
        self.regions: list[Region] = all_regions if all_regions is not None else [root]
        self.states_by_path: dict[str, State[Any]] = states_by_path or {}
        self.listeners: list[Listener] = []
        self.started = False
        self._sim = not getattr(self.clock, "realtime", False)
        self._dt = self.clock.dt
        self._schedule: list[tuple[float, int, str, bool]] = []
        self._schedule_seq = 0
        #: pause buttons: (rising-edge detector ``fn(ctx) -> bool``, state) checked before each tick
        self._toggles: list[tuple[Callable[[Context], bool], StateView]] = []
        for region in self.regions:
            region.listeners = self.listeners
        #: Top-level states without outgoing transitions: one that finishes ends the machine.
        self._terminal = frozenset(root.terminal_states())

    # -- running --------------------------------------------------------------------------------
    def start(self) -> None:
        """Enter the initial states at the current time (done by the first ``tick`` if not called)."""
        if self.started:
            return
        self.started = True
        ctx = self.ctx
        ctx._now = self.clock.time_at(ctx._tick) if not self._sim else ctx._tick * self._dt
        self._apply_schedule(ctx._now)
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
        n = ctx._tick = ctx._tick + 1
        now = n * self._dt if self._sim else self.clock.time_at(n)
        ctx._dt = now - ctx._now
        ctx._now = now
        if self._schedule:
            self._apply_schedule(now)
        if ctx._pending:
            ctx.begin_tick()
        if self._toggles:
            self._check_toggles(ctx)
        try:
            self.root.tick(ctx)
        except StateRuntimeError:
            self._emergency_stop()
            raise
        if self.listeners:
            for listener in self.listeners:
                listener.on_tick(self)

    # -- inputs ---------------------------------------------------------------------------------
    def schedule_signal(self, name: str, at: float, value: bool | int = True) -> None:
        """Set signal ``name`` to ``value`` at machine time ``at`` (applied before the first tick at or after it).

        ``name`` is a non-empty string, ``at`` a finite number of seconds >= 0, ``value`` ``True``/``False``
        or ``1``/``0``; anything else raises ``TypeError`` or ``ValueError``. A time already past is applied
        before the next tick.
        """
        check_signal_name(name)
        at = seconds_argument("at", at)
        level = signal_level(value)
        self._schedule_seq += 1
        bisect.insort(self._schedule, (at, self._schedule_seq, name, level))

    def _apply_schedule(self, now: float) -> None:
        """Apply the scheduled signal changes due by ``now`` (between ticks: before the tick's boundary)."""
        schedule = self._schedule
        while schedule and schedule[0][0] <= now + 1e-9:
            _, _, name, value = schedule.pop(0)
            self.ctx.set_signal(name, value)

    # -- state of the machine -------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        """True once the root level has reached a ``Final`` state, or a top-level state without outgoing transitions
        has finished (a root ``Sequence`` ends the machine with its outcome)."""
        if not self.started:
            return False
        active = self.root.current
        if active.is_final:
            return True
        state = active.state
        return state.finished and state in self._terminal

    @property
    def outcome(self) -> str | None:
        """The outcome of the ``Final`` state reached (or of the finished top-level state), or ``None`` while
        unfinished."""
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
    def dt(self) -> float:
        """The tick period, seconds."""
        return self._dt

    @property
    def ticks(self) -> int:
        return self.ctx.tick

    def state(self, path: str) -> State[Any]:
        """The state at ``path`` (ids joined by ``/``; under a ``Parallel``, the region name is a step).

        Raises ``KeyError`` (with close matches) for a path that names no state, ``TypeError`` for a non-string.
        """
        if not isinstance(path, str):
            raise TypeError(f"a state path is a string like 'drive/turn', got {shown_value(path)}")
        try:
            return self.states_by_path[path.strip("/")]
        except KeyError:
            close = difflib.get_close_matches(path, list(self.states_by_path), n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"no state at path '{path}'{hint}") from None

    def resolve(self, path: str, scope: str = "") -> State[Any]:
        """The state ``path`` names when written in the level at ``scope`` (see :func:`fsm.model.paths.resolve_path`).

        Raises ``TypeError`` for a path or scope that is not a string, ``KeyError`` for a path that names no state.
        """
        if not isinstance(path, str) or not isinstance(scope, str):
            raise TypeError("path and scope are strings like 'drive/turn', "
                            f"got {shown_value(path)} and {shown_value(scope)}")
        full = resolve_path(path, scope, self.states_by_path)
        if full is None:
            raise KeyError(f"no state '{path}' seen from '{scope or '/'}'")
        return self.states_by_path[full]

    # -- pause / resume -------------------------------------------------------------------------
    def pause(self, path: str | None = None) -> None:
        """Suspend the active state at ``path`` and its subtree: not ticked, clocks frozen, no exit/enter.

        Without a path (``None`` or ``""``) the whole machine pauses (its top-level active state); the clock
        goes on. Raises ``TypeError`` for a path that is not a string, ``KeyError`` for one that names no
        state, ``ValueError`` when that state is not active.
        """
        _check_path(path)
        if not self.started:
            self.start()
        state = self.root.active if not path else self.state(path)
        record = wiring(state)
        if not record.active:
            raise ValueError(f"cannot pause '{path}': it is not active")
        if record.paused:
            return
        record.paused = True
        now = self.ctx.now
        for sub in self._active_subtree(state):
            held = wiring(sub)
            if held.frozen_since is None:  # already frozen by an earlier pause below: keep that time
                held.frozen_since = now
                if type(sub).on_pause is not State.on_pause:
                    sub.on_pause(self.ctx)
        if self.listeners:
            self._notify_pause(state, True)

    def resume(self, path: str | None = None) -> None:
        """Continue a paused state (the whole machine without a path) exactly where it was.

        States below it that are still held by another pause stay frozen until that one is resumed.
        ``path`` is checked as in :meth:`pause`; resuming a state that is not paused does nothing.
        """
        _check_path(path)
        state = self.root.active if not path else self.state(path)
        record = wiring(state)
        if not record.paused:
            return
        record.paused = False
        now = self.ctx.now
        held = any(wiring(s).paused for s in self._ancestors(state))
        if not held:
            self.thaw(state, now)
        if self.listeners:
            self._notify_pause(state, False)

    def thaw(self, state: State[Any], now: float) -> None:
        """Unfreeze ``state`` and its subtree after a pause or a suspension, stopping at states that are paused
        themselves: their clocks go on from where they stood (the frozen time is not counted)."""
        record = wiring(state)
        if record.frozen_since is not None:
            record.entered_at += now - record.frozen_since
            record.frozen_since = None
            if record.paused is False and type(state).on_resume is not State.on_resume:
                state.on_resume(self.ctx)
        for region in _inner_regions(state):
            if region.started and not region.current.paused:
                self.thaw(region.active, now)

    @staticmethod
    def _ancestors(state: State[Any]) -> list[State[Any]]:
        out = []
        region = wiring(state).region
        while region is not None and region.owner is not None:
            out.append(region.owner)
            region = wiring(region.owner).region
        return out

    def _active_subtree(self, state: State[Any]) -> list[State[Any]]:
        out = [state]
        for region in _inner_regions(state):
            if region.started:
                out.extend(self._active_subtree(region.active))
        return out

    def _check_toggles(self, ctx: Context) -> None:
        """``pause_signal``: each rising edge pauses the state if it runs, resumes it if paused (one push button).
        An edge while the state is not active is used up."""
        for edge, state in self._toggles:
            if edge(ctx) and state.active:
                if state.paused:
                    self.resume(state.path)
                else:
                    self.pause(state.path)

    def add_pause_button(self, state: StateView, signal: str, debounce: float = 0.0) -> None:
        """Each rising edge of ``signal`` (debounced by ``debounce`` seconds) pauses ``state`` when it runs and
        resumes it when it is paused (one push button, checked before each tick)."""
        filt = Debounced(self.ctx.signal_history(signal), debounce)
        last = [False]

        def edge(ctx: Context) -> bool:
            level = filt.advance(ctx.now)
            rose = level and not last[0]
            last[0] = level
            return rose
        self._toggles.append((edge, state))

    def notify_monitor(self, owner: State[Any], monitor: Monitor) -> None:
        """Tell the listeners that a monitor (or a timeout) of ``owner`` fired."""
        for listener in self.listeners:
            hook = getattr(listener, "on_monitor", None)
            if hook is not None:
                hook(self.ctx, owner, monitor)

    def notify_skipped(self, state: StateView) -> None:
        """Tell the listeners that ``state``, just entered, was skipped by its precondition."""
        for listener in self.listeners:
            hook = getattr(listener, "on_skipped", None)
            if hook is not None:
                hook(self.ctx, state)

    def _notify_pause(self, state: State[Any], paused: bool) -> None:
        for listener in self.listeners:
            hook = getattr(listener, "on_pause", None)
            if hook is not None:
                hook(self.ctx, state, paused)

    # -- listeners ------------------------------------------------------------------------------
    def add_listener(self, listener: L) -> L:
        """Attach a listener: an object with ``on_transition(ctx, source, target, transition)`` and
        ``on_tick(machine)`` methods (subclass :class:`Listener` and override what you need); returns it.

        Raises ``TypeError`` for anything else (``None``, a plain function), before the machine runs.
        """
        missing = [m for m in ("on_transition", "on_tick") if not callable(getattr(listener, m, None))]
        if missing:
            raise TypeError(f"a listener needs the methods on_transition(ctx, source, target, transition) and "
                            f"on_tick(machine); {shown_value(listener)} lacks {' and '.join(missing)} "
                            "(subclass fsm.Listener and override what you need)")
        self.listeners.append(listener)
        return listener

    def remove_listener(self, listener: Listener) -> None:
        """Detach a listener attached with :meth:`add_listener` (``ValueError`` if it is not attached)."""
        try:
            self.listeners.remove(listener)
        except ValueError:
            raise ValueError(f"{shown_value(listener)} is not a listener of this machine") from None

    # -- errors ---------------------------------------------------------------------------------
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


def _inner_regions(state: State[Any]) -> tuple[Region, ...]:
    """The regions below ``state``: its own and the exception sequence running for it, if any."""
    record = wiring(state)
    w = record.supervisor
    running = w.level if w is not None else None
    if running is not None:
        return record.regions + (running,)
    return record.regions


# -- argument checks (shared with Context.set_signal) --------------------------------------------------
def seconds_argument(name: str, value: Any) -> float:
    """A time argument: a real number (not a bool, not a string), finite and >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number of seconds, got {shown_value(value)}")
    seconds = float(value)
    if not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"{name} must be a finite number of seconds >= 0, got {value!r}")
    return seconds


def _check_path(path: Any) -> None:
    if path is not None and not isinstance(path, str):
        raise TypeError(f"a state path is a string like 'drive/turn' (or None for the whole machine), "
                        f"got {shown_value(path)}")
