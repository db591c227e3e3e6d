"""Running a scenario: one deterministic run with a recording listener, then every expectation checked against
the record. A failure names the expectation (and where it is written), what was expected, what happened, the
first tick where the run diverged from it and the trace around that tick.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Container
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

from fsm.loading.loader import compile as compile_spec
from fsm.model.errors import StateRuntimeError, print_traceback, traceback_wanted
from fsm.model.expr import ExprRuntimeError, parse
from fsm.model.jsonpos import pointer
from fsm.runtime.machine import Listener
from fsm.runtime.region import wiring
from fsm.runtime.transition import fired_index
from fsm.session.session import PauseState, Session, SetSignal, SetVars, StopRules, tick_at

from .model import (
    EPS,
    Approx,
    AtExpect,
    EnteredExpect,
    ExitedExpect,
    FinishedExpect,
    InvariantExpect,
    LoadedScenario,
    MonitorsExpect,
    NeverExpect,
    OutcomeExpect,
    Scenario,
    SkippedExpect,
    TemporalExpect,
    TransitionsExpect,
    VisitsExpect,
    active_matches,
    state_matches,
)
from .paths import first_few, prefixes
from .temporal import Count, Formula, Tick, Watch, bounds, tree_names, unbounded, within
from .timeline import PauseChange as PauseInputChange
from .timeline import SignalChange, VarSet, expand, pause_changes

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Fired, Machine
    from fsm.runtime.state import State

#: Trace lines shown before and after the diverging tick.
CONTEXT_BEFORE, CONTEXT_AFTER = 4, 3


class Entry(NamedTuple):
    """A state entered: by a transition (``kind`` its type) or as an initial state (``kind`` ``"initial"``)."""

    tick: int
    time: float
    path: str
    source: str | None
    kind: str


class ActiveChange(NamedTuple):
    """The active leaf paths from ``tick`` on."""

    tick: int
    paths: tuple[str, ...]


class VarChange(NamedTuple):
    """A blackboard variable that changed at ``tick`` (``old`` or ``new`` is ``_UNSET`` when it had no value)."""

    tick: int
    name: str
    old: Any
    new: Any


class MonitorFiring(NamedTuple):
    """A monitor or timeout that fired at ``tick``: its owner's path, its label, ``kind`` (monitor or timeout) and
    behaviour."""

    tick: int
    owner: str
    label: str
    kind: str
    behavior: str


class PauseChange(NamedTuple):
    """A state paused (``paused``) or resumed at ``tick``."""

    tick: int
    path: str
    paused: bool


class Event(NamedTuple):
    """A line of a failure's trace: at ``tick``, sorted by ``order`` within it (inputs, then entries, firings and
    pauses, then variable changes)."""

    tick: int
    order: int
    text: str


class Finish(NamedTuple):
    """A watched state (named by an ``outcome`` expectation's ``state``) that finished at ``tick``."""

    tick: int
    path: str
    outcome: str | None


class Snapshot(NamedTuple):
    """What an ``at`` expectation looks at: active leaf paths, variables, the active states held by a pause and
    those suspended while an exception sequence runs."""

    active: tuple[str, ...]
    vars: dict[str, Any]
    paused: frozenset[str]
    suspended: frozenset[str]


def held_states(machine: Machine) -> tuple[frozenset[str], frozenset[str]]:
    """The paths of the active states held by a pause (their own or an ancestor's) and of those suspended (frozen
    while a monitor's exception sequence runs, not by a pause)."""
    paused: set[str] = set()
    suspended: set[str] = set()
    root = machine.root
    if not root.started:
        return frozenset(), frozenset()
    todo: list[tuple[State[Any], bool]] = [(root.active, False)]
    while todo:
        state, held = todo.pop()
        held = held or state.paused
        if held:
            paused.add(state.path)
        elif wiring(state).frozen_since is not None:
            suspended.add(state.path)
        todo.extend((r.active, held) for r in wiring(state).regions if r.started)
    return frozenset(paused), frozenset(suspended)


class InvariantWatch:
    """An invariant checked after every tick of its window until it first fails."""

    def __init__(self, index: int, text: str, fn: Any, names: list[str], vars_only: bool, first: int, last: int,
                 signals: tuple[str, ...]) -> None:
        self.index = index
        self.text = text
        self.fn = fn
        self.names = names
        self.vars_only = vars_only
        self.first = first
        self.last = last
        self.signals = signals
        self.failed: int | None = None
        #: the failure was reported already (a test by hand raises it once)
        self.reported = False
        self.values: dict[str, Any] = {}
        self.error: str | None = None
        self._errors = (ExprRuntimeError, TypeError, ValueError, ArithmeticError, KeyError)
        #: (name, signal) and (name, car reading) for the names read from outside the variables
        self._signals, self._car = outside_names(names)

    def _values(self, machine: Machine) -> dict[str, Any]:
        """What the expression reads: the variables, and only the signals and car readings it names."""
        ctx = machine.ctx
        if self.vars_only:
            return ctx.vars
        values = dict(ctx.vars)
        values.update((name, ctx.signals.get(signal, False)) for name, signal in self._signals)
        if ctx.car is not None:
            read_car(ctx.car, self._car, values)
        return values

    def check(self, machine: Machine, tick: int) -> None:
        values = self._values(machine)
        try:
            if self.fn(values) is True:
                return
        except self._errors as exc:
            self.error = str(exc)
        self.failed = tick
        self.values = {n: values.get(n, _UNSET) for n in self.names}


def outside_names(names: list[str]) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """The names of signals and car readings among ``names``: (``signal_X``, X) and (``car_Y``, Y)."""
    return ([(n, n[len("signal_"):]) for n in names if n.startswith("signal_")],
            [(n, n[len("car_"):]) for n in names if n.startswith("car_")])


def read_car(car: Any, readings: list[tuple[str, str]], values: dict[str, Any]) -> None:
    """The car readings named (``car_Y``, Y) into ``values`` (numbers only)."""
    for name, reading in readings:
        value = getattr(car, reading, None)
        if isinstance(value, (int, float)):
            values[name] = value


class Recording(Listener):
    """What the run did, tick by tick: states entered (and which of them were skipped by their precondition),
    active leaf paths when they change, variable changes, monitor firings, pauses, the transitions fired, the
    outcomes of watched states, the invariants, and a snapshot at each tick an ``at`` expectation looks at."""

    def __init__(self, snapshot_ticks: Container[int], watched: list[State[Any]] | None = None,
                 invariants: list[InvariantWatch] | None = None, temporal: TemporalRun | None = None) -> None:
        self.entries: list[Entry] = []
        #: indices into ``entries`` of the entries skipped by a precondition
        self.skipped: set[int] = set()
        self.active: list[ActiveChange] = []
        self.var_changes: list[VarChange] = []
        self.snapshots: dict[int, Snapshot] = {}
        self._want = snapshot_ticks
        self._vars: dict[str, Any] = {}
        self._moved = True
        self.monitors: list[MonitorFiring] = []
        self.pauses: list[PauseChange] = []
        #: how many var changes, monitor firings and pauses were recorded (one count to see that one was)
        self.recorded = 0
        #: (source path, transition index) of every transition fired (for coverage)
        self.fired: set[tuple[str, int]] = set()
        self.finishes: list[Finish] = []
        self._watched = {id(s): s for s in watched or ()}
        self._recorded: dict[int, bool] = {k: True for k in self._watched}
        self.invariants = invariants or []
        self.temporal = temporal

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Any) -> None:
        self.monitors.append(MonitorFiring(ctx.tick, owner.path, monitor.label, monitor.kind, monitor.behavior))
        self.recorded += 1

    def on_pause(self, ctx: Context, state: State[Any], paused: bool) -> None:
        self.pauses.append(PauseChange(ctx.tick, state.path, paused))
        self.recorded += 1

    def on_skipped(self, ctx: Context, state: State[Any]) -> None:
        for k in range(len(self.entries) - 1, -1, -1):
            if self.entries[k].path == state.path:
                self.skipped.add(k)
                break
        if id(state) in self._watched:
            self._recorded[id(state)] = True
            self.finishes.append(Finish(ctx.tick, state.path, state.outcome))

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        self.entries.append(Entry(ctx.tick, ctx.now, target.path, source.path if source is not None else None,
                                  transition.type_name if transition is not None else "initial"))
        self._moved = True
        if source is not None and transition is not None:
            self.fired.add((source.path, fired_index(transition)))
        if self._watched:
            if source is not None:  # what was left with the source: record how the watched states in it finished
                self._record_finishes(ctx.tick, source)
            if id(target) in self._watched:
                self._recorded[id(target)] = False

    def on_tick(self, machine: Machine) -> None:
        tick = machine.ctx.tick
        moved = self._moved
        if moved:
            self._moved = False
            self.active.append(ActiveChange(tick, tuple(machine.active_paths)))
        current = machine.ctx.vars
        if current != self._vars or any(type(v) is not type(self._vars.get(k)) for k, v in current.items()):
            self._record_vars(tick, current)
        if self._watched:
            self._record_finishes(tick)
        for inv in self.invariants:
            if inv.failed is None and inv.first <= tick <= inv.last:
                inv.check(machine, tick)
        if self.temporal is not None:
            self.temporal.step(machine, self, tick, moved)
        if tick in self._want:
            self.snapshots[tick] = Snapshot(self.active[-1].paths, dict(current), *held_states(machine))

    def _record_vars(self, tick: int, current: dict[str, Any]) -> None:
        """The variables that changed (in value or type) since the last tick."""
        for name in sorted(set(current) | set(self._vars)):
            old, new = self._vars.get(name, _UNSET), current.get(name, _UNSET)
            if old is not new and (old != new or type(old) is not type(new)):
                self.var_changes.append(VarChange(tick, name, old, new))
                self.recorded += 1
        self._vars = dict(current)

    def _record_finishes(self, tick: int, left: State[Any] | None = None) -> None:
        """How the watched states that finished at this tick (or, with ``left``, in the state left) finished."""
        for key, st in self._watched.items():
            if not self._recorded[key] and st.finished and (left is None or st is left or
                                                            st.path.startswith(left.path + "/")):
                self._recorded[key] = True
                self.finishes.append(Finish(tick, st.path, st.outcome))

    def final(self, machine: Machine) -> Snapshot:
        return Snapshot(tuple(machine.active_paths), dict(machine.ctx.vars), *held_states(machine))

    def active_at(self, tick: int) -> tuple[str, ...]:
        current: tuple[str, ...] = ()
        for t, paths in self.active:
            if t > tick:
                break
            current = paths
        return current

    def exits(self) -> list[tuple[int, str]]:
        """(tick, path) of every state left: no longer active after a tick, or entered again while active (a
        restart, a self-transition); a state entered and skipped in one tick is left in it."""
        out: list[tuple[int, str]] = []
        was: set[str] = set()
        by_tick: dict[int, list[str]] = {}
        for e in self.entries:
            by_tick.setdefault(e.tick, []).append(e.path)
        changes = {c.tick: c.paths for c in self.active}
        states = {e.path for e in self.entries}
        for tick in sorted(set(by_tick) | set(changes)):
            entered = by_tick.get(tick, [])
            for path in entered:
                if path in was:
                    out.append((tick, path))
            leaves = changes.get(tick)
            if leaves is None:
                continue
            now = prefixes(leaves)
            out += [(tick, p) for p in sorted((was | set(entered)) - now) if p in states]
            was = states & now
        return out


