"""ArucoGateFound, ArucoMarkerFound and ArucoGateCenter on a scripted camera (FakeCar.see): what they decide from
detections alone, and how the gate's pose travels from the transition to the next states."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import fsm
from fsm.sim.fake import FakeCar
from fsm.vision.detector import Detection
from fsm.vision.gates import Gate


def det(marker_id: int, x: float, y: float) -> Detection:
    z = np.zeros(3)
    return Detection(marker_id, np.zeros((4, 2), np.float32), 0.15, z, z, (x, y, 0.15), math.hypot(x, y),
                     math.atan2(y, x), math.pi, 0.0)


def gate_seen_from(car: FakeCar, center: tuple[float, float], heading: float, width: float = 0.7,
                   ids: tuple[int, int] = (3, 4)) -> Gate:
    """The gate (world centre, heading) as the car at its pose sees it: both markers in the car frame."""
    nx, ny = -math.sin(heading), math.cos(heading)
    c, s = math.cos(car.heading), math.sin(car.heading)
    out = []
    for side in (1, -1):
        wx, wy = center[0] + side * nx * width / 2 - car.x, center[1] + side * ny * width / 2 - car.y
        out.append((c * wx + s * wy, -s * wx + c * wy))
    return Gate.from_markers(det(ids[0], *out[0]), det(ids[1], *out[1]))


def move(car: FakeCar, dt: float = 0.0125) -> None:
    """Kinematic bicycle on the scripted car (odometry = truth here)."""
    v = car.speed_command
    delta = car.steering * car.max_steering_angle
    car.x += v * dt * math.cos(car.heading)
    car.y += v * dt * math.sin(car.heading)
    car.heading += v * dt * math.tan(delta) / car.wheelbase
    car.travel(abs(v) * dt)


def load(states: list[dict[str, Any]], transitions: list[dict[str, Any]], car: FakeCar) -> fsm.Machine:
    return fsm.load({"initial": states[0]["id"], "states": states, "transitions": transitions}, car=car)


def test_gate_found_fires_in_range_and_hands_the_point_before_the_gate() -> None:
    car = FakeCar()
    m = load([{"id": "look", "type": "Idle"}, {"id": "go", "type": "ApproachPoint", "speed": 0.5}],
             [{"type": "ArucoGateFound", "from": "look", "to": "go", "range": 2.5, "before": 1.0}], car)
    m.start()
    far = gate_seen_from(car, (3.0, 0.2), 0.0)
    car.see([far.left, far.right], [far])
    m.tick()
    assert m.active_path == "look"  # 3 m: out of range
    near = gate_seen_from(car, (2.4, 0.2), 0.0)
    for _ in range(2):
        car.see([near.left, near.right], [near])
        m.tick()
        if m.active_path == "look":
            m.tick()  # the same frame again: no new evidence
            assert m.active_path == "look"
    assert m.active_path == "go"
    gate = m.ctx.vars["gate"]
    assert gate["ids"] == [3, 4] and gate["x"] == pytest.approx(2.4) and gate["y"] == pytest.approx(0.2)
    assert m.state("go")._tx == pytest.approx(1.4) and m.state("go")._ty == pytest.approx(0.2)


def test_gate_found_with_ids_ignores_other_gates_and_gates_seen_askew() -> None:
    car = FakeCar()
    m = load([{"id": "look", "type": "Idle"}, {"id": "stop", "type": "Idle"}],
             [{"type": "ArucoGateFound", "from": "look", "to": "stop", "ids": [8, 9], "frames": 1}], car)
    m.start()
    other = gate_seen_from(car, (2.0, 0.0), 0.0)
    car.see([other.left, other.right], [other])
    m.tick()
    assert m.active_path == "look"
    askew = gate_seen_from(car, (2.0, 0.0), math.radians(75), ids=(8, 9))
    car.see([askew.left, askew.right], [askew])
    m.tick()
    assert m.active_path == "look"
    mine = gate_seen_from(car, (2.0, 0.0), math.radians(20), ids=(8, 9))
    car.see([mine.left, mine.right], [])  # paired from the ids even if the view did not pair them
    m.tick()
    assert m.active_path == "stop"


def test_marker_found_fires_for_its_id_within_range() -> None:
    car = FakeCar()
    m = load([{"id": "drive", "type": "Idle"}, {"id": "five", "type": "Idle"}, {"id": "seven", "type": "Idle"}],
             [{"type": "ArucoMarkerFound", "from": "drive", "to": "five", "marker": 5, "range": 1.2},
              {"type": "ArucoMarkerFound", "from": "drive", "to": "seven", "marker": 7, "range": 1.2}], car)
    m.start()
    for frame in ([det(7, 2.0, 0.0)], [det(7, 1.5, 0.0), det(5, 3, 0)], [det(7, 1.1, 0.0)], [det(7, 1.0, 0.0)]):
        car.see(frame)
        m.tick()
    assert m.active_path == "seven"


def test_marker_unpaired_fires_for_one_post_of_a_gate_never_seen_whole() -> None:
    """One marker in view without its partner (the other post outside the field of view) is a gate not yet seen
    whole; markers of a gate in view, of a remembered gate, of a passed gate or beyond range are not."""
    car = FakeCar()
    m = load([{"id": "look", "type": "Idle"}, {"id": "back", "type": "Idle"}],
             [{"type": "ArucoMarkerUnpaired", "from": "look", "to": "back", "range": 4.5}], car)
    m.start()
    whole = gate_seen_from(car, (2.0, 0.0), 0.0, ids=(3, 4))
    for frame in ([whole.left, whole.right], [whole.left, whole.right], [det(3, 2.0, 0.35)], [det(3, 2.0, 0.35)],
                  [det(8, 5.0, 1.0)], [det(8, 5.0, 1.0)], [det(11, 3.0, 1.6)]):
        car.see(frame, [whole] if len(frame) == 2 else [])
        m.tick()
    assert m.active_path == "look"  # the lone 3 belongs to a gate seen before; 8 is beyond range; 11 seen once
    m.ctx.vars["gates_passed"] = [[20, 21]]
    for _ in range(2):
        car.see([det(21, 3.0, -1.0)])
        m.tick()
    assert m.active_path == "look"  # a post of a gate passed
    for _ in range(2):
        car.see([det(11, 3.0, 1.6)])
        m.tick()
    assert m.active_path == "back"


@pytest.mark.parametrize("y0, heading0, gate_heading",
                         [(0.3, -10, 0), (-0.25, 15, 10), (0.6, -25, -25), (-0.4, 10, 20)])
def test_gate_center_lines_the_car_up_and_motor_drives_through(y0: float, heading0: float,
                                                               gate_heading: float) -> None:
    car = FakeCar()
    car.y, car.heading = y0, math.radians(heading0)
    center, h = (1.6, 0.0), math.radians(gate_heading)
    m = load([{"id": "find", "type": "Idle"}, {"id": "center", "type": "ArucoGateCenter"},
              {"id": "through", "type": "Motor", "speed": 0.5, "distance": 2.5},
              {"id": "done", "type": "Final"}],
             [{"type": "ArucoGateFound", "from": "find", "to": "center", "frames": 1},
              {"type": "Finished", "from": "center", "to": "through", "outcome": "succeeded"},
              {"type": "Finished", "from": "through", "to": "done"}], car)
    m.start()
    outcome_seen = None
    crossed = None
    for k in range(2000):
        if k % 4 == 0:  # a frame every 50 ms, while both markers are in the 56 degree field of view
            g = gate_seen_from(car, center, h)
            visible = all(d.position[0] > 0.3 and abs(d.bearing) < math.radians(28) for d in (g.left, g.right))
            car.see([g.left, g.right] if visible else [], [g] if visible else [])
        m.tick()
        if m.active_path == "through" and outcome_seen is None:
            outcome_seen = car.x, car.y, car.heading
        before = (car.x - center[0]) * math.cos(h) + (car.y - center[1]) * math.sin(h)
        move(car)
        after = (car.x - center[0]) * math.cos(h) + (car.y - center[1]) * math.sin(h)
        if before < 0 <= after:
            crossed = -(car.x - center[0]) * math.sin(h) + (car.y - center[1]) * math.cos(h)
        if m.finished:
            break
    assert m.outcome == "succeeded" and outcome_seen is not None
    x, y, th = outcome_seen
    lateral = -(x - center[0]) * math.sin(h) + (y - center[1]) * math.cos(h)
    assert abs(lateral) <= 0.04 and abs(th - h) <= math.radians(4)
    # Motor drove straight on through the gate, near its centre (posts 0.35 m either side)
    assert crossed is not None and abs(crossed) < 0.1


def test_gate_center_without_a_gate_is_lost() -> None:
    car = FakeCar()
    m = load([{"id": "c", "type": "ArucoGateCenter"}, {"id": "lost", "type": "Final", "outcome": "lost"}],
             [{"type": "Finished", "from": "c", "to": "lost", "outcome": "lost"}], car)
    m.start()
    car.see()
    m.tick()
    m.tick()
    assert m.outcome == "lost" and car.speed_command == 0.0


def test_pass_point_fires_when_odometry_crosses_the_start_line_nearby() -> None:
    car = FakeCar()
    m = load([{"id": "drive", "type": "Idle"}, {"id": "home", "type": "Final"}],
             [{"type": "PassPoint", "from": "drive", "to": "home", "within": 1.0, "after": 5.0}], car)
    m.start()
    car.x, car.y = -0.5, 2.0  # crossing x = 0 too far to the side: not home
    car.travel(6.0)
    m.tick()
    car.x = 0.2
    m.tick()
    assert not m.finished
    car.x, car.y = -0.3, 0.3
    m.tick()
    car.x = 0.05
    m.tick()
    assert m.finished


def test_align_heading_turns_back_to_the_corridor_snapped_to_90_degrees() -> None:
    car = FakeCar()
    car.heading = math.radians(25)  # after a gate turned 25 degrees
    m = load([{"id": "s", "type": "AlignHeading", "snap": 90}, {"id": "done", "type": "Final"}],
             [{"type": "Finished", "from": "s", "to": "done"}], car)
    m.ctx.vars["gate"] = {"ids": [1, 2], "x": 2.0, "y": 0.0, "heading": 0.4, "approach_heading": math.radians(8)}
    m.start()
    m.tick()
    assert car.steering < 0  # towards 0 degrees (8 snapped), i.e. right
    for _ in range(400):
        m.tick()
        move(car)
        if m.finished:
            break
    assert m.finished and abs(car.heading) <= math.radians(5)


def test_follow_wall_without_distance_keeps_the_lane_but_clear_of_the_other_wall() -> None:
    car = FakeCar(left=1.2, right=0.7)
    m = load([{"id": "keep", "type": "FollowWall", "side": "right", "distance": "lane"}], [], car)
    m.start()
    assert m.state("keep").target == pytest.approx(0.7)
    car2 = FakeCar(left=0.2, right=1.5)
    m2 = load([{"id": "keep", "type": "FollowWall", "side": "right", "distance": "lane", "clear": 0.6}], [], car2)
    m2.start()
    assert m2.state("keep").target == pytest.approx(1.5 + 0.2 - 0.6)


def test_gate_found_keeps_the_handed_point_inside_the_walls() -> None:
    car = FakeCar(left=0.5, right=0.4)
    m = load([{"id": "look", "type": "Idle"}, {"id": "go", "type": "ApproachPoint"}],
             [{"type": "ArucoGateFound", "from": "look", "to": "go", "frames": 1}], car)
    m.start()
    g = gate_seen_from(car, (2.2, 0.1), math.radians(-25))  # its point 1 m before lies 0.52 m to the left
    car.see([g.left, g.right], [g])
    m.tick()
    assert m.active_path == "go" and m.state("go")._ty == pytest.approx(0.5 - 0.35)


def test_the_wall_clamp_never_moves_the_point_past_the_gate_centre() -> None:
    """The side readings describe the walls beside the car: a car turned 20 degrees away from a gate 3 m ahead
    sees its centre 1.5 m to the left while the left wall reads 0.9 m; the point before the gate is kept."""
    car = FakeCar(left=0.9, right=1.0)
    m = load([{"id": "look", "type": "Idle"}, {"id": "go", "type": "ApproachPoint"}],
             [{"type": "ArucoGateFound", "from": "look", "to": "go", "frames": 1, "range": 4.0}], car)
    m.start()
    g = gate_seen_from(car, (3.0, 1.5), 0.0)
    car.see([g.left, g.right], [g])
    m.tick()
    assert m.active_path == "go"
    assert m.state("go")._tx == pytest.approx(2.0) and m.state("go")._ty == pytest.approx(1.5)


def test_gates_seen_while_busy_are_remembered_and_driven_to_from_memory() -> None:
    """The car's gate memory is fed on every frame, whatever state is active: a gate seen while the machine was
    busy elsewhere (no camera transition active) is found from memory once it is out of view."""
    car = FakeCar()
    m = load([{"id": "busy", "type": "Idle"}, {"id": "look", "type": "Idle"},
              {"id": "go", "type": "ApproachPoint"}],
             [{"type": "Timeout", "from": "busy", "to": "look", "seconds": 0.05},
              {"type": "ArucoGateFound", "from": "look", "to": "go", "range": 4.0, "memory": True}], car)
    m.start()
    g = gate_seen_from(car, (3.5, 0.3), 0.0, ids=(12, 13))
    car.see([g.left, g.right], [g])
    m.tick()
    assert m.active_path == "busy" and "12,13" in car.gate_memory.gates
    car.x = 0.5  # the car moved on (odometry); the camera lost the gate
    for _ in range(8):
        car.see()
        m.tick()
    assert m.active_path == "go"
    assert m.ctx.vars["gates_seen"]["12,13"]["width"] == pytest.approx(0.7)
    assert m.state("go")._tx == pytest.approx(2.5) and m.state("go")._ty == pytest.approx(0.3)


@pytest.mark.parametrize("y0, outcome", [(0.05, "close"), (0.3, "wide"), (-0.3, "wide")])
def test_gate_center_near_the_gate_finishes_wide_when_driving_on_would_hit_a_post(y0: float, outcome: str) -> None:
    car = FakeCar()
    car.y = y0
    m = load([{"id": "find", "type": "Idle"}, {"id": "center", "type": "ArucoGateCenter"},
              {"id": "back", "type": "Final", "outcome": "backed"}, {"id": "on", "type": "Final"}],
             [{"type": "ArucoGateFound", "from": "find", "to": "center", "frames": 1},
              {"type": "Finished", "from": "center", "to": "back", "outcome": "wide"},
              {"type": "Finished", "from": "center", "to": "on"}], car)
    m.start()
    g = gate_seen_from(car, (0.38, 0.0), 0.0)  # 0.7 m wide: the posts 0.35 m either side of the centre line
    car.see([g.left, g.right], [g])
    m.tick()
    m.tick()
    m.tick()
    assert m.outcome == ("backed" if outcome == "wide" else "succeeded")
    assert (m.ctx.vars.get("gates_passed") == [[3, 4]]) == (outcome == "close")  # a wide gate is not passed yet


def test_approach_point_without_a_point_or_a_handed_target_is_missed() -> None:
    car = FakeCar()
    m = load([{"id": "go", "type": "ApproachPoint"}, {"id": "nowhere", "type": "Final", "outcome": "missed"}],
             [{"type": "Finished", "from": "go", "to": "nowhere", "outcome": "missed"}], car)
    m.start()
    m.tick()
    assert m.outcome == "missed" and car.speed_command == 0.0


def test_gate_approach_refines_the_point_as_the_gate_comes_nearer() -> None:
    """A gate first seen with its heading 12 degrees off: ArucoGateApproach moves its point with each new frame
    while the point is still `refine` m ahead, and hands the fresh pose on (`gate`); ApproachPoint would not."""
    car = FakeCar(left=3.0, right=3.0)
    m = load([{"id": "look", "type": "Idle"}, {"id": "go", "type": "ArucoGateApproach", "speed": 0.5},
              {"id": "there", "type": "Final"}],
             [{"type": "ArucoGateFound", "from": "look", "to": "go", "frames": 1, "range": 4.5},
              {"type": "Finished", "from": "go", "to": "there"}], car)
    m.start()
    center, true_heading = (4.0, 0.3), 0.0
    rough = gate_seen_from(car, center, math.radians(12))  # the far sighting's heading error
    car.see([rough.left, rough.right], [rough])
    m.tick()
    assert m.active_path == "go"
    first = (m.state("go")._tx, m.state("go")._ty)
    assert first[1] == pytest.approx(0.3 - math.sin(math.radians(12)), abs=1e-6)
    for k in range(1500):
        if k % 4 == 0 and m.active_path == "go":
            g = gate_seen_from(car, center, true_heading)
            if all(d.position[0] > 0.3 and abs(d.bearing) < math.radians(28) for d in (g.left, g.right)):
                car.see([g.left, g.right], [g])
        m.tick()
        move(car)
        if m.finished:
            break
    assert m.finished
    # it arrived at the point 1 m before the gate as the nearer frames put it, not at the first, rough one
    assert car.x == pytest.approx(3.0, abs=0.2) and car.y == pytest.approx(0.3, abs=0.15)
    assert m.ctx.vars["gate"]["heading"] == pytest.approx(0.0, abs=1e-6)
