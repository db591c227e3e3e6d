"""Generated paths (issue 34, point 5; docs/scenarios.md "Generated paths"): fsmctl test --explore searches a
machine's bounded inputs on the simulated clock, writes scenario files that replay what it reached (and pass),
reports what it could not reach and why, cuts an invariant violation down to a minimal scenario that reproduces
it, and refuses unbounded inputs naming the missing bound."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsm.tools.cli import main

REPO = Path(__file__).resolve().parents[1]
MENU = REPO / "diagrams" / "eeros" / "case7_menu.json"
AXIS = REPO / "diagrams" / "eeros" / "case1_axis.scenario.json"


def test_explore_reaches_everything_and_the_scenarios_it_writes_pass(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "gen"
    assert main(["test", "--explore", str(MENU), "--duration", "8", "--step", "1", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "reached 21/21 (states, transitions, monitors)" in text and "unreached" not in text
    files = sorted(out.glob("*.scenario.json"))
    assert len(files) >= 3
    doc = json.loads(files[-1].read_text(encoding="utf-8"))
    assert (out / doc["machine"]).resolve() == MENU.resolve()  # relative to the folder the scenario is in
    assert "Confirm the expectations" in doc["description"] and doc["expect"][0]["visits"]
    assert main(["test", "-q", *map(str, files)]) == 0
    assert capsys.readouterr().out.strip().endswith(f"{len(files)} passed, 0 failed")


def test_explore_with_plants_reports_what_it_could_not_reach_and_why(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    pause = REPO / "diagrams" / "eeros" / "case4_pause.scenario.json"
    assert main(["test", "--explore", str(pause), "--duration", "12", "--step", "1", "-o", str(tmp_path / "g")]) == 0
    text = capsys.readouterr().out
    assert "reached 8/10" in text
    assert "unreached: monitor arm/out: timeout timeout 6 s: not reached by any input sequence within 12 slots of " \
           "1 s (bounded depth" in text
    files = sorted((tmp_path / "g").glob("*.scenario.json"))
    assert json.loads(files[0].read_text(encoding="utf-8"))["plants"]  # the scenario's plants and plugins kept
    assert main(["test", "-q", *map(str, files)]) == 0


def test_an_invariant_violation_comes_back_as_a_minimal_scenario(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "gen"
    assert main(["test", "--explore", str(MENU), "--duration", "3", "--step", "1", "--invariant", "ran != 'AC'",
                 "-o", str(out)]) == 1
    assert "VIOLATION 'ran != 'AC'' at tick 160 (t=2 s) after 3 input(s)" in capsys.readouterr().out
    doc = json.loads((out / "violation.scenario.json").read_text(encoding="utf-8"))
    assert doc["inputs"] == [{"at": 0.0, "signal": "button_a", "value": True},
                             {"at": 1.0, "signal": "button_a", "value": False},
                             {"at": 2.0, "signal": "button_c", "value": True}]
    assert doc["expect"] == [{"invariant": "ran != 'AC'"}]
    assert main(["test", str(out / "violation.scenario.json")]) == 1  # it reproduces the violation
    assert "'ran != 'AC'' is false at tick 160 (t=2 s) (ran = \"AC\")" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--step", "1"], "--explore needs bounds: --duration (how long each explored path runs, in simulated seconds)"),
    (["--duration", "5"], "--explore needs bounds: --step (how often an input may change, in seconds)"),
    (["--duration", "5", "--step", "1", "--var", "ran"], "--var ran: give the variable and the values to try"),
    (["--duration", "5", "--step", "1", "--var", "rann=1,2"], "--var rann: the machine has no variable 'rann' "
                                                              "(did you mean 'ran'?)"),
    (["--duration", "5", "--step", "9"], "--step 9 is longer than --duration 5"),
    (["--duration", "5", "--step", "1", "--invariant", "ran >"], "--invariant 'ran >'"),
])
def test_unbounded_or_bad_explore_input_is_refused(argv: list[str], message: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["test", "--explore", str(MENU), *argv, "-o", str(tmp_path / "g")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "g").exists()


def test_explore_refuses_an_existing_output_folder_before_searching(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "g").mkdir()
    assert main(["test", "--explore", str(AXIS), "--duration", "5", "--step", "1", "-o", str(tmp_path / "g")]) == 2
    assert "-o " in capsys.readouterr().err and list((tmp_path / "g").iterdir()) == []
