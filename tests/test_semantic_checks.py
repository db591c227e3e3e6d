"""Semantic checks at load time: null is never a parameter's value (validation and the JSON Schema agree),
Var compares values of one kind (bool is not a number), the outcome analysis follows the Parallel join rule,
and ``signal_names`` tells which input signals a machine reads."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsm
from fsm import DiagramError
from fsm.loading.loader import signal_names
from fsm.model.errors import StateRuntimeError

SCHEMA = json.loads((Path(fsm.__file__).parent / "schema" / "machine.schema.json").read_text(encoding="utf-8"))


def errors_of(doc: dict[str, Any]) -> list[fsm.Problem]:
    _spec, problems = fsm.check(doc)
    return [p for p in problems if p.severity == "error"]


def pos_of(text: str, needle: str) -> tuple[int, int]:
    offset = text.index(needle)
    return text.count("\n", 0, offset) + 1, offset - (text.rfind("\n", 0, offset) + 1) + 1


# -- null ---------------------------------------------------------------------------------------------------
BASE = {
    "name": "m", "description": "d", "initial": "a",
    "states": [{"id": "a", "type": "FSMState", "description": "x", "machine": {
                   "initial": "x", "states": [{"id": "x", "type": "Final", "outcome": "ok"}]}},
               {"id": "b", "type": "Final", "outcome": "done"}],
    "transitions": [{"type": "Finished", "from": "a", "to": "b", "outcome": "ok", "priority": 1, "preempt": False},
                    {"type": "Timeout", "from": "a", "to": "b", "seconds": 1.5},
                    {"type": "Signal", "from": "a", "to": "b", "signal": "s", "edge": "high", "label": "s"},
                    {"type": "Var", "from": "a", "to": "b", "var": "v", "op": "==", "value": 1}],
}

NULL_PLACES = [("name",), ("description",), ("states", 0, "description"), ("states", 1, "outcome"),
               ("states", 0, "machine", "states", 0, "outcome"), ("transitions", 0, "outcome"),
               ("transitions", 0, "priority"), ("transitions", 0, "preempt"), ("transitions", 1, "seconds"),
               ("transitions", 2, "edge"), ("transitions", 2, "label"), ("transitions", 3, "value"),
               ("transitions", 3, "op"), ("states", 1, "layout")]


def with_null(path: tuple[Any, ...]) -> dict[str, Any]:
    doc = json.loads(json.dumps(BASE))
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = None
    return doc


def test_base_document_is_valid_for_both() -> None:
    assert errors_of(BASE) == []
    assert jsonschema.Draft202012Validator(SCHEMA).is_valid(BASE)


@pytest.mark.parametrize("path", NULL_PLACES, ids=["/".join(map(str, p)) for p in NULL_PLACES])
def test_null_is_refused_by_validation_and_by_the_schema(path: tuple[Any, ...]) -> None:
    doc = with_null(path)
    ptr = "".join(f"/{k}" for k in path)
    problems = errors_of(doc)
    assert [p.pointer for p in problems if "null" in p.message] == [ptr], [str(p) for p in problems]
    assert "leave the key out" in (problems[0].hint or "") or "give it a value" in (problems[0].hint or "")
    assert not jsonschema.Draft202012Validator(SCHEMA).is_valid(doc)


def test_null_is_located_in_the_file(tmp_path: Path) -> None:
    text = json.dumps(with_null(("transitions", 1, "seconds")), indent=2)
    f = tmp_path / "m.json"
    f.write_text(text)
    with pytest.raises(DiagramError) as info:
        fsm.load(f)
    [p] = info.value.problems
    assert (p.line, p.column) == pos_of(text, '"seconds": null')
    assert p.element == "transition a -> b" and "may not be null" in p.message


def test_the_schema_allows_null_nowhere() -> None:
    assert '"null"' not in json.dumps(SCHEMA)
    world = json.loads((Path(fsm.__file__).parent / "schema" / "world.schema.json").read_text(encoding="utf-8"))
    assert '"null"' not in json.dumps(world)


# -- Var kinds ------------------------------------------------------------------------------------------------
def var_doc(transitions: list[tuple[str, str, Any]], variables: dict[str, Any] | None = None) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
        "transitions": [{"type": "Var", "from": "a", "to": "b", "var": v, "op": op, "value": value}
                        for v, op, value in transitions]}
    if variables is not None:
        doc["vars"] = variables
    return doc


@pytest.mark.parametrize(("initial", "value"), [
    (True, 1), (1, True), (False, 0), (0, False), (5, "5"), ("5", 5), (True, "true"), ("x", 1.5), (1.5, False),
    (None, 1), ([1], 1), ({"a": 1}, "a"),
])
def test_var_against_an_initial_value_of_another_kind_is_an_error(initial: Any, value: Any) -> None:
    [p] = errors_of(var_doc([("x", "==", value)], {"x": initial}))
    assert p.pointer == "/transitions/0/value"
    assert "cannot compare variable 'x'" in p.message and "initial value" in p.message


@pytest.mark.parametrize(("initial", "value"), [(1, 2.5), (2.5, 1), (True, False), ("a", "b"), (0, 0)])
def test_var_against_an_initial_value_of_the_same_kind_is_fine(initial: Any, value: Any) -> None:
    assert errors_of(var_doc([("x", "==", value)], {"x": initial})) == []


def test_var_comparisons_of_one_variable_agree_with_the_first_when_there_is_no_initial_value() -> None:
    problems = errors_of(var_doc([("x", "==", 1), ("x", "==", True), ("x", ">", 2.5), ("x", "!=", "1"),
                                  ("y", "==", "on")]))
    assert [p.pointer for p in problems] == ["/transitions/1/value", "/transitions/3/value"]
    assert "/transitions/0" in problems[0].message


@pytest.mark.parametrize("op", ["<", "<=", ">", ">="])
def test_ordering_true_false_is_an_error(op: str) -> None:
    [p] = errors_of(var_doc([("x", op, True)]))
    assert p.pointer == "/transitions/0/op"


def test_var_in_nested_machines_sees_the_top_level_vars() -> None:
    doc = {"initial": "a", "vars": {"armed": False},
           "states": [{"id": "a", "type": "FSMState", "machine": var_doc([("armed", "==", 0)])}]}
    [p] = errors_of(doc)
    assert p.pointer == "/states/0/machine/transitions/0/value"


@pytest.mark.parametrize(("stored", "value"), [(1, True), (True, 1), ("5", 5), (0, False)])
def test_var_at_run_time_refuses_a_value_of_another_kind(stored: Any, value: Any) -> None:
    m = fsm.load(var_doc([("x", "==", value)]))
    m.ctx.vars["x"] = stored
    with pytest.raises(StateRuntimeError, match="cannot compare variable 'x'"):
        m.tick()


def test_var_at_run_time_compares_ints_and_floats() -> None:
    m = fsm.load(var_doc([("x", ">=", 2.5)]))
    m.ctx.vars["x"] = 3
    assert fsm.run(m, max_ticks=2).outcome == "succeeded"


# -- the Parallel join rule ---------------------------------------------------------------------------------
def region(name: str, outcomes: list[str]) -> dict[str, Any]:
    """A region that ends in one of ``outcomes``, chosen by signal ``<name>_<i>`` (none: it never ends)."""
    states: list[dict[str, Any]] = [{"id": "wait", "type": "Idle"}]
    transitions = []
    for i, outcome in enumerate(outcomes):
        states.append({"id": f"end{i}", "type": "Final", "outcome": outcome})
        transitions.append({"type": "Signal", "from": "wait", "to": f"end{i}", "signal": f"{name}_{i}",
                            "edge": "high"})
    return {"name": name, "initial": "wait", "states": states, "transitions": transitions}


def parallel(regions: list[list[str]], join: str, routes: list[str]) -> dict[str, Any]:
    states: list[dict[str, Any]] = [{"id": "p", "type": "Parallel", "join": join,
                                     "regions": [region(f"r{i}", outs) for i, outs in enumerate(regions)]}]
    transitions = []
    for outcome in routes:
        states.append({"id": f"to_{outcome}", "type": "Final", "outcome": outcome})
        transitions.append({"type": "Finished", "from": "p", "to": f"to_{outcome}", "outcome": outcome})
    return {"initial": "p", "states": states, "transitions": transitions}


def test_join_all_cannot_succeed_when_a_region_never_succeeds() -> None:
    doc = parallel([["succeeded"], ["aborted"]], "all", ["succeeded", "aborted"])
    [p] = errors_of(doc)
    assert p.pointer == "/transitions/0/outcome" and "never finishes with outcome 'succeeded'" in p.message
    assert "join=all" in (p.hint or "")


def test_join_all_hides_outcomes_behind_a_region_that_cannot_succeed() -> None:
    doc = parallel([["failed"], ["succeeded", "timeout"]], "all", ["failed", "timeout"])
    [p] = errors_of(doc)
    assert p.pointer == "/transitions/1/outcome" and "'timeout'" in p.message


def test_join_any_can_end_with_any_regions_outcome() -> None:
    assert errors_of(parallel([["succeeded"], ["aborted"]], "any", ["succeeded", "aborted"])) == []


def outcomes_by_running(regions: list[list[str]], join: str) -> set[str]:
    """Every outcome the Parallel really finishes with, over all choices and finishing orders."""
    seen: set[str] = set()
    choices = [range(len(outs)) for outs in regions]
    for pick in itertools.product(*choices):
        for order in itertools.permutations(range(len(regions))):
            m = fsm.load(parallel(regions, join, []))
            for step, r in enumerate(order):
                m.schedule_signal(f"r{r}_{pick[r]}", 0.0125 * (step + 1))
            fsm.run(m, max_ticks=len(regions) + 3)
            p = m.state("p")
            if p.finished:
                seen.add(p.outcome or "")
        # and all regions finishing in the same tick
        m = fsm.load(parallel(regions, join, []))
        for r in range(len(regions)):
            m.schedule_signal(f"r{r}_{pick[r]}", 0.0125)
        fsm.run(m, max_ticks=4)
        if m.state("p").finished:
            seen.add(m.state("p").outcome or "")
    return seen


_outcome_names = st.sampled_from(["succeeded", "aborted", "timeout"])


@settings(max_examples=40, deadline=None)
@given(regions=st.lists(st.lists(_outcome_names, min_size=1, max_size=2, unique=True), min_size=2, max_size=3),
       join=st.sampled_from(["all", "any"]))
def test_outcome_analysis_is_exactly_what_runs_produce(regions: list[list[str]], join: str) -> None:
    spec, problems = fsm.check(parallel(regions, join, []))
    assert spec is not None
    from fsm.loading.outcomes import state_outcomes

    analysed = state_outcomes(spec.states[0])
    assert analysed == outcomes_by_running(regions, join)
    # and a Finished on an outcome outside the analysis is an error, one inside is not
    for outcome in ["succeeded", "aborted", "timeout"]:
        problems = errors_of(parallel(regions, join, [outcome]))
        assert bool(problems) == (outcome not in analysed), (outcome, [str(p) for p in problems])


# -- signal names ---------------------------------------------------------------------------------------------
def test_signal_names_lists_every_signal_read_at_any_depth() -> None:
    doc = parallel([["succeeded"], ["aborted", "timeout"]], "all", [])
    doc["states"].append({"id": "idle", "type": "Idle"})
    doc["transitions"] = [{"type": "Signal", "from": "p", "to": "idle", "signal": "estop", "preempt": True}]
    spec, _ = fsm.check(doc)
    assert signal_names(spec) == {"estop", "r0_0", "r1_0", "r1_1"}


def test_signal_names_of_a_machine_without_signals_is_empty() -> None:
    spec, _ = fsm.check(var_doc([("x", "==", 1)]))
    assert signal_names(spec) == set()
    assert signal_names(None) == set()


def test_signal_names_of_the_mission_example() -> None:
    spec, problems = fsm.check(Path(__file__).resolve().parents[1] / "diagrams" / "examples" / "mission.json")
    assert not [p for p in problems if p.severity == "error"]
    assert {"start", "gripped"} <= signal_names(spec)
