"""Closed-loop gate driving on the simulated car: through one gate without touching a post, a blind camera finds no
gate (decisions come from pixels), and the acceptance run of diagrams/gate_run.uxf on two gate worlds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.sim.car import SimCar
from fsm.sim.loop import Simulation
from fsm.sim.world import parse_world
from fsm.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
DIAGRAMS = ROOT / "diagrams"

ONE_GATE = {
    "initial": "follow",
    "states": [
        {"id": "follow", "type": "FollowWall", "side": "right", "distance": 0.4, "speed": 0.8},
        {"id": "approach", "type": "ApproachPoint", "speed": 0.5, "tolerance": 0.15},
        {"id": "center", "type": "ArucoGateCenter"},
        {"id": "through", "type": "Motor", "speed": 0.5, "distance": 1.3},
        {"id": "stop", "type": "Stop"},
        {"id": "done", "type": "Final"},
    ],
    "transitions": [
        {"type": "ArucoGateFound", "from": "follow", "to": "approach", "range": 3.5},
        {"type": "Finished", "from": "approach", "to": "center"},
        {"type": "Finished", "from": "center", "to": "through"},
        {"type": "Finished", "from": "through", "to": "stop"},
        {"type": "Finished", "from": "stop", "to": "done"},
    ],
}


def corridor(gate: dict[str, Any]) -> Any:
    return parse_world({"walls": [{"points": [[0, 0], [14, 0], [14, 2], [0, 2]], "closed": True}],
                        "start": {"x": 1.0, "y": 0.5, "heading": 0}, "gates": [gate]})


@pytest.mark.parametrize("gate", [
    {"markers": [7, 21], "center": [6.0, 1.1], "heading": 15, "width": 0.6, "marker_size": 0.12},
    {"markers": [40, 3], "center": [5.0, 0.8], "heading": -20, "width": 0.8, "marker_size": 0.18},
])
def test_through_one_gate_without_touching_a_post(gate: dict[str, Any]) -> None:
    car = SimCar(corridor(gate), seed=2)
    sim = Simulation(fsm.load(ONE_GATE, car=car), car)
    sim.run(duration=40)
    m = sim.metrics()
    assert sim.machine.outcome == "succeeded"
    assert m["gates_passed"] == 1 and m["collisions"] == 0, m
    assert "center" in sim.states_seen


def test_a_blind_camera_finds_no_gate() -> None:
    """Markers of 4 mm: rendered into the frames, but too small to resolve, so no gate is ever found."""
    gate = {"markers": [7, 21], "center": [6.0, 1.0], "heading": 0, "width": 0.8, "marker_size": 0.004}
    car = SimCar(corridor(gate), seed=0)
    sim = Simulation(fsm.load(ONE_GATE, car=car), car)
    sim.run(duration=6)
    assert sim.machine.active_path == "follow" and car.rendered_frames > 50
    assert sim.metrics()["gates_passed"] == 0


@pytest.mark.parametrize("world, seed", [("gates.json", 0), ("gates_wide.json", 3)])
def test_gate_run_passes_every_gate_and_comes_home(world: str, seed: int, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    summary = tmp_path / "s.json"
    code = main(["run", str(DIAGRAMS / "gate_run.uxf"), "--world", str(DIAGRAMS / "worlds" / world),
                 "--seed", str(seed), "--summary", str(summary), "-q"])
    assert code == 0, capsys.readouterr().err
    s = json.loads(summary.read_text())
    assert s["outcome"] == "succeeded"
    assert s["gates_total"] >= 4 and s["gates_passed"] == s["gates_total"], s["gates"]
    assert s["collisions"] == 0
    assert all(g["passed_at"] is not None for g in s["gates"])
    assert s["odometry_error_m"] < 2.0


def test_marker_ids_trigger_behaviours_turn_around_on_7_and_stop_on_5() -> None:
    car = SimCar(__import__("fsm.sim.world", fromlist=["load_world"]).load_world(DIAGRAMS / "worlds" / "signs.json"),
                 seed=1)
    sim = Simulation(fsm.load(DIAGRAMS / "marker_signs.json", car=car), car)
    sim.run(duration=60)
    assert sim.machine.outcome == "succeeded"
    assert sim.states_seen[:4] == ["drive", "turn_around", "back", "stop"]
    assert sim.metrics()["collisions"] == 0
    x, y, th = car.true_pose()
    assert x < 2.0 and abs(car.speed) < 0.02  # stopped in front of marker 5 on the west wall
