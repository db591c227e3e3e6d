"""Controller: a session run under commands from another thread (a debugger's page), applied between ticks.

The controller owns the tick loop of one run: it runs the session in short chunks of ticks
(:meth:`Session.run <fsm.session.session.Session.run>`, unchanged), and between two ticks (never inside one) it
applies the
commands that arrived meanwhile, so debugging never changes what a tick does:

- ``pause`` / ``resume`` the run itself (the machine's own pause of a subtree is an input, ``PauseState``);
- ``step`` 1 or N ticks, or ``step_transition`` to the next tick in which a transition fires or a monitor fires;
- ``speed``: real time x k, or ``None`` for as fast as possible (steps always run as fast as possible);
- ``stop``: end the loop (the caller writes the trace and the outputs);
- ``break`` / ``unbreak`` (``breakpoint``: its number): breakpoints (:mod:`fsm.debug.breakpoints`); a hit
  pauses after the tick it happened in;
- ``input``: an input (:mod:`fsm.session.inputs`: a variable, a signal, a forced reading, a monitor fired, a state
  finished), checked against the machine (:mod:`fsm.debug.inject`: a variable it has, a value of its kind, a
  signal it reads), submitted for the next tick and recorded in the trace by the session; a run that raises
  shortly after an injection has the injection undone (rewound to before it) rather than the run ended;
- ``reload``: a hot reload (:mod:`fsm.debug.reload`, from the file watcher, never from a page: its argument is a
compiled
  plan): the machine replaced between two ticks, keeping the variables and the active states by path; an active
  state that no longer exists pauses the run there; a ``reload`` line in the trace and a rewind does it again;
- ``watch`` / ``unwatch`` / ``watched``: expressions whose values are kept for the ticks a page can see: the tick
  of every status published (after each chunk of ticks, at most :data:`CHUNK` apart, and wherever the run pauses: a
  step's end, a breakpoint, a rewind), never on the ticks between (``watched`` messages carry the new ones; nothing
  is evaluated while there is none). An expression breakpoint is tested after every tick; a watch is not;
- ``watch_values``: the watches' exact values at every tick of a range, computed when asked by re-simulation
  (:mod:`fsm.debug.resim`: from the latest snapshot before the range, or from the start), the run untouched: what
  the page shows at the cursor's tick and plots;
- ``why``: what a tick did and why (:mod:`fsm.debug.explain`), by re-simulation, the run untouched;
- ``rewind``: back to an earlier tick: the nearest snapshot at or before it restored (:mod:`fsm.session.snapshot`:
  taken every :data:`SNAPSHOT_PERIOD` simulated seconds or less often, so that taking them costs the run at most
  :data:`SNAPSHOT_SHARE` of its time) and the run re-simulated from there with the inputs given up to that tick;
  before the first snapshot, the run built afresh (``factory``) and re-run from its start. The run is
  deterministic, so it is the same run; later inputs are dropped, so the run forks from there. The history a
  rewind needs (snapshots, inputs, reloads) is kept for ``horizon`` simulated seconds back: a rewind further back
  is refused with how far back it can go.

Whoever watches reads :attr:`Controller.snapshot` (replaced, never changed, after each chunk: safe from another
thread) and takes :attr:`Controller.messages` (replies to commands, notices).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from fsm.debug.breakpoints import (
    Breakpoint,
    BreakpointError,
    Happened,
    Watch,
    active_set,
    expression_values,
    hits,
    make_breakpoint,
)
from fsm.debug.inject import check_injection
from fsm.debug.reload import ReloadRefused, swap_machine
from fsm.debug.resim import MAX_COLUMNS, MAX_RANGE, Rows, aside, exact_now, rows_between
from fsm.debug.watch import WatchExpr, compile_watch, row_function
from fsm.model.errors import DiagramError, StateRuntimeError
from fsm.session.inputs import InputError, input_from_json
from fsm.session.session import Input, Session, StopRules
from fsm.session.snapshot import Snapshot, restore, take

#: Most ticks run between two looks at the commands (a few milliseconds of the hallway lap).
CHUNK = 256
#: The longest step, in ticks.
MAX_STEP = 10_000_000
#: Speeds (x real time) a run may be paced at; ``None`` is as fast as possible.
MIN_SPEED, MAX_SPEED = 0.01, 10_000.0
#: Behind real time by more than this (seconds of machine time at the chosen speed), the pace starts afresh
#: instead of running the backlog at full speed.
MAX_BACKLOG = 0.25
#: How often (s) a running run's trace gets the samples kept for its current block, so a page shows the car moving.
FLUSH = 0.1
#: A run that raises this long (simulated seconds) after an injection has the injection undone, not the run ended.
UNDO_WINDOW = 5.0
#: Watch expressions at most, and the ticks of their values kept (about 20 minutes at 80 Hz)
MAX_WATCHES, MAX_WATCH_TICKS = 20, 100_000
#: How long the loop sleeps at most while paused or ended before it looks at the commands again (s).
IDLE = 0.1
#: Snapshots for rewind: at most one every this many simulated seconds, and no more often than keeps their cost
#: under this share of the run's own time (at full speed on the hallway lap: one every 60-100 s of the run, so a
#: rewind re-simulates about a tenth of a second at most; see docs/performance.md); whatever they cost, at least one
#: every third of the rewind horizon, so that what lies beyond the horizon is let go.
SNAPSHOT_PERIOD = 30.0
SNAPSHOT_SHARE = 0.02
#: How far back (simulated seconds) a live run can be rewound by default: its rewind history is kept for this long.
DEFAULT_HORIZON = 1800.0


class Controller:
    """Runs ``session`` (see the module docstring). ``factory`` builds the same run afresh (for ``rewind``);
    ``speed`` is x real time (``None``: as fast as possible); ``paused`` starts paused at tick 0; ``signals``: the
    signal names the machine reads (for breakpoint expressions)."""

    def __init__(self, session: Session, *, factory: Callable[[], Session] | None = None,
                 speed: float | None = 1.0, paused: bool = False, signals: Iterable[str] = (),
                 clock: Callable[[], float] = time.monotonic, fresh: Callable[[], Session] | None = None,
                 horizon: float = DEFAULT_HORIZON, snapshot_period: float | None = SNAPSHOT_PERIOD,
                 snapshot_share: float = SNAPSHOT_SHARE, on_restore: Callable[[Session], None] | None = None) -> None:
        self.session = session
        self.factory = factory
        #: builds the same run afresh without recording it (``why`` re-simulates with it; default: ``factory``)
        self.fresh = fresh or factory
        self.speed = speed
        self.paused = paused
        self.signals = tuple(sorted(set(signals)))
        self._first_signals = self.signals  # a rewind to before every reload reads these again
        self.clock = clock
        self.breakpoints: list[Breakpoint] = []
        #: the inputs given through the controller, each with the tick before which it applied
        self.log: list[tuple[int, Input]] = []
        #: the hot reloads so far: the tick before which each applied, its plan, its trace line's details
        self.reloads: list[tuple[int, Any, dict[str, Any]]] = []
        #: why the run ended (``finished``, ``limit``, ``error``, a world's reason), or None while it can go on
        self.ended: str | None = None
        self.error: str | None = None
        #: the last breakpoint hit (or step that ended at a transition), shown until the run goes on
        self.hit: dict[str, Any] | None = None
        self.quit = False
        #: the loop has returned (Stop, Ctrl-C): its last status says "stopped", not "running"
        self.stopped = False
        #: replies to commands and notices, for whoever watches (taken from the left)
        self.messages: deque[dict[str, Any]] = deque()
        self.snapshot: dict[str, Any] = {}
        #: called (from the loop's thread) after each new snapshot: a watcher's wake-up
        self.notify: Callable[[], None] | None = None
        #: whether the last snapshot needs a watcher now (the run paused or ended, a reply or notice waits) or only
        #: tells a running run's progress, which a watcher may pick up at its own pace (a page redraws at most 30
        #: times a second; a status is published after every chunk, hundreds of times a second at full speed)
        self.urgent = True
        self._commands: deque[tuple[str, dict[str, Any], Any]] = deque()
        self._wake = threading.Condition()
        self._interrupt = False
        self._budget = 0
        self._to_transition = False
        self._anchor: tuple[float, int] | None = None
        self._next_id = 1
        self._next_watch = 1
        self._seq = 0
        self._shown: dict[str, Any] = {}  # the last snapshot published, without its seq
        self._replied = False  # a command was answered since (its reply is news even if the status is not)
        self._flushed = 0.0
        self._inputs_key: tuple[int, int, int] = (0, -1, 0)
        self._inputs_list: list[list[Any]] = []
        self._watch = Watch()
        self._active: set[str] = set()
        #: ticks ran with no breakpoint and no step to a transition: ``_active`` is older than the machine
        self._stale = False
        self._end = session.stop_rules.end_tick(0, session.dt)
        #: watch expressions: (number, text, the checked expression); their values per tick since the run began
        self.watches: list[tuple[int, str, WatchExpr]] = []
        self.watch_log: deque[tuple[int, tuple[Any, ...]]] = deque(maxlen=MAX_WATCH_TICKS)
        self._watch_new: list[tuple[int, tuple[Any, ...]]] = []
        #: the watches' row after a tick: one generated function for them all (:mod:`fsm.debug.watch`)
        self._watch_row: Callable[[Any], tuple[Any, ...]] = row_function([])
        #: how far back (simulated seconds) rewind reaches (``inf``: to the start; 0: no rewind)
        self.horizon = horizon
        # a horizon shorter than the period: snapshots often enough that a rewind reaches about that far back
        self.snapshot_period = None if horizon <= 0 or snapshot_period is None else min(snapshot_period, horizon / 3)
        self.snapshot_share = snapshot_share
        #: called (from the loop's thread) after a rewind restored a snapshot: the recorder writes to a new stream
        self.on_restore = on_restore
        #: called (from the loop's thread) when a rewind undid hot reloads, with the document of the machine that
        #: runs now (None: the one the run started with): the page served from then on draws it
        self.machine_changed: Callable[[dict[str, Any] | None], None] | None = None
        #: the snapshots kept (oldest first), what one costs (s of this thread's processor time) and this thread's
        #: processor time when the last one was taken
        self.snapshots: list[Snapshot] = []
        self._snap_cost = 0.0
        self._snap_wall = 0.0
        #: the earliest tick a rewind reaches (above 0 once the horizon let the start go)
        self.earliest = 0
        #: whether inputs older than the horizon were let go (Why re-simulates from the start: it needs them all)
        self._forgot_inputs = False
        #: the document of the last reload let go with the horizon (the machine before the reloads kept)
        self._base_document: dict[str, Any] | None = None
        self._attach(session)

    # -- from any thread ------------------------------------------------------------------------------------------
    def send(self, name: str, args: dict[str, Any] | None = None, reply: Any = None) -> None:
        """Queue command ``name`` with ``args``; its reply (``{"kind": "reply", "id": reply, ...}``) goes to
        :attr:`messages`. Applied by the loop at the next tick boundary."""
        with self._wake:
            self._commands.append((name, dict(args or {}), reply))
            self._interrupt = True
            self._wake.notify()

    # -- the loop ---------------------------------------------------------------------------------------------------
    def loop(self, stop: Callable[[], bool] | None = None) -> None:
        """Run until a ``stop`` command or ``stop()`` (checked between chunks: Ctrl-C); while paused or after the
        run ended, wait for commands (a rewind makes an ended run go on)."""
        self._start()
        while True:
            self._drain()
            if self.quit or (stop is not None and stop()):
                break
            if self.ended is not None or (self.paused and not self._budget):
                self._publish()
                self._idle(IDLE)
                continue
            ticks, wait = self._chunk()
            if not ticks:
                self._idle(wait)
                continue
            self._run(ticks)
            self._snapshot()
            self._publish()
        self.stopped = True  # the last status says so: a page must not go on showing "running"
        self._publish()

    def _start(self) -> None:
        session = self.session
        try:
            session.start()
        except StateRuntimeError as exc:
            self._failed(exc)
        self._watch.clear()
        self._active = active_set(session.machine)
        self._stale = False
        self._publish()

    def _idle(self, seconds: float) -> None:
        with self._wake:
            if not self._commands:
                self._wake.wait(seconds)

    def _chunk(self) -> tuple[int, float]:
        """How many ticks to run now (a step's rest, or what the pace allows), or how long to wait for the next."""
        session = self.session
        left = self._end - session.ticks
        if self._budget:
            return min(self._budget, CHUNK, left), 0.0
        if self.speed is None:
            return min(CHUNK, left), 0.0
        now = self.clock()
        dt = session.dt
        if self._anchor is None:
            self._anchor = (now, session.ticks)
        wall0, tick0 = self._anchor
        due = tick0 + int((now - wall0) * self.speed / dt + 1e-9)
        if (due - session.ticks) * dt > MAX_BACKLOG * self.speed:  # too slow for this pace: start it afresh
            self._anchor = (now, session.ticks)
            due = session.ticks + 1
        n = due - session.ticks
        if n <= 0:
            return 0, max((session.ticks + 1 - tick0) * dt / self.speed - (now - wall0), 0.0005)
        return min(n, CHUNK, left), 0.0

    def _run(self, ticks: int) -> None:
        """Run a chunk of ``ticks``. The session's loop calls the controller after a tick only while something
        looks at every tick (a breakpoint, a step to the next transition): then once, through :meth:`_looker`, and
        the listener noting transitions is attached. Otherwise the ticks run as in a plain run, and commands,
        ``stop()`` (Ctrl-C) and watches wait for the end of the chunk (at most :data:`CHUNK` ticks)."""
        session = self.session
        before = session.ticks
        self._interrupt = False
        looking = bool(self.breakpoints) or self._to_transition
        self._look(session.machine, looking)
        try:
            result = session.run(until=self._looker() if looking else None, stop_rules=StopRules(max_ticks=ticks))
        except StateRuntimeError as exc:
            if not self._undo_injection(exc):
                self._failed(exc)
            return
        finally:
            if not looking:
                self._stale = True
        if self._budget > 0:
            self._budget = max(0, self._budget - (session.ticks - before))
            if not self._budget:
                self._to_transition = False
        self._ended_by(result.stopped)

    def _ended_by(self, stopped: str) -> None:
        """Whether the chunk that stopped for ``stopped`` ended the run (finished, at its limit, a world's reason)."""
        session = self.session
        if stopped == "finished":
            self.ended = "finished"
        elif stopped == "limit":
            if session.ticks >= self._end:
                self.ended = "limit"
        elif stopped not in ("until", "stopped"):
            self.ended = stopped
        if self.ended is not None:
            self._budget = 0

    def _undo_injection(self, exc: StateRuntimeError) -> bool:
        """A run that raises within :data:`UNDO_WINDOW` seconds after an injection is not ended by it: the
        injection is undone (the run rewound to just before it applied, dropping it) and the run paused there, the
        page told what raised. A run that raises again without it, when resumed, ends as any run does."""
        if self.factory is None or not self.log:
            return False
        tick, item = self.log[-1]
        failed = self.session.machine.ctx.tick  # the tick that raised
        if failed - tick > UNDO_WINDOW / self.session.dt or tick - 1 < self.earliest:
            return False
        self.rewind(max(0, tick - 1))
        self.hit = {"breakpoint": None, "text": "injection undone",
                    "why": f"the run raised in tick {failed}, after the injection '{item.describe()}' (applied before "
                           f"tick {tick}): {exc}. The injection was undone: the run is paused before it",
                    "tick": self.session.ticks, "time": round(self.session.now, 9)}
        self.messages.append({"kind": "hit", **self.hit})
        return True

    def _failed(self, exc: StateRuntimeError) -> None:
        self.ended = "error"
        self.error = str(exc)
        self._budget = 0

    def _look(self, machine: Any, looking: bool) -> None:
        """Attach the listener noting each tick's transitions while something looks at them, detach it otherwise (a
        listener costs the machine a call after every tick); what is active now is where looking starts from."""
        watch = self._watch
        listeners = machine.listeners
        attached = any(listener is watch for listener in listeners)
        if looking and not attached:
            watch.clear()
            listeners.append(watch)
            self._resync()
        elif looking and self._stale:
            watch.clear()
            self._resync()
        elif not looking and attached:
            listeners[:] = [listener for listener in listeners if listener is not watch]

    def _looker(self) -> Callable[[Session], bool]:
        """The session's per-tick hook for one chunk, while something looks (see :meth:`_run`): after each tick, a
        breakpoint hit or the end of a step to a transition ends the chunk, as does a command waiting. What cannot
        change within a chunk is bound once."""
        watch = self._watch
        breakpoints = self.breakpoints
        to_transition = self._to_transition
        happened_now = self._happened

        def after_tick(session: Session) -> bool:
            happened = happened_now() if watch.moved else None
            if breakpoints and self._breakpoint_hit(session, happened):
                return True
            if to_transition and happened is not None and self._transition_seen(happened):
                return True
            return self._interrupt

        return after_tick

    def _breakpoint_hit(self, session: Session, happened: Happened | None) -> bool:
        found = hits(self.breakpoints, happened, session.machine, self.signals)
        if not found:
            return False
        for bp, _why in found:
            bp.hits += 1
        bp, why = found[0]
        self._pause_at({"breakpoint": bp.id, "text": bp.text, "why": why, "also": [b.id for b, _ in found[1:]]})
        return True

    def _transition_seen(self, happened: Happened) -> bool:
        """A step to the next transition ends at the tick one fired (a monitor too)."""
        if not (any(src is not None for src, _dst, _type in happened.transitions) or happened.monitors):
            return False
        what = [f"{s} -> {d}" for s, d, _t in happened.transitions if s is not None]
        what += [f"monitor {label} of {owner}" for owner, label, _k, _e in happened.monitors]
        self._pause_at({"breakpoint": None, "text": "step to the next transition", "why": "; ".join(what)})
        return True

    def _note_watches(self, session: Session) -> None:
        """The watch expressions' values after this tick (between two ticks: what the trace says at it): one call
        of the generated function, which keeps the last row (the same object) when nothing read moved. Rows are
        tuples of plain values, which the garbage collector stops tracking: a long log costs it nothing."""
        entry = (session.ticks, self._watch_row(session.machine.ctx))
        self.watch_log.append(entry)
        self._watch_new.append(entry)

    def _plan_watches(self) -> None:
        self._watch_row = row_function([w for _n, _t, w in self.watches])

    def _resync(self) -> None:
        """Take the active states as they are between two ticks (after ticks nothing looked at)."""
        self._active = active_set(self.session.machine)
        self._stale = False

    def _happened(self) -> Happened:
        watch = self._watch
        now = active_set(self.session.machine)
        before = self._active
        self._active = now
        entered = sorted(now - before)
        left = sorted(before - now)
        for src, dst, _type in watch.transitions:  # a restart leaves and enters the same state
            if src == dst:
                entered.append(dst)
                left.append(src)
        happened = Happened(watch.transitions, watch.monitors, entered, left)
        watch.clear()
        return happened

    def _pause_at(self, hit: dict[str, Any]) -> None:
        session = self.session
        self.hit = {**hit, "tick": session.ticks, "time": round(session.now, 9)}
        self.paused = True
        self._budget = 0
        self._to_transition = False
        self.messages.append({"kind": "hit", **self.hit})

    # -- commands -----------------------------------------------------------------------------------------------------
    def _drain(self) -> None:
        while True:
            with self._wake:
                if not self._commands:
                    return
                name, args, reply = self._commands.popleft()
            try:
                answer = self._apply(name, args)
            except (BreakpointError, InputError, ReloadRefused, ValueError, TypeError) as exc:
                message: dict[str, Any] = {"kind": "reply", "id": reply, "command": name, "ok": False,
                                           "error": getattr(exc, "message", None) or str(exc)}
                for key in ("column", "field"):  # where the mistake is: a column, or the form's field
                    where = getattr(exc, key, None)
                    if where is not None:
                        message[key] = where
                self.messages.append(message)
            else:
                self.messages.append({"kind": "reply", "id": reply, "command": name, "ok": True, **answer})
            self._replied = True

    def _apply(self, name: str, args: dict[str, Any]) -> dict[str, Any]:
        """Apply one command; raises ValueError (or a more precise error) with what is wrong with it."""
        handler = getattr(self, f"_cmd_{name}", None)
        if handler is None or name.startswith("_"):
            raise ValueError(f"unknown command {name!r}")
        answer: dict[str, Any] = handler(args)
        return answer

    def _going_on(self) -> None:
        if self.ended is not None:
            raise ValueError(f"the run has ended ({self.ended}); rewind to an earlier tick to go on")

    def _cmd_pause(self, args: dict[str, Any]) -> dict[str, Any]:
        self.paused = True
        self._budget = 0
        self._to_transition = False
        return {}

    def _cmd_resume(self, args: dict[str, Any]) -> dict[str, Any]:
        self._going_on()
        self.paused = False
        self._budget = 0
        self._to_transition = False
        self.hit = None
        self._anchor = None
        return {}

    def _cmd_step(self, args: dict[str, Any]) -> dict[str, Any]:
        self._going_on()
        n = args.get("n", 1)
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_STEP:
            raise ValueError(f"a step is 1 to {MAX_STEP} ticks, got {n!r}")
        self.paused = True
        self.hit = None
        self._budget = n
        self._to_transition = False
        return {}

    def _cmd_step_transition(self, args: dict[str, Any]) -> dict[str, Any]:
        self._going_on()
        self.paused = True
        self.hit = None
        self._budget = MAX_STEP
        self._to_transition = True
        self._watch.clear()
        self._resync()
        return {}

    def _cmd_speed(self, args: dict[str, Any]) -> dict[str, Any]:
        x = args.get("x")
        if x is not None and (isinstance(x, bool) or not isinstance(x, (int, float))
                              or not MIN_SPEED <= x <= MAX_SPEED):
            raise ValueError(f"a speed is {MIN_SPEED:g} to {MAX_SPEED:g} x real time, or null for as fast as "
                             f"possible; got {x!r}")
        self.speed = None if x is None else float(x)
        self._anchor = None
        return {}

    def _cmd_stop(self, args: dict[str, Any]) -> dict[str, Any]:
        self.quit = True
        return {}

    def _cmd_break(self, args: dict[str, Any]) -> dict[str, Any]:
        bp = make_breakpoint(self._next_id, args.get("spec"), self.session.machine, self.signals)
        self._next_id += 1
        if not self.breakpoints:  # ticks ran unlooked at: start from the states active now
            self._watch.clear()
            self._resync()
        self.breakpoints.append(bp)
        return {"breakpoint": bp.to_json()}

    def _cmd_unbreak(self, args: dict[str, Any]) -> dict[str, Any]:
        number = args.get("breakpoint")
        kept = [bp for bp in self.breakpoints if bp.id != number]
        if len(kept) == len(self.breakpoints):
            raise ValueError(f"no breakpoint {number!r}")
        self.breakpoints = kept
        return {}

    def _cmd_watch(self, args: dict[str, Any]) -> dict[str, Any]:
        """``expr``: an expression of the document's language, whose value is kept from now on at the ticks a page
        can see (plotted by the page); an expression that does not parse is refused with its column."""
        if len(self.watches) >= MAX_WATCHES:
            raise ValueError(f"at most {MAX_WATCHES} watch expressions; remove one first")
        watch = compile_watch(args.get("expr"), self.session.machine, self.signals)
        self.watches.append((self._next_watch, watch.text, watch))
        self._next_watch += 1
        self._plan_watches()
        self.watch_log.clear()  # a new column: the rows so far have one value fewer
        self._watch_new = []
        if self.session.machine.started:
            self._note_watches(self.session)
        return {"watch": self._next_watch - 1}

    def _cmd_unwatch(self, args: dict[str, Any]) -> dict[str, Any]:
        number = args.get("watch")
        kept = [w for w in self.watches if w[0] != number]
        if len(kept) == len(self.watches):
            raise ValueError(f"no watch {number!r}")
        self.watches = kept
        self._plan_watches()
        self.watch_log.clear()
        self._watch_new = []
        return {}

    def _cmd_watched(self, args: dict[str, Any]) -> dict[str, Any]:
        """The watch expressions' values so far (a page that joins late, or reconnects)."""
        return {"rows": list(self.watch_log)}

    def _cmd_watch_values(self, args: dict[str, Any]) -> dict[str, Any]:
        """The watch expressions' exact values at every tick from ``from`` to ``to`` (default: the current tick),
        computed by re-simulation (:meth:`watch_values`), at most :data:`~fsm.debug.resim.MAX_RANGE` ticks (a longer
        range: its last ones, and ``clipped`` says so); ``width``: a plot's pixel columns (more than twice as many
        ticks: each column's least and greatest value). Costs as much as running those ticks, and only when asked."""
        now = self.session.ticks
        last = _tick(args, "to", now, now)
        first = _tick(args, "from", last, now)
        width = args.get("width")
        if width is not None and (isinstance(width, bool) or not isinstance(width, int)
                                  or not 1 <= width <= MAX_COLUMNS):
            raise ValueError(f"watch_values: a width is 1 to {MAX_COLUMNS} pixel columns, got {width!r}")
        if first > last:
            raise ValueError(f"watch_values: from ({first}) is after to ({last})")
        if not self.watches:
            raise ValueError("watch_values: there is no watch expression; add one first")
        clipped: list[str] = []
        if first < self.earliest:
            if last < self.earliest:
                raise ValueError(self._beyond_horizon(first))
            clipped.append(f"ticks before {self.earliest} are beyond the rewind horizon (--rewind-horizon "
                           f"{self.horizon:g} s)")
            first = self.earliest
        if last - first + 1 > MAX_RANGE:
            clipped.append(f"at most {MAX_RANGE} ticks a request: ticks {first} to {last - MAX_RANGE} left out")
            first = last - MAX_RANGE + 1
        answer = self.watch_values(first, last).to_json(width)
        answer.update(watches=[number for number, _text, _w in self.watches], clipped="; ".join(clipped) or None)
        return answer

    def watch_values(self, first: int, last: int) -> Rows:
        """The watches' rows after each tick from ``first`` to ``last`` (at most the current tick), the run itself
        untouched: at the current tick, read from the run; else re-simulated (:meth:`_resimulated`)."""
        row = row_function([w for _n, _t, w in self.watches])
        session = self.session
        out = Rows(first, last)
        if first == last == session.ticks and session.machine.started:
            out.source = "live"
            out.add(first, row(session.machine.ctx))
            return out
        with self._resimulated(first, last) as (again, reloads, source):
            out.source = source
            rows_between(again, row, first, last, out, reloads)
        return out

    @contextmanager
    def _resimulated(self, first: int, last: int) -> Iterator[tuple[Session, list[tuple[int, Any]], str]]:
        """The run standing between two ticks at or before ``first``, to be run on to ``last`` at most, with the hot
        reloads to do again on the way and where it came from; the run itself is untouched. From the latest snapshot
        at or before ``first``, restored in the run's own objects, which are given back as they are now afterwards
        (:func:`~fsm.debug.resim.aside`); or, where there is none or the run cannot be snapshotted now (the car
        touches a wall), a run built afresh with the inputs given. Raises ValueError saying why when neither can be
        done (the inputs before the rewind horizon let go)."""
        session = self.session
        snap = next((snap for snap in reversed(self.snapshots) if snap.tick <= first), None)
        if snap is not None and snap.extra.get("session") is session and exact_now(session):
            with aside(session) as start:
                start(snap)
                given = {id(item) for _t, item in self.log}
                session.keep_scheduled(lambda item: id(item) not in given)
                for t, item in self.log:
                    if snap.tick < t <= last:
                        session.schedule_tick(t, item)
                yield session, [(at, plan) for at, plan, _i in self.reloads if at > snap.tick], \
                    f"snapshot at tick {snap.tick}"
            return
        if self.fresh is None:
            raise ValueError("this run cannot be re-simulated (it was not started with a way to build it again)")
        if self._forgot_inputs or self.earliest:
            raise ValueError(f"tick {first} cannot be re-simulated now: the car touches a wall at the current tick, "
                             "so the run cannot be snapshotted to re-simulate from an earlier one, and its inputs "
                             f"before tick {self.earliest} are beyond the rewind horizon; step on a few ticks and ask "
                             "again")
        fresh = self._fresh(last)
        try:
            fresh.start()
        except StateRuntimeError as exc:
            raise ValueError(f"the run raised at its start: {exc}") from None
        yield fresh, [(at, plan) for at, plan, _i in self.reloads], "start"

    def _cmd_input(self, args: dict[str, Any]) -> dict[str, Any]:
        self._going_on()
        item = input_from_json(args.get("input"))
        session = self.session
        item = check_injection(item, session.machine, self.signals)
        tick = session.ticks + (1 if session.machine.started else 0)
        session.submit(item)
        self.log.append((tick, item))
        return {"tick": tick, "text": item.describe()}

    def _cmd_reload(self, args: dict[str, Any]) -> dict[str, Any]:
        """``plan``: the compiled plan of the edited document; ``info``: what its trace line says besides (the
        file, the new regions, the document); ``signals``: the signal names the new machine reads."""
        self._going_on()
        info = dict(args.get("info") or {})
        signals = tuple(sorted(set(args.get("signals") or self.signals)))
        info["signals"] = signals  # kept with the reload: a rewind past it reads them again, one before it not
        try:
            swap = self._swap(args["plan"], info)
        except DiagramError as exc:  # it cannot be built here (it drives a car and this run has none): not swapped
            raise ValueError(f"the edited machine cannot run here: {exc}") from None
        except StateRuntimeError as exc:
            self._failed(exc)
            raise ValueError(f"the reloaded machine failed: {exc}") from None
        self.signals = signals
        text = swap.describe()
        self.messages.append({"kind": "reload", "ok": True, "tick": self.reloads[-1][0],
                              "file": info.get("file"), "text": text, "kept": swap.kept,
                              "missing": [list(m) for m in swap.missing]})
        if swap.missing:
            self._pause_at({"breakpoint": None, "text": "hot reload",
                            "why": "; ".join(f"{old} no longer exists, entered {new}" for old, new in swap.missing)})
        return {"text": text}

    def _swap(self, plan: Any, info: dict[str, Any]) -> Any:
        """Replace the machine by ``plan``'s (the loop's thread, between ticks), record it and remember it."""
        session = self.session
        machine = session.machine
        tick = session.ticks + (1 if machine.started else 0)
        swap = swap_machine(machine, plan)
        session.replace_machine(swap.machine)
        details = {key: value for key, value in info.items() if key in ("file", "regions", "document")}
        details.setdefault("file", "")
        details["regions"] = [{"path": r.path, "name": r.name, "states": [s.path for s in r.states.values()]}
                              for r in swap.machine.regions]
        details.update(kept=swap.kept, missing=[{"path": o, "entered": n} for o, n in swap.missing],
                       started=[{"path": o, "entered": n} for o, n in swap.started], text=swap.describe())
        if session.recorder is not None:
            session.recorder.on_reload(tick, round(tick * session.dt, 9), details)
        self.reloads.append((tick, plan, info))
        self._watch.clear()
        self._active = active_set(swap.machine)
        self._stale = False
        return swap

    def _cmd_why(self, args: dict[str, Any]) -> dict[str, Any]:
        """Why tick ``tick`` (default: the last one run) did what it did (:mod:`fsm.debug.explain`): the run
        re-simulated to just before it as watch values are (:meth:`_resimulated`: from a snapshot or from the start,
        hot reloads done again), then that tick run with its checks kept; the run itself is not touched. Costs as
        much as running those ticks, and only when asked."""
        from fsm.debug.explain import explain_next

        now = self.session.ticks
        tick = args.get("tick", now)
        if isinstance(tick, bool) or not isinstance(tick, int) or not 1 <= tick <= now:
            raise ValueError(f"why: a tick from 1 to the current {now}, got {tick!r}")
        if tick - 1 < self.earliest:
            raise ValueError(f"why: {self._beyond_horizon(tick - 1)}")
        with self._resimulated(tick - 1, tick) as (session, reloads, _source):
            before = rows_between(session, lambda ctx: (), tick - 1, tick - 1, Rows(tick - 1, tick - 1), reloads)
            if before.stopped is not None or session.ticks != tick - 1:
                raise ValueError(f"why: the re-simulation did not get to tick {tick}: {before.stopped}")
            return {"why": explain_next(session, self.signals).to_json()}

    def _fresh(self, last: int) -> Session:
        """The run built afresh (not recorded, not started) with the inputs given up to tick ``last`` scheduled: what
        Why and watch values re-simulate from the start."""
        assert self.fresh is not None
        session = self.fresh()
        for t, item in self.log:
            if t <= last:
                session.schedule_tick(t, item)
        return session

    def _cmd_rewind(self, args: dict[str, Any]) -> dict[str, Any]:
        tick = args.get("tick")
        now = self.session.ticks
        if isinstance(tick, bool) or not isinstance(tick, int) or not 0 <= tick <= now:
            raise ValueError(f"rewind to a tick from 0 to the current {now}, got {tick!r}")
        if self.horizon <= 0:
            raise ValueError("this run keeps no rewind history (--rewind-horizon 0)")
        before = len(self.log)
        dropped = self.rewind(tick)
        inputs = before - len(self.log)
        return {"tick": tick, "dropped": inputs, "reloads_dropped": dropped - inputs}

    def rewind(self, tick: int) -> int:
        """Back to ``tick`` (the loop's thread only): the nearest snapshot at or before it restored, else the run
        built afresh, then re-run to ``tick`` with the inputs given up to it; paused there. Returns how many later
        inputs and reloads were dropped."""
        if tick < self.earliest:
            raise ValueError(self._beyond_horizon(tick))
        snap = next((snap for snap in reversed(self.snapshots) if snap.tick <= tick), None)
        if snap is None and self.factory is None:
            raise ValueError("this run cannot be rewound (it was not started with a way to build it again)")
        keep = [(t, item) for t, item in self.log if t <= tick]
        dropped = len(self.log) - len(keep)
        reloads = [r for r in self.reloads if r[0] <= tick]
        undone = [r for r in self.reloads if r[0] > tick]
        unloaded = len(undone)  # the machine goes back to the one before them
        self.snapshots = [s for s in self.snapshots if snap is not None and s.tick <= snap.tick]
        if snap is None:
            session = self.factory() if self.factory is not None else self.session
            for t, item in keep:
                session.schedule_tick(t, item)
            self.signals = self._first_signals
        else:
            session = self._restore(snap, keep)
            reloads = [r for r in reloads if r[0] > snap.tick]  # those before it are in the snapshot's machine
        self.session = session
        self.log = keep
        self.reloads = [r for r in self.reloads if snap is not None and r[0] <= snap.tick]
        while self.watch_log and self.watch_log[-1][0] > tick:  # the same run up to ``tick``: kept
            self.watch_log.pop()
        self.ended = self.error = self.hit = None
        self.paused = True
        self._budget = 0
        self._to_transition = False
        self._anchor = None
        self._shown = {}  # a new trace: its status is published even if it reads as the last one did
        self._attach(session)
        self._start()
        self._replay(tick, reloads)
        self.messages.append({"kind": "rewound", "tick": self.session.ticks, "dropped": dropped,
                              "reloads_dropped": unloaded, "snapshot": None if snap is None else snap.tick})
        if unloaded:
            self._machine_back(undone, unloaded)
        return dropped + unloaded

    def _machine_back(self, undone: list[tuple[int, Any, dict[str, Any]]], count: int) -> None:
        """A rewind undid ``count`` hot reloads (``undone``): the page served from now on draws the machine that
        runs now, and the pages are told to rebuild themselves from it, as after a reload."""
        document = self.reloads[-1][2].get("document") if self.reloads else self._base_document
        if self.machine_changed is not None:
            self.machine_changed(document)
        file = next((str(info.get("file")) for _at, _plan, info in undone if info.get("file")), "the machine")
        self.messages.append({
            "kind": "reload", "ok": True, "rewound": True, "tick": self.session.ticks, "file": file,
            "text": f"the rewind to tick {self.session.ticks} undid {count} later hot reload{'s' * (count != 1)}, so "
                    "the run goes on with the machine it had then"})

    def _restore(self, snap: Snapshot, keep: list[tuple[int, Input]]) -> Session:
        """The run as it was at ``snap`` (restored in place), its trace cut there, the inputs of ``keep`` after it
        scheduled again (those the run had scheduled then besides, such as ``--signal``, stay)."""
        live: Any = self.session.recorder.out if self.session.recorder is not None else None
        restore(snap)
        session: Session = snap.extra["session"]
        machine = session.machine
        machine.listeners[:] = [lst for lst in machine.listeners if not isinstance(lst, Watch)]
        if session.recorder is not None and live is not None:
            session.recorder.out = live.fork(snap.extra["mark"])
        given = {id(item) for _t, item in self.log}
        session.keep_scheduled(lambda item: id(item) not in given)
        for t, item in keep:
            if t > snap.tick:
                session.schedule_tick(t, item)
        self.signals = snap.extra["signals"]
        self._snap_wall = time.thread_time()
        if self.on_restore is not None:
            self.on_restore(session)
        return session

    def _replay(self, tick: int, reloads: list[tuple[int, Any, dict[str, Any]]]) -> None:
        """Run the session to ``tick`` doing ``reloads`` again on the way (no breakpoint looks at these ticks: they
        were looked at the first time)."""
        session = self.session
        try:
            for at, plan, info in reloads:  # each reload again, before the tick it applied before
                if self.ended is None and session.ticks < at - 1:
                    self._ended_by(session.run(stop_rules=StopRules(max_ticks=at - 1 - session.ticks)).stopped)
                if self.ended is None:
                    self._swap(plan, info)
                    self.signals = info.get("signals", self.signals)
            session = self.session
            if tick > session.ticks and self.ended is None:
                self._ended_by(session.run(stop_rules=StopRules(max_ticks=tick - session.ticks)).stopped)
        except StateRuntimeError as exc:
            self._failed(exc)
        self._watch.clear()
        self._active = active_set(session.machine)
        self._stale = False
        values = expression_values(session.machine, self.signals)
        for bp in self.breakpoints:
            if bp.test is not None and bp.enabled:  # "becomes true" counts from here
                bp.last = bp.test(values) is True
        while self.watch_log and self.watch_log[-1][0] > session.ticks:  # (an error ended the run before ``tick``)
            self.watch_log.pop()
        self._watch_new = []

    def _beyond_horizon(self, tick: int) -> str:
        dt = self.session.dt
        return (f"tick {tick} ({tick * dt:.2f} s) is beyond the rewind horizon: this run can be rewound to tick "
                f"{self.earliest} ({self.earliest * dt:.2f} s) at the earliest (--rewind-horizon {self.horizon:g} s "
                "of simulated time; a longer one keeps more history)")

    # -- snapshots ----------------------------------------------------------------------------------------------
    def _snapshot(self) -> None:
        """After a chunk: a snapshot when one is due (see :data:`SNAPSHOT_PERIOD`) and the run can be snapshotted
        now (its world says so: a car pressed against a wall cannot); then the history beyond the horizon let go."""
        period = self.snapshot_period
        session = self.session
        if period is None or self.ended is not None or not session.machine.started:
            return
        last = self.snapshots[-1].tick if self.snapshots else 0
        age = (session.ticks - last) * session.dt
        if age < period - 1e-9:
            return
        # paced by what a snapshot costs, but never held off past a third of the horizon: else one slow snapshot on
        # a loaded machine keeps the start (and every input since) for the rest of the run, beyond the horizon
        overdue = age >= self.horizon / 3 - 1e-9
        if not overdue and time.thread_time() - self._snap_wall < self._snap_cost / self.snapshot_share:
            return
        recorder = session.recorder
        out: Any = recorder.out if recorder is not None else None
        driver = session.driver
        ready = getattr(driver, "snapshot_ready", None)
        if out is None or not hasattr(out, "fork") or (driver is not None and (ready is None or not ready())):
            return
        t0 = time.thread_time()  # this thread's processor time: neither the other threads nor the load count
        snap = take([session], session.ticks, shared=[out, session.machine.listeners])
        snap.extra.update(session=session, mark=out.mark(), signals=self.signals)
        self.snapshots.append(snap)
        self._snap_wall = time.thread_time()
        cost = self._snap_wall - t0
        self._snap_cost = cost if not self._snap_cost else min(cost, 2 * self._snap_cost)
        self._forget()

    def _forget(self) -> None:
        """Let go what is older than the horizon: the snapshots but the newest one at or before it (the earliest
        tick a rewind reaches from now on), and the inputs and reloads that snapshot holds already."""
        if self.horizon == float("inf"):
            return
        session = self.session
        cut = session.ticks - self.horizon / session.dt
        older = [k for k, snap in enumerate(self.snapshots) if snap.tick <= cut + 1e-9]
        if not older:
            return
        del self.snapshots[:older[-1]]
        first = self.snapshots[0].tick
        self.earliest = first
        kept = [(t, item) for t, item in self.log if t > first]
        self._forgot_inputs = self._forgot_inputs or len(kept) < len(self.log)
        self.log = kept
        gone = [r for r in self.reloads if r[0] <= first]
        if gone:
            self._base_document = gone[-1][2].get("document")
            self.reloads = [r for r in self.reloads if r[0] > first]
        session.forget_applied(first)

    def _news(self) -> bool:
        """Whether a reply or a notice came since the last status: a message waits whose kind is not ``watched``
        (which every status with watches ends with). Read from the loop's thread while a watcher takes messages
        from the left."""
        try:
            return bool(self.messages) and self.messages[-1].get("kind") != "watched"
        except IndexError:  # taken meanwhile
            return False

    def _inputs_shown(self) -> list[list[Any]]:
        """The last 200 inputs as a page lists them, described again only when the log changed (a status is
        published after every chunk of ticks)."""
        log = self.log
        key = (id(log), len(log), id(log[-1][1]) if log else 0)
        if key != self._inputs_key:
            self._inputs_key = key
            self._inputs_list = [[t, item.describe()] for t, item in log[-200:]]
        return self._inputs_list

    def _attach(self, session: Session) -> None:
        """A new listener for ``session``'s transitions (attached to its machine by :meth:`_look` while something
        looks at them)."""
        self._watch = Watch()

    # -- what a watcher sees ----------------------------------------------------------------------------------------
    def _publish(self) -> None:
        session = self.session
        machine = session.machine
        news = self._news()
        if self.watches and machine.started and (not self.watch_log or self.watch_log[-1][0] < session.ticks):
            self._note_watches(session)  # the ticks a page can show, and only those
        if self.ended is not None:
            state = "ended"
        elif self.stopped:
            state = "stopped"
        elif self.paused and not self._budget:
            state = "paused"
        else:
            state = "running"
        snapshot = {
            "tick": session.ticks, "time": round(session.now, 9), "state": state,
            "ended": self.ended, "error": self.error, "outcome": machine.outcome,
            "speed": self.speed, "active": machine.active_paths if machine.started else [],
            "hit": self.hit, "end_tick": self._end if self._end < 2**62 else None,
            "breakpoints": [bp.to_json() for bp in self.breakpoints],
            "inputs": self._inputs_shown(),
            "can_rewind": (self.factory is not None or bool(self.snapshots)) and self.horizon > 0,
            "rewind_from": self.earliest,
            "watches": [{"id": number, "text": text} for number, text, _fn in self.watches],
        }
        if self._watch_new:  # the values since the last publish, to every page (the server writes inf and nan as text)
            self.messages.append({"kind": "watched", "rows": self._watch_new})
            self._watch_new = []
            self._replied = True
        if snapshot == self._shown and not self._replied:  # a paused run looks every IDLE seconds: nothing new
            return
        self._replied = False
        self._shown = snapshot
        self._seq += 1
        self.snapshot = {"seq": self._seq, **snapshot}
        self.urgent = state != "running" or news
        recorder = session.recorder
        now = self.clock()
        if recorder is not None and (state != "running" or now - self._flushed > FLUSH):
            self._flushed = now
            recorder.flush_samples(machine)  # the car where it is, not up to a keyframe period ago
        notify = self.notify
        if notify is not None:
            notify()


def _tick(args: dict[str, Any], key: str, default: int, now: int) -> int:
    tick = args.get(key, default)
    if isinstance(tick, bool) or not isinstance(tick, int) or not 0 <= tick <= now:
        raise ValueError(f"watch_values: {key} is a tick from 0 to the current {now}, got {tick!r}")
    return tick


__all__ = ["CHUNK", "Controller"]
