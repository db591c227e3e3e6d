"""Closed-loop runs of the example machines on the simulated car, and ``fsmctl run`` with a car end to end."""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.sim.car import SimCar
from fsm.sim.loop import Simulation
from fsm.sim.world import load_world
from fsm.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
DIAGRAMS = ROOT / "diagrams"
HALLWAY = DIAGRAMS / "worlds" / "hallway.json"
OBSTACLE = DIAGRAMS / "worlds" / "obstacle.json"
EXAMPLES = ["hallway_lap", "lap", "turn_left", "lane_change", "corner_turn", "gate_run", "gate_side", "gate_home",
            "marker_signs"]
#: One lap of the hallway at 0.4 m from the outer wall, corners cut: about 55 m.
LAP_M = 55.0


def simulate(machine: str, world: Path, seed: int, duration: float = 400.0) -> Simulation:
    car = SimCar(load_world(world), seed=seed)
    sim = Simulation(fsm.load(DIAGRAMS / f"{machine}.json", car=car), car)
    sim.run(duration=duration)
    return sim


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_hallway_lap_three_laps_without_collision(seed: int) -> None:
    sim = simulate("hallway_lap", HALLWAY, seed)
    m = sim.metrics()
    assert sim.machine.outcome == "succeeded"
    assert m["collisions"] == 0 and m["min_wall_distance_m"] > 0.15
    assert 2.8 * LAP_M < m["distance_m"] < 3.2 * LAP_M
    assert m["wall_error_rms_m"] < 0.03, m
    assert m["wall_error_samples"] > 1000
    x, y, _ = sim.car.true_pose()
    start = sim.car.world.start
    assert abs(x - start.x) < 0.5 and abs(y - start.y) < 0.2  # back at the start
    assert abs(sim.car.speed) < 0.011 and sim.car._cmd_speed == 0.0


def test_lane_change_passes_the_obstacle() -> None:
    sim = simulate("lane_change", OBSTACLE, seed=0)
    m = sim.metrics()
    assert sim.machine.outcome == "succeeded"
    assert m["collisions"] == 0 and m["min_wall_distance_m"] > 0.1
    assert "beside" in sim.states_seen and "back" in sim.states_seen
    xs = [x for _, x, y, _ in sim.track]
    assert max(xs) > 20  # went past the obstacle at x = 10 to the end of the hallway
    left_lane = [y for _, x, y, _ in sim.track if 10.0 <= x <= 10.6]
    assert left_lane and min(left_lane) > 0.6 + 0.095  # beside the 0.6 m deep box: in the other lane


def test_corner_turn_with_a_nested_fsm_state() -> None:
    sim = simulate("corner_turn", HALLWAY, seed=0)
    m = sim.metrics()
    assert sim.machine.outcome == "succeeded"
    assert m["collisions"] == 0
    assert {"turn/arc", "turn/settle", "along"} <= set(sim.states_seen)
    x, y, th = sim.car.true_pose()
    assert x > 19.0 and 3.0 < y < 6.0  # up the right-hand side after the corner


