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


#: A loop from benchmarks/bench_gate_worlds.py (seed 21): the gate 6/5 stands 1.9 m after the start, 0.6 m to the
#: left, outside the camera's view from the start pose; the home stretch used to stop at the start line before it.
GATE_AFTER_START = {'description': 'random loop 21: 20.9 x 11.8 m, corridors 1.93 m, 7 gates, start on straight 1',
                    'walls': [{'points': [[0, 0], [20.898, 0], [20.898, 11.81], [0, 11.81]], 'closed': True},
                              {'points': [[1.932, 1.932], [18.966, 1.932], [18.966, 9.878], [1.932, 9.878]],
                               'closed': True}],
                    'gates': [{'markers': [35, 26],
                               'center': [14.77, 1.111],
                               'heading': 4.0,
                               'width': 0.91,
                               'marker_size': 0.112,
                               'height': 0.2},
                              {'markers': [22, 21],
                               'center': [11.14, 1.234],
                               'heading': -14.9,
                               'width': 0.93,
                               'marker_size': 0.189,
                               'height': 0.2},
                              {'markers': [31, 47],
                               'center': [17.898, 0.624],
                               'heading': -23.7,
                               'width': 0.75,
                               'marker_size': 0.172,
                               'height': 0.2},
                              {'markers': [29, 25],
                               'center': [19.912, 4.943],
                               'heading': 95.0,
                               'width': 0.63,
                               'marker_size': 0.157,
                               'height': 0.2},
                              {'markers': [6, 5],
                               'center': [19.819, 8.799],
                               'heading': 98.5,
                               'width': 0.65,
                               'marker_size': 0.183,
                               'height': 0.2},
                              {'markers': [8, 16],
                               'center': [11.448, 11.124],
                               'heading': 170.3,
                               'width': 0.84,
                               'marker_size': 0.107,
                               'height': 0.2},
                              {'markers': [7, 18],
                               'center': [1.105, 3.812],
                               'heading': 279.2,
                               'width': 0.75,
                               'marker_size': 0.19,
                               'height': 0.2}],
                    'start': {'x': 20.403, 'y': 6.938, 'heading': 90.0}}


def run_loop21(tmp_path: Path, capsys: pytest.CaptureFixture[str], machine: Path) -> dict[str, Any]:
    world = tmp_path / "loop21.json"
    world.write_text(json.dumps(GATE_AFTER_START))
    summary = tmp_path / "s.json"
    code = main(["run", str(machine), "--world", str(world), "--seed", "0", "--summary", str(summary), "-q"])
    assert code == 0, capsys.readouterr().err
    s = json.loads(summary.read_text())
    assert s["outcome"] == "succeeded" and s["collisions"] == 0
    assert s["gates_passed"] == s["gates_total"] == 7, s["gates"]
    return s


def test_gate_run_backs_off_at_the_start_when_it_sees_one_post_of_a_gate(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """From the start pose the camera sees one marker of 6/5 (its partner is outside the field of view): the car
    backs off 1 m, sees the whole gate and passes it first. The first 15 s of the lap show it (6/5 is passed at
    9.2 s, the next gate at 28 s); the whole lap of this machine on this world is driven by the test below."""
    world = tmp_path / "loop21.json"
    world.write_text(json.dumps(GATE_AFTER_START))
    summary = tmp_path / "s.json"
    code = main(["run", str(DIAGRAMS / "gate_run.uxf"), "--world", str(world), "--seed", "0", "--duration", "15",
                 "--summary", str(summary), "-q"])
    assert code == 0, capsys.readouterr().err
    s = json.loads(summary.read_text())
    assert s["visited"][:3] == ["look", "view", "side1"] and s["collisions"] == 0
    assert [i for i, g in enumerate(s["gates"]) if g["passed_at"] is not None] == [4]


def test_gate_run_passes_a_gate_just_after_the_start_on_the_home_stretch(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """Without the back-off at the start the car leaves 6/5 behind; the home stretch passes it before the lap ends
    (it used to stop at the start line before it). The suite's one whole lap of loop 21."""
    doc = json.loads((DIAGRAMS / "gate_run.json").read_text())
    doc["transitions"] = [t for t in doc["transitions"] if t["type"] != "ArucoMarkerUnpaired"]
    for state in doc["states"]:
        if "machine" in state:
            state["machine"]["file"] = str(DIAGRAMS / state["machine"]["file"])
    doc.pop("$schema", None)
    machine = tmp_path / "gate_run_no_lone_post.json"
    machine.write_text(json.dumps(doc))
    s = run_loop21(tmp_path, capsys, machine)
    assert "view" not in s["visited"]
    first = s["gates"][4]  # 6/5, just after the start: passed last, on the home stretch
    assert first["passed_at"] == max(g["passed_at"] for g in s["gates"])


#: Random loop 217 of bench_gate_worlds.py --anywhere: the start is 0.43 m from the inner wall and 1.7 m before a
#: corner, so the car takes that corner while it settles to the outer wall, without the corner arc that ends a
#: straight; its fourth straight then runs across the start line.
START_BEFORE_CORNER = {"walls": [{"points": [[0, 0], [16.356, 0], [16.356, 9.51], [0, 9.51]], "closed": True},
                                 {"points": [[2.568, 2.568], [13.788, 2.568], [13.788, 6.941], [2.568, 6.941]],
                                  "closed": True}],
                       "gates": [{"markers": [26, 33], "center": [10.995, 1.562], "heading": 19.1, "width": 0.84,
                                  "marker_size": 0.128, "height": 0.2},
                                 {"markers": [23, 29], "center": [6.948, 1.752], "heading": 14.1, "width": 0.9,
                                  "marker_size": 0.16, "height": 0.2},
                                 {"markers": [31, 24], "center": [15.1, 5.684], "heading": 109.4, "width": 0.96,
                                  "marker_size": 0.117, "height": 0.2},
                                 {"markers": [32, 2], "center": [10.755, 7.717], "heading": 190.4, "width": 0.85,
                                  "marker_size": 0.186, "height": 0.2},
                                 {"markers": [48, 44], "center": [5.099, 8.201], "heading": 202.2, "width": 0.78,
                                  "marker_size": 0.161, "height": 0.2}],
                       "start": {"x": 2.144, "y": 4.244, "heading": 270.0}}


def test_gate_run_ends_at_the_start_line_when_the_first_corner_came_while_settling(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The fourth straight crosses the start line (PassPoint on side4): the lap ends there, one lap long. Before,
    the home stretch began after the start, drove a second lap on drifting odometry and touched walls 7 times."""
    world = tmp_path / "loop217.json"
    world.write_text(json.dumps(START_BEFORE_CORNER))
    summary = tmp_path / "s.json"
    code = main(["run", str(DIAGRAMS / "gate_run.uxf"), "--world", str(world), "--seed", "0", "--summary",
                 str(summary), "-q"])
    assert code == 0, capsys.readouterr().err
    s = json.loads(summary.read_text())
    assert s["outcome"] == "succeeded" and s["collisions"] == 0
    assert s["gates_passed"] == s["gates_total"] == 5
    assert all(g["times_passed"] == 1 for g in s["gates"])
    assert s["distance_m"] < 55, "one lap of this loop is about 45 m"
