"""The committed JSON Schema: not stale, valid Draft 2020-12, and in agreement with ``fsmctl validate`` on
valid and invalid documents (so what an editor flags through ``$schema`` is what fsmctl flags)."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest

import fsm
from fsm.loading.registry import default_registry
from fsm.model.document import json_schema
from fsm.tools.cli.schema import schema_text

REPO = Path(__file__).resolve().parents[1]
COMMITTED = REPO / "fsm" / "schema" / "machine.schema.json"
REGENERATE = "fsmctl schema -o fsm/schema/machine.schema.json"


@pytest.fixture(scope="module")
def schema() -> dict[str, Any]:
    return json.loads(COMMITTED.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def validator(schema: dict[str, Any]) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(schema, format_checker=jsonschema.Draft202012Validator.FORMAT_CHECKER)


def test_committed_schema_is_not_stale() -> None:
    committed = COMMITTED.read_text(encoding="utf-8")
    generated = schema_text(default_registry())
    assert committed == generated, f"fsm/schema/machine.schema.json is stale; regenerate it with `{REGENERATE}`"


def test_committed_schema_equals_the_generated_dict(schema: dict[str, Any]) -> None:
    assert schema == json_schema(default_registry()), f"stale schema; regenerate it with `{REGENERATE}`"


def test_schema_is_valid_draft_2020_12(schema: dict[str, Any]) -> None:
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)
    assert jsonschema.validators.validator_for(schema) is jsonschema.Draft202012Validator


def test_schema_knows_every_registered_type(schema: dict[str, Any]) -> None:
    registry = default_registry()
    assert schema["$defs"]["State"]["properties"]["type"]["enum"] == sorted(registry.states)
    assert schema["$defs"]["Transition"]["properties"]["type"]["enum"] == sorted(registry.transitions)
    for name in registry.states:
        assert f"state.{name}" in schema["$defs"]
    for name in registry.transitions:
        assert f"transition.{name}" in schema["$defs"]


def test_schema_is_shipped_in_the_package() -> None:
    from importlib import resources

    text = resources.files("fsm.schema").joinpath("machine.schema.json").read_text(encoding="utf-8")
    assert json.loads(text) == json.loads(COMMITTED.read_text(encoding="utf-8"))


# -- agreement with fsmctl ------------------------------------------------------------------------------
RING = {
    "$schema": "../fsm/schema/machine.schema.json",
    "name": "ring",
    "description": "three states in a ring",
    "initial": "a",
    "vars": {"count": 0, "mode": "fast"},
    "states": [
        {"id": "a", "type": "Idle", "description": "first", "layout": {"x": 10, "y": 20}},
        {"id": "b", "type": "Idle"},
        {"id": "done", "type": "Final", "outcome": "aborted"},
    ],
    "transitions": [
        {"type": "Timeout", "from": "a", "to": "b", "seconds": 0.25, "priority": 2},
        {"type": "Signal", "from": "b", "to": "a", "signal": "back", "edge": "falling"},
        {"type": "Var", "from": "b", "to": "done", "var": "count", "op": ">=", "value": 3},
        {"type": "Always", "from": "a", "to": "done", "preempt": True, "priority": -1},
    ],
}

NESTED = {
    "initial": "outer",
    "states": [
        {"id": "outer", "type": "FSMState", "machine": {
            "name": "inner",
            "initial": "x",
            "states": [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Final", "outcome": "ok"}],
            "transitions": [{"type": "Timeout", "from": "x", "to": "y", "seconds": 1}],
        }},
        {"id": "both", "type": "Parallel", "join": "any", "regions": [
            {"name": "left", "initial": "l", "states": [{"id": "l", "type": "Idle"}, {"id": "lf", "type": "Final"}],
             "transitions": [{"type": "InState", "from": "l", "to": "lf", "state": "right/r"}]},
            {"name": "right", "initial": "r", "states": [{"id": "r", "type": "Idle"}]},
        ]},
        {"id": "end", "type": "Final"},
    ],
    "transitions": [
        {"type": "Finished", "from": "outer", "to": "both", "outcome": "ok"},
        {"type": "Finished", "from": "both", "to": "end"},
    ],
}


def _examples() -> list[Path]:
    """The example machines of the repository (machine documents only: they have "states")."""
    found = []
    for path in sorted((REPO / "diagrams").rglob("*.json")):
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except ValueError:
            continue
        if isinstance(data, dict) and "states" in data and "initial" in data and path.parent.name != "eeros":
            found.append(path)  # the EEROS cases need their plugin's types (tests/test_eeros_cases.py)
    return found


VALID = {"ring": RING, "nested": NESTED}


@pytest.mark.parametrize("name", sorted(VALID))
def test_valid_documents_pass_the_schema_and_fsmctl(validator: jsonschema.Draft202012Validator, name: str) -> None:
    document = VALID[name]
    errors = [e.message for e in validator.iter_errors(document)]
    assert errors == []
    _spec, problems = fsm.check(document)
    assert [p for p in problems if p.severity == "error"] == []


def test_the_repository_has_example_machines() -> None:
    assert _examples(), "no example machine under diagrams/"


@pytest.mark.parametrize("path", _examples(), ids=lambda p: str(p.relative_to(REPO)))
def test_example_machines_pass_the_schema_and_fsmctl(validator: jsonschema.Draft202012Validator, path: Path) -> None:
    document = json.loads(path.read_text(encoding="utf-8"))
    assert [e.message for e in validator.iter_errors(document)] == []
    _spec, problems = fsm.check(str(path))
    assert [p for p in problems if p.severity == "error"] == [], "\n".join(map(str, problems))
    # included files are machine documents too
    for sub in _includes(document, path.parent):
        assert [e.message for e in validator.iter_errors(json.loads(sub.read_text()))] == [], sub


def _includes(node: Any, directory: Path) -> list[Path]:
    out: list[Path] = []
    if isinstance(node, dict):
        if set(node) == {"file"} and isinstance(node["file"], str):
            out.append(directory / node["file"])
        for value in node.values():
            out.extend(_includes(value, directory))
    elif isinstance(node, list):
        for value in node:
            out.extend(_includes(value, directory))
    return out


def _mutated(path: tuple[str | int, ...], value: Any = None, delete: bool = False, base: Any = None) -> Any:
    doc = copy.deepcopy(base if base is not None else RING)
    node = doc
    for key in path[:-1]:
        node = node[key]
    if delete:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return doc


# Shape mistakes: the schema (an editor) and fsmctl must both reject each one.
INVALID = {
    "unknown top-level key": _mutated(("colour",), "red"),
    "unknown state parameter": _mutated(("states", 0, "speed"), 3),
    "unknown transition parameter": _mutated(("transitions", 0, "sconds"), 1),
    "unknown state type": _mutated(("states", 1, "type"), "Idel"),
    "unknown transition type": _mutated(("transitions", 3, "type"), "Allways"),
    "missing type": _mutated(("states", 1, "type"), delete=True),
    "missing id": _mutated(("states", 1, "id"), delete=True),
    "missing initial": _mutated(("initial",), delete=True),
    "missing states": _mutated(("states",), delete=True),
    "empty states": _mutated(("states",), []),
    "states not a list": _mutated(("states",), {"a": {"type": "Idle"}}),
    "seconds a string": _mutated(("transitions", 0, "seconds"), "0.25"),
    "seconds a boolean": _mutated(("transitions", 0, "seconds"), True),
    "seconds zero": _mutated(("transitions", 0, "seconds"), 0),
    "seconds negative": _mutated(("transitions", 0, "seconds"), -1),
    "seconds missing": _mutated(("transitions", 0, "seconds"), delete=True),
    "edge not in the enum": _mutated(("transitions", 1, "edge"), "sideways"),
    "op not in the enum": _mutated(("transitions", 2, "op"), "=~"),
    "var value a list": _mutated(("transitions", 2, "value"), [3]),
    "priority a string": _mutated(("transitions", 0, "priority"), "high"),
    "priority a fraction": _mutated(("transitions", 0, "priority"), 1.5),
    "preempt a number": _mutated(("transitions", 3, "preempt"), 1),
    "id with a slash": _mutated(("states", 0, "id"), "a/b"),
    "id a number (not legacy)": _mutated(("states", 0, "id"), 0),
    "empty id": _mutated(("states", 0, "id"), ""),
    "from a number (not legacy)": _mutated(("transitions", 0, "from"), 1),
    "outcome empty": _mutated(("states", 2, "outcome"), ""),
    "name a number": _mutated(("name",), 5),
    "layout a list": _mutated(("states", 0, "layout"), [1, 2]),
    "machine missing": _mutated(("states", 0, "machine"), delete=True, base=NESTED),
    "machine a string": _mutated(("states", 0, "machine"), "inner.json", base=NESTED),
    "include with an extra key": _mutated(("states", 0, "machine"), {"file": "x.json", "mode": "r"}, base=NESTED),
    "include with an empty name": _mutated(("states", 0, "machine"), {"file": ""}, base=NESTED),
    "unknown key in a nested machine": _mutated(("states", 0, "machine", "colour"), "red", base=NESTED),
    "wrong type in a nested machine": _mutated(("states", 0, "machine", "transitions", 0, "seconds"), "1",
                                               base=NESTED),
    "regions empty": _mutated(("states", 1, "regions"), [], base=NESTED),
    "join not in the enum": _mutated(("states", 1, "join"), "some", base=NESTED),
}


@pytest.mark.parametrize("name", sorted(INVALID))
def test_invalid_documents_fail_the_schema_and_fsmctl(validator: jsonschema.Draft202012Validator, name: str) -> None:
    document = INVALID[name]
    assert not validator.is_valid(document), f"the schema accepts: {name}"
    _spec, problems = fsm.check(document)
    assert any(p.severity == "error" for p in problems), f"fsmctl accepts: {name}"


# Shape edge cases where the two must agree either way.
EDGES = {
    "priority 2.0 (an integer in JSON Schema)": _mutated(("transitions", 0, "priority"), 2.0),
    "seconds an integer": _mutated(("transitions", 0, "seconds"), 1),
    "outcome null on Finished": _mutated(("transitions", 0), {"type": "Finished", "from": "outer", "to": "both",
                                                              "outcome": None}, base=NESTED),
    "description null": _mutated(("states", 0, "description"), None),
    "var value null": _mutated(("transitions", 2, "value"), None),
    "var value a string": _mutated(("transitions", 2, "value"), "three"),
    "name null": _mutated(("name",), None),
    "vars empty": _mutated(("vars",), {}),
    "transitions empty": _mutated(("transitions",), []),
    "vars a list": _mutated(("vars",), [1]),
    "id with spaces": _mutated(("states", 1, "id"), "b b"),
}


@pytest.mark.parametrize("name", sorted(EDGES))
def test_schema_and_fsmctl_agree_on_edge_cases(validator: jsonschema.Draft202012Validator, name: str) -> None:
    document = EDGES[name]
    schema_ok = validator.is_valid(document)
    _spec, problems = fsm.check(document)
    # only shape problems count here: fix the semantic ones the mutation may cause (unknown ids, ...)
    shape = [p for p in problems if p.severity == "error" and not _semantic(p)]
    assert schema_ok == (not shape), (
        f"{name}: schema says {'valid' if schema_ok else 'invalid'}, fsmctl says "
        + ("valid" if not shape else "; ".join(map(str, shape)))
    )


def _semantic(problem: fsm.Problem) -> bool:
    text = problem.message
    return any(s in text for s in ("names unknown state", "is not a state of", "can never finish",
                                   "never finishes with", "unreachable", "names no state", "duplicate id",
                                   "cannot compare variable"))


def test_schema_of_a_document_is_reachable_through_its_dollar_schema(tmp_path: Path) -> None:
    """A document's "$schema" is allowed by the schema itself (editors need it) and by fsmctl."""
    document = {**RING, "$schema": "https://example.invalid/machine.schema.json"}
    schema = json.loads(COMMITTED.read_text(encoding="utf-8"))
    assert jsonschema.Draft202012Validator(schema).is_valid(document)
    assert fsm.check(document)[1] == []
