"""Hypothesis fuzz of the two readers of ``fsmctl sweep`` (issue 22): the sweep file (fsm/tools/sweep/spec.py
``read_spec_file``, then every check ``plan`` makes before a run) and the resume reader of ``sweep.jsonl``
(fsm/tools/sweep/folder.py ``read_records``). From random bytes, JSON of the right shape with wrong values, and cut-off
real files, only the project's own error type (``DiagramError``) comes out; and the records the resume reader
keeps can always be written into sweep.csv and sweep.html."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fsm.model.errors import DiagramError
from fsm.tools.sweep.folder import read_records
from fsm.tools.sweep.results import csv_text, html_page
from fsm.tools.sweep.runner import plan
from fsm.tools.sweep.spec import read_spec_file

REPO = Path(__file__).resolve().parents[1]
FUZZ = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                       HealthCheck.too_slow])

#: Text a generator seldom draws: lone surrogates (valid as JSON escapes, not as UTF-8), NUL, markup.
nasty_text = st.sampled_from(["\ud800", "x\udc80", "\x00", "</script><b>", "a\nb", "\u2028", "../../x"])
json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12) | nasty_text,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=10)


def either(right: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    """Mostly a value of the right type (maybe a wrong one), sometimes any JSON at all."""
    return st.one_of(right, right, right, json_values)


sweep_files = st.fixed_dictionaries({}, optional={
    "machine": either(st.sampled_from(["mission.json", "nothere.json", "", "/", "mission.json/x", "hallway.json"])),
    "worlds": either(st.lists(st.sampled_from(["hallway.json", "*.json", "nope/*.json", "[", "", "mission.json",
                                               "../*", "\x00"]) | st.text(max_size=8), max_size=3)),
    "seeds": either(st.text(alphabet="0123456789:- e+", max_size=8)
                    | st.lists(st.integers(min_value=-3, max_value=2**64), max_size=4)),
    "set": either(st.dictionaries(
        st.sampled_from(["mission/drive/right_lane.distance", "mission/back_off/reverse.speed", "mission/halt.still",
                         "done.outcome", "nostate.x", "mission.blocking", ".", "a.", "x", "/.speed"])
        | st.text(max_size=10), either(st.lists(json_values, max_size=3)), max_size=3)),
    "vars": either(st.dictionaries(st.text(max_size=6), either(st.lists(json_values, max_size=3)), max_size=3)),
    "duration": either(st.floats() | st.integers(min_value=-10, max_value=10**400)),
    "noise": either(st.booleans()),
    "plugins": either(st.lists(st.from_regex(r"\Azz_nope_[a-z]{1,5}(\.py)?\Z"), max_size=2)),
    "outputs": either(st.fixed_dictionaries({}, optional={k: either(st.booleans())
                                                          for k in ("trace", "report", "plot", "video", "gif")})),
    "name": either(st.text(max_size=8)),
})


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a machine and a world, where the fuzzed sweep files are written."""
    folder = tmp_path_factory.mktemp("sweepfuzz")
    (folder / "mission.json").write_bytes((REPO / "diagrams" / "mission.json").read_bytes())
    (folder / "hallway.json").write_bytes((REPO / "diagrams" / "worlds" / "hallway.json").read_bytes())
    return folder


def read_and_plan(path: Path, base: Path) -> None:
    """What ``fsmctl sweep FILE`` does before the first run; only a DiagramError may come out."""
    try:
        spec = read_spec_file(path)
        plan(spec, base, "fuzz", str(path), base / "out", max_runs=64)
    except DiagramError as exc:
        assert exc.problems and all(str(p) for p in exc.problems)
    assert not (base / "out").exists()


@FUZZ
@given(raw=st.binary(max_size=300))
def test_a_sweep_file_of_random_bytes(raw: bytes, base: Path) -> None:
    path = base / "random.json"
    path.write_bytes(raw)
    read_and_plan(path, base)


@FUZZ
@given(data=sweep_files)
def test_a_sweep_file_of_the_right_shape_with_wrong_values(data: dict[str, Any], base: Path) -> None:
    path = base / "shaped.json"
    path.write_text(json.dumps(data))
    read_and_plan(path, base)


REAL = json.dumps({"$schema": "../fsm/schema/sweep.schema.json", "name": "lanes", "machine": "mission.json",
                   "worlds": ["hallway.json"], "seeds": [0, 1, 2],
                   "set": {"mission/drive/right_lane.distance": [0.4, 0.5]}, "vars": {"lane": [1, 2]},
                   "duration": 0.5, "noise": False, "outputs": {"plot": True}}, indent=2).encode()


@FUZZ
@given(cut=st.integers(min_value=0, max_value=len(REAL)))
def test_a_cut_off_sweep_file(cut: int, base: Path) -> None:
    path = base / "cut.json"
    path.write_bytes(REAL[:cut])
    read_and_plan(path, base)


