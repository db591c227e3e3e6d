"""One rule for what a machine is loaded from (fsm.loading.sources), shared by fsm.load, fsm.check and fsm.run: a
path, JSON text, a document dict, a spec or a plan; JSON text's problems are located as ``<text>.json:line:col`` by
each of them alike, and anything else is a TypeError naming the argument."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.loading.loader import compile as compile_plan

DOC: dict[str, Any] = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                       "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.5}]}
BAD = '{"initial": "a",\n "states": [{"id": "a", "type": "Nope"}]}'


def test_load_check_and_run_take_json_text() -> None:
    text = json.dumps(DOC, indent=2)
    assert fsm.check(text)[1] == []
    assert fsm.run(fsm.load(text)).outcome == "succeeded"
    assert fsm.run(text).outcome == "succeeded"
    assert fsm.run("\ufeff \n" + text).outcome == "succeeded"


def test_json_text_problems_are_located_alike_by_each_call() -> None:
    spec, problems = fsm.check(BAD)
    assert spec is None or problems
    shown = [str(p) for p in problems]
    assert shown and shown[0].startswith("<text>.json:2:25 ") and "unknown state type 'Nope'" in shown[0]
    for call in (fsm.load, fsm.run):
        with pytest.raises(fsm.DiagramError) as caught:
            call(BAD)
        assert [str(p) for p in caught.value.problems] == shown


def test_a_plan_is_a_source_of_each_call(tmp_path: Path) -> None:
    plan = compile_plan(DOC)
    assert fsm.check(plan) == (plan.spec, [])
    assert fsm.run(fsm.load(plan)).outcome == fsm.run(plan).outcome == "succeeded"
    path = tmp_path / "m.json"
    path.write_text(json.dumps(DOC), encoding="utf-8")
    assert fsm.run(fsm.load(path)).outcome == fsm.run(fsm.load(str(path))).outcome == "succeeded"


@pytest.mark.parametrize("call", [fsm.load, fsm.check])
def test_another_kind_of_source_is_a_type_error_naming_the_argument(call: Any) -> None:
    with pytest.raises(TypeError, match=r"^src must be a path, JSON text, a document dict, a spec or a plan; got 42"):
        call(42)
    with pytest.raises(TypeError, match=r"^source must be a path, JSON text, a document dict, a spec, a plan or a "
                                        r"machine; got \[1\]"):
        fsm.run([1])  # type: ignore[arg-type]  # the wrong type is what this test is about


def test_the_includes_of_text_are_found_from_base_dir() -> None:
    """mission.json includes grip.json beside it: given as text, its includes are found from ``base_dir``."""
    folder = Path(__file__).resolve().parents[1] / "diagrams" / "examples"
    text = (folder / "mission.json").read_text(encoding="utf-8")
    with pytest.raises(fsm.DiagramError, match="include file 'grip.json' not found"):
        fsm.run(text, max_ticks=1, base_dir=folder / "no")
    assert fsm.run(text, max_ticks=1, base_dir=folder).ticks == 1
    assert fsm.check(text, base_dir=folder)[1] == []