class TemporalRun:
    """The temporal expectations of a run (:mod:`.temporal`). The recording tells it each tick whether states moved
    or variables changed; it gathers only what some formula reads (the variables and signals named, entries,
    firings, pauses, the active states, outcomes) and steps only the watches whose formulas read something that
    changed (see :class:`~.temporal.Watch`): a tick where nothing they read moved costs a few tests."""

    def __init__(self, watches: list[Any], outside: list[str], outcome_states: list[State[Any]], dt: float) -> None:
        self.watches = watches
        self.dt = dt
        self.signals, self.car = outside_names(outside)
        self.outcome_states = [(st.path, st) for st in outcome_states]
        self._outcome_keys: dict[str, Any] = {}
        self.now = Tick()
        self.values: dict[str, Any] = {}
        self._entries = 0
        self._monitors = 0
        self._pauses = 0
        self._var_changes = 0
        #: the recording's count of var changes, monitor firings and pauses when last gathered
        self._recorded = -1
        self._active: Any = None
        need: frozenset[str] = frozenset().union(*(w.deps for w in watches))
        self.need_entries = "@entries" in need
        self.need_active = "@active" in need
        self.firsts = {w.first for w in watches}
        #: the next tick is looked at whatever happens: a watch was forced or steps every tick, a firing is to clear
        self.awake = True
        #: read before each tick's look, when a formula reads them: signal levels and the outcomes of states
        self._reads = ([self._read_signals] if self.signals else []) + \
            ([self._read_outcomes] if self.outcome_states else [])

    def at(self, tick: int) -> str:
        return f"tick {tick} (t={round(tick * self.dt, 9):g} s)"

    def time(self, tick: int) -> str:
        return f"{round(tick * self.dt, 9):g}"

    def step(self, machine: Machine, rec: Recording, tick: int, moved: bool) -> None:
        """After each tick: read what the formulas use, and step the watches whose inputs changed."""
        changed: set[str] = set()
        for read in self._reads:
            read(machine.ctx, tick, changed)
        if changed or moved or self.awake or rec.recorded != self._recorded or tick in self.firsts:
            self.now.tick = tick
            self._gather(machine.ctx, rec, changed)
            self._step_watches(tick, changed)

    def _read_signals(self, ctx: Context, tick: int, changed: set[str]) -> None:
        values = self.values
        signals = ctx.signals
        for name, signal in self.signals:
            level = signals.get(signal, False)
            if values.get(name) is not level:
                values[name] = level
                changed.add(name)

    def _read_outcomes(self, ctx: Context, tick: int, changed: set[str]) -> None:
        """A state that finished since the last tick: its outcome, and the tick, into :attr:`now`."""
        for path, st in self.outcome_states:
            outcome = st.outcome
            if outcome is not None:
                key = (wiring(st).entered_at, outcome)
                if self._outcome_keys.get(path) != key:
                    self._outcome_keys[path] = key
                    self.now.outcomes[path] = (tick, outcome)
                    changed.add("@outcome")

    def _gather(self, ctx: Context, rec: Recording, changed: set[str]) -> None:
        """Variables, car readings, entries, monitor firings, pauses and active states into :attr:`now` and
        :attr:`values`; what changed is added to ``changed``."""
        if len(rec.var_changes) != self._var_changes or not self.values:
            self._read_vars(ctx, rec, changed)
        if self.car and ctx.car is not None:
            read_car(ctx.car, self.car, self.values)
        if self.need_entries:
            self._read_entries(rec, changed)
        if len(rec.monitors) != self._monitors or self.now.fired:
            self._read_firings(rec, changed)
        if len(rec.pauses) != self._pauses:
            self._pauses = len(rec.pauses)
            changed.add("@paused")
        if self.need_active and rec.active[-1] is not self._active:
            self._read_active(rec.active[-1], changed)
        self._recorded = rec.recorded

    def _read_vars(self, ctx: Context, rec: Recording, changed: set[str]) -> None:
        changed.update(c.name for c in rec.var_changes[self._var_changes:])
        self._var_changes = len(rec.var_changes)
        self.values.update(ctx.vars)

    def _read_entries(self, rec: Recording, changed: set[str]) -> None:
        """The states entered (and run) and skipped at this tick."""
        now = self.now
        entries = rec.entries
        if len(entries) != self._entries:
            new = range(self._entries, len(entries))
            now.entered = frozenset(entries[k].path for k in new if k not in rec.skipped)
            now.skipped = frozenset(entries[k].path for k in new if k in rec.skipped)
            self._entries = len(entries)
            changed.add("@entries")
        elif now.entered or now.skipped:
            now.entered = now.skipped = frozenset()
            changed.add("@entries")

    def _read_firings(self, rec: Recording, changed: set[str]) -> None:
        """The owners of the monitors that fired at this tick (none: the last tick's are cleared)."""
        self.now.fired = frozenset(f.owner for f in rec.monitors[self._monitors:])
        self._monitors = len(rec.monitors)
        changed.add("@fired")

    def _read_active(self, active: ActiveChange, changed: set[str]) -> None:
        """The active states: every prefix of an active leaf's path."""
        self._active = active
        self.now.active = frozenset("/".join(p.split("/")[:k]) for p in active.paths  # as paths.prefixes, inline:
                                    for k in range(1, p.count("/") + 2))  # it runs on the checked tick
        changed.add("@active")

    def _step_watches(self, tick: int, changed: set[str]) -> None:
        """Step each open watch whose inputs changed, that was forced (it reads one tick's values and they changed
        at the last look), whose window starts, or that steps every tick."""
        now, values, at = self.now, self.values, self.at
        awake = bool(self.car) or bool(now.fired)
        for w in self.watches:
            if w.done:
                continue
            dirty = not w.live_deps.isdisjoint(changed)
            if dirty or w.force or tick == w.first or w.live_every:
                w.step(tick, now, values, at)
                w.force = dirty and w.transient
                awake = awake or w.force or w.live_every
        self.awake = awake


