"""``set`` on states and transitions and ``guard`` on transitions: order of firing, priorities, trace, summary,
and the load-time errors of bad expressions."""

from __future__ import annotations

import io
from typing import Any

import pytest

import fsm
from fsm import State, StateParams, register_state
from fsm.loading.registry import Registry, default_registry, using
from fsm.runtime.region import wiring
from fsm.trace.recorder import Recorder, summary
from helpers import trace_events

REG = default_registry()


def machine(states: list[dict[str, Any]], transitions: list[dict[str, Any]], **vars: Any) -> fsm.Machine:
    return fsm.load({"initial": states[0]["id"], "vars": vars, "states": states, "transitions": transitions},
                    registry=REG)


def problems(doc: dict[str, Any]) -> list[fsm.Problem]:
    return [p for p in fsm.check(doc, registry=REG)[1] if p.severity == "error"]


def test_order_exit_then_transition_set_then_entry() -> None:
    """Firing: the source's exit set, the transition's set, the target's entry set (each sees the one before)."""
    m = machine(
        [{"id": "a", "type": "Idle", "set": {"on_exit": {"log": "log + 'x'"}}},
         {"id": "b", "type": "Idle", "set": {"on_enter": {"log": "log + 'e'"}}}],
        [{"type": "Always", "from": "a", "to": "b", "set": {"log": "log + 't'"}}], log="")
    fsm.run(m, max_ticks=1)
    assert m.ctx.vars["log"] == "xte"


def test_set_around_the_state_hooks() -> None:
    """A state's entry set runs before its own on_enter (which sees the value), its exit set after on_exit."""
    seen: list[Any] = []
    registry = Registry()
    with using(registry):
        @register_state(name="Probe")
        class Probe(State):
            def on_enter(self, ctx: Any) -> None:
                seen.append(("enter", ctx.vars["n"]))

            def on_exit(self, ctx: Any) -> None:
                seen.append(("exit", ctx.vars["n"]))
    for name, cls in REG.states.items():
        registry.states.setdefault(name, cls)
    registry.transitions.update(REG.transitions)
    registry.conditions.update(REG.conditions)
    m = fsm.load({"initial": "p", "vars": {"n": 0},
                  "states": [{"id": "p", "type": "Probe", "set": {"on_enter": {"n": 1}, "on_exit": {"n": "n * 10"}}},
                             {"id": "q", "type": "Final"}],
                  "transitions": [{"type": "Always", "from": "p", "to": "q"}]}, registry=registry)
    fsm.run(m, max_ticks=2)
    assert seen == [("enter", 1), ("exit", 1)] and m.ctx.vars["n"] == 10


def test_assignments_run_in_order_and_see_each_other() -> None:
    m = machine([{"id": "a", "type": "Idle", "set": {"on_enter": {"x": "x + 1", "y": "x * 2"}}}], [], x=1, y=0)
    m.start()
    assert m.ctx.vars == {"x": 2, "y": 4}


def test_false_guard_blocks_and_priority_order_with_guards() -> None:
    m = machine(
        [{"id": "a", "type": "Idle"}, {"id": "hi", "type": "Final", "outcome": "hi"},
         {"id": "lo", "type": "Final", "outcome": "lo"}, {"id": "mid", "type": "Final", "outcome": "mid"}],
        [{"type": "Always", "from": "a", "to": "lo"},
         {"type": "Always", "from": "a", "to": "hi", "priority": 2, "guard": "n > 5"},
         {"type": "Always", "from": "a", "to": "mid", "priority": 1, "guard": "n > 0"}], n=0)
    assert fsm.run(m, max_ticks=3).outcome == "lo"
    m = machine(*_three(), n=3)
    assert fsm.run(m, max_ticks=3).outcome == "mid"
    m = machine(*_three(), n=9)
    assert fsm.run(m, max_ticks=3).outcome == "hi"


def _three() -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    return ([{"id": "a", "type": "Idle"}, {"id": "hi", "type": "Final", "outcome": "hi"},
             {"id": "lo", "type": "Final", "outcome": "lo"}, {"id": "mid", "type": "Final", "outcome": "mid"}],
            [{"type": "Always", "from": "a", "to": "lo"},
             {"type": "Always", "from": "a", "to": "hi", "priority": 2, "guard": "n > 5"},
             {"type": "Always", "from": "a", "to": "mid", "priority": 1, "guard": "n > 0"}])


def test_guard_and_the_type_must_both_hold() -> None:
    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                [{"type": "Signal", "from": "a", "to": "b", "signal": "go", "guard": "armed"}], armed=False)
    m.schedule_signal("go", 0.1)
    fsm.run(m, max_ticks=20)
    assert not m.finished  # the edge came while not armed
    m.ctx.vars["armed"] = True
    m.ctx.set_signal("go", False)
    fsm.run(m, max_ticks=2)
    m.ctx.set_signal("go", True)
    fsm.run(m, max_ticks=2)
    assert m.finished


