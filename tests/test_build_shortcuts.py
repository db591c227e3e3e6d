"""The compile and build stages' shortcuts for plain elements give what the long way gives: a plain state's and a
plain transition's plan (made as a tuple in the level's loop) has the fields the NamedTuple names, equal to the
plan ``_Compiler.state`` makes; a record sealed by ``seal_all``'s loop holds what ``StateWiring.seal`` fixes; and a
machine with every kind of element (plain, guarded, preemptive, prioritised, nested, parallel, bound by reference)
runs the same trace either way."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsm.loading import building, compiling
from fsm.loading.building import build
from fsm.loading.checking import signal_names
from fsm.loading.compiling import compile_machine
from fsm.loading.loader import analyse
from fsm.model.plan import NOTHING, GuardPlan, MachinePlan, StatePlan, TransitionPlan
from fsm.runtime import region as region_module
from fsm.runtime.region import StateWiring, wiring
from fsm.runtime.state import State

MIXED: dict[str, Any] = {
    "name": "mixed",
    "initial": "a",
    "vars": {"n": 0},
    "states": [
        {"id": "a", "type": "Idle"},
        {"id": "b", "type": "Idle", "set": {"on_enter": {"n": "n + 1"}}},
        {"id": "c", "type": "Wait", "seconds": 0.05, "until": "n > 100"},
        {"id": "d", "type": "Idle"},
        {"id": "p", "type": "Parallel", "regions": [
            {"name": "left", "initial": "l0", "states": [{"id": "l0", "type": "Idle"}, {"id": "l1", "type": "Wait",
                                                                                        "seconds": 0.02},
                                                         {"id": "lf", "type": "Final"}],
             "transitions": [{"type": "Always", "from": "l0", "to": "l1"},
                             {"type": "Finished", "from": "l1", "to": "lf"}]},
            {"name": "right", "initial": "r0", "states": [{"id": "r0", "type": "Idle"}, {"id": "rf", "type": "Final"}],
             "transitions": [{"type": "InState", "from": "r0", "to": "rf", "state": "/p/left/lf"}]},
        ]},
        {"id": "e", "type": "Idle"},
    ],
    "transitions": [
        {"type": "Always", "from": "a", "to": "b"},
        {"type": "Always", "from": "b", "to": "c", "guard": "n >= 1", "set": {"n": "n + 1"}},
        {"type": "Finished", "from": "c", "to": "d"},
        {"type": "Always", "from": "d", "to": "e", "priority": 1},
        {"type": "Always", "from": "d", "to": "p", "priority": 2},
        {"type": "Signal", "from": "p", "to": "a", "signal": "stop", "preempt": True},
        {"type": "Finished", "from": "p", "to": "e"},
        {"type": "Always", "from": "e", "to": "b"},
        {"type": "Always", "from": "e", "to": "a", "guard": "n > 3", "priority": 1},
    ],
}


def ring(n: int) -> dict[str, Any]:
    return {"name": "plain", "initial": "s0", "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
            "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"} for i in range(n)]}


def plan_of(doc: dict[str, Any]) -> MachinePlan:
    spec, analysis, problems = analyse(doc)
    assert spec is not None and analysis is not None and not [p for p in problems if p.severity == "error"]
    return compile_machine(spec, analysis)


def test_a_plain_transition_and_state_plan_have_the_fields_their_record_names() -> None:
    plan = plan_of(ring(3))
    for i, sp in enumerate(plan.root.states):
        assert type(sp) is StatePlan
        assert sp._asdict() == {
            "cls": sp.cls, "params": sp.params, "id": f"s{i}", "path": f"s{i}", "on_enter": None, "on_exit": None,
            "supervision": None, "regions": (), "sequence": None, "preempt": (), "regular": sp.regular,
            "on_complete": None, "checks": NOTHING}
        assert sp.cls.__name__ == "Idle" and sp.params.id == f"s{i}"
        (tp,) = sp.regular
        assert type(tp) is TransitionPlan
        assert tp._asdict() == {
            "cls": tp.cls, "params": tp.params, "source": f"s{i}", "target": f"s{(i + 1) % 3}", "position": i,
            "guard": GuardPlan(), "assign": None, "counter": None, "conditions": NOTHING}
        assert tp.cls.__name__ == "Always" and tp.params.from_ == f"s{i}"


def test_the_plain_states_shortcut_makes_the_plans_the_long_way_makes(monkeypatch: pytest.MonkeyPatch) -> None:
    spec, analysis, _problems = analyse(MIXED)
    assert spec is not None and analysis is not None
    short = compile_machine(spec, analysis)
    monkeypatch.setattr(compiling, "_plain_class", lambda cls: False)  # every state the long way
    long = compile_machine(spec, analysis)
    assert normal(short) == normal(long)
    # priorities: higher first, stable; the preemptive transition apart
    d = next(sp for sp in short.root.states if sp.id == "d")
    assert [tp.target for tp in d.regular] == ["p", "e"]
    p = next(sp for sp in short.root.states if sp.id == "p")
    assert [tp.target for tp in p.preempt] == ["a"] and [tp.target for tp in p.regular] == ["e"]


def normal(value: Any) -> Any:
    """``value`` with each function (a compiled ``set``, made anew by each compile) as its name."""
    if isinstance(value, tuple):
        return type(value)(*map(normal, value)) if hasattr(value, "_fields") else tuple(map(normal, value))
    if isinstance(value, dict):
        return {key: normal(v) for key, v in value.items()}
    return value.__qualname__ if callable(value) and hasattr(value, "__code__") else value


SEALED = ("is_final", "arms", "watched", "tick_hook", "enter_hook", "exit_hook")


def sealed(record: StateWiring) -> tuple[Any, ...]:
    # a hook made by ``seal`` as a closure (the exit condition's tick) is a new function each time: compared by kind
    return tuple(getattr(record, name) if not callable(getattr(record, name)) or hasattr(getattr(record, name),
                                                                                          "__self__")
                 else getattr(record, name).__qualname__ for name in SEALED)


@pytest.fixture
def seal_calls(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The path of each record ``StateWiring.seal`` is called on."""
    calls: list[str] = []
    original = StateWiring.seal

    def spy(record: StateWiring) -> None:
        calls.append(record.state.path)
        original(record)

    monkeypatch.setattr(StateWiring, "seal", spy)
    return calls


