"""Scenario sets and markers (issue 34, point 10; docs/scenarios.md "Matrix, skip and xfail"): a matrix expands one
scenario into named cases, each its own line in `fsmctl test`, its own JUnit test case and its own pytest item;
`skip` and `xfail` carry a reason; a matrix over 10,000 cases needs --max-runs; bad cases are located errors."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario
from fsm.tools.scenario.model import cases

#: y = 2 n once, then a 0.5 s wait.
MACHINE = {"initial": "main", "vars": {"n": 0, "y": 0, "fast": False},
           "states": [{"id": "main", "type": "Sequence", "steps": [
               {"id": "double", "type": "SetVar", "assign": {"y": "n * 2"}},
               {"id": "w", "type": "Wait", "seconds": 0.5}]}]}


def write(tmp_path: Path, **keys: Any) -> Path:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    doc = {"machine": "m.json", "duration": 1, "expect": [{"at": 0.5, "vars": {"y": 4}}, {"invariant": "y <= 2 * n"}],
           **keys}
    path = tmp_path / "t.scenario.json"
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return path


TABLE = {"cases": [{"name": "two", "vars": {"n": 2}},
                   {"name": "one", "vars": {"n": 1}, "xfail": "y is 2 here: the expectation is for n = 2"},
                   {"name": "late", "vars": {"n": 2}, "inputs": [{"at": 0.25, "set": {"n": 3}}]},
                   {"name": "later", "vars": {"n": 5}, "skip": "not built yet"}]}


def test_a_product_matrix_names_each_combination(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sc = write(tmp_path, matrix={"vars": {"n": [1, 2], "fast": [False, True]}})
    assert [c.name for c in cases(load_scenario(sc))] == ["t[n=1,fast=false]", "t[n=1,fast=true]",
                                                         "t[n=2,fast=false]", "t[n=2,fast=true]"]
    assert main(["test", "-q", str(sc)]) == 1
    out = capsys.readouterr().out
    assert out.count("FAIL t[n=1,") == 2 and "expected y = 4, got 2" in out
    assert out.strip().endswith("2 passed, 2 failed")


def test_a_table_with_inputs_skip_and_xfail_and_its_junit_report(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    sc = write(tmp_path, matrix=TABLE)
    report = tmp_path / "r.xml"
    assert main(["test", str(sc), "--junit", str(report)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("PASS t[two]")
    assert out[1].startswith("XFAIL t[one]: y is 2 here: the expectation is for n = 2 (expect[0] at 0.5 s: expected y")
    assert out[2].startswith("PASS t[late]")  # n = 3 from 0.25 s: y stays 4, the invariant holds
    assert out[3] == "SKIP t[later]: not built yet"
    assert out[-1] == "2 passed, 0 failed, 1 skipped, 1 xfailed"
    suite = ET.parse(report).getroot().find("testsuite")
    assert suite is not None and suite.get("tests") == "4" and suite.get("skipped") == "2"
    names = {c.get("name"): c for c in suite.iter("testcase")}
    assert list(names) == ["t[two]", "t[one]", "t[late]", "t[later]"]
    skipped = names["t[later]"].find("skipped")
    assert skipped is not None and skipped.get("message") == "not built yet"
    xfailed = names["t[one]"].find("skipped")
    assert xfailed is not None and xfailed.get("message") == "xfail: y is 2 here: the expectation is for n = 2"


def test_an_xfail_that_passes_is_reported_xpass(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sc = write(tmp_path, matrix={"vars": {"n": [2]}}, xfail="bug 12")
    assert main(["test", str(sc)]) == 0
    out = capsys.readouterr().out
    assert "XPASS t[n=2] (41 ticks, 0.5125 s): expected to fail: bug 12" in out
    assert "0 passed, 0 failed, 1 xpassed" in out
    assert main(["test", str(write(tmp_path, skip="flaky rig"))]) == 0
    assert "SKIP t: flaky rig" in capsys.readouterr().out


def test_each_case_is_a_pytest_item_with_its_marker(tmp_path: Path) -> None:
    write(tmp_path, matrix=TABLE)
    run = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "-rsx", str(tmp_path)],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert "2 passed, 1 skipped, 1 xfailed" in run.stdout, run.stdout + run.stderr
    assert "SKIPPED [1] t.scenario.json: not built yet" in run.stdout
    assert "XFAIL t.scenario.json::t[one]" in run.stdout
    listed = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--collect-only", "-q",
                             str(tmp_path)], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert [line for line in listed.stdout.splitlines() if "::" in line] == [
        "t.scenario.json::t[two]", "t.scenario.json::t[one]", "t.scenario.json::t[late]", "t.scenario.json::t[later]"]


def test_a_matrix_over_10000_cases_needs_max_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sc = write(tmp_path, matrix={"vars": {"n": list(range(101)), "y": list(range(100))}})
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    assert str(info.value.problems[0]).endswith(
        "at /matrix: error: the matrix expands to 10,100 cases; more than 10,000 need --max-runs 10100 (fsmctl "
        "test) or --fsm-max-runs 10100 (pytest) (fewer values, or a table of 'cases')")
    assert len(cases(load_scenario(sc, max_runs=10_100))) == 10_100
    with pytest.raises(DiagramError) as info:
        load_scenario(sc, max_runs=500)
    assert "the matrix expands to 10,100 cases; more than --max-runs 500" in str(info.value)
    with pytest.raises(SystemExit) as stop:
        main(["test", str(sc), "--max-runs", "0"])
    assert stop.value.code == 2
    assert "--max-runs: expected a whole number >= 1, got '0'" in capsys.readouterr().err


def test_bad_cases_are_located_errors(tmp_path: Path) -> None:
    sc = write(tmp_path, matrix={"cases": [{"name": "a", "vars": {"nn": 1}}, {"name": "a", "vars": {"fast": 1}},
                                           {"name": "b", "inputs": [{"at": 9, "set": {"n": 1}}]}]})
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    found = [str(p) for p in info.value.problems]
    assert any("/matrix/cases/0/vars/nn: error: the machine has no variable 'nn' (did you mean 'n'?)" in f
               for f in found), found
    assert any("/matrix/cases/1/name: error: two cases are named 'a'" in f for f in found), found
    assert any("/matrix/cases/1/vars/fast: error: 'fast' is true/false in the machine, this value is a number: 1"
               in f for f in found), found
    assert any("/matrix/cases/2/inputs/0/at: error: at 9 s is after the end of the run (1 s)" in f
               for f in found), found
    sc = write(tmp_path, matrix={"cases": [{"name": "a", "vasr": {"n": 1}}], "vars": {"n": [1]}})
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    assert "unknown key 'vasr' (did you mean 'vars'?)" in str(info.value)
    sc = write(tmp_path, matrix={"cases": [{"name": "a"}], "vars": {"n": [1]}})
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    assert "a matrix has 'vars' (every combination of their values) or 'cases' (a list), one of them" in \
        str(info.value)