def test_guard_as_condition_object() -> None:
    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                [{"type": "Always", "from": "a", "to": "b",
                  "guard": {"type": "All", "conditions": [{"type": "TimeSince", "seconds": 0.5},
                                                          {"type": "Expr", "expr": "n == 1"}]}}], n=1)
    fsm.run(m, max_ticks=100)
    assert m.finished and m.now == pytest.approx(0.5)


def test_counter_loop_and_preemptive_guard() -> None:
    m = machine([{"id": "count", "type": "Idle", "set": {"on_enter": {"n": "n + 1"}}},
                 {"id": "done", "type": "Final"}],
                [{"type": "Always", "from": "count", "to": "done", "preempt": True, "guard": "n >= 5"},
                 {"type": "Always", "from": "count", "to": "count"}], n=0)
    fsm.run(m, max_ticks=50)
    assert m.finished and m.ctx.vars["n"] == 5


def test_trace_has_vars_where_they_changed_and_summary_has_final_values() -> None:
    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle", "set": {"on_enter": {"n": "n + 1"}}},
                 {"id": "c", "type": "Final"}],
                [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.05},
                 {"type": "Always", "from": "b", "to": "c", "set": {"flag": True}}], n=0, flag=False, k=1)
    out = io.StringIO()
    rec = m.add_listener(Recorder(out))
    m.start()
    rec.flush(m)
    m.ctx.vars["k"] = 2  # a change made by a state's code between ticks is seen at the next tick's line
    fsm.run(m, max_ticks=10)
    lines = trace_events(out.getvalue())
    assert lines[0]["vars"] == {"n": 0, "flag": False, "k": 1}
    assert lines[1]["tick"] == 1 and lines[1]["vars"] == {"k": 2} and lines[1]["transitions"] == []
    by_tick = {line["tick"]: line for line in lines}
    assert by_tick[4]["vars"] == {"n": 1} and by_tick[5]["vars"] == {"flag": True}
    assert all("vars" not in line for t, line in by_tick.items() if t not in (0, 1, 4, 5))
    assert summary(m, rec)["vars"] == {"n": 1, "flag": True, "k": 2}


def test_machine_without_guards_pays_nothing() -> None:
    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
                [{"type": "Always", "from": "a", "to": "b"}, {"type": "Always", "from": "b", "to": "a"}])
    from fsm.model.plan import ActionKind, GuardKind

    state = wiring(m.root.states["a"])
    assert state.enter_hook is None and state.exit_hook is None
    assert state.regular[0].kind is GuardKind.ALWAYS and state.regular[0].effect is ActionKind.NONE


@pytest.mark.parametrize("op", ["<", "<=", ">", ">=", "==", "!="])
def test_inline_guard_and_counter_agree_with_their_closures(op: str) -> None:
    """A guard ``var OP constant`` on an ``Always`` and a ``set`` ``x = var OP constant`` run inline in the region
    (GuardKind.COMPARE, ActionKind.COUNTER); written either way round, they fire and count exactly as the closures
    would."""
    from fsm.model.plan import ActionKind, GuardKind

    for text in (f"n {op} 2", f"2 {op} n"):
        for n in (1, 2, 3, 2.5, -7):
            m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
                        [{"type": "Always", "from": "a", "to": "b", "guard": text, "set": {"k": "n * 3"}}], n=n, k=0)
            tr = wiring(m.root.states["a"]).regular[0]
            assert tr.kind is GuardKind.COMPARE and tr.effect is ActionKind.COUNTER, "the inline paths are not taken"
            assert tr.test is not None
            fsm.run(m, max_ticks=1)
            fires = bool(tr.test(m.ctx))
            assert (m.active_path == "b") == fires, (text, n)
            assert m.ctx.vars["k"] == (n * 3 if fires else 0), (text, n)


def test_inline_guard_keeps_the_kind_check_and_an_added_action_ends_the_inline_counter() -> None:
    from fsm.model.errors import StateRuntimeError

    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
                [{"type": "Always", "from": "a", "to": "b", "guard": "n >= 0", "set": {"k": "n + 1"}}], n=0, k=0)
    m.ctx.vars["n"] = True  # a bool is no number, though Python would compare it
    with pytest.raises(StateRuntimeError, match="holds True"):
        fsm.run(m, max_ticks=1)
    m = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
                [{"type": "Always", "from": "a", "to": "b", "set": {"k": "n + 1"}}], n=0, k=0)
    tr = wiring(m.root.states["a"]).regular[0]
    seen: list[int] = []
    tr.then(lambda ctx: seen.append(ctx.vars["k"]))
    assert tr.counter is None
    fsm.run(m, max_ticks=1)
    assert seen == [1] and m.ctx.vars["k"] == 1


