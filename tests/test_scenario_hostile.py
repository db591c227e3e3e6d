"""``fsmctl test`` against hostile scenarios: ``--junit`` never replaces a file the scenarios name (machine,
include, world, plugin), huge times give located messages instead of tracebacks, a scenario's missing plugin
fails that scenario (not a ``--plugin`` flag nobody gave), a plugin's ``sys.exit`` fails its scenario instead of
ending the command with status 0, and the JUnit report stays valid XML whatever the ids hold."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from helpers import cli

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "diagrams" / "examples"


def write(path: Path, doc: Any) -> str:
    path.write_text(json.dumps(doc) if not isinstance(doc, str) else doc, encoding="utf-8")
    return str(path)


def mission_copy(tmp_path: Path, name: str = "m", **extra: Any) -> str:
    """A scenario ``NAME.scenario.json`` of a copy of the mission machine (which includes grip.json)."""
    for machine in ("mission.json", "grip.json"):
        shutil.copy(EXAMPLES / machine, tmp_path / machine)
    doc = {"machine": "mission.json", "duration": 10, "inputs": [{"at": 0.5, "signal": "start"}],
           "expect": [{"outcome": "aborted"}], **extra}
    return write(tmp_path / f"{name}.scenario.json", doc)


# -- --junit never replaces an input --------------------------------------------------------------------------
@pytest.mark.parametrize("target", ["mission.json", "grip.json", "world.json", "plug.py", "cli_plug.py"])
@pytest.mark.parametrize("valid", [True, False])
def test_junit_naming_a_file_the_scenario_names_is_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                           target: str, valid: bool) -> None:
    shutil.copy(REPO / "diagrams" / "worlds" / "hallway.json", tmp_path / "world.json")
    (tmp_path / "plug.py").write_text("X = 1\n", encoding="utf-8")
    (tmp_path / "cli_plug.py").write_text("Y = 1\n", encoding="utf-8")
    expect = [{"outcome": "aborted"}] if valid else [{"bogus": 1}]  # an invalid one names its files too
    scenario = mission_copy(tmp_path, world="world.json", plugins=["plug.py"], expect=expect)
    before = (tmp_path / target).read_bytes()
    code, out, err = cli(capsys, "--plugin", str(tmp_path / "cli_plug.py"), "test", scenario,
                         "--junit", str(tmp_path / target))
    assert code == 2, err
    assert f"--junit {tmp_path / target}: is the same file as the input" in err
    assert (tmp_path / target).read_bytes() == before
    assert out == ""  # refused before anything ran


def test_junit_next_to_the_inputs_is_written(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    scenario = mission_copy(tmp_path)
    code, out, err = cli(capsys, "test", scenario, "--junit", str(tmp_path / "report.xml"))
    assert code == 0, err
    assert ET.parse(tmp_path / "report.xml").getroot().find("testsuite").get("tests") == "1"  # type: ignore[union-attr]


# -- huge and odd times ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("extra, pointer, message", [
    ({"duration": 1e308}, "/duration", "makes infinitely many ticks, more than 10,000,000"),
    ({"dt": 1e-300}, "/dt", "makes 1e+301 ticks, more than 10,000,000"),
    ({"dt": 1e308}, "/dt", "dt 1e+308 s is longer than the run (10 s): not one tick would run"),
    ({"max_ticks": 10**400}, "/max_ticks", "'max_ticks': Input should be less than or equal to 9223372036854775807"),
    ({"inputs": [{"at": 1e308, "signal": "start"}]}, "/inputs/0/at", "at 1e+308 s is after the end of the run"),
    ({"expect": [{"at": 1e308, "active": "run"}]}, "/expect/0/at", "at 1e+308 s is after the end of the run"),
    ({"expect": [{"monitors": {"owner": "grip", "at": [1, 1e308]}}]}, "/expect/0/monitors/at/1",
     "at 1e+308 s is after the end of the run (10 s)"),
    ({"inputs": [{"at": 1, "press": "start", "duration": 1e308, "bounce": {"count": 1000, "interval": 1e307}}]},
     "/inputs/0/bounce", "the bounce lasts inf s"),
    ({"duration": 1e308, "max_ticks": 100, "expect": [{"at": 2, "active": "run"}]}, "/expect/0/at",
     "at 2 s is after the end of the run (1.25 s)"),
])
def test_huge_times_give_located_problems(capsys: pytest.CaptureFixture[str], tmp_path: Path, extra: dict[str, Any],
                                          pointer: str, message: str) -> None:
    scenario = mission_copy(tmp_path, **extra)
    code, out, err = cli(capsys, "test", scenario)
    assert code == 1
    assert f" at {pointer}: error: " in err and message in err, err
    assert out.splitlines()[-1] == "0 passed, 0 failed, 1 invalid"


@pytest.mark.parametrize("item", [
    {"at": 1, "press": "start", "duration": 1e308},
    {"at": 1, "signal": "start", "width": 1e308},
    {"at": 1, "press": "start", "duration": 1e308, "bounce": {"count": 2, "interval": 1e300}},
])
def test_a_press_or_pulse_released_after_the_end_runs(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                      item: dict[str, Any]) -> None:
    """A release far after the run (even one whose time overflows to infinity) is never seen: the run goes on."""
    scenario = mission_copy(tmp_path, inputs=[item], expect=[{"visits": ["wait_start", "run"]}])
    code, out, err = cli(capsys, "test", scenario)
    assert code == 0, out + err
    assert out.splitlines()[-1] == "1 passed, 0 failed"


# -- plugins --------------------------------------------------------------------------------------------------
def test_a_missing_plugin_fails_its_scenario_and_the_others_run(capsys: pytest.CaptureFixture[str],
                                                                tmp_path: Path) -> None:
    missing = mission_copy(tmp_path, "missing", plugins=["no_such_plugin_module_zz"])
    good = mission_copy(tmp_path, "good")
    code, out, err = cli(capsys, "test", missing, good)
    assert code == 1, (out, err)
    assert f"{missing}:1:" in err and "at /plugins/0: error: plugin 'no_such_plugin_module_zz' cannot be loaded: " \
                                     "no module named 'no_such_plugin_module_zz'" in err
    assert "--plugin" not in err
    assert out.splitlines() == ["ERROR missing: invalid scenario (1 problem(s) above)", "PASS good (440 ticks, 5.5 s)",
                                "1 passed, 0 failed, 1 invalid"]


def test_a_broken_plugin_names_its_entry_and_where_it_failed(capsys: pytest.CaptureFixture[str],
                                                             tmp_path: Path) -> None:
    (tmp_path / "broken.py").write_text("x = 1\nraise RuntimeError('boom')\n", encoding="utf-8")
    scenario = mission_copy(tmp_path, plugins=["broken.py"])
    code, _, err = cli(capsys, "test", scenario)
    assert code == 1
    assert "at /plugins/0: error: plugin error: " in err and "RuntimeError: boom" in err
    assert f"(it failed at {tmp_path / 'broken.py'}:2)" in err


def test_a_missing_command_line_plugin_is_a_usage_error_said_once(capsys: pytest.CaptureFixture[str],
                                                                  tmp_path: Path) -> None:
    scenario = mission_copy(tmp_path)
    code, out, err = cli(capsys, "--plugin", "no_such_plugin_module_zz", "test", scenario, scenario)
    assert code == 2
    assert err.count("--plugin no_such_plugin_module_zz: no module named") == 1
    assert out == ""


def test_a_plugin_calling_sys_exit_fails_its_scenario(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    (tmp_path / "quit.py").write_text(
        "import sys\nfrom fsm import State, register_state\n\n\n@register_state\nclass QuitNow(State):\n"
        "    def tick(self, ctx):\n        sys.exit(0)\n", encoding="utf-8")
    write(tmp_path / "q.json", {"initial": "q", "states": [{"id": "q", "type": "QuitNow"}]})
    quits = write(tmp_path / "quits.scenario.json", {"machine": "q.json", "plugins": ["quit.py"], "duration": 1,
                                                     "expect": [{"finished": True}]})
    good = mission_copy(tmp_path)
    code, out, err = cli(capsys, "test", quits, good, "--junit", str(tmp_path / "r.xml"))
    assert code == 1, out + err
    assert out.splitlines()[0].startswith("FAIL quits: a plugin ended the process during the run (SystemExit: 0)")
    assert out.splitlines()[-1] == "1 passed, 1 failed"
    suite = ET.parse(tmp_path / "r.xml").getroot().find("testsuite")
    assert suite is not None and (suite.get("tests"), suite.get("failures")) == ("2", "1")


# -- the JUnit report stays XML -------------------------------------------------------------------------------
def test_junit_report_with_control_characters_in_ids_parses(capsys: pytest.CaptureFixture[str],
                                                            tmp_path: Path) -> None:
    a, b = "a\x1b[2J\x00", "b\x9b31m\u00e9"
    write(tmp_path / "m.json", {"initial": a, "states": [{"id": a, "type": "Idle"}, {"id": b, "type": "Idle"}],
                                "transitions": [{"type": "Timeout", "from": a, "to": b, "seconds": 1}]})
    scenario = write(tmp_path / "s.scenario.json", {"name": "n\x07", "machine": "m.json", "duration": 2,
                                                    "expect": [{"at": 1.5, "active": a}]})
    invalid = write(tmp_path / "bad.scenario.json", {"machine": "m.json", "expect": [{"never": ["zz\x1b]0;t\x07"]}]})
    code, out, err = cli(capsys, "test", scenario, invalid, "--junit", str(tmp_path / "r.xml"))
    assert code == 1
    root = ET.parse(tmp_path / "r.xml").getroot()  # raises on a character XML 1.0 forbids
    cases = root.findall(".//testcase")
    assert [c.get("name") for c in cases] == ["n\\x07", "bad"]
    failure = cases[0].find("failure")
    assert failure is not None and "expected 'a\\x1b[2J\\x00' active, active: b\x9b31m\u00e9" in (failure.text or "")
    error = cases[1].find("error")
    assert error is not None and "no state 'zz\\x1b]0;t\\x07'" in (error.text or "")
