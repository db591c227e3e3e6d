"""Substitution and coverage details of issue 34, item 6: states inside an included machine file can be substituted,
a misspelt parameter in a substitution that matched several states is said once, and a run's trace records the
steps skipped by their precondition, so that the report's coverage counts them apart."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsm.model.errors import DiagramError
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario, run_scenario

SUB = {"initial": "slow", "states": [{"id": "slow", "type": "Wait", "seconds": 30}, {"id": "ok", "type": "Final"}],
       "transitions": [{"type": "Finished", "from": "slow", "to": "ok"}]}


def test_a_state_inside_an_included_file_is_substituted(tmp_path: Path) -> None:
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "inner.json").write_text(json.dumps(SUB), encoding="utf-8")
    # the include's own include is relative to it: parts/outer.json includes inner.json next to it
    outer = {"initial": "deep", "states": [{"id": "deep", "type": "FSMState", "machine": {"file": "inner.json"}},
                                           {"id": "fin", "type": "Final"}],
             "transitions": [{"type": "Finished", "from": "deep", "to": "fin"}]}
    (tmp_path / "parts" / "outer.json").write_text(json.dumps(outer), encoding="utf-8")
    top = {"initial": "main", "states": [{"id": "main", "type": "FSMState", "machine": {"file": "parts/outer.json"}},
                                         {"id": "end", "type": "Final"}],
           "transitions": [{"type": "Finished", "from": "main", "to": "end"}]}
    (tmp_path / "m.json").write_text(json.dumps(top), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3,
                              "substitute": [{"state": "deep/slow", "with": {"type": "Wait", "seconds": 1}}],
                              "expect": [{"outcome": "succeeded", "within": [1, 1.1]}]}), encoding="utf-8")
    result = run_scenario(load_scenario(sc))
    assert result.passed, [f.message for f in result.failures]
    assert (tmp_path / "parts" / "inner.json").read_text(encoding="utf-8") == json.dumps(SUB)  # files untouched


def test_a_misspelt_parameter_is_said_once_for_every_state_the_substitution_matched(tmp_path: Path) -> None:
    doc = {"initial": "main", "states": [{"id": "main", "type": "Sequence", "steps": [
        {"id": k, "type": "Wait", "seconds": 0.5} for k in ("a", "b", "c")]}]}
    (tmp_path / "m.json").write_text(json.dumps(doc), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "substitute": [
        {"type": "Wait", "with": {"type": "Wait", "secs": 1}}], "expect": [{"outcome": "succeeded"}]}),
        encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    found = [str(p) for p in info.value.problems]
    unknown = [f for f in found if "unknown parameter 'secs'" in f]
    assert len(unknown) == 1, found
    assert unknown[0].endswith("at /substitute/0/with/secs: error: with this substitution the machine is invalid: "
                               "unknown parameter 'secs' (in 3 states: 'a', 'b', 'c') (did you mean 'seconds'?)")
    assert len(found) == 2  # and 'seconds' missing, once


def test_the_trace_records_skips_and_the_reports_coverage_counts_them_apart(tmp_path: Path) -> None:
    doc = {"initial": "main", "vars": {"go": False}, "states": [{"id": "main", "type": "Sequence", "steps": [
        {"id": "a", "type": "Wait", "seconds": 0.1}, {"id": "b", "type": "Wait", "seconds": 0.1, "precondition": "go"},
        {"id": "c", "type": "Wait", "seconds": 0.1}]}]}
    machine = tmp_path / "m.json"
    machine.write_text(json.dumps(doc), encoding="utf-8")
    trace, page = tmp_path / "m.jsonl", tmp_path / "m.html"
    assert main(["run", str(machine), "--trace", str(trace), "--duration", "1"]) == 0
    lines = [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()]
    line = next(e for e in lines if "skipped" in e)
    assert line["skipped"] == ["main/b"] and line["tick"] == 8
    assert [t["to"] for t in line["transitions"]] == ["main/b"]  # entered, and skipped
    assert main(["report", str(trace), "-o", str(page)]) == 0
    html = page.read_text(encoding="utf-8")
    section = html[html.index('<section id="coverage-box">'):]
    assert "states 3/4, transitions 2/2, monitors 0/0 (83.3&#8201;%)" in section
    assert "<tr><th>only skipped (precondition false)</th><td>main/b</td></tr>" in section
    assert "<tr><th>never entered</th><td>none</td></tr>" in section
