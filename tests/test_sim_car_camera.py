"""The camera in the simulated car: markers rendered from the true pose and detected in the pixels, world checks
for markers, posts as obstacles, and odometry that is dead reckoning (not ground truth)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.sim.car import SimCar
from fsm.sim.world import parse_world

ROOT = Path(__file__).resolve().parent.parent


def corridor(gates: list[dict[str, Any]] | None = None, markers: list[dict[str, Any]] | None = None,
             **car: Any) -> Any:
    doc: dict[str, Any] = {"walls": [{"points": [[0, -1], [30, -1], [30, 1], [0, 1]], "closed": True}],
                           "start": {"x": 1.0, "y": 0.0, "heading": 0},
                           "gates": gates or [], "markers": markers or []}
    if car:
        doc["car"] = car
    return parse_world(doc)


GATE = {"markers": [3, 4], "center": [4.0, 0.0], "heading": 0, "width": 0.7}


def run(car: SimCar, seconds: float) -> None:
    for _ in range(int(round(seconds / 0.01))):
        car.step()


def test_the_car_sees_a_gate_in_rendered_pixels() -> None:
    car = SimCar(corridor([GATE]), seed=1)
    run(car, 0.2)
    view = car.camera()
    assert view is not None and view.frame == 4 and car.rendered_frames == 4
    assert sorted(d.id for d in view.detections) == [3, 4]
    (gate,) = view.gates
    assert gate.ids == (3, 4)  # left, right as seen from the car
    assert gate.center[0] == pytest.approx(3.0, abs=0.05) and gate.center[1] == pytest.approx(0.0, abs=0.03)
    assert abs(gate.heading) < math.radians(3)
    assert car.camera_image().shape == (480, 640, 3)


def test_a_blind_camera_finds_nothing_although_it_renders() -> None:
    """Markers too small to resolve: rendered, but no detection. Decisions come from pixels, not the world file."""
    tiny = {**GATE, "marker_size": 0.004}
    car = SimCar(corridor([tiny]), seed=1)
    run(car, 0.5)
    assert car.rendered_frames == 10
    assert car.camera().detections == () and car.camera().gates == ()


def test_nothing_in_view_renders_nothing() -> None:
    behind = {**GATE, "center": [0.5, 0.0], "heading": 180}
    car = SimCar(corridor([behind]))
    run(car, 0.5)
    assert car.camera_frames == 10 and car.rendered_frames == 0 and car.camera().detections == ()


def test_standalone_markers_are_seen_and_posts_are_obstacles() -> None:
    sign = {"id": 5, "position": [3.0, 0.0], "facing": 180, "size": 0.15, "height": 0.2, "post": True}
    car = SimCar(corridor(markers=[sign]), seed=0)
    run(car, 0.1)
    d = car.camera().marker(5)
    assert d is not None and d.distance == pytest.approx(2.0, abs=0.05)  # from the car centre
    car.set_speed(1.0)
    run(car, 3.0)
    assert car.collisions == 1  # drove into the post


@pytest.mark.parametrize("doc, pointer, words", [
    ({"gates": [{"markers": [3, 3], "center": [4, 0]}]}, "/gates/0/markers/1", "used twice"),
    ({"gates": [GATE], "markers": [{"id": 4, "position": [5, 0.9], "facing": 270}]}, "/markers/0/id", "used twice"),
    ({"gates": [{"markers": [3, 50], "center": [4, 0]}]}, "/gates/0/markers/1", "not in DICT_4X4_50"),
    ({"markers": [{"id": 1, "position": [5, 0.9], "facing": 270, "size": 0}]}, "/markers/0/size", "greater than 0"),
    ({"car": {"camera": {"pitch": 30}}}, "/car/camera/pitch", "points into the floor"),
    ({"car": {"camera": {"dictionary": "DICT_9X9_7"}}}, "/car/camera", "unknown ArUco dictionary"),
])
def test_bad_markers_and_cameras_are_located_errors(doc: dict[str, Any], pointer: str, words: str) -> None:
    base: dict[str, Any] = {"walls": [{"points": [[0, -1], [30, -1], [30, 1], [0, 1]], "closed": True}],
                            "start": {"x": 1.0, "y": 0.0}}
    with pytest.raises(DiagramError) as err:
        parse_world({**base, **doc}, "w.json")
    problems = err.value.problems
    assert any(p.pointer == pointer and words in p.message for p in problems), [(p.pointer, p.message)
                                                                                for p in problems]


def test_odometry_is_dead_reckoning_that_drifts() -> None:
    car = SimCar(corridor(), seed=3)
    car.set_speed(1.0)
    car.set_steering(0.3)
    run(car, 1.5)
    x, y, th = car.pose()
    tx, ty, tth = car.true_pose()
    assert (x, y) != (tx - 1.0, ty)  # not the ground truth ...
    assert 0.0 < car.odometry_error() < 0.2  # ... but close to it after 1.5 m
    assert abs(th - tth) < math.radians(5)
    exact = SimCar(corridor(), seed=3, noise=False)
    exact.set_speed(1.0)
    run(exact, 2.0)
    assert exact.odometry_error() < 0.02


def test_states_and_transitions_never_read_ground_truth() -> None:
    pattern = re.compile(r"true_pose|true_distance|\.body\b|odometry_error|world\.")
    offenders = []
    for folder in ("states", "transitions"):
        for path in (ROOT / "fsm" / folder).rglob("*.py"):
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if pattern.search(line):
                    offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not offenders, "\n".join(offenders)