def make_temporal(loaded: LoadedScenario, machine: Machine) -> TemporalRun | None:
    """The watches of the scenario's invariants, temporal expectations and ``at`` ... ``holds`` (all compiled when
    the scenario was loaded: :attr:`LoadedScenario.formulas`), or None when it has none."""
    by_path = machine.states_by_path
    watches: list[Watch] = []
    outside: set[str] = set()
    outcome_paths: set[str] = set()
    for i, exp in enumerate(loaded.scenario.expect):
        formulas = {k: loaded.formulas[i, k].fresh() for k, _text in exp.formulas()}
        for f in formulas.values():
            outcome_paths |= f.state_paths()
            outside |= {n for n in f.deps if n.startswith(("signal_", "car_"))}
            f.bind(by_path)
        if formulas:
            watches += _watches(loaded, i, exp, formulas)
    if not watches:
        return None
    states = [by_path[p] for p in sorted(outcome_paths) if p in by_path]
    return TemporalRun(watches, sorted(outside), states, loaded.dt)


def _watches(loaded: LoadedScenario, i: int, exp: Any, formulas: dict[str, Formula]) -> list[Watch]:
    """The watch of expectation ``i`` with compiled ``formulas``: an invariant, an ``at`` ... ``holds`` or a
    temporal expectation (over its window, with its trigger, span and counts)."""
    dt = loaded.dt
    within = getattr(exp, "within", None)
    first, last = (0, loaded.end_tick) if within is None else (tick_at(within[0], dt), _last_tick(within[1], dt))
    if isinstance(exp, InvariantExpect):
        return [Watch(i, "always", formulas["invariant"], first, last, label="invariant")]
    if isinstance(exp, AtExpect):
        tick = min(tick_at(exp.at, dt), loaded.end_tick)
        return [Watch(i, "at", formulas["holds"], tick, tick, label=f"at {exp.at:g} s")]
    if not isinstance(exp, TemporalExpect):
        return []
    mode = next(k for k in ("always", "never", "eventually") if k in formulas)
    span = exp.ticks if exp.ticks is not None else (tick_at(exp.seconds, dt) if exp.seconds is not None else None)
    return [Watch(i, mode, formulas[mode], first, last, until=formulas.get("until"), after=formulas.get("after"),
                  span=span, nth=exp.nth, count=Count(exp.count, exp.min, exp.max),
                  at=None if exp.at is None else [tick_at(t, dt) for t in exp.at])]


