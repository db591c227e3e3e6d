"""Generated paths (``fsmctl test --explore``): search the space of a machine's inputs on the simulated clock for
input sequences that reach every state, fire every transition and every monitor, as @xstate/test does for
statecharts.

The space is bounded by the user: every ``step`` seconds one input may change (a signal the machine reads goes high
or low, a variable given with ``--var`` takes one of its values, or nothing), for at most ``duration`` seconds. The
search is breadth first over input sequences, each run from the start (runs are deterministic): a sequence that
reached something new is kept and extended, by one input at every later slot. What it reaches is written as
scenario files whose expectations (the states visited, how the run ended) the user confirms; what it could not
reach is reported with why (the bound it hit). Invariants are checked on every path; the first violation is cut
down to a minimal input sequence (inputs dropped one at a time while it still fails) and written as a scenario
that reproduces it.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.runtime.machine import Listener
from fsm.runtime.region import transition_wiring, wiring
from fsm.runtime.supervisor import supervisor_of
from fsm.runtime.transition import fired_index
from fsm.session.session import Session, SetSignal, SetVars, StopRules, ticks_for

from .paths import first_few

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Machine
    from fsm.runtime.state import State

#: One input at a slot: ("wait",), ("signal", name, level) or ("set", name, value).
Action = tuple[Any, ...]
WAIT: Action = ("wait",)
#: What the run is given for an action, and how a scenario writes it (the wait is neither).
_EVENTS: dict[str, Callable[[Action], Any]] = {"signal": lambda a: SetSignal(a[1], a[2]),
                                               "set": lambda a: SetVars({a[1]: a[2]})}
_INPUTS: dict[str, Callable[[Action], dict[str, Any]]] = {"signal": lambda a: {"signal": a[1], "value": a[2]},
                                                          "set": lambda a: {"set": {a[1]: a[2]}}}


@dataclass
class Space:
    """The bounded input space: signals, variables and their values, the slot length and the horizon."""

    signals: list[str]
    values: dict[str, list[Any]]
    step: float
    duration: float
    dt: float

    @property
    def slots(self) -> int:
        return max(1, math.floor(self.duration / self.step + 1e-9))

    def actions(self) -> list[Action]:
        out: list[Action] = []
        for s in self.signals:
            out += [("signal", s, True), ("signal", s, False)]
        for name, values in self.values.items():
            out += [("set", name, v) for v in values]
        return out


class _Reach(Listener):
    """What one run reached: states entered (and ran), transitions fired, monitors fired, in order."""

    def __init__(self, invariants: list[tuple[str, Any]]) -> None:
        self.entered: list[str] = []
        self.skipped: set[str] = set()
        self.fired: set[tuple[str, int]] = set()
        self.monitors: set[tuple[str, str, str]] = set()
        self.invariants = invariants
        self.violation: tuple[int, str] | None = None

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any], transition: Any) -> None:
        self.entered.append(target.path)
        if source is not None and transition is not None:
            self.fired.add((source.path, fired_index(transition)))

    def on_skipped(self, ctx: Context, state: State[Any]) -> None:
        self.skipped.add(state.path)

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Any) -> None:
        self.monitors.add((owner.path, monitor.label, monitor.kind))

    def on_tick(self, machine: Machine) -> None:
        if self.violation is None and self.invariants:
            values = dict(machine.ctx.vars)
            values.update({f"signal_{k}": v for k, v in machine.ctx.signals.items()})
            for text, fn in self.invariants:
                try:
                    ok = fn(values) is True
                except Exception:  # a variable without a value, a division by zero: a violation too
                    ok = False
                if not ok:
                    self.violation = (machine.ctx.tick, text)
                    return

    def targets(self) -> set[str]:
        ran = set(self.entered) - self.skipped  # a step only skipped by its precondition did not run
        return ({f"state {p}" for p in ran} | {f"transition {s}#{i}" for s, i in self.fired}
                | {f"monitor {o}: {k} {label}" for o, label, k in self.monitors})


@dataclass
class ExploreResult:
    """What the search found: per target the input sequence that first reached it, the targets it could not reach,
    the invariant violation (minimal) if any, the runs made and the time taken."""

    targets: list[str]
    reached: dict[str, tuple[Action, ...]] = field(default_factory=dict)
    runs: int = 0
    seconds: float = 0.0
    exhausted: bool = False
    violation: tuple[tuple[Action, ...], int, str] | None = None

    @property
    def unreached(self) -> list[str]:
        return [t for t in self.targets if t not in self.reached]


class Explorer:
    """The search over one machine (a compiled plan, the plants behind it) in a :class:`Space`."""

    def __init__(self, plan: Any, plants: list[tuple[type, Any]], space: Space,
                 invariants: list[tuple[str, Any]]) -> None:
        self.plan = plan
        self.plants = plants
        self.space = space
        self.invariants = invariants

    def run(self, path: tuple[Action, ...]) -> tuple[_Reach, Machine]:
        """One run with the inputs of ``path`` (input k before the first tick at k * step)."""
        sp = self.space
        stop = StopRules(max_ticks=ticks_for(sp.duration, sp.dt))
        session = Session.open(self.plan, dt=sp.dt, stop=stop, record=False)
        machine = session.machine
        for cls, params in self.plants:
            cls(params).attach(machine)
        for k, action in enumerate(path):
            if action[0] in _EVENTS:
                session.schedule(k * sp.step, _EVENTS[action[0]](action))
        reach = machine.add_listener(_Reach(self.invariants))
        try:
            session.start()
            reach.on_tick(machine)
            session.run()
        except Exception as exc:  # a machine that fails on this path: said as a violation of running at all
            if reach.violation is None:
                reach.violation = (machine.ctx.tick, f"the machine failed: {exc}")
        return reach, machine

    def targets(self, machine: Machine) -> list[str]:
        out = []
        for path, state in machine.states_by_path.items():
            out.append(f"state {path}")
            out += [f"transition {path}#{transition_wiring(t).index}" for t in wiring(state).transitions]
            w = supervisor_of(state)
            out += [f"monitor {path}: {m.kind} {m.label}" for m in (w.monitors if w is not None else ())]
        return out

    def search(self, max_runs: int, deadline: float | None = None) -> ExploreResult:
        """Breadth first over input sequences (a wait or an action per slot) until every target is reached (and,
        with invariants, one breaks) or ``max_runs`` runs or ``deadline`` seconds are spent."""
        t0 = time.perf_counter()
        first, machine = self.run(())
        result = ExploreResult(self.targets(machine), runs=1)
        for t in first.targets():
            result.reached.setdefault(t, ())
        self._violation(result, (), first)
        wanted = set(result.targets)
        queue: deque[tuple[Action, ...]] = deque([()])
        actions = self.space.actions()

        def over_budget() -> bool:
            return result.runs >= max_runs or (deadline is not None and time.perf_counter() - t0 > deadline)

        while queue and not result.exhausted and not self._done(result, wanted):
            self._extend(result, queue, actions, wanted, over_budget)
        if result.violation is not None:
            result.violation = self._minimal(*result.violation)
        result.seconds = time.perf_counter() - t0
        return result

    def _done(self, result: ExploreResult, wanted: set[str]) -> bool:
        """Every target reached and, with invariants (every path is extended until one breaks), one broken."""
        return wanted <= set(result.reached) and not (self.invariants and result.violation is None)

    def _extend(self, result: ExploreResult, queue: deque[tuple[Action, ...]], actions: list[Action],
                wanted: set[str], over_budget: Callable[[], bool]) -> None:
        """Run the next prefix of the queue followed by each action after each number of waits; a path that reached
        something new (or any, while hunting for a broken invariant) is queued to be extended in turn."""
        prefix = queue.popleft()
        hunting = bool(self.invariants)
        for gap, action in itertools.product(range(self.space.slots - len(prefix)), actions):
            if over_budget():
                result.exhausted = True
                return
            path = (*prefix, *([WAIT] * gap), action)
            if self._try(result, path) or (hunting and result.violation is None):
                queue.append(path)
            if hunting and result.violation is not None and wanted <= set(result.reached):
                return

    def _try(self, result: ExploreResult, path: tuple[Action, ...]) -> bool:
        """One run of ``path`` into ``result`` (its first broken invariant, the targets it reached first); whether
        it reached a target no path had."""
        reach, _m = self.run(path)
        result.runs += 1
        self._violation(result, path, reach)
        new = [t for t in reach.targets() if t not in result.reached]
        for t in new:
            result.reached[t] = path
        return bool(new)

    def _violation(self, result: ExploreResult, path: tuple[Action, ...], reach: _Reach) -> None:
        if result.violation is None and reach.violation is not None:
            result.violation = (path, *reach.violation)

    def _minimal(self, path: tuple[Action, ...], tick: int, text: str) -> tuple[tuple[Action, ...], int, str]:
        """Drop inputs (make them waits) one at a time while the same invariant still fails; trailing waits go."""
        current = list(path)
        for k in range(len(current)):
            if current[k] == WAIT:
                continue
            trial = current[:k] + [WAIT] + current[k + 1:]
            reach, _m = self.run(tuple(trial))
            if reach.violation is not None and reach.violation[1] == text:
                current, tick = trial, reach.violation[0]
        while current and current[-1] == WAIT:
            current.pop()
        return tuple(current), tick, text


# -- writing the scenarios ------------------------------------------------------------------------------------------
def scenario_doc(path: tuple[Action, ...], space: Space, machine_ref: str, base: dict[str, Any], reach: _Reach,
                 machine: Machine, what: list[str], expect: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """A scenario that replays ``path``: its inputs, and as expectations what the run showed (to confirm)."""
    inputs = [{"at": round(k * space.step, 9), **_INPUTS[action[0]](action)} for k, action in enumerate(path)
              if action[0] in _INPUTS]
    visits = [p for p, _same in itertools.groupby(reach.entered)]
    if expect is None:
        expect = [{"visits": visits}]
        expect.append({"outcome": machine.outcome} if machine.finished else {"finished": False})
    doc: dict[str, Any] = {"description": "Generated by fsmctl test --explore; it reaches " + first_few(what, 6)
                           + ". Confirm the expectations: they say what the "
                           "run did, not what it should do.", "machine": machine_ref, **base,
                           "dt": space.dt, "duration": space.duration, "inputs": inputs, "expect": expect}
    return doc


def write_scenarios(explorer: Explorer, result: ExploreResult, folder: Any, machine_file: str,
                    base: dict[str, Any], out_dir: str) -> list[str]:
    """One scenario per input sequence that first reached something (its targets named), and the violation's."""
    ref = os.path.relpath(os.path.abspath(machine_file), os.path.abspath(out_dir))
    by_path: dict[tuple[Action, ...], list[str]] = {}
    for target, path in result.reached.items():
        by_path.setdefault(path, []).append(target)
    names = []
    for n, (path, what) in enumerate(sorted(by_path.items(), key=lambda kv: (len(kv[0]), str(kv[0])))):
        reach, machine = explorer.run(path)
        name = f"explore_{n + 1:03d}.scenario.json"
        folder.write(name, json.dumps(scenario_doc(path, explorer.space, ref, base, reach, machine, what), indent=1)
                     + "\n")
        names.append(name)
    if result.violation is not None:
        path, _tick, text = result.violation
        reach, machine = explorer.run(path)
        expect = [{"invariant": text}] if not text.startswith("the machine failed") else [{"finished": True}]
        doc = scenario_doc(path, explorer.space, ref, base, reach, machine, [f"a violation of '{text}'"], expect)
        doc["description"] = (f"Generated by fsmctl test --explore: the shortest input sequence found that breaks "
                              f"'{text}' (inputs dropped while it still breaks it). It fails until that is fixed.")
        folder.write("violation.scenario.json", json.dumps(doc, indent=1) + "\n")
        names.append("violation.scenario.json")
    return names


__all__ = ["Action", "ExploreResult", "Explorer", "Space", "scenario_doc", "write_scenarios"]
