"""A finished run's record in sweep.jsonl that cannot be reused is said by the located-problems path machine
documents take (issue 31): the warning names the line and column of the first wrong value and its key."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsm.tools.sweep.folder import read_records, record_problem

GOOD: dict[str, Any] = {"key": "k0", "id": "0000", "ok": True, "index": 0, "seed": 0, "run_seed": 7, "params": {},
                        "command": "fsmctl run m.json", "summary": {"wall_error_rms_m": 0.1, "outcome": "done"},
                        "world": None, "track": [[0, 1, 0.5], [1.5, 2]], "dwell": {"a": 1.0}, "files": ["a.json"],
                        "seconds": 1, "flags": []}


def test_a_good_record_is_reused(tmp_path: Path) -> None:
    jsonl = tmp_path / "sweep.jsonl"
    jsonl.write_text(json.dumps(GOOD) + "\n", encoding="utf-8")
    resume = read_records(jsonl)
    assert list(resume.records) == ["k0"] and resume.warnings == []


@pytest.mark.parametrize("change, at, message", [
    ({"track": [[0, 1], [1e308, "x"]]}, '[1e+308, "x"]', "'track/1': not a point (x, y within 1e+06 m)"),
    ({"index": True}, '"index": true', "'index': Input should be a valid integer, got True"),
    ({"params": 5}, '"params": 5', "'params': Input should be a valid dictionary, got 5"),
    ({"summary": {"wall_error_rms_m": "far"}}, '"wall_error_rms_m": "far"',
     "'summary/wall_error_rms_m': not a number, got 'far'"),
    ({"dwell": {"a": -1e13}}, '"a": -10000000000000.0', "'dwell/a': not seconds, got -10000000000000.0"),
    ({"files": None}, '"files": null', "'files' may not be null"),
])
def test_a_wrong_value_is_named_at_its_line_and_column(tmp_path: Path, change: dict[str, Any], at: str,
                                                       message: str) -> None:
    """The warning's column is where the key (or the list's item) is written, as in a machine document's error."""
    line = json.dumps(dict(GOOD, **change))
    jsonl = tmp_path / "sweep.jsonl"
    jsonl.write_text(json.dumps(dict(GOOD, key="k1")) + "\n" + line + "\n", encoding="utf-8")
    resume = read_records(jsonl)
    assert list(resume.records) == ["k1"]
    assert resume.warnings == [f"{jsonl}:2:{line.index(at) + 1}: warning: not the record of a finished run "
                               f"({message}): ignored; such a run runs again"]


def test_a_missing_field_is_named() -> None:
    rec = {k: v for k, v in GOOD.items() if k != "command"}
    problem = record_problem(rec)
    assert problem is not None and problem.message == "missing required field 'command'"