def count_verdict(n: int, c: Any) -> tuple[bool, str]:
    """Whether ``n`` occurrences meet an expectation's ``count`` (or ``min``..``max``, or at least one), and what
    it wanted, in words."""
    if unbounded(c):
        return n >= 1, "at least once"
    return within(n, c), bounds(c, _times)


def _times(n: int) -> str:
    return "once" if n == 1 else f"{n} times"


class _Unset:
    def __repr__(self) -> str:
        return "unset"


_UNSET = _Unset()


@dataclass
class Failure:
    """One expectation that did not hold."""

    index: int
    where: str
    kind: str
    message: str
    tick: int | None = None
    time: float | None = None
    trace: list[str] = field(default_factory=list)

    def lines(self) -> list[str]:
        head = f"{self.where}: expect[{self.index}] {self.kind}: {self.message}" if self.index >= 0 else \
            f"{self.where}: {self.message}"
        return [head] + [f"    {line}" for line in self.trace]


@dataclass
class ScenarioResult:
    """The outcome of one scenario: passed, or the failures; what ran (ticks, simulated and wall time)."""

    name: str
    file: str
    ticks: int = 0
    sim_time: float = 0.0
    wall_time: float = 0.0
    outcome: str | None = None
    failures: list[Failure] = field(default_factory=list)
    #: markers: the reason it was not run, the reason it is expected to fail
    skipped: str | None = None
    xfail: str | None = None

    @property
    def status(self) -> str:
        """passed, failed, skipped, xfailed (expected to fail, and failed) or xpassed (expected to fail, passed)."""
        if self.skipped is not None:
            return "skipped"
        if self.xfail is not None:
            return "xfailed" if self.failures else "xpassed"
        return "failed" if self.failures else "passed"

    @property
    def passed(self) -> bool:
        """Not a failure: passed, skipped, or marked xfail (whether it failed or not, as pytest by default)."""
        return self.status != "failed"

    def summary_line(self) -> str:
        status = self.status
        if status == "skipped":
            return f"SKIP {self.name}: {self.skipped}"
        if status == "xpassed":
            return f"XPASS {self.name} ({self.ticks} ticks, {self.sim_time:g} s): expected to fail: {self.xfail}"
        if status == "xfailed":
            first = self.failures[0]
            return f"XFAIL {self.name}: {self.xfail} (expect[{first.index}] {first.kind}: {first.message})" \
                if first.index >= 0 else f"XFAIL {self.name}: {self.xfail} ({first.message})"
        if self.passed:
            return f"PASS {self.name} ({self.ticks} ticks, {self.sim_time:g} s)"
        first = self.failures[0]
        more = f" (+{len(self.failures) - 1} more)" if len(self.failures) > 1 else ""
        at = f" (tick {first.tick}, t={first.time:g} s)" if first.tick is not None and first.time is not None else ""
        return f"FAIL {self.name}: expect[{first.index}] {first.kind}{at}: {first.message}{more}" \
            if first.index >= 0 else f"FAIL {self.name}: {first.message}"


def expression_names(text: str) -> list[str]:
    """The names an expression reads, in order of first use."""
    return tree_names(parse(text))


def _last_tick(t: float, dt: float) -> int:
    """The last tick whose time is at most ``t``."""
    n = math.floor(t / dt + EPS) if math.isfinite(t / dt) else 2**62
    return max(n, 0)


