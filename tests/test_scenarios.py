"""``fsmctl test`` and scenario files: every example scenario passes; failures name the expectation, where it is
written and the first diverging tick; bad scenario files give every located error at once; bounce timelines are
exact on the simulated clock; the JUnit report parses with the right counts; the committed schema is current."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from fsm.tools.cli import main
from fsm.tools.scenario.model import SCENARIO_SCHEMA_PATH, Bounce, scenario_schema_text
from fsm.tools.scenario.timeline import press_changes, seen_levels

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((REPO / "diagrams").rglob("*.scenario.json"))
MISSION = str(REPO / "diagrams" / "examples" / "mission.json")
BLINKER = str(REPO / "diagrams" / "examples" / "blinker.json")

#: Toggles between off and on at each rising edge of 'button' (what a bounce makes of one press).
TOGGLE = {
    "initial": "off",
    "states": [{"id": "off", "type": "Idle"}, {"id": "on", "type": "Idle"}],
    "transitions": [
        {"type": "Signal", "from": "off", "to": "on", "signal": "button"},
        {"type": "Signal", "from": "on", "to": "off", "signal": "button"},
    ],
}


def write(tmp_path: Path, name: str, doc: Any) -> str:
    path = tmp_path / name
    path.write_text(json.dumps(doc, indent=2) if not isinstance(doc, str) else doc, encoding="utf-8")
    return str(path)


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["test", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def mission(**extra: Any) -> dict[str, Any]:
    return {"machine": MISSION, "duration": 10, "inputs": [{"at": 0.5, "signal": "start"}], **extra}


# -- the examples -----------------------------------------------------------------------------------------
def test_there_are_example_scenarios_for_the_examples() -> None:
    names = {p.name for p in EXAMPLES}
    assert {"mission.scenario.json", "blinker.scenario.json", "drive.scenario.json",
            "corner_turn.scenario.json"} <= names


def test_every_example_scenario_passes(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, *map(str, EXAMPLES))
    assert code == 0, out + err
    lines = out.splitlines()
    assert len([ln for ln in lines if ln.startswith("PASS ")]) == len(EXAMPLES)
    assert lines[-1] == f"{len(EXAMPLES)} passed, 0 failed"
    assert re.search(r"^PASS mission \(320 ticks, 4 s\)$", out, re.M)
    assert err == ""


def test_example_scenarios_pass_the_committed_schema() -> None:
    schema = json.loads(SCENARIO_SCHEMA_PATH.read_text(encoding="utf-8"))
    validator = jsonschema.Draft202012Validator(schema)
    for path in EXAMPLES:
        errors = list(validator.iter_errors(json.loads(path.read_text(encoding="utf-8"))))
        assert not errors, f"{path}: {[e.message for e in errors]}"
    assert list(validator.iter_errors({"machine": "m.json", "expect": [{"outcome": "x"}], "dtt": 1}))
    assert list(validator.iter_errors({"machine": "m.json", "expect": [{"outcome": "x"}],
                                       "inputs": [{"at": -1, "signal": "s"}]}))


def test_committed_scenario_schema_is_current() -> None:
    assert SCENARIO_SCHEMA_PATH.read_text(encoding="utf-8") == scenario_schema_text(), \
        "regenerate it: python -m fsm.tools.scenario --schema fsm/schema/scenario.schema.json"
    jsonschema.Draft202012Validator.check_schema(json.loads(scenario_schema_text()))


# -- failures are precise -------------------------------------------------------------------------------------
def test_a_wrong_order_fails_at_the_tick_where_the_sequence_diverged(capsys: pytest.CaptureFixture[str],
                                                                     tmp_path: Path) -> None:
    # no 'gripped': the gripper gives up at 5.5 s (tick 440), so 'retreat' never follows 'grip'
    file = write(tmp_path, "order.scenario.json", mission(expect=[
        {"outcome": "aborted"},
        {"visits": ["approach", "grip", "retreat"]},
    ]))
    code, out, _ = run(capsys, file)
    assert code == 1
    first = out.splitlines()[0]
    assert first.startswith("FAIL order: expect[1] visits (tick 440, t=5.5 s): expected 'retreat' to be entered "
                            "after 'grip' (run/work/grip at tick 200 (t=2.5 s))"), first
    assert "next entered: run/work/grip/gave_up at tick 440" in first
    assert f"{file}:14:5: expect[1] visits" in out  # where the expectation is written (json.dumps, indent 2)
    assert re.search(r"^ *> tick +440 t=5\.5 +enter run/work/grip/gave_up \(Timeout from run/work/grip/closing\)$",
                     out, re.M), out
    assert re.search(r"^ *tick +200 t=2\.5 +enter run/work/grip", out, re.M)  # context before
    assert out.splitlines()[-1] == "0 passed, 1 failed"


def test_a_wrong_value_and_a_wrong_active_state_fail_at_their_tick(capsys: pytest.CaptureFixture[str],
                                                                   tmp_path: Path) -> None:
    file = write(tmp_path, "value.scenario.json", {
        "machine": str(REPO / "diagrams" / "examples" / "drive.json"), "dt": 0.01, "duration": 6,
        "inputs": [{"at": 1.0, "signal": "go"}, {"at": 3.0, "set": {"distance": 4.5}}],
        "expect": [{"at": 3.2, "vars": {"distance": 5}}, {"at": 1.5, "active": "drive/cruise"}],
    })
    code, out, _ = run(capsys, file)
    assert code == 1
    assert "FAIL value: expect[0] at 3.2 s (tick 320, t=3.2 s): expected distance = 5, got 4.5 " \
           "(since tick 300 (t=3 s)) (+1 more)" in out
    assert "expect[1] at 1.5 s: expected 'drive/cruise' active, active: drive/accelerate" in out
    assert re.search(r"^ *> tick +150 t=1\.5 +\(nothing happened\)$", out, re.M)
    assert re.search(r"^ *tick +300 t=3 +set distance = 4\.5 \(input 1\)$", out, re.M)


def test_a_wrong_outcome_and_a_never_visited_state_fail_at_their_tick(capsys: pytest.CaptureFixture[str],
                                                                      tmp_path: Path) -> None:
    file = write(tmp_path, "outcome.scenario.json", mission(
        inputs=[{"at": 0.5, "signal": "start"}, {"at": 1.0, "press": "estop", "duration": 0.1}],
        expect=[{"outcome": "succeeded"}, {"never": ["stopped"]}, {"transitions": {"max": 1}}]))
    code, out, _ = run(capsys, file)
    assert code == 1
    assert "FAIL outcome: expect[0] outcome (tick 80, t=1 s): expected outcome 'succeeded', got 'aborted' " \
           "(finished in safe_stop at tick 80 (t=1 s)) (+2 more)" in out
    assert "expect[1] never: 'stopped' was entered (run/monitor/stopped) at tick 80 (t=1 s)" in out
    assert "expect[2] transitions: expected at most 1 transitions, 3 fired" in out


def test_an_unfinished_machine_fails_an_outcome_at_the_end_of_the_run(capsys: pytest.CaptureFixture[str],
                                                                      tmp_path: Path) -> None:
    file = write(tmp_path, "blink.scenario.json",
                 {"machine": BLINKER, "max_ticks": 100, "expect": [{"outcome": "done"}, {"finished": True}]})
    code, out, _ = run(capsys, file)
    assert code == 1
    assert "expect[0] outcome (tick 100, t=1.25 s): expected outcome 'done', but the machine had not finished " \
           "when the run ended at tick 100" in out


def test_quiet_prints_only_failures_and_the_summary(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    good = write(tmp_path, "good.scenario.json", mission(expect=[{"outcome": "aborted"}]))
    bad = write(tmp_path, "bad.scenario.json", mission(expect=[{"outcome": "succeeded"}]))
    code, out, _ = run(capsys, "-q", good, bad)
    assert code == 1
    assert "PASS" not in out and "FAIL bad:" in out
    assert out.splitlines()[-1] == "1 passed, 1 failed"


# -- bad scenario files -----------------------------------------------------------------------------------------
def test_bad_scenarios_give_every_located_error_at_once(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = """{
  "machine": "nope.json",
  "dtt": 0.01,
  "inputs": [
    {"at": -1, "signal": "start"},
    {"at": 2, "press": "button", "duration": 0.2, "bounce": {"count": 60, "interval": 0.002}},
    {"at": 1, "sett": {"x": 1}}
  ],
  "expect": [
    {"outcome": 3},
    {"visit": ["a"]}
  ]
}
"""
    file = write(tmp_path, "bad.scenario.json", text)
    code, out, err = run(capsys, file)
    assert code == 1
    lines = err.splitlines()
    expected = [
        f"{file}:2:3 at /machine: error: machine file not found",
        f"{file}:3:3 at /dtt: error: unknown key 'dtt' (did you mean 'dt'?)",
        f"{file}:5:6 at /inputs/0/at: error: input 0: 'at': Input should be greater than or equal to 0, got -1",
        f"{file}:6:51 at /inputs/1/bounce: error: input 1: the bounce lasts 0.24 s",
        f"{file}:7:5 at /inputs/2: error: input 2: an input is an object with 'signal', 'press', 'set', 'pause' or "
        "'resume'",
        f"{file}:10:6 at /expect/0/outcome: error: expectation 0: 'outcome': Input should be a valid string, got 3",
        f"{file}:11:5 at /expect/1: error: expectation 1: an expectation is an object with one of",
    ]
    assert len(lines) == len(expected), err
    for line, start in zip(lines, expected, strict=True):
        assert line.startswith(start), (line, start)
    assert "Traceback" not in err
    assert out.splitlines() == ["ERROR bad: invalid scenario (7 problem(s) above)", "0 passed, 0 failed, 1 invalid"]


def test_scenario_shape_errors_read_as_a_machine_documents(capsys: pytest.CaptureFixture[str],
                                                           tmp_path: Path) -> None:
    """A scenario's pydantic errors go through the core's located-problems path: the same words as the same
    mistake in a machine document, at the object it is in (a nested bounce gets its own "did you mean")."""
    machine = write(tmp_path, "m.json", {"initial": "a", "states": [{"id": "a", "type": "Wait", "seconds": -1}]})
    assert main(["validate", machine]) == 1
    machine_err = capsys.readouterr().err
    assert "at /states/0/seconds: error: state 'a': 'seconds': Input should be greater than or equal to 0, got -1" \
        in machine_err
    text = (
        '{"machine": "%s",\n'
        ' "inputs": [{"at": -1, "signal": "start"},\n'
        '            {"at": 1, "press": "b", "bounce": {"cuont": 3, "interval": 0.01}}],\n'
        ' "expect": [{"outcome": "succeeded", "whithin": 2}]}\n' % MISSION)
    file = write(tmp_path, "shape.scenario.json", text)
    code, out, err = run(capsys, file)
    assert code == 1
    assert err.splitlines() == [
        f"{file}:2:14 at /inputs/0/at: error: input 0: 'at': Input should be greater than or equal to 0, got -1",
        f"{file}:3:37 at /inputs/1/bounce: error: input 1: missing required key 'count' (How many times the "
        "contact bounces (opens and closes again).)",
        f"{file}:3:48 at /inputs/1/bounce/cuont: error: input 1: unknown key 'cuont' (did you mean 'count'?)",
        f"{file}:4:38 at /expect/0/whithin: error: expectation 0: unknown key 'whithin' (did you mean 'within'?)",
    ]
    assert out.splitlines()[-1] == "0 passed, 0 failed, 1 invalid"


def test_unknown_state_names_are_located_with_suggestions(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    file = write(tmp_path, "names.scenario.json", mission(
        inputs=[{"at": 0.5, "signal": "strat"}],
        expect=[{"visits": ["wait_start", "aproach"]}, {"at": 1, "active": "run/wrk"}]))
    code, _, err = run(capsys, file)
    assert code == 1
    assert re.search(r"names\.scenario\.json:\d+:\d+ at /inputs/0: warning: input 0: the machine reads no signal "
                     r"'strat' \(did you mean 'start'\?\)", err)
    assert "at /expect/0/visits/1: error: expectation 0: the machine has no state 'aproach' (did you mean " \
           "'approach'?)" in err
    assert "at /expect/1/active: error: expectation 1: no state path starts with 'run/wrk'" in err


@pytest.mark.parametrize("doc, message", [
    ({"machine": MISSION, "expect": [{"at": 700, "active": "run"}]}, "at 700 s is after the end of the run (600 s)"),
    ({"machine": MISSION, "dt": 1e-5, "expect": [{"outcome": "x"}]}, "more than 10,000,000"),
    ({"machine": MISSION, "inputs": [{"at": 1, "signal": "start", "value": True, "width": 0.1}],
      "expect": [{"outcome": "x"}]}, "'value' sets a level and 'width' makes a pulse"),
    ({"machine": MISSION, "expect": [{"transitions": {}}]}, "give 'count', 'min' or 'max'"),
    ({"machine": MISSION, "expect": []}, "'expect': List should have at least 1 item"),
    ({"expect": [{"outcome": "x"}]}, "missing required key 'machine'"),
    ({"machine": str(REPO / "diagrams" / "corner_turn.json"), "expect": [{"outcome": "x"}]},
     "this machine drives the car; name the world"),
    ([1, 2], "a scenario must be a JSON object, got array"),
])
def test_bad_scenarios(capsys: pytest.CaptureFixture[str], tmp_path: Path, doc: Any, message: str) -> None:
    file = write(tmp_path, "x.scenario.json", doc)
    code, _, err = run(capsys, file)
    assert code == 1
    assert message in err, err
    assert re.match(re.escape(file) + r"(:\d+:\d+)?( at \S+)?: error: ", err), err


def test_invalid_json_and_a_missing_file_are_located(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    broken = write(tmp_path, "broken.scenario.json", '{"machine": "m.json",\n  "expect": [}\n')
    code, _, err = run(capsys, broken, str(tmp_path / "missing.scenario.json"))
    assert code == 1
    assert f"{broken}:2:14: error: invalid JSON" in err
    assert "missing.scenario.json: error: scenario file not found" in err


def test_a_broken_machine_reports_the_machines_own_errors(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    machine = write(tmp_path, "m.json", {"initial": "a", "states": [{"id": "a", "type": "Idel"}]})
    file = write(tmp_path, "s.scenario.json", {"machine": "m.json", "expect": [{"outcome": "x"}]})
    code, _, err = run(capsys, file)
    assert code == 1
    assert f"{file}:2:3" in err and "at /machine: error: the machine" in err
    assert f"{machine}:" in err and "Idel" in err


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["test"]) == 2
    assert "give scenario files (*.scenario.json), or --explore MACHINE" in capsys.readouterr().err
    good = write(tmp_path, "good.scenario.json", mission(expect=[{"outcome": "aborted"}]))
    assert main(["test", good, "--junit", str(tmp_path / "no" / "such" / "r.xml")]) == 2
    assert "--junit" in capsys.readouterr().err
    assert main(["test", good, "--junit", good]) == 2  # never over a scenario
    assert "same file as the input" in capsys.readouterr().err
    assert json.loads(Path(good).read_text(encoding="utf-8"))["machine"] == MISSION


# -- JUnit ------------------------------------------------------------------------------------------------------
def test_junit_report_parses_with_the_right_counts(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    good = write(tmp_path, "good.scenario.json", mission(expect=[{"outcome": "aborted"}]))
    bad = write(tmp_path, "bad.scenario.json", mission(expect=[{"outcome": "succeeded"}]))
    invalid = write(tmp_path, "invalid.scenario.json", {"machine": MISSION})
    report = tmp_path / "report.xml"
    code, out, _ = run(capsys, good, bad, invalid, "--junit", str(report))
    assert code == 1
    assert out.splitlines()[-1] == "1 passed, 1 failed, 1 invalid"
    root = ET.parse(report).getroot()
    suite = root.find("testsuite")
    assert suite is not None
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("3", "1", "1")
    cases = {c.get("name"): c for c in suite.findall("testcase")}
    assert set(cases) == {"good", "bad", "invalid"}
    assert cases["good"].find("failure") is None and cases["good"].find("error") is None
    failure = cases["bad"].find("failure")
    assert failure is not None and "expected outcome 'succeeded', got 'aborted'" in (failure.get("message") or "")
    assert "> tick" in (failure.text or "")
    error = cases["invalid"].find("error")
    assert error is not None and "missing required key 'expect'" in (error.text or "")


def test_junit_report_on_standard_output_moves_the_report_to_stderr(capsys: pytest.CaptureFixture[str],
                                                                    tmp_path: Path) -> None:
    good = write(tmp_path, "good.scenario.json", mission(expect=[{"outcome": "aborted"}]))
    code, out, err = run(capsys, good, "--junit", "-")
    assert code == 0
    assert ET.fromstring(out.split("\n", 1)[1]).find("testsuite").get("tests") == "1"  # type: ignore[union-attr]
    assert "PASS good" in err and "1 passed, 0 failed" in err


# -- bounce on the simulated clock ----------------------------------------------------------------------------
def test_press_changes_are_exact_multiples_of_the_interval() -> None:
    changes = press_changes(1.0, 0.5, Bounce(count=2, interval=0.003))
    assert changes == [(1.0, True), (1.003, False), (1.006, True), (1.009, False), (1.012, True),
                       (1.5, False), (1.503, True), (1.506, False), (1.509, True), (1.512, False)]
    assert press_changes(0.0, 0.2) == [(0.0, True), (0.2, False)]


def test_a_tick_sees_the_last_level_due_by_its_time() -> None:
    changes = press_changes(0.1, 0.2, Bounce(count=3, interval=0.002))  # settles within one tick of 0.0125 s
    levels = seen_levels(changes, 0.0125, 30)
    assert levels[7] is False and levels[8] is True  # tick 8 is t = 0.1
    assert all(levels[8:24]) and not any(levels[24:])  # released at 0.3 s = tick 24


@pytest.mark.parametrize("interval, toggles", [
    (0.002, 1),   # faster than a tick: one press, one rising edge
    (0.0125, 5),  # one change per tick: every bounce is an edge: 3 rising edges on the press, 2 on the release
])
def test_bounce_edges_follow_the_core_rule(capsys: pytest.CaptureFixture[str], tmp_path: Path, interval: float,
                                           toggles: int) -> None:
    write(tmp_path, "toggle.json", TOGGLE)
    file = write(tmp_path, "bounce.scenario.json", {
        "machine": "toggle.json", "duration": 2,
        "inputs": [{"at": 0.5, "press": "button", "duration": 0.5, "bounce": {"count": 2, "interval": interval}}],
        "expect": [{"transitions": {"count": toggles}}],
    })
    code, out, _ = run(capsys, file)
    assert code == 0, out


def test_three_rapid_bouncing_presses_count_as_three(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    write(tmp_path, "toggle.json", TOGGLE)
    bounce = {"count": 5, "interval": 0.001}
    file = write(tmp_path, "three.scenario.json", {
        "machine": "toggle.json", "dt": 0.01, "duration": 1,
        "inputs": [{"at": t, "press": "button", "duration": 0.05, "bounce": bounce} for t in (0.1, 0.2, 0.3)],
        "expect": [{"visits": ["off", "on", "off", "on"]}, {"at": 0.35, "active": "on"},
                   {"transitions": {"count": 3}}],
    })
    code, out, _ = run(capsys, file)
    assert code == 0, out


def test_variable_sets_and_levels_apply_before_the_tick_at_their_time(capsys: pytest.CaptureFixture[str],
                                                                      tmp_path: Path) -> None:
    file = write(tmp_path, "vars.scenario.json", {
        "machine": str(REPO / "diagrams" / "examples" / "drive.json"), "dt": 0.01, "duration": 5,
        "inputs": [{"at": 0.004, "signal": "go", "value": True}, {"at": 2.0, "set": {"distance": 10}}],
        "expect": [{"at": 0.01, "active": "drive/accelerate"}, {"at": 1.99, "active": "drive/cruise"},
                   {"at": 2.0, "active": "succeeded", "vars": {"distance": 10}}, {"outcome": "succeeded"}],
    })
    code, out, _ = run(capsys, file)
    assert code == 0, out


def test_the_scenario_package_imports_neither_the_cli_nor_the_car() -> None:
    """fsm/tools/scenario may import the core and, lazily, the car; never the CLI (which imports it)."""
    import subprocess
    import sys

    code = ("import sys, fsm.tools.scenario, fsm.tools.scenario.junit, fsm.tools.scenario.timeline; "
            "print(sorted(m for m in sys.modules if m.startswith(('fsm.tools.cli', 'fsm.sim', 'pymunk', 'cv2'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True).stdout
    assert out.strip() == "[]"
