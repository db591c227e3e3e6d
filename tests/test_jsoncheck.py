"""fsm.trace.jsoncheck: the trace schema compiled into plain checks says what jsonschema says (stricter only in that
1.0 is
not a whole number), names where and what; a keyword it does not check is refused, never ignored."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.trace.jsoncheck import compile_definition, compile_schema, describe
from trace_lines import LINES, V1, WILD

SCHEMA = json.loads((Path(__file__).resolve().parents[1] / "fsm" / "schema" / "trace.schema.json").read_text())
#: Each definition of the schema, and a line of the kind it describes (None: a value, drawn wild).
BASES: dict[str, Any] = {**{name: None for name in SCHEMA["$defs"]},
                         **{k: LINES[k] for k in LINES if k in SCHEMA["$defs"]},
                         "event_v1": V1, "transition": LINES["event"]["transitions"][0], "car": LINES["event"]["car"]}


def _reference(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator({"$schema": SCHEMA["$schema"], "$defs": SCHEMA["$defs"],
                                            "$ref": f"#/$defs/{name}"})


REFERENCES = {name: _reference(name) for name in SCHEMA["$defs"]}
CHECKS = {name: compile_definition(SCHEMA, name) for name in SCHEMA["$defs"]}


def _agree(name: str, value: Any) -> None:
    mismatch = CHECKS[name](value)
    valid = REFERENCES[name].is_valid(value)
    if (mismatch is None) != valid:
        # the one difference allowed: a whole number written with a fraction (1.0) where an integer belongs
        assert valid and "expected a whole number" in mismatch.text and ".0" in mismatch.text, (name, value, mismatch)


def test_every_line_type_passes_both() -> None:
    for name, base in BASES.items():
        if base is not None:
            assert CHECKS[name](base) is None, name
            assert REFERENCES[name].is_valid(base), name
    whole = compile_schema(SCHEMA)
    for kind in ("header", "event", "keyframe", "samples", "rows", "sample", "frame", "input", "end"):
        assert whole(LINES[kind]) is None
    assert "fits none of its 9 allowed forms" in str(whole({"type": "nothing"}))


def _paths(value: Any, here: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [here]
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, here + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            out += _paths(v, here + (i,))
    return out


def _put(value: Any, path: tuple[Any, ...], new: Any) -> Any:
    if not path:
        return new
    copy = dict(value) if isinstance(value, dict) else list(value)
    copy[path[0]] = _put(copy[path[0]], path[1:], new)
    return copy


@st.composite
def definitions_and_values(draw: Any) -> tuple[str, Any]:
    name = draw(st.sampled_from(sorted(BASES)))
    base = BASES[name]
    if base is None:
        return name, draw(WILD)
    return name, _put(base, draw(st.sampled_from(_paths(base))), draw(WILD))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(definitions_and_values())
def test_the_compiled_checks_say_what_jsonschema_says(case: tuple[str, Any]) -> None:
    _agree(*case)


@pytest.mark.parametrize(("name", "value", "says"), [
    ("event", {**LINES["event"], "transitions": [{**LINES["event"]["transitions"][0], "tick": 1.0}]},
     "at /transitions/0/tick: expected a whole number, found 1.0"),
    ("keyframe", {**LINES["keyframe"], "vars": []}, "at /vars: expected an object, found a list of 0"),
    ("time", -0.5, "expected a number at least 0, found -0.5"),
    ("period", 0, "expected a number more than 0, found 0"),
    ("reading", True, "expected a number or a string, found true (a boolean)"),
    ("header", {**LINES["header"], "format": "x" * 100}, "at /format: expected 'tral-fsm-trace', found 'xxxxxxxxxx"),
    ("car", {"odometry": [1, 2]}, "at /odometry: expected 3 items, found 2"),
    ("samples", {**LINES["samples"], "data": "a b"}, "at /data: expected base64 text, found 'a b' (a string)"),
])
def test_a_mismatch_says_where_what_was_expected_and_what_was_found(name: str, value: Any, says: str) -> None:
    assert str(CHECKS[name](value)).startswith(says)


def test_a_keyword_that_is_not_checked_is_refused() -> None:
    for schema, says in (({"type": "object", "patternProperties": {}}, "patternProperties"),
                         ({"$ref": "other.json#/x"}, "unresolvable $ref"),
                         ({"const": [1]}, "const and enum of lists"),
                         ({"type": "decimal"}, "unknown type")):
        with pytest.raises(ValueError, match=says.replace("$", r"\$")):
            compile_schema(schema)


def test_a_definition_may_refer_to_itself() -> None:
    tree = {"$defs": {"node": {"type": "object", "properties": {"kids": {"type": "array",
                                                                         "items": {"$ref": "#/$defs/node"}}}}}}
    check = compile_definition(tree, "node")
    assert check({"kids": [{"kids": []}, {}]}) is None
    assert str(check({"kids": [{"kids": [3]}]})) == "at /kids/0/kids/0: expected an object, found 3"


def test_found_values_are_described_briefly() -> None:
    assert describe("3") == "'3' (a string)" and describe(None) == "null" and describe(False) == "false (a boolean)"
    assert describe(10 ** 30) == "a whole number of 31 digits" and describe([1, 2]) == "a list of 2"
    assert describe("x" * 1000).endswith("…' (a string)") and len(describe("x" * 1000)) < 60
