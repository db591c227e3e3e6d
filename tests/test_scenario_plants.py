"""Plants without Python (issue 34, point 9; docs/scenarios.md "Plants"): Integrator (an axis with limit switches),
Queue (a conveyor with a counter), Button (pressed on a condition, with bounce) and TimerSensor, wired to the
machine's variables and signals by expressions; the thesis's simple axis stated with them passes; bad parameters are
located errors with suggestions."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario, run_scenario

REPO = Path(__file__).resolve().parents[1]
AXIS = REPO / "diagrams" / "eeros" / "declarative" / "axis.scenario.json"

#: sets 'grab' true for 0.1 s at 0.5 s and at 1.5 s, and 'go' true at 1 s
MACHINE = {"initial": "main", "vars": {"grab": False, "go": False, "n": 0}, "states": [
    {"id": "main", "type": "Sequence", "steps": [
        {"id": "w1", "type": "Wait", "seconds": 0.5}, {"id": "g1", "type": "SetVar", "assign": {"grab": True}},
        {"id": "w2", "type": "Wait", "seconds": 0.1}, {"id": "r1", "type": "SetVar", "assign": {"grab": False}},
        {"id": "w3", "type": "Wait", "seconds": 0.3}, {"id": "go", "type": "SetVar", "assign": {"go": True}},
        {"id": "w4", "type": "Wait", "seconds": 0.4}, {"id": "g2", "type": "SetVar", "assign": {"grab": True}},
        {"id": "w5", "type": "Wait", "seconds": 0.1}, {"id": "r2", "type": "SetVar", "assign": {"grab": False}},
        {"id": "w6", "type": "Wait", "seconds": 2}]}]}


def run(tmp_path: Path, plants: list[dict[str, Any]], expect: list[dict[str, Any]]) -> list[str]:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 4, "plants": plants, "expect": expect}, indent=1),
                  encoding="utf-8")
    return [f.message for f in run_scenario(load_scenario(sc)).failures]


def test_the_thesis_axis_stated_without_python_passes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["test", str(AXIS)]) == 0
    assert "PASS axis (720 ticks, 9 s)" in capsys.readouterr().out
    doc = json.loads(AXIS.read_text(encoding="utf-8"))
    assert "plugins" not in doc and doc["plants"][0]["type"] == "Integrator"


@pytest.mark.parametrize("name", ["rendezvous", "rendezvous_estop"])
def test_the_thesis_detailed_rendezvous_without_python_passes(name: str) -> None:
    """Case 8 with Queue and Integrator plants, with and without its emergency stop: case 8's figures (5 handovers,
    4 retries, one offer withdrawn, aborted at 30 s) with the stop, 7 handovers in 40 s without."""
    path = AXIS.parent / f"{name}.scenario.json"
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert "plugins" not in doc and {p["type"] for p in doc["plants"]} == {"Queue", "Integrator"}
    result = run_scenario(load_scenario(path))
    assert result.passed, [f.message for f in result.failures]
    assert result.outcome == ("aborted" if name.endswith("estop") else None)


def test_a_wrong_plant_fails_the_axis_scenario(tmp_path: Path) -> None:
    doc = json.loads(AXIS.read_text(encoding="utf-8"))
    doc["machine"] = str(AXIS.parent / doc["machine"])
    doc["plants"][0]["rate"] = "0.5 * cmd"  # twice as fast: the positions the thesis gives are missed
    (tmp_path / "t.scenario.json").write_text(json.dumps(doc), encoding="utf-8")
    failures = run_scenario(load_scenario(tmp_path / "t.scenario.json")).failures
    assert any("expected axis_x = 0.25 ± 0.001, got 0" in f.message for f in failures), [f.message for f in failures]


def test_a_queue_supplies_parts_and_counts_takes_and_misses(tmp_path: Path) -> None:
    queue = {"name": "feed", "type": "Queue", "arrive_every": 1.0, "take": "grab", "present": "part"}
    assert run(tmp_path, [queue], [
        {"at": 0.4, "vars": {"feed_count": 0, "feed_taken": 0, "feed_misses": 0}},
        {"at": 0.7, "vars": {"feed_count": 0, "feed_misses": 1}},  # grabbed at 0.5 s: nothing there yet
        {"at": 1.2, "vars": {"feed_count": 1}}, {"at": 1.2, "holds": "signal_part"},
        {"at": 1.7, "vars": {"feed_count": 0, "feed_taken": 1}},
        {"at": 3.5, "vars": {"feed_count": 2}}]) == []


def test_a_button_pressed_on_a_condition_with_bounce_and_a_timer_sensor(tmp_path: Path) -> None:
    button = {"name": "op", "type": "Button", "signal": "b", "press_when": "go", "delay": 0.25, "duration": 0.2,
              "bounce": {"count": 2, "interval": 0.0125}}
    sensor = {"name": "s", "type": "TimerSensor", "signal": "warm", "when": "go", "delay": 0.5, "hold": 0.25}
    found = run(tmp_path, [button, sensor], [
        {"eventually": "rose(signal_b)", "count": 5},  # bouncing twice: 3 rises on the press, 2 on the release
        {"never": "signal_b", "within": [0, 1.15]},
        {"eventually": "signal_b", "within": [1.15, 1.4]},
        {"always": "not signal_b", "within": [1.5, 4]},
        {"never": "signal_warm", "within": [0, 1.4]},
        {"eventually": "rose(signal_warm)", "count": 1},
        {"at": 1.6, "holds": "signal_warm"}, {"at": 2.0, "holds": "not signal_warm"}])
    assert found == []


def test_bad_plant_parameters_are_located(tmp_path: Path) -> None:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 4, "expect": [{"finished": True}], "plants": [
        {"name": "ax", "type": "Integrator", "rate": "0.2 * gerb"},
        {"name": "q", "type": "Queue", "take": "grab + 1"},
        {"name": "z", "type": "Integrator", "rate": "1", "min": 2, "max": 1}]}, indent=1), encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    found = [str(p) for p in info.value.problems if p.severity == "error"]
    assert len(found) == 3, found
    assert "at /plants/0/rate: error: plant 0: rate: unknown variable 'gerb'" in found[0]
    assert found[0].endswith("(did you mean grab?)")
    assert "at /plants/1/take: error: plant 1: take: '+' needs a number, got true/false" in found[1]
    assert "at /plants/2: error: plant 2: 'min' 2 must be below 'max' 1" in found[2]