def run_scenario(loaded: LoadedScenario, coverage: Any = None) -> ScenarioResult:
    """Run the scenario's machine on its timeline and check every expectation; with ``coverage`` (a
    :class:`fsm.tools.scenario.coverage.Coverage`), add what the run entered and fired to it."""
    sc = loaded.scenario
    dt = loaded.dt
    result = ScenarioResult(loaded.name, loaded.file, xfail=loaded.xfail)
    if loaded.skip is not None:
        result.skipped = loaded.skip
        return result
    signals, sets = expand(sc, dt)
    pauses = pause_changes(sc, dt)
    session = _open(loaded)
    machine = session.machine
    machine.ctx.vars.update(loaded.initial_vars)  # a matrix case's initial values: set before the start
    _attach_plants(loaded, machine)
    _schedule(session, signals, sets, pauses)
    at_ticks = {min(tick_at(e.at, dt), loaded.end_tick) for e in sc.expect if isinstance(e, AtExpect)}
    rec = machine.add_listener(Recording(at_ticks, _watched(sc, machine),
                                         temporal=make_temporal(loaded, machine)))
    t0 = time.perf_counter()
    error = _run(session, rec)
    result.wall_time = time.perf_counter() - t0
    result.ticks = machine.ticks
    result.sim_time = round(machine.now, 9)
    result.outcome = machine.outcome
    if coverage is not None:
        coverage.add(machine, rec, key=os.path.normpath(os.path.join(os.path.dirname(loaded.file), sc.machine)))
    check = Checker(loaded, machine, rec, signals, sets, pauses)
    if error is not None:
        result.failures.append(Failure(-1, loaded.file, "error", f"the machine failed: {error}", error.tick,
                                       error.time, check.trace(error.tick)))
    result.failures += [f for i, exp in enumerate(sc.expect) if (f := check.expectation(i, exp)) is not None]
    return result


def _open(loaded: LoadedScenario) -> Session:
    """The run's session: the machine driving the simulated car in the scenario's world, or the machine alone."""
    plan = compile_spec(loaded.spec)
    stop = StopRules(max_ticks=loaded.end_tick)
    if loaded.world_path is None:
        return Session.open(plan, dt=loaded.dt, stop=stop, record=False)
    from fsm.sim import simulate

    sc = loaded.scenario
    return simulate(plan, world=loaded.world_path, seed=sc.seed, noise=sc.noise, dt=loaded.dt, stop=stop)


def _attach_plants(loaded: LoadedScenario, machine: Machine) -> None:
    """Attach the scenario's plants to the machine."""
    for cls, params in loaded.plants:
        cls(params).attach(machine)


def _schedule(session: Session, signals: list[SignalChange], sets: list[VarSet],
              pauses: list[PauseInputChange]) -> None:
    """The scenario's inputs given to the session, each before the first tick at or after its time."""
    for change in signals:
        session.schedule(change.time, SetSignal(change.name, change.level))
    for s in sets:
        session.schedule(s.time, SetVars(s.values))
    for pc in pauses:
        session.schedule(pc.time, PauseState(pc.path, pc.paused))


def _watched(sc: Scenario, machine: Machine) -> list[Any]:
    """The states whose outcomes an expectation names (``{"outcome": ..., "state": ...}``)."""
    return [st for path, st in machine.states_by_path.items() if _outcome_named(sc, path)]


def _outcome_named(sc: Scenario, path: str) -> bool:
    """An ``outcome`` expectation names the state at ``path`` (``{"outcome": ..., "state": ...}``)."""
    return any(state_matches(e.state, path) for e in sc.expect if isinstance(e, OutcomeExpect) and e.state is not None)


def _run(session: Session, rec: Recording) -> StateRuntimeError | None:
    """Start and run the session (the recording sees the first tick); the error a state raised, if one did."""
    try:
        session.start()
        rec.on_tick(session.machine)
        session.run()
    except StateRuntimeError as exc:
        if traceback_wanted():
            print_traceback(exc)
        return exc
    return None


def _shown(value: Any) -> str:
    if value is _UNSET:
        return "unset"
    try:
        return json.dumps(value, ensure_ascii=False)
    except (TypeError, ValueError):
        return repr(value)


def _same(expected: Any, got: Any) -> bool:
    """JSON equality: kinds must agree (true is not 1), numbers compare by value (3 == 3.0)."""
    if bool not in (type(expected), type(got)) and isinstance(expected, (int, float)) and \
            isinstance(got, (int, float)):
        return expected == got or (isinstance(expected, float) and isinstance(got, float)
                                   and math.isclose(expected, got, rel_tol=1e-12, abs_tol=0.0))
    return type(expected) is type(got) and expected == got


def _unmet(want: Any, got: Any) -> str | None:
    """``want`` as a failure says it, when ``got`` is not it (nor within its tolerance); else ``None``."""
    if isinstance(want, Approx):
        close = isinstance(got, (int, float)) and not isinstance(got, bool) and \
            abs(got - want.value) <= want.tolerance * (1 + 1e-12) + 1e-12
        return None if close else f"{want.value:g} ± {want.tolerance:g}"
    return None if _same(want, got) else _shown(want)


def _inactive(exp: AtExpect, active: tuple[str, ...]) -> list[str]:
    """The states ``exp.active`` names that are not active, said as one problem."""
    wanted = [exp.active] if isinstance(exp.active, str) else exp.active or []
    missing = [w for w in wanted if not any(active_matches(w, p) for p in active)]
    if not missing:
        return []
    return [f"expected {', '.join(repr(w) for w in missing)} active, active: " + (", ".join(active) or "(none)")]


def _wrong_held(exp: AtExpect, snap: Snapshot) -> list[str]:
    """The states of ``exp.paused`` and ``exp.suspended`` held (or not) other than expected."""
    problems = []
    for key, held in (("paused", snap.paused), ("suspended", snap.suspended)):
        for name, want_held in (getattr(exp, key) or {}).items():
            is_held = any(state_matches(name, p) for p in held)
            if is_held != want_held:
                shown = ", ".join(sorted(held)) or "none"
                problems.append(f"expected '{name}' {'' if want_held else 'not '}{key}, it was "
                                f"{'' if is_held else 'not '}({key}: {shown})")
    return problems