def test_the_whole_real_sweep_file_plans(base: Path) -> None:
    """The file the truncations are cut from is a good one: 1 world x 3 seeds x 2 x 2 values."""
    path = base / "real.json"
    path.write_bytes(REAL)
    assert len(plan(read_spec_file(path), base, "fuzz", str(path), base / "out").jobs) == 12


# -- the resume reader -----------------------------------------------------------------------------------------
#: A record as a worker writes it (a run of the hallway lap, cut short).
RECORD: dict[str, Any] = {
    "id": "0000", "index": 0, "key": "18bdeaebe4df61b3", "world": "/w/hallway.json", "seed": 0,
    "run_seed": 2365664812863293653, "params": {"lap1/bottom.speed": 0.8}, "command": "fsmctl run lap.json",
    "ok": True, "states": ["lap1/bottom"],
    "summary": {"outcome": None, "finished": False, "ticks": 40, "sim_time": 0.5, "transitions": 0,
                "distance_m": 0.19, "collisions": 0, "wall_error_rms_m": None, "seed": 1, "noise": True},
    "track": [[10.001, 0.5, 0], [10.007, 0.5, 0], [10.016, 0.5, 1]], "dwell": {"lap1": 0.5, "lap1/bottom": 0.5},
    "seconds": 0.159, "files": ["summary.json"]}

wrong_records = st.builds(
    lambda changes, gone, summary, key: {**{k: v for k, v in RECORD.items() if k not in gone}, **changes,
                                         "summary": {**RECORD["summary"], **summary}, "key": key}
    if "summary" not in changes else {**{k: v for k, v in RECORD.items() if k not in gone}, **changes, "key": key},
    st.dictionaries(st.sampled_from(sorted(RECORD)), json_values
                    | st.lists(st.lists(st.floats() | st.integers(), max_size=3), max_size=3), max_size=3),
    st.sets(st.sampled_from(sorted(RECORD)), max_size=2),
    st.dictionaries(st.sampled_from(["outcome", "collisions", "wall_error_rms_m", "sim_time"]), json_values,
                    max_size=2),
    st.sampled_from(["k1", "k2", "k3"]) | json_values)


def reports_of(path: Path, keys: set[str] | None) -> None:
    """Read ``path`` back as a resume does; the kept records make a whole sweep.csv and sweep.html."""
    try:
        resume = read_records(path, keys)
    except DiagramError as exc:
        assert exc.problems
        return
    records = list(resume.records.values())
    for params in ([], ["lap1/bottom.speed", "x"]):
        csv_text(records, params).encode("utf-8")
        html_page("fuzz", records, params, {"/w/hallway.json": [[[0, 0], [20, 0]]]}).encode("utf-8")
    assert all(isinstance(w, str) for w in resume.warnings)


@FUZZ
@given(raw=st.binary(max_size=400), all_keys=st.booleans())
def test_a_sweep_jsonl_of_random_bytes(raw: bytes, all_keys: bool, tmp_path: Path) -> None:
    path = tmp_path / "sweep.jsonl"
    path.write_bytes(raw)
    reports_of(path, None if all_keys else {"k1"})


@FUZZ
@given(records=st.lists(wrong_records, max_size=4), cut=st.integers(min_value=0, max_value=60), all_keys=st.booleans())
@example(records=[{**RECORD, "params": {"lap1/bottom.speed": "\ud800"}}], cut=0, all_keys=True)
@example(records=[{**RECORD, "world": "\udc80"}], cut=0, all_keys=True)
@example(records=[{**RECORD, "summary": {**RECORD["summary"], "wall_error_rms_m": 10**308}}], cut=0, all_keys=True)
@example(records=[{**RECORD, "track": [[1e308, -1e308, 0]]}], cut=0, all_keys=True)
@example(records=[{**RECORD, "dwell": {"a": float("nan")}}], cut=0, all_keys=True)
@example(records=[{**RECORD, "files": None}], cut=0, all_keys=True)
def test_records_of_the_right_shape_with_wrong_values(records: list[dict[str, Any]], cut: int, all_keys: bool,
                                                       tmp_path: Path) -> None:
    path = tmp_path / "sweep.jsonl"
    text = "".join(json.dumps(r) + "\n" for r in records)
    path.write_text(text[:len(text) - cut] if cut and text else text)
    reports_of(path, None if all_keys else {"k1", "k2"})


def test_the_unchanged_record_is_kept(tmp_path: Path) -> None:
    """The record the wrong ones are made from is a good one (so the fuzz changes a record that counts)."""
    path = tmp_path / "sweep.jsonl"
    path.write_text(json.dumps(RECORD) + "\n")
    assert list(read_records(path, {RECORD["key"]}).records) == [RECORD["key"]]
