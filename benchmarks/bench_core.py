#!/usr/bin/env python
"""Core benchmark of tral-fsm against its peers (issue 2, "Performance").

Workloads, all measured in one run on the same machine:

  flat    (a) a ring of 100 states, each leaving by ``Always`` to the next: transitions per second.
  nested  (b) three levels of nesting, 10 x 10 x 10: a root ring of 10 composites, each a chain of 10
              composites, each a chain of 10 leaves (``Always``) ending in a ``Final``; composites
              leave by ``Finished``. Transitions per second, every fired transition at any level
              counted (1,110 transitions per 1,000 ticks).
  load    (c) load + validate + build of a 1000-state ring from a file on disk: median wall time (ms).

Peers run equivalent workloads (see benchmarks/README.md): transitions (Machine, HierarchicalMachine),
python-statemachine, sismic and py_trees. A peer that is not installed is reported, not fatal.
Every workload is checked before and after timing (the active state after a known number of steps
must be the expected one), so a broken equivalent cannot produce a number.

    python benchmarks/bench_core.py             # full run (about 1-2 minutes)
    python benchmarks/bench_core.py --quick     # smoke test (< 30 s)
    python benchmarks/bench_core.py --only flat --only sismic --json out.json
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

# The repository has top-level folders named ``transitions/`` and ``states/`` (installed as
# ``fsm.transitions`` / ``fsm.states``). When the repository root is on sys.path (``python -m ...`` or
# ``python -c`` from the root) ``import transitions`` would find that folder instead of the PyPI
# package. Drop the root from sys.path: ``fsm`` itself is found through the installed package.
REPO = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or os.getcwd()).resolve() != REPO]

import fsm  # noqa: E402

FLAT_N = 100          # states in the flat ring (a)
FAN = 10              # nesting fan-out (b): FAN x FAN x FAN
LOAD_N = 1000         # states in the loaded document (c)

TARGET_FLAT = 1_000_000
TARGET_FLAT_RATIO = 7.0
TARGET_NESTED = 300_000
TARGET_LOAD_MS = 50.0


# ---------------------------------------------------------------------------------------------------
# expected positions (the same rule for every library: the active state after S steps from the start)
# ---------------------------------------------------------------------------------------------------
def flat_position(steps: int) -> str:
    return f"s{steps % FLAT_N}"


def nested_position(steps: int) -> str:
    return f"c{steps // (FAN * FAN) % FAN}/m{steps // FAN % FAN}/l{steps % FAN}"


def nested_transitions(steps: int) -> int:
    """Transitions fired by ``steps`` ticks from the start: a leaf transition each tick, plus a
    ``Finished`` of the middle level every FAN ticks, plus one of the root level every FAN**2 ticks."""
    return steps + steps // FAN + steps // (FAN * FAN)


class WorkloadError(AssertionError):
    """An equivalent workload did not do what it claims."""


def expect(actual: Any, expected: Any, what: str) -> None:
    if actual != expected:
        raise WorkloadError(f"{what}: expected {expected!r}, got {actual!r}")


# ---------------------------------------------------------------------------------------------------
# documents
# ---------------------------------------------------------------------------------------------------
def ring_doc(n: int) -> dict[str, Any]:
    return {
        "name": f"ring{n}",
        "initial": "s0",
        "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
        "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"} for i in range(n)],
    }


def nested_doc() -> dict[str, Any]:
    def chain(prefix: str, n: int, child: Callable[[int], dict[str, Any]] | None, tr_type: str) -> dict[str, Any]:
        if child is None:
            states = [{"id": f"{prefix}{i}", "type": "Idle"} for i in range(n)]
        else:
            states = [{"id": f"{prefix}{i}", "type": "FSMState", "machine": child(i)} for i in range(n)]
        states.append({"id": "end", "type": "Final"})
        trans = [{"type": tr_type, "from": f"{prefix}{i}", "to": f"{prefix}{i + 1}" if i < n - 1 else "end"}
                 for i in range(n)]
        return {"initial": f"{prefix}0", "states": states, "transitions": trans}

    def leaves(_: int) -> dict[str, Any]:
        return chain("l", FAN, None, "Always")

    def middle(_: int) -> dict[str, Any]:
        return chain("m", FAN, leaves, "Finished")

    return {
        "name": "nested",
        "initial": "c0",
        "states": [{"id": f"c{k}", "type": "FSMState", "machine": middle(k)} for k in range(FAN)],
        "transitions": [{"type": "Finished", "from": f"c{k}", "to": f"c{(k + 1) % FAN}"} for k in range(FAN)],
    }


# ---------------------------------------------------------------------------------------------------
# adapters: one per (library, workload). ``run(n)`` performs n steps and returns (seconds, transitions);
# ``position()`` is the active leaf as "s7" or "c1/m2/l3"; ``steps`` counts the steps done so far.
# ---------------------------------------------------------------------------------------------------
class Adapter:
    library = ""      # label in the table
    key = ""          # name for --only
    dist = ""         # distribution name for the version
    workload = ""     # flat | nested
    note = ""

    def __init__(self) -> None:
        self.steps = 0

    def setup(self) -> None:
        raise NotImplementedError

    def run(self, n: int) -> tuple[float, int]:
        raise NotImplementedError

    def position(self) -> str:
        raise NotImplementedError

    def expected_position(self) -> str:
        return flat_position(self.steps) if self.workload == "flat" else nested_position(self.steps)

    def check(self, when: str) -> None:
        expect(self.position(), self.expected_position(), f"{self.library} {self.workload}, {when}, "
                                                          f"active state after {self.steps} steps")

    def precheck(self) -> None:
        """Step through known positions (crossing every level boundary) before anything is timed."""
        self.check("at start")
        marks = (1, FLAT_N - 1, FLAT_N, FLAT_N + 1) if self.workload == "flat" else (
            1, FAN - 1, FAN, FAN + 1, FAN * FAN, FAN * FAN * FAN, FAN * FAN * FAN + FAN + 1)
        start, done = self.steps, 0
        for mark in marks:
            self.run(mark - done)
            done = mark
            self.check("before timing")
        if self.workload == "nested" or self.key != "py_trees":
            return
        expect(self.steps - start, FLAT_N, f"{self.library}: leaf changes in {FLAT_N + 1} ticks")


# -- tral-fsm -----------------------------------------------------------------------------------------
class OursFlat(Adapter):
    library, key, dist, workload = "tral-fsm", "tral-fsm", "tral-fsm", "flat"

    def setup(self) -> None:
        self.m = fsm.load(ring_doc(FLAT_N))

    def run(self, n: int) -> tuple[float, int]:
        m = self.m
        tick = m.tick
        before = m.transition_count
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            tick()
        dt = time.perf_counter() - t0
        self.steps += n
        fired = m.transition_count - before
        expect(fired, n, "tral-fsm flat: transitions fired per tick")
        return dt, fired

    def position(self) -> str:
        return self.m.active_path if self.m.started else "s0"


class OursNested(OursFlat):
    workload = "nested"

    def setup(self) -> None:
        self.m = fsm.load(nested_doc())

    def run(self, n: int) -> tuple[float, int]:
        m = self.m
        tick = m.tick
        before = m.transition_count
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            tick()
        dt = time.perf_counter() - t0
        fired = m.transition_count - before
        expect(fired, nested_transitions(self.steps + n) - nested_transitions(self.steps),
               "tral-fsm nested: transitions fired")
        self.steps += n
        return dt, fired

    def position(self) -> str:
        return self.m.active_path if self.m.started else "c0/m0/l0"


# -- transitions ----------------------------------------------------------------------------------------
def _ring_spec(n: int) -> dict[str, Any]:
    return {
        "initial": "s0",
        "states": [f"s{i}" for i in range(n)],
        "transitions": [{"trigger": "next", "source": f"s{i}", "dest": f"s{(i + 1) % n}"} for i in range(n)],
    }


def transitions_machine(spec: dict[str, Any], hierarchical: bool) -> Any:
    if hierarchical:
        from transitions.extensions import HierarchicalMachine as cls
    else:
        from transitions import Machine as cls
    return cls(states=spec["states"], transitions=spec["transitions"], initial=spec["initial"],
               auto_transitions=False)


class TransitionsFlat(Adapter):
    library, key, dist, workload = "transitions Machine", "transitions", "transitions", "flat"
    note = "auto_transitions=False; one 'next' trigger per step"

    hierarchical = False

    def make(self, spec: dict[str, Any]) -> Any:
        return transitions_machine(spec, self.hierarchical)

    def setup(self) -> None:
        self.m = self.make(_ring_spec(FLAT_N))

    def run(self, n: int) -> tuple[float, int]:
        step = self.m.next
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            step()
        dt = time.perf_counter() - t0
        self.steps += n
        return dt, n

    def position(self) -> str:
        return self.m.state


class HsmFlat(TransitionsFlat):
    library, key = "transitions HierarchicalMachine", "transitions-hsm"
    hierarchical = True


class HsmNested(HsmFlat):
    workload = "nested"
    note = ("final=True leaves, compound on_final triggers 'done' (queued=True); "
            "one 'next' trigger per step")

    def setup(self) -> None:
        from transitions.extensions import HierarchicalMachine

        holder: dict[str, Any] = {}

        def completion(final_state: str) -> Callable[[], None]:
            # transitions calls on_final of every ancestor whose active subtree is all final, so the
            # root composite would also see its child's completion: only the real one triggers 'done'.
            def on_final() -> None:
                m = holder["m"]
                if m.state == final_state:
                    m.done()
            return on_final

        states: list[Any] = []
        trans: list[dict[str, str]] = []
        for k in range(FAN):
            c = f"c{k}"
            mids: list[Any] = []
            for j in range(FAN):
                m = f"m{j}"
                leaves: list[Any] = [f"l{i}" for i in range(FAN)] + [{"name": "end", "final": True}]
                mids.append({"name": m, "children": leaves, "initial": "l0", "on_final": completion(f"{c}_{m}_end")})
                for i in range(FAN):
                    trans.append({"trigger": "next", "source": f"{c}_{m}_l{i}",
                                  "dest": f"{c}_{m}_l{i + 1}" if i < FAN - 1 else f"{c}_{m}_end"})
                trans.append({"trigger": "done", "source": f"{c}_{m}",
                              "dest": f"{c}_m{j + 1}" if j < FAN - 1 else f"{c}_end"})
            mids.append({"name": "end", "final": True})
            states.append({"name": c, "children": mids, "initial": "m0", "on_final": completion(f"{c}_end")})
            trans.append({"trigger": "done", "source": c, "dest": f"c{(k + 1) % FAN}"})
        self.m = HierarchicalMachine(states=states, transitions=trans, initial="c0", auto_transitions=False,
                                     queued=True)
        holder["m"] = self.m

    def run(self, n: int) -> tuple[float, int]:
        step = self.m.next
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            step()
        dt = time.perf_counter() - t0
        fired = nested_transitions(self.steps + n) - nested_transitions(self.steps)
        self.steps += n
        return dt, fired

    def position(self) -> str:
        return self.m.state.replace("_", "/")


# -- python-statemachine ------------------------------------------------------------------------------------
def psm_ring_doc(n: int) -> dict[str, Any]:
    states: dict[str, Any] = {
        f"s{i}": {"transitions": [{"event": "next", "target": f"s{(i + 1) % n}"}]} for i in range(n)}
    states["s0"]["initial"] = True
    return {"name": f"ring{n}", "states": states}


def psm_ring_class(n: int) -> Any:
    """The ring as a StateChart subclass built with the Python API (about 1.5x faster to run than a
    class from ``statemachine.io.load``, so the peer gets its better number)."""
    from statemachine import State, StateChart

    states = {f"s{i}": State(initial=i == 0) for i in range(n)}
    event = None
    for i in range(n):
        t = states[f"s{i}"].to(states[f"s{(i + 1) % n}"])
        event = t if event is None else event | t
    return type(f"Ring{n}", (StateChart,), {**states, "next": event, "__module__": __name__})


def psm_nested_class() -> Any:
    """Compound states; a compound that reaches its final child raises done.state.<id> (SCXML semantics),
    taken in the same macrostep as the 'next' that caused it (``done_state_<id>`` declares that event).
    Ids are unique machine-wide and use '_' (a '.' would make done.state descriptors prefix-match)."""
    from statemachine import State, StateChart

    compound = type(State.Compound)

    def chain(prefix: str, name: str, child: Callable[[str], dict[str, Any]] | None) -> dict[str, Any]:
        ids = [f"{prefix}{name}{i}" for i in range(FAN)]
        ns: dict[str, Any] = {}
        for i, sid in enumerate(ids):
            if child is None:
                ns[sid] = State(initial=i == 0)
            else:
                ns[sid] = compound(sid, (State.Compound,), {**child(sid + "_"), "__module__": __name__},
                                   initial=i == 0)
        end = ns[f"{prefix}end"] = State(final=True)
        if child is None:
            event = None
            for i, sid in enumerate(ids):
                t = ns[sid].to(ns[ids[i + 1]] if i < FAN - 1 else end)
                event = t if event is None else event | t
            ns["next"] = event
        else:
            for i, sid in enumerate(ids):
                ns[f"done_state_{sid}"] = ns[sid].to(ns[ids[i + 1]] if i < FAN - 1 else end)
        return ns

    def leaves(prefix: str) -> dict[str, Any]:
        return chain(prefix, "l", None)

    def middle(prefix: str) -> dict[str, Any]:
        return chain(prefix, "m", leaves)

    ns: dict[str, Any] = {"__module__": __name__}
    for k in range(FAN):
        ns[f"c{k}"] = compound(f"c{k}", (State.Compound,), {**middle(f"c{k}_"), "__module__": __name__},
                               initial=k == 0)
    for k in range(FAN):
        ns[f"done_state_c{k}"] = ns[f"c{k}"].to(ns[f"c{(k + 1) % FAN}"])
    return type("Nested", (StateChart,), ns)


def psm_load_class(path: Path, *, validate: bool = False) -> Any:
    from statemachine.io import load

    return load(str(path), validate=validate)


class PsmFlat(Adapter):
    library, key, dist, workload = "python-statemachine", "python-statemachine", "python-statemachine", "flat"
    note = "StateChart subclass built with the Python API; sm.send('next') per step"

    def setup(self) -> None:
        from statemachine import State

        if self.workload == "nested" and not hasattr(State, "Compound"):
            raise Unsupported("this version has no compound states")
        self.sm = (psm_ring_class(FLAT_N) if self.workload == "flat" else psm_nested_class())()

    def run(self, n: int) -> tuple[float, int]:
        send = self.sm.send
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            send("next")
        dt = time.perf_counter() - t0
        fired = n if self.workload == "flat" else (
            nested_transitions(self.steps + n) - nested_transitions(self.steps))
        self.steps += n
        return dt, fired

    def position(self) -> str:
        ids = [s.id for s in self.sm.configuration]
        return max(ids, key=len).replace("_", "/")


class PsmNested(PsmFlat):
    workload = "nested"
    note = "compound states, done.state.<id> events for Finished; sm.send('next') per step"


# -- sismic ---------------------------------------------------------------------------------------------------
def sismic_ring(n: int) -> Any:
    from sismic.model import BasicState, CompoundState, Statechart, Transition

    sc = Statechart(f"ring{n}")
    sc.add_state(CompoundState("ring", initial="s0"), None)
    for i in range(n):
        sc.add_state(BasicState(f"s{i}"), "ring")
    for i in range(n):
        sc.add_transition(Transition(f"s{i}", f"s{(i + 1) % n}", event="next"))
    return sc


def sismic_nested() -> Any:
    from sismic.model import BasicState, CompoundState, FinalState, Statechart, Transition

    # sismic has no completion events: a final state raises an internal 'done' on entry, and each
    # composite leaves on 'done' (inner-first priority makes the innermost composite take it).
    sc = Statechart("nested")
    sc.add_state(CompoundState("ring", initial="c0"), None)
    trans = []
    for k in range(FAN):
        c = f"c{k}"
        sc.add_state(CompoundState(c, initial=f"{c}_m0"), "ring")
        trans.append(Transition(c, f"c{(k + 1) % FAN}", event="done"))
        for j in range(FAN):
            m = f"{c}_m{j}"
            sc.add_state(CompoundState(m, initial=f"{m}_l0"), c)
            trans.append(Transition(m, f"{c}_m{j + 1}" if j < FAN - 1 else f"{c}_end", event="done"))
            for i in range(FAN):
                sc.add_state(BasicState(f"{m}_l{i}"), m)
                trans.append(Transition(f"{m}_l{i}", f"{m}_l{i + 1}" if i < FAN - 1 else f"{m}_end", event="next"))
            sc.add_state(FinalState(f"{m}_end", on_entry="send('done')"), m)
        sc.add_state(FinalState(f"{c}_end", on_entry="send('done')"), c)
    for t in trans:
        sc.add_transition(t)
    return sc


class SismicFlat(Adapter):
    library, key, dist, workload = "sismic", "sismic", "sismic", "flat"
    note = "Python API; queue('next') + execute_once() per step"

    def setup(self) -> None:
        from sismic.interpreter import Interpreter

        self.it = Interpreter(sismic_ring(FLAT_N) if self.workload == "flat" else sismic_nested())
        self.it.execute_once()  # enter the initial configuration

    def run(self, n: int) -> tuple[float, int]:
        queue = self.it.queue
        execute_once = self.it.execute_once
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            queue("next")
            execute_once()
        dt = time.perf_counter() - t0
        self.steps += n
        return dt, n

    def position(self) -> str:
        return self.it.configuration[-1].replace("_", "/")


class SismicNested(SismicFlat):
    workload = "nested"
    note = "Python API; final states send('done'); queue('next') + execute() per step"

    def run(self, n: int) -> tuple[float, int]:
        queue = self.it.queue
        execute = self.it.execute
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            queue("next")
            execute()
        dt = time.perf_counter() - t0
        fired = nested_transitions(self.steps + n) - nested_transitions(self.steps)
        self.steps += n
        return dt, fired

    def precheck(self) -> None:
        # Count the transitions sismic reports, not only the position, for the first 1,000 steps.
        self.check("at start")
        fired = 0
        for _ in range(FAN * FAN * FAN):
            self.it.queue("next")
            fired += sum(len(ms.transitions) for ms in self.it.execute())
            self.steps += 1
        expect(fired, nested_transitions(self.steps), "sismic nested: transitions reported by sismic")
        self.check("before timing")
        super().precheck()


# -- py_trees -------------------------------------------------------------------------------------------------
class PyTreesFlat(Adapter):
    library, key, dist, workload = "py_trees tick_once", "py_trees", "py_trees", "flat"
    note = "memory Sequence of leaves RUNNING once then SUCCESS; root.tick_once() per step"

    def setup(self) -> None:
        import py_trees
        from py_trees.common import Status

        self.count = [0]
        count = self.count
        running, success = Status.RUNNING, Status.SUCCESS

        class Step(py_trees.behaviour.Behaviour):
            """RUNNING on its first tick, SUCCESS on the second: one tick = one state change."""

            def __init__(self, name: str) -> None:
                super().__init__(name)
                self.first = True

            def initialise(self) -> None:
                self.first = True

            def update(self) -> Status:
                if self.first:
                    self.first = False
                    return running
                count[0] += 1
                return success

        class Composite(py_trees.composites.Sequence):
            """A memory Sequence whose completion counts as a transition (the ``Finished`` equivalent)."""

            def terminate(self, new_status: Status) -> None:
                if new_status == success:
                    count[0] += 1

        Sequence = py_trees.composites.Sequence
        if self.workload == "flat":
            self.root = Sequence("ring", memory=True, children=[Step(f"s{i}") for i in range(FLAT_N)])
        else:
            self.root = Sequence("ring", memory=True, children=[
                Composite(f"c{k}", memory=True, children=[
                    Composite(f"m{j}", memory=True, children=[Step(f"l{i}") for i in range(FAN)])
                    for j in range(FAN)])
                for k in range(FAN)])
        self.Composite = py_trees.composites.Composite
        self.root.tick_once()  # the first tick enters the first leaf (RUNNING); no transition
        self.running = Status.RUNNING

    def run(self, n: int) -> tuple[float, int]:
        tick = self.root.tick_once
        before = self.count[0]
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            tick()
        dt = time.perf_counter() - t0
        fired = self.count[0] - before
        # The position rule counts leaf changes: a leaf succeeds every tick but the one where the
        # whole ring completes (the root Sequence restarts on the next tick).
        self.steps = self._leaf_successes()
        return dt, fired

    def _leaf_successes(self) -> int:
        c = self.count[0]
        if self.workload == "flat":
            return c
        # count = leaves + middle completions + top completions: invert nested_transitions (increasing)
        lo, hi = 0, c
        while lo < hi:
            mid = (lo + hi) // 2
            if nested_transitions(mid) < c:
                lo = mid + 1
            else:
                hi = mid
        expect(nested_transitions(lo), c, "py_trees nested: transitions counted (leaves + completions)")
        return lo

    def position(self) -> str:
        node = self.root
        names = []
        while isinstance(node, self.Composite):
            node = node.current_child
            names.append(node.name)
        return "/".join(names)

    def check(self, when: str) -> None:
        if self.root.status != self.running:
            # The tick where the whole ring completed: every leaf has run, the next tick restarts.
            cycle = FLAT_N if self.workload == "flat" else FAN * FAN * FAN
            expect(self.steps % cycle, 0, f"py_trees {self.workload}, {when}: ring completed off-cycle")
            return
        super().check(when)


class PyTreesNested(PyTreesFlat):
    workload = "nested"
    note = "nested memory Sequences (completion counted as a transition); root.tick_once() per step"


class Unsupported(Exception):
    """The installed version of a peer cannot express the workload."""


RATE_ADAPTERS: list[type[Adapter]] = [
    OursFlat, TransitionsFlat, HsmFlat, PsmFlat, SismicFlat, PyTreesFlat,
    OursNested, HsmNested, PsmNested, SismicNested, PyTreesNested,
]

MODULE_OF = {"tral-fsm": "fsm", "transitions": "transitions", "transitions-hsm": "transitions",
             "python-statemachine": "statemachine", "sismic": "sismic", "py_trees": "py_trees"}
DIST_OF = {"tral-fsm": "tral-fsm", "transitions": "transitions", "transitions-hsm": "transitions",
           "python-statemachine": "python-statemachine", "sismic": "sismic", "py_trees": "py_trees"}


# ---------------------------------------------------------------------------------------------------
# (c) load + validate + build of a 1000-state ring from disk
# ---------------------------------------------------------------------------------------------------
class Loader:
    library = ""
    key = ""
    note = ""

    def __init__(self, directory: Path) -> None:
        self.dir = directory

    def prepare(self) -> None:
        """Write the file (not timed)."""

    def once(self) -> Any:
        """Load + validate + build; returns something ``verify`` can step."""
        raise NotImplementedError

    def verify(self, built: Any) -> None:
        raise NotImplementedError


class OursLoad(Loader):
    library, key = "tral-fsm fsm.load", "tral-fsm"
    note = "JSON file; shape + semantic validation; build"

    def prepare(self) -> None:
        self.path = self.dir / "ring1000.json"
        self.path.write_text(json.dumps(ring_doc(LOAD_N), indent=1))

    def once(self) -> Any:
        return fsm.load(self.path)

    def verify(self, m: Any) -> None:
        m.tick()
        m.tick()
        expect(m.active_path, "s2", "tral-fsm load: active state after 2 ticks")
        expect(len(m.states_by_path), LOAD_N, "tral-fsm load: states built")


class PsmLoad(Loader):
    library, key = "python-statemachine io.load(validate=True)", "python-statemachine"
    note = "native JSON file, JSON-Schema validated, class + instance"
    validate = True

    def prepare(self) -> None:
        import statemachine.io as sio

        if not hasattr(sio, "load"):
            raise Unsupported("this version has no statemachine.io.load")
        self.path = self.dir / "ring1000_psm.json"
        self.path.write_text(json.dumps(psm_ring_doc(LOAD_N), indent=1))

    def once(self) -> Any:
        return psm_load_class(self.path, validate=self.validate)()

    def verify(self, sm: Any) -> None:
        sm.send("next")
        sm.send("next")
        expect([s.id for s in sm.configuration], ["s2"], "python-statemachine load: active state after 2 events")
        expect(len(sm.states), LOAD_N, "python-statemachine load: states built")


class PsmLoadNoValidate(PsmLoad):
    library = "python-statemachine io.load"
    note = "native JSON file, no schema validation, class + instance"
    validate = False


class SismicLoad(Loader):
    library, key = "sismic import_from_yaml", "sismic"
    note = "YAML file, schema-checked, + Interpreter"

    def prepare(self) -> None:
        from sismic.io import export_to_yaml

        self.path = self.dir / "ring1000.yaml"
        export_to_yaml(sismic_ring(LOAD_N), filepath=str(self.path))

    def once(self) -> Any:
        from sismic.interpreter import Interpreter
        from sismic.io import import_from_yaml

        return Interpreter(import_from_yaml(filepath=str(self.path)))

    def verify(self, it: Any) -> None:
        it.execute_once()
        for _ in range(2):
            it.queue("next")
            it.execute_once()
        expect(it.configuration, ["ring", "s2"], "sismic load: configuration after 2 events")
        expect(len(it.statechart.states), LOAD_N + 1, "sismic load: states built")


class TransitionsLoad(Loader):
    library, key = "transitions Machine", "transitions"
    note = "JSON file (json.load) -> Machine(auto_transitions=False)"

    def prepare(self) -> None:
        self.path = self.dir / "ring1000_transitions.json"
        self.path.write_text(json.dumps(_ring_spec(LOAD_N), indent=1))

    hierarchical = False

    def once(self) -> Any:
        with open(self.path, encoding="utf-8") as f:
            spec = json.load(f)
        return transitions_machine(spec, self.hierarchical)

    def verify(self, m: Any) -> None:
        m.next()
        m.next()
        expect(m.state, "s2", f"{self.library} load: state after 2 triggers")
        expect(len(m.states), LOAD_N, f"{self.library} load: states built")


class HsmLoad(TransitionsLoad):
    library, key = "transitions HierarchicalMachine", "transitions-hsm"
    note = "JSON file (json.load) -> HierarchicalMachine(auto_transitions=False)"
    hierarchical = True


LOAD_ADAPTERS: list[type[Loader]] = [OursLoad, PsmLoad, PsmLoadNoValidate, SismicLoad, TransitionsLoad, HsmLoad]


# ---------------------------------------------------------------------------------------------------
# measuring
# ---------------------------------------------------------------------------------------------------
def availability(key: str) -> str | None:
    """None if usable, else why not ("not installed", "shadowed by ...")."""
    import importlib

    module = MODULE_OF[key]
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return "not installed"
    if key != "tral-fsm":
        origin = Path(getattr(mod, "__file__", "") or "").resolve()
        if REPO in origin.parents and ".venv" not in origin.parts:
            return f"shadowed by {origin}"
    return None


def version(key: str) -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version(DIST_OF[key])
    except PackageNotFoundError:
        return "?"


class Timer:
    """Same gc policy for everyone: collect before each timed repeat; keep gc on (or off with --no-gc)."""

    def __init__(self, gc_off: bool) -> None:
        self.gc_off = gc_off

    def __enter__(self) -> Timer:
        gc.collect()
        if self.gc_off:
            gc.disable()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.gc_off:
            gc.enable()


def calibrate(adapter: Adapter, seconds: float, timer: Timer) -> int:
    """Steps per repeat so that one repeat lasts about ``seconds`` (also serves as the warm-up)."""
    n = 16
    while True:
        with timer:
            dt, _ = adapter.run(n)
        if dt >= 0.02 or n >= 1 << 24:
            break
        n *= 4
    return max(FAN, int(n * seconds / dt))


def measure_rates(args: argparse.Namespace, selected: list[type[Adapter]], results: list[dict[str, Any]]) -> None:
    timer = Timer(args.no_gc)
    for workload in ("flat", "nested"):
        live: list[tuple[Adapter, dict[str, Any], int]] = []
        for cls in (c for c in selected if c.workload == workload):
            adapter = cls()
            row: dict[str, Any] = {"workload": workload, "library": cls.library, "key": cls.key,
                                   "version": version(cls.key), "unit": "transitions/s", "note": cls.note}
            results.append(row)
            why = availability(cls.key)
            if why is not None:
                row["status"] = why
                if why == "not installed":
                    row["version"] = "-"
                continue
            try:
                t0 = time.perf_counter()
                adapter.setup()
                row["build_s"] = time.perf_counter() - t0
                adapter.precheck()
                n = args.n or calibrate(adapter, args.seconds, timer)
                adapter.check("after warm-up")
            except Unsupported as exc:
                row["status"] = f"unsupported: {exc}"
                continue
            except WorkloadError as exc:
                row["status"] = f"BROKEN: {exc}"
                continue
            except Exception as exc:  # noqa: BLE001 - one peer failing must not hide the others
                row["status"] = f"ERROR: {type(exc).__name__}: {exc}"
                continue
            row.update(status="ok", steps_per_repeat=n, runs=[])
            live.append((adapter, row, n))
            print(f"  [{workload}] {cls.library}: {n} steps per repeat", file=sys.stderr, flush=True)
        # Round-robin over libraries, so that load from other processes spreads over all of them.
        for r in range(args.repeat):
            for adapter, row, n in live:
                if row["status"] != "ok":
                    continue
                try:
                    with timer:
                        dt, fired = adapter.run(n)
                    adapter.check(f"after repeat {r + 1}")
                except WorkloadError as exc:
                    row["status"] = f"BROKEN: {exc}"
                    continue
                except Exception as exc:  # noqa: BLE001
                    row["status"] = f"ERROR: {type(exc).__name__}: {exc}"
                    continue
                row["runs"].append(fired / dt)
        for _, row, _ in live:
            if row["status"] == "ok":
                row["best"] = max(row["runs"])
                row["median"] = statistics.median(row["runs"])


def measure_loads(args: argparse.Namespace, selected: list[type[Loader]], results: list[dict[str, Any]]) -> None:
    timer = Timer(args.no_gc)
    with tempfile.TemporaryDirectory(prefix="tral-bench-") as tmp:
        live: list[tuple[Loader, dict[str, Any]]] = []
        for cls in selected:
            loader = cls(Path(tmp))
            row: dict[str, Any] = {"workload": "load", "library": cls.library, "key": cls.key,
                                   "version": version(cls.key), "unit": "ms", "note": cls.note}
            results.append(row)
            why = availability(cls.key)
            if why is not None:
                row["status"] = why
                if why == "not installed":
                    row["version"] = "-"
                continue
            try:
                loader.prepare()
                with timer:
                    t0 = time.perf_counter()
                    built = loader.once()   # first load in the process: imports, registries, caches
                    row["first_ms"] = (time.perf_counter() - t0) * 1e3
                loader.verify(built)
                del built
            except Unsupported as exc:
                row["status"] = f"unsupported: {exc}"
                continue
            except WorkloadError as exc:
                row["status"] = f"BROKEN: {exc}"
                continue
            except Exception as exc:  # noqa: BLE001
                row["status"] = f"ERROR: {type(exc).__name__}: {exc}"
                continue
            row.update(status="ok", runs=[])
            live.append((loader, row))
            print(f"  [load] {cls.library}: first load {row['first_ms']:.1f} ms", file=sys.stderr, flush=True)
        for _ in range(args.load_repeat):
            for loader, row in live:
                with timer:
                    t0 = time.perf_counter()
                    built = loader.once()
                    dt = time.perf_counter() - t0
                row["runs"].append(dt * 1e3)
                del built
        for _, row in live:
            row["median"] = statistics.median(row["runs"])
            row["best"] = min(row["runs"])


# ---------------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------------
def ours(results: list[dict[str, Any]], workload: str) -> dict[str, Any] | None:
    for row in results:
        if row["workload"] == workload and row["key"] == "tral-fsm" and row.get("status") == "ok":
            return row
    return None


def add_ratios(results: list[dict[str, Any]]) -> None:
    for row in results:
        base = ours(results, row["workload"])
        if row.get("status") != "ok" or base is None or row is base:
            continue
        if row["unit"] == "ms":
            row["tral_fsm_speedup"] = row["median"] / base["median"]
        else:
            row["tral_fsm_speedup"] = base["best"] / row["best"]


def targets(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    flat = ours(results, "flat")
    if flat is not None:
        out.append({"target": "(a) flat >= 1,000,000 transitions/s", "value": f"{flat['best']:,.0f}/s",
                    "pass": flat["best"] >= TARGET_FLAT})
        peers = [r for r in results if r["workload"] == "flat" and r.get("status") == "ok" and r is not flat]
        all_peers = [c.library for c in RATE_ADAPTERS if c.workload == "flat" and c.key != "tral-fsm"]
        missing = [lib for lib in all_peers if lib not in {r["library"] for r in peers}]
        if peers:
            fastest = max(peers, key=lambda r: r["best"])
            ratio = flat["best"] / fastest["best"]
            value = f"{ratio:.1f}x {fastest['library']} ({fastest['best']:,.0f}/s)"
            if missing:  # a PASS against a subset of the peers would claim too much
                value += f"; not measured: {', '.join(missing)}"
            out.append({"target": f"(a) flat >= {TARGET_FLAT_RATIO:g}x the fastest peer", "value": value,
                        "pass": (ratio >= TARGET_FLAT_RATIO) if not missing or ratio < TARGET_FLAT_RATIO else None})
        else:
            out.append({"target": f"(a) flat >= {TARGET_FLAT_RATIO:g}x the fastest peer",
                        "value": "no peer measured", "pass": None})
    nested = ours(results, "nested")
    if nested is not None:
        out.append({"target": "(b) nested >= 300,000 transitions/s", "value": f"{nested['best']:,.0f}/s",
                    "pass": nested["best"] >= TARGET_NESTED})
    load = ours(results, "load")
    if load is not None:
        out.append({"target": "(c) load+validate+build 1000 states < 50 ms", "value": f"{load['median']:.1f} ms median",
                    "pass": load["median"] < TARGET_LOAD_MS})
    for row in results:  # tral-fsm itself failed a workload: its targets are missed
        if row["key"] == "tral-fsm" and row.get("status") != "ok":
            out.append({"target": f"({'abc'[['flat', 'nested', 'load'].index(row['workload'])]}) {row['workload']}",
                        "value": row.get("status", "?"), "pass": False})
    return out


def print_table(results: list[dict[str, Any]], goals: list[dict[str, Any]], env: dict[str, Any]) -> None:
    titles = {"flat": f"(a) flat ring of {FLAT_N} states, transitions/s",
              "nested": f"(b) nested {FAN}x{FAN}x{FAN}, transitions/s (all levels)",
              "load": f"(c) load + validate + build, {LOAD_N}-state ring from disk, ms"}
    header = f"{'library':<44} {'version':<9} {'best':>13} {'median':>13}  {'tral-fsm x':>10}"
    print(f"\ntral-fsm core benchmark  |  Python {env['python']}  {env['machine']}  {env['cpus']} CPUs  "
          f"load avg {env['loadavg_start']} -> {env['loadavg_end']}")
    for workload in ("flat", "nested", "load"):
        rows = [r for r in results if r["workload"] == workload]
        if not rows:
            continue
        print(f"\n{titles[workload]}")
        print(header)
        print("-" * len(header))
        for r in rows:
            if r.get("status") != "ok":
                print(f"{r['library']:<44} {r['version']:<9} {r.get('status', '?')}")
                continue
            if r["unit"] == "ms":
                best, med = f"{r['best']:.1f} ms", f"{r['median']:.1f} ms"
            else:
                best, med = f"{r['best']:,.0f}", f"{r['median']:,.0f}"
            ratio = "-" if "tral_fsm_speedup" not in r else f"{r['tral_fsm_speedup']:.1f}x"
            print(f"{r['library']:<44} {r['version']:<9} {best:>13} {med:>13}  {ratio:>10}")
    print("\n'tral-fsm x' = how many times faster tral-fsm is (rates: best/best; load: median/median).")
    if goals:
        print("\nTargets (issue 2)")
        for g in goals:
            mark = "n/a " if g["pass"] is None else ("PASS" if g["pass"] else "MISS")
            print(f"  {mark}  {g['target']:<48} {g['value']}")


# ---------------------------------------------------------------------------------------------------
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="short smoke run (a few seconds)")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--only", action="append", default=[], metavar="NAME",
                   help="run only these workloads (flat, nested, load) and/or libraries (tral-fsm, transitions, "
                        "transitions-hsm, python-statemachine, sismic, py_trees); repeatable or comma-separated. "
                        "tral-fsm always runs, for the ratios.")
    p.add_argument("--repeat", type=int, help="timed repeats per rate workload (default 5, quick 2)")
    p.add_argument("--seconds", type=float, help="target seconds per repeat (default 1.0, quick 0.05)")
    p.add_argument("--n", type=int, help="fixed steps per repeat instead of calibrating")
    p.add_argument("--load-repeat", type=int, help="timed loads for (c) (default 7, quick 3)")
    p.add_argument("--no-gc", action="store_true", help="disable the garbage collector while timing")
    args = p.parse_args(argv)
    args.repeat = args.repeat or (2 if args.quick else 5)
    args.seconds = args.seconds or (0.05 if args.quick else 1.0)
    args.load_repeat = args.load_repeat or (3 if args.quick else 7)
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    workloads = {"flat", "nested", "load"}
    libraries = set(MODULE_OF)
    names = [n.strip() for item in args.only for n in item.split(",") if n.strip()]
    want_w = {n for n in names if n in workloads}
    want_l = {n for n in names if n in libraries}
    unknown = [n for n in names if n not in workloads and n not in libraries]
    if unknown:
        print(f"unknown --only name(s): {', '.join(unknown)}; choose from "
              f"{', '.join(sorted(workloads))}, {', '.join(sorted(libraries))}", file=sys.stderr)
        return 2

    def chosen(workload: str, key: str) -> bool:
        return (not want_w or workload in want_w) and (not want_l or key in want_l or key == "tral-fsm")

    env = {"python": platform.python_version(), "implementation": platform.python_implementation(),
           "machine": platform.machine(), "platform": platform.platform(), "cpus": os.cpu_count(),
           "loadavg_start": " ".join(f"{x:.2f}" for x in os.getloadavg()),
           "quick": args.quick, "repeat": args.repeat, "seconds_per_repeat": args.seconds,
           "load_repeat": args.load_repeat, "gc": "off while timing" if args.no_gc else "on, collected before each repeat"}
    results: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    measure_rates(args, [c for c in RATE_ADAPTERS if chosen(c.workload, c.key)], results)
    if chosen("load", "tral-fsm"):
        measure_loads(args, [c for c in LOAD_ADAPTERS if chosen("load", c.key)], results)
    env["loadavg_end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    env["wall_s"] = round(time.perf_counter() - t0, 1)
    add_ratios(results)
    goals = targets(results)
    print_table(results, goals, env)
    print(f"\n({env['wall_s']} s wall)")
    if args.json:
        Path(args.json).write_text(json.dumps({"environment": env, "results": results, "targets": goals},
                                              indent=2) + "\n")
    broken = [r for r in results if str(r.get("status", "")).startswith(("BROKEN", "ERROR"))]
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