@pytest.mark.parametrize("name", EXAMPLES)
def test_examples_are_in_sync_with_their_diagrams(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    uxf = DIAGRAMS / f"{name}.uxf"
    if not uxf.exists():
        pytest.skip("no .uxf yet")
    code = main(["convert", str(uxf), "--check", "-o", str(DIAGRAMS / f"{name}.json")])
    assert code == 0, capsys.readouterr().err


# -- fsmctl run with a car ---------------------------------------------------------------------------
def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_fsmctl_run_hallway_lap_default_world(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the default world is found next to the machine, not in the cwd
    summary, trace = tmp_path / "s.json", tmp_path / "t.jsonl"
    code, out, err = run_cli(capsys, "run", str(DIAGRAMS / "hallway_lap.json"), "--summary", str(summary),
                             "--trace", str(trace), "--expect", "succeeded")
    assert code == 0, err
    assert err == ""  # no progress bar when standard error is not a terminal
    s = json.loads(summary.read_text())
    assert s["outcome"] == "succeeded" and s["collisions"] == 0
    assert s["world"].endswith("hallway.json")
    for key in ("distance_m", "collisions", "min_wall_distance_m", "sim_time", "wall_time", "realtime_factor",
                "wall_error_rms_m"):
        assert key in s
    lines = [line for line in map(json.loads, trace.read_text().splitlines()) if line["type"] == "event"]
    assert lines[0]["transitions"][0]["type"] == "initial"
    assert {"x", "y", "left", "right", "front", "speed", "steering", "distance"} <= set(lines[0]["car"])
    assert lines[-1]["active"] == ["done"]
    assert "0 collisions" in out


def test_fsmctl_run_same_seed_same_trace(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    traces = []
    for k, seed in enumerate(("3", "3", "4")):
        trace = tmp_path / f"t{k}.jsonl"
        assert run_cli(capsys, "run", str(DIAGRAMS / "corner_turn.json"), "--seed", seed, "--trace", str(trace),
                       "-q")[0] == 0
        traces.append(trace.read_text())
    assert traces[0] == traces[1]
    assert traces[0] != traces[2]


def test_fsmctl_run_video_and_plot(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    cv2 = pytest.importorskip("cv2")
    video, png, summary = tmp_path / "c.mp4", tmp_path / "c.png", tmp_path / "s.json"
    code, _, err = run_cli(capsys, "run", str(DIAGRAMS / "corner_turn.json"), "--video", str(video),
                           "--plot", str(png), "--summary", str(summary), "-q")
    assert code == 0, err
    # H.264 (plays in browsers) through imageio-ffmpeg's ffmpeg, a declared dependency
    assert json.loads(summary.read_text())["video"]["codec"] == "h264"
    assert video.read_bytes()[4:8] == b"ftyp"  # an MP4 container
    cap = cv2.VideoCapture(str(video))
    assert cap.isOpened()
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    assert len(frames) > 20  # 18 s at 4x and 25 fps
    first, last = frames[0], frames[-1]
    assert first.shape[1] >= 1000 and (first != last).any()
    assert (first < 100).any()  # walls and text are drawn
    assert not list(tmp_path.glob(".*part*"))  # the temporary file was moved into place
    img = cv2.imread(str(png))
    assert img is not None and img.shape[1] >= 1000


def test_fsmctl_run_world_errors_before_the_run(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    code, _, err = run_cli(capsys, "run", str(DIAGRAMS / "corner_turn.json"), "--world",
                           str(tmp_path / "absent.json"), "--summary", str(summary))
    assert code == 1 and "world file not found" in err and not summary.exists()
    world = json.loads(HALLWAY.read_text())
    world["start"] = {"x": 10.0, "y": 0.02}
    bad = tmp_path / "inside.json"
    bad.write_text(json.dumps(world, indent=2))
    code, _, err = run_cli(capsys, "run", str(DIAGRAMS / "corner_turn.json"), "--world", str(bad))
    assert code == 1 and f"{bad}:" in err and "at /start" in err and "inside or touching" in err
    assert "Traceback" not in err


def test_fsmctl_run_bad_state_parameter_is_located(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    doc = {"initial": "f", "states": [{"id": "f", "type": "FollowWall", "side": "up", "distance": 0}]}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc, indent=1))
    code, _, err = run_cli(capsys, "run", str(path))
    assert code == 1
    assert "/states/0/side" in err and "/states/0/distance" in err and f"{path}:" in err


PLUGIN = textwrap.dedent('''
    from fsm import State, register_state

    @register_state
    class Explode(State):
        """Raises after 1 s."""
        needs_car = True

        def tick(self, ctx):
            if ctx.now > 1.0:
                raise ZeroDivisionError("the controller divided by zero")

    @register_state
    class Interrupt(State):
        """Acts as if Ctrl-C was pressed after 1 s."""
        needs_car = True

        def tick(self, ctx):
            if ctx.now > 1.0:
                raise KeyboardInterrupt
''')


@pytest.fixture(scope="module")
def plugin(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """One plugin module for the whole file: its types register once in the process-wide registry."""
    import sys

    name = "tral_fsm_test_car_plugin"
    folder = tmp_path_factory.mktemp("plugin")
    (folder / f"{name}.py").write_text(PLUGIN)
    sys.path.insert(0, str(folder))
    yield name
    # Leave the process-wide registry as it was: other tests compare it with the committed schema.
    from fsm.loading.registry import default_registry

    registry = default_registry()
    for type_name in ("Explode", "Interrupt"):
        registry.states.pop(type_name, None)
    registry._loaded_plugins.discard(name)
    sys.modules.pop(name, None)
    sys.path.remove(str(folder))


def test_fsmctl_run_exception_in_a_state_stops_the_car_and_writes_outputs(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, plugin: str) -> None:
    doc = {"initial": "drive", "states": [
        {"id": "drive", "type": "FSMState", "machine": {"initial": "go", "states": [
            {"id": "go", "type": "Motor", "speed": 1.0, "distance": 0.6},
            {"id": "bad", "type": "Explode"}], "transitions": [{"type": "Finished", "from": "go", "to": "bad"}]}}]}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    summary, trace, png = tmp_path / "s.json", tmp_path / "t.jsonl", tmp_path / "p.png"
    code, _, err = run_cli(capsys, "--plugin", plugin, "run", str(path), "--summary", str(summary),
                           "--trace", str(trace), "--plot", str(png))
    assert code == 1
    assert "state 'drive/bad'" in err and "at tick 81" in err and "ZeroDivisionError" in err
    assert "the car was stopped" in err and "Traceback" not in err
    s = json.loads(summary.read_text())
    assert s["error"]["state"] == "drive/bad" and s["error"]["tick"] == 81
    assert s["distance_m"] > 0.5
    assert "drive/bad" in trace.read_text()
    assert png.exists()


def test_fsmctl_run_ctrl_c_still_writes_summary_and_trace(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                          plugin: str) -> None:
    doc = {"initial": "i", "states": [{"id": "i", "type": "Interrupt"}]}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    summary, trace, video = tmp_path / "s.json", tmp_path / "t.jsonl", tmp_path / "v.avi"
    code, out, _ = run_cli(capsys, "--plugin", plugin, "run", str(path), "--summary", str(summary),
                           "--trace", str(trace), "--video", str(video))
    assert code == 130
    s = json.loads(summary.read_text())
    assert s["interrupted"] is True and s["sim_time"] == pytest.approx(1.0125)
    assert trace.exists() and video.stat().st_size > 0
    assert "interrupted" in out


def test_fsmctl_run_without_a_car_is_unchanged(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
           "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1}]}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    summary = tmp_path / "s.json"
    code, out, _ = run_cli(capsys, "run", str(path), "--summary", str(summary))
    assert code == 0 and "car:" not in out
    assert "collisions" not in json.loads(summary.read_text())
    code, _, err = run_cli(capsys, "run", str(path), "--plot", str(tmp_path / "p.png"))
    assert code == 2 and "--world" in err
    code, out, _ = run_cli(capsys, "run", str(path), "--world", str(HALLWAY))  # --world: drive anyway
    assert code == 0 and "car:" in out


def test_default_world_is_found_for_a_copied_machine(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(DIAGRAMS / "corner_turn.json", tmp_path / "corner_turn.json")
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, "run", "corner_turn.json", "-q")
    assert code == 0, err  # falls back to the checkout's diagrams/worlds/hallway.json