@pytest.mark.parametrize("doc", [MIXED, ring(5)], ids=["mixed", "ring"])
def test_every_record_holds_what_seal_fixes_and_only_plain_ones_are_made_sealed(
        doc: dict[str, Any], seal_calls: list[str]) -> None:
    calls = seal_calls
    machine = build(plan_of(doc))
    records = [wiring(state) for state in machine.states_by_path.values()]
    as_built = [sealed(record) for record in records]
    made = sorted(calls)
    for record in records:
        record.seal()
    assert [sealed(record) for record in records] == as_built
    # MIXED has an InState transition (it binds): every record sealed; the ring's states are all made sealed
    assert made == (sorted(machine.states_by_path) if doc is MIXED else [])


def test_without_binding_elements_only_the_records_of_plain_states_go_unsealed(seal_calls: list[str]) -> None:
    doc = {k: v for k, v in MIXED.items()}
    doc["states"] = [dict(st) for st in MIXED["states"] if st["id"] != "p"] + [{"id": "p", "type": "Idle"}]
    doc["transitions"] = [tr for tr in MIXED["transitions"] if tr["from"] != "p" or tr.get("preempt")]
    build(plan_of(doc))
    calls = seal_calls
    # b: a set; c: Wait ticks and finishes; d: two transitions and p a preemptive one; e: two transitions
    assert sorted(calls) == ["b", "c", "d", "e", "p"]


def test_a_state_class_with_a_hook_is_not_made_sealed() -> None:
    class Ticking(State[Any]):
        def tick(self, ctx: Any) -> None:
            pass

    class Binding(State[Any]):
        def bind(self, machine: Any) -> None:
            pass

    class Ending(State[Any]):
        is_final = True

    assert region_module.sealed_as_made(State)
    assert not any(region_module.sealed_as_made(cls) for cls in (Ticking, Binding, Ending))


def trace(doc: dict[str, Any]) -> list[Any]:
    machine = build(plan_of(doc))
    machine.start()
    seen = []
    for tick in range(80):
        if tick == 40:
            machine.ctx.set_signal("stop")
        machine.tick()
        seen.append((machine.active_paths, dict(machine.ctx.vars), machine.transition_count))
    return seen


def test_the_mixed_machine_runs_the_same_trace_either_way(monkeypatch: pytest.MonkeyPatch) -> None:
    short = trace(MIXED)
    monkeypatch.setattr(compiling, "_plain_class", lambda cls: False)
    monkeypatch.setattr(region_module, "sealed_as_made", lambda cls: False)  # every record sealed
    monkeypatch.setattr(building, "sealed_as_made", lambda cls: False)
    assert trace(MIXED) == short
    paths = {p for active, _vars, _count in short for p in active}
    assert {"a", "b", "c", "d", "e", "p/left/l1", "p/right/r0"} <= paths, paths  # every kind of element was run


@pytest.mark.parametrize("doc", [ring(3), MIXED], ids=["flat", "nested"])
def test_the_files_of_a_plan_are_every_level_s_file(doc: dict[str, Any], tmp_path: Path) -> None:
    path = tmp_path / "machine.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    spec, analysis, _problems = analyse(path)
    assert spec is not None and analysis is not None
    files = compile_machine(spec, analysis).files
    assert files == compiling._files(spec) and len(files) == 1 and Path(files[0]).name == "machine.json"


@pytest.mark.parametrize("doc", [ring(3), MIXED, {**ring(2), "name": "seq", "states": [
    {"id": "s0", "type": "Idle"}, {"id": "s1", "type": "Sequence", "pause_signal": "hold", "steps": [
        {"id": "w", "type": "Wait", "seconds": 1}]}]}], ids=["plain", "signal-transition", "sequence"])
def test_the_signals_of_a_plan_are_those_its_elements_read(doc: dict[str, Any]) -> None:
    spec, analysis, _problems = analyse(doc)
    assert spec is not None and analysis is not None
    signals = compile_machine(spec, analysis).signals
    assert signals == frozenset(signal_names(spec))
    assert signals == {"plain": frozenset(), "mixed": {"stop"}}.get(str(doc["name"]), {"hold"})