# -- load-time errors -------------------------------------------------------------------------------------------
BASE = {"initial": "a", "vars": {"n": 0, "on": False},
        "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}]}


@pytest.mark.parametrize("transition, pointer, words", [
    ({"guard": "n >"}, "/transitions/0/guard", "expected a value"),
    ({"guard": "m > 1"}, "/transitions/0/guard", "unknown variable 'm'"),
    ({"guard": "n + 1"}, "/transitions/0/guard", "gives a number, true/false is needed"),
    ({"guard": "on < 1"}, "/transitions/0/guard", "only equal or not"),
    ({"set": {"n": "n / 0"}}, "/transitions/0/set/n", "division by zero"),
    ({"set": {"n": "'text'"}}, "/transitions/0/set/n", "assigns text to variable 'n'"),
    ({"set": {"on": 1}}, "/transitions/0/set/on", "assigns a number to variable 'on'"),
    ({"set": {"not": 1}}, "/transitions/0/set/not", "keyword"),
    ({"set": {"bad name": 1}}, "/transitions/0/set/bad name", "pattern"),
    ({"guard": {"type": "Nope"}}, "/transitions/0/guard/type", "unknown condition type 'Nope'"),
    ({"guard": {"type": "Expr", "expr": "zz"}}, "/transitions/0/guard/expr", "unknown variable 'zz'"),
    ({"guard": {"type": "Not", "condition": {"type": "InState", "state": "nowhere"}}},
     "/transitions/0/guard/condition/state", "names no state"),
    ({"guard": {"type": "SignalHigh", "signal": "s", "debounce": -1}}, "/transitions/0/guard/debounce",
     "greater than or equal to 0"),
])
def test_bad_guards_and_sets_are_located(transition: dict[str, Any], pointer: str, words: str) -> None:
    doc = {**BASE, "transitions": [{"type": "Always", "from": "a", "to": "b", **transition}]}
    found = problems(doc)
    assert len(found) == 1, found
    assert found[0].pointer == pointer and words in found[0].message, str(found[0])


def test_a_variable_only_set_assigns_is_known_and_gets_its_kind() -> None:
    doc = {**BASE, "states": [{"id": "a", "type": "Idle", "set": {"on_enter": {"seen": True}}},
                              {"id": "b", "type": "Idle"}],
           "transitions": [{"type": "Always", "from": "a", "to": "b", "guard": "seen and n == 0"},
                           {"type": "Always", "from": "b", "to": "a", "guard": "seen > 1"}]}
    found = problems(doc)
    assert [p.pointer for p in found] == ["/transitions/1/guard"] and "only equal or not" in found[0].message


def test_expression_errors_point_into_the_json_string(tmp_path: Any) -> None:
    path = tmp_path / "m.json"
    path.write_text('{"initial": "a", "vars": {"n": 0},\n "states": [{"id": "a", "type": "Idle"}],\n'
                    ' "transitions": [{"type": "Always", "from": "a", "to": "a", "guard": "n >= 1 +"}]}\n')
    found = [p for p in fsm.check(str(path), registry=REG)[1] if p.severity == "error"]
    assert len(found) == 1
    p = found[0]
    line = path.read_text().splitlines()[p.line - 1]
    assert p.line == 3 and line[p.column - 1:] == '"}]}', str(p)  # the end of the expression
    assert "column 9 of the expression" in p.message


def test_runtime_error_names_the_state_and_phase() -> None:
    m = machine([{"id": "a", "type": "Idle", "set": {"on_enter": {"q": "n / d"}}}], [], n=1, d=0, q=0)
    with pytest.raises(fsm.StateRuntimeError) as info:
        m.start()
    assert info.value.path == "a" and info.value.phase == "set on_enter" and "division by zero" in str(info.value)


def test_schema_has_set_guard_and_conditions() -> None:
    from fsm.model.document import json_schema

    schema = json_schema(REG)
    base = schema["$defs"]["transition.Always"]["properties"]
    assert "guard" in base and "set" in base
    assert any(b.get("$ref") == "#/$defs/Condition" for b in base["guard"]["anyOf"])
    assert set(schema["$defs"]["Condition"]["properties"]["type"]["enum"]) >= {
        "All", "Any", "Not", "Expr", "InState", "SignalEdge", "SignalHigh", "SignalLow", "TimeSince"}
    assert "set" in schema["$defs"]["state.Idle"]["properties"]


def test_idle_params_accept_set() -> None:
    assert StateParams(id="a", type="Idle", set={"on_enter": {"x": 1}}).set is not None  # type: ignore[arg-type]