class Checker:
    """Checks expectations against a run's record (``rec``) and the machine as it ended; a failure keeps the
    trace around its first diverging tick."""
    def __init__(self, loaded: LoadedScenario, machine: Machine, rec: Recording, signals: list[Any],
                 sets: list[Any], pauses: list[Any] | None = None) -> None:
        self.loaded = loaded
        self.pause_inputs = list(pauses or ())
        self.machine = machine
        self.rec = rec
        self.dt = loaded.dt
        self.signals = signals
        self.sets = sets
        self.last_tick = machine.ticks
        #: expectation index -> (watch, verdict) of the formulas checked during the run
        self.verdicts: dict[int, tuple[Any, Any]] = {}
        temporal = rec.temporal
        if temporal is not None:
            for w in temporal.watches:
                self.verdicts[w.index] = (w, w.finish(self.last_tick, temporal.at, temporal.time))

    def t(self, tick: int) -> float:
        return round(tick * self.dt, 9)

    def at(self, tick: int) -> str:
        return f"tick {tick} (t={self.t(tick):g} s)"

    def failure(self, i: int, kind: str, message: str, tick: int | None) -> Failure:
        where = self.loaded.where(pointer("expect", i))
        return Failure(i, where, kind, message, tick, None if tick is None else self.t(tick),
                       self.trace(tick) if tick is not None else [])

    # -- the trace ----------------------------------------------------------------------------------------
    def events(self) -> list[Event]:
        """What happened, in tick order: the run's own events, the scenario's inputs and the failed checks."""
        out = self._run_events() + self._input_events() + self._check_events()
        out.sort(key=lambda e: (e.tick, e.order))
        return out

    def _run_events(self) -> list[Event]:
        rec = self.rec
        out: list[Event] = []
        for e in rec.entries:
            how = "initial" if e.kind == "initial" else f"{e.kind} from {e.source}"
            out.append(Event(e.tick, 1, f"enter {e.path} ({how})"))
        for k in sorted(rec.skipped):
            e = rec.entries[k]
            out.append(Event(e.tick, 1, f"skip {e.path} (precondition false)"))
        out += [Event(fin.tick, 1, f"finished {fin.path}: {fin.outcome}") for fin in rec.finishes
                if _outcome_named(self.loaded.scenario, fin.path)]
        out += [Event(tick, 2, f"var {name}: {_shown(old)} -> {_shown(new)}")
                for tick, name, old, new in rec.var_changes]
        out += [Event(tick, 1, f"{kind} of {owner} fired ({label}): {behavior}")
                for tick, owner, label, kind, behavior in rec.monitors]
        out += [Event(tick, 1, f"{'pause' if paused else 'resume'} {path}") for tick, path, paused in rec.pauses]
        return out

    def _input_events(self) -> list[Event]:
        last = self.last_tick
        out = [Event(c.tick, 0, f"signal {c.name} {'high' if c.level else 'low'} (at {c.time:g} s, input {c.index})")
               for c in self.signals if c.tick <= last]
        out += [Event(s.tick, 0, f"set {', '.join(f'{k} = {_shown(v)}' for k, v in s.values.items())} "
                                 f"(input {s.index})") for s in self.sets if s.tick <= last]
        out += [Event(pc.tick, 0, f"{'pause' if pc.paused else 'resume'} {pc.path} (input {pc.index})")
                for pc in self.pause_inputs if pc.tick <= last]
        return out

    def _check_events(self) -> list[Event]:
        out = [Event(inv.failed, 3, f"invariant {inv.text} false") for inv in self.rec.invariants
               if inv.failed is not None]
        out += [Event(verdict.tick, 3, f"invariant {w.body.text} false" if w.label == "invariant" else
                      f"{w.label} {w.body.text} failed")
                for w, verdict in self.verdicts.values() if verdict is not None]
        return out

    def trace(self, tick: int) -> list[str]:
        """The trace lines around ``tick`` (marked ``>``) and the active states at that tick."""
        events = self.events()
        before = [e for e in events if e.tick < tick][-CONTEXT_BEFORE:]
        at = [e for e in events if e.tick == tick]
        after = [e for e in events if e.tick > tick][:CONTEXT_AFTER]
        lines = [f"  tick {e.tick:>6} t={self.t(e.tick):<9g} {e.text}" for e in before]
        lines += [f"> tick {e.tick:>6} t={self.t(e.tick):<9g} {e.text}" for e in at]
        if not at:
            lines.append(f"> tick {tick:>6} t={self.t(tick):<9g} (nothing happened)")
        lines += [f"  tick {e.tick:>6} t={self.t(e.tick):<9g} {e.text}" for e in after]
        active = self.rec.active_at(tick)
        lines.append(f"  active at tick {tick}: {', '.join(active) or '(none)'}")
        return lines

    # -- the expectations ---------------------------------------------------------------------------------
    def expectation(self, i: int, exp: Any) -> Failure | None:
        """The failure of expectation ``i`` (``exp``) in this run, or ``None`` when it holds."""
        check: Callable[[Checker, int, Any], Failure | None] = _CHECKS[type(exp)]
        return check(self, i, exp)

    def outcome(self, i: int, exp: OutcomeExpect) -> Failure | None:
        """The machine (or the state named) finishes with this outcome (within the window, if given)."""
        if exp.state is not None:
            return self.state_outcome(i, exp)
        m = self.machine
        fin = end = self.last_tick  # the run stops in the tick the machine finishes
        if m.outcome == exp.outcome:
            return None if self.inside(fin, exp.within) else self.failure(
                i, "outcome", f"expected outcome '{exp.outcome}'{self.window(exp.within)}, the machine finished "
                              f"with it at {self.at(fin)}", fin)
        if m.outcome is None:
            return self.failure(i, "outcome", f"expected outcome '{exp.outcome}', but the machine had not "
                                              f"finished when the run ended at {self.at(end)}", end)
        return self.failure(i, "outcome", f"expected outcome '{exp.outcome}', got '{m.outcome}' "
                                          f"(finished in {m.root.active.path} at {self.at(fin)})", fin)

    def finished(self, i: int, exp: FinishedExpect) -> Failure | None:
        """The machine has (or has not) finished when the run ends."""
        m = self.machine
        fin = end = self.last_tick  # the run stops in the tick the machine finishes
        if m.finished == exp.finished:
            return None
        if exp.finished:
            return self.failure(i, "finished", f"expected the machine to finish, but it was still in "
                                               f"{m.active_path} when the run ended at {self.at(end)}", end)
        return self.failure(i, "finished", f"expected the machine not to finish, but it finished with "
                                           f"'{m.outcome}' at {self.at(fin)}", fin)

    def never(self, i: int, exp: NeverExpect) -> Failure | None:
        """None of these states is entered."""
        for e in self.rec.entries:
            hit = next((n for n in exp.never if state_matches(n, e.path)), None)
            if hit is not None:
                return self.failure(i, "never", f"'{hit}' was entered ({e.path}) at {self.at(e.tick)}", e.tick)
        return None

    def transitions(self, i: int, exp: TransitionsExpect) -> Failure | None:
        """The number of transitions fired is within the bounds."""
        c = exp.transitions
        n = self.machine.transition_count
        if within(n, c):
            return None
        want = bounds(c, str)
        fired = [e for e in self.rec.entries if e.kind != "initial"]
        limit = c.count if c.count is not None else c.max
        tick = fired[limit].tick if limit is not None and n > limit else self.last_tick
        return self.failure(i, "transitions", f"expected {want} transitions, {n} fired", tick)

    def entered(self, i: int, exp: EnteredExpect) -> Failure | None:
        """A state is entered and runs, as often as counted."""
        rec = self.rec
        ran = [(e.tick, e.path) for k, e in enumerate(rec.entries)
               if k not in rec.skipped and state_matches(exp.entered, e.path)]
        return self.counted(i, "entered", exp, ran, f"'{exp.entered}' to be entered (and run)")

    def skipped(self, i: int, exp: SkippedExpect) -> Failure | None:
        """A state is skipped by its precondition, as often as counted."""
        rec = self.rec
        skipped = [(rec.entries[k].tick, rec.entries[k].path) for k in sorted(rec.skipped)
                   if state_matches(exp.skipped, rec.entries[k].path)]
        return self.counted(i, "skipped", exp, skipped, f"'{exp.skipped}' to be skipped by its precondition")

    def exited(self, i: int, exp: ExitedExpect) -> Failure | None:
        """A state is left, as often as counted."""
        left = [(t, p) for t, p in self.rec.exits() if state_matches(exp.exited, p)]
        return self.counted(i, "exited", exp, left, f"'{exp.exited}' to be left")

    # -- windows and counts -------------------------------------------------------------------------------
    def inside(self, tick: int, within: list[float] | None) -> bool:
        if within is None:
            return True
        t = tick * self.dt
        return within[0] - EPS <= t <= within[1] + EPS

    @staticmethod
    def window(within: list[float] | None) -> str:
        """`` between A s and B s`` (with its leading space), or nothing without a window."""
        return "" if within is None else f" between {within[0]:g} s and {within[1]:g} s"

    def counted(self, i: int, kind: str, c: Any, events: list[tuple[int, str]], what: str) -> Failure | None:
        """An event that must happen ``count`` (or ``min``..``max``, or at least one) times within a window."""
        inside = [e for e in events if self.inside(e[0], c.within)]
        n = len(inside)
        ok, want = count_verdict(n, c)
        if ok:
            return None
        msg = f"expected {what} {want}{self.window(c.within)}, it happened {_times(n)}"
        if n:
            msg += f" (at {self._times_of(inside, 6)} s)"
        outside = [e for e in events if not self.inside(e[0], c.within)]
        if outside:
            msg += (f"; outside the window at {', '.join(f'{self.t(t):g}' for t, _p in outside[:4])} s"
                    + (", ..." if len(outside) > 4 else ""))
        return self.failure(i, kind, msg, self._count_tick(c, inside))

    def _times_of(self, events: list[tuple[int, str]], shown: int) -> str:
        """The times of the first ``shown`` events in seconds, "..." after them when there are more."""
        return first_few([f"{self.t(t):g}" for t, _p in events], shown)

    def _count_tick(self, c: Any, inside: list[tuple[int, str]]) -> int:
        """Where a count failed: at the event one too many, else at the end of the window (or of the run)."""
        limit: int | None = c.count if c.count is not None else c.max
        return inside[limit][0] if limit is not None and len(inside) > limit else self._window_end(c.within)

    def _window_end(self, within: list[float] | None) -> int:
        """The last tick of a window (or of the run) that the run reached."""
        return self.last_tick if within is None else min(_last_tick(within[1], self.dt), self.last_tick)

    def state_outcome(self, i: int, exp: OutcomeExpect) -> Failure | None:
        assert exp.state is not None
        fins = [f for f in self.rec.finishes if state_matches(exp.state, f.path)]
        if any(f.outcome == exp.outcome and self.inside(f.tick, exp.within) for f in fins):
            return None
        seen = "; ".join(f"{f.path} finished with '{f.outcome}' at {self.at(f.tick)}" for f in fins[:4]) or \
            "it never finished"
        tick = next((f.tick for f in fins if self.inside(f.tick, exp.within)),
                    fins[0].tick if fins else self._window_end(exp.within))
        return self.failure(i, "outcome", f"expected '{exp.state}' to finish with '{exp.outcome}'"
                                          f"{self.window(exp.within)}: {seen}", tick)

    def invariant(self, i: int, exp: InvariantExpect) -> Failure | None:
        if i in self.verdicts:
            return self.formula(i)
        inv = next(w for w in self.rec.invariants if w.index == i)  # by hand: MachineTest.always
        if inv.failed is None:
            return None
        values = ", ".join(f"{n} = {_shown(v)}" for n, v in inv.values.items())
        why = f"could not be evaluated: {inv.error}" if inv.error else "is false"
        return self.failure(i, "invariant", f"'{exp.invariant}' {why} at {self.at(inv.failed)}"
                                            f"{' (' + values + ')' if values else ''}", inv.failed)

    def formula(self, i: int, exp: Any = None) -> Failure | None:
        """A formula's verdict (an invariant, a temporal expectation, an ``at``'s ``holds``)."""
        watch, verdict = self.verdicts[i]
        if verdict is None:
            return None
        return self.failure(i, watch.label, verdict.message, min(verdict.tick, self.last_tick))

    def monitor_check(self, i: int, exp: MonitorsExpect) -> Failure | None:
        c = exp.monitors
        fired = [f for f in self.rec.monitors if self._is_firing_of(c, f)]
        ok, want = count_verdict(len(fired), c)
        if ok:
            return None if c.at is None else self._monitor_times(i, c, fired)
        what = ("" if c.behavior is None else f" with {c.behavior}") + self.window(c.within)
        tick = self._count_tick(c, [(f.tick, f.owner) for f in fired])
        return self.failure(i, "monitors", f"expected a monitor of '{c.owner}'{what} to fire {want}, it fired "
                                           f"{_times(len(fired))}", tick)

    def _is_firing_of(self, c: Any, f: MonitorFiring) -> bool:
        """A firing of a monitor of ``c``'s owner (with its behavior and kind, when given) in its window."""
        return state_matches(c.owner, f.owner) and (c.behavior is None or f.behavior == c.behavior) and \
            (c.kind is None or f.kind == c.kind) and self.inside(f.tick, c.within)

    def _monitor_times(self, i: int, c: Any, fired: list[MonitorFiring]) -> Failure | None:
        """A monitor's firings at exactly the ticks of ``c.at``, or a failure at the first that differs."""
        wanted = [tick_at(t, self.dt) for t in c.at]
        got = [f.tick for f in fired]
        if got == wanted:
            return None
        first = next((k for k, (a, b) in enumerate(zip(got, wanted, strict=False)) if a != b),
                     min(len(got), len(wanted)))
        tick = got[first] if first < len(got) else (wanted[first] if first < len(wanted) else self.last_tick)
        times = [round(f.tick * self.dt, 9) for f in fired]
        return self.failure(i, "monitors", f"expected the monitor of '{c.owner}' to fire at "
                                           f"{', '.join(f'{t:g}' for t in c.at)} s, it fired at "
                                           f"{', '.join(f'{t:g}' for t in times) or 'no time'} s",
                            min(tick, self.last_tick))

    def visits(self, i: int, exp: VisitsExpect) -> Failure | None:
        wanted = exp.visits
        entries = self.rec.entries
        pos = 0
        last: Entry | None = None
        for k, name in enumerate(wanted):
            found = next((j for j in range(pos, len(entries)) if state_matches(name, entries[j].path)), None)
            if found is None:
                after = f"after '{wanted[k - 1]}' ({last.path} at {self.at(last.tick)})" if last else "at all"
                return self._not_visited(i, name, after, pos, last)
            last = entries[found]
            pos = found + 1
        return None

    def _not_visited(self, i: int, name: str, after: str, pos: int, last: Entry | None) -> Failure:
        """``visits``: ``name`` was not entered after the entry ``pos - 1`` (``last``); when it was before, and
        what was entered next."""
        entries = self.rec.entries
        earlier = next((e for e in entries[:pos] if state_matches(name, e.path)), None)
        # the next state entered, not counting the initial sub-states entered together with the last match
        nxt = next((e for e in entries[pos:] if last is None or e.tick != last.tick
                    or not e.path.startswith(last.path + "/")), None)
        msg = f"expected '{name}' to be entered {after}, but it never was"
        if earlier is not None:
            msg += f" (only before, at {self.at(earlier.tick)})"
        if nxt is None:
            return self.failure(i, "visits", msg + "; nothing was entered after that until the run ended at "
                                f"{self.at(self.last_tick)}", self.last_tick)
        return self.failure(i, "visits", msg + f"; next entered: {nxt.path} at {self.at(nxt.tick)}", nxt.tick)

    def at_check(self, i: int, exp: AtExpect) -> Failure | None:
        tick = tick_at(exp.at, self.dt)
        snap = self.rec.snapshots.get(tick)
        if snap is None:  # the machine finished (or the run ended) before: it stays as it ended
            snap = self.rec.final(self.machine)
        verdict = self.verdicts[i][1] if exp.holds is not None else None
        problems = [*_inactive(exp, snap.active), *self._wrong_vars(exp, snap.vars, tick), *_wrong_held(exp, snap),
                    *([verdict.message] if verdict is not None else [])]
        if not problems:
            return None
        ended = "" if tick <= self.last_tick else f" (the run ended before, at {self.at(self.last_tick)})"
        return self.failure(i, f"at {exp.at:g} s", "; ".join(problems) + ended, min(tick, self.last_tick))

    def _wrong_vars(self, exp: AtExpect, values: dict[str, Any], tick: int) -> list[str]:
        """The variables of ``exp.vars`` without their expected value (or within its tolerance) at ``tick``."""
        problems = []
        for name, want in (exp.vars or {}).items():
            got = values.get(name, _UNSET)
            expected = _unmet(want, got)
            if expected is None:
                continue
            changed = [c for c in self.rec.var_changes if c.name == name and c.tick <= tick]
            since = f" (since {self.at(changed[-1].tick)})" if changed else ""
            problems.append(f"expected {name} = {expected}, got {_shown(got)}{since}")
        return problems


#: The check of each kind of expectation.
_CHECKS: dict[type, Callable[[Checker, int, Any], Failure | None]] = {
    OutcomeExpect: Checker.outcome, FinishedExpect: Checker.finished, VisitsExpect: Checker.visits,
    NeverExpect: Checker.never, AtExpect: Checker.at_check, TemporalExpect: Checker.formula,
    TransitionsExpect: Checker.transitions, MonitorsExpect: Checker.monitor_check, EnteredExpect: Checker.entered,
    SkippedExpect: Checker.skipped, ExitedExpect: Checker.exited, InvariantExpect: Checker.invariant,
}
