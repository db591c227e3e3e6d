"""The TRAL driving states and the car transitions, each control law in isolation on a scripted car (FakeCar)."""

from __future__ import annotations

import math
from typing import Any

import pytest

import fsm
from fsm.model.errors import DiagramError
from fsm.sim.fake import FakeCar
from fsm.sim.io import CarIO

DT = 0.0125


def machine(states: list[dict[str, Any]], transitions: list[dict[str, Any]] | None = None,
            car: FakeCar | None = None) -> tuple[fsm.Machine, FakeCar]:
    car = car or FakeCar()
    doc = {"initial": states[0]["id"], "states": states, "transitions": transitions or []}
    return fsm.load(doc, car=car), car


def test_fake_car_implements_the_interface() -> None:
    assert isinstance(FakeCar(), CarIO)


def test_follow_wall_derivative_is_the_slope_over_d_samples_so_noise_barely_steers() -> None:
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "side": "right", "distance": 0.4, "p": 0.0, "i": 0.0,
                       "d": 1.0, "d_samples": 4}], car=FakeCar(right=0.40))
    m.start()
    for k in range(1, 8):  # the wall recedes at 0.1 m/s: the slope is exact from the second sample on
        car.new_sample(right=0.40 + 0.1 * k * 0.05)
        for _ in range(4):
            m.tick()
    assert car.steering == pytest.approx(-0.1, abs=1e-6)
    car.new_sample(right=car.right + 0.01)  # one noisy sample: a quarter of the 2-sample law's kick (0.2)
    for _ in range(4):
        m.tick()
    assert -0.1 - 0.12 < car.steering < -0.1


# -- BasicFollowWall: the report's formula --------------------------------------------------------------
def test_basic_follow_wall_is_the_reports_pd_formula_per_sample() -> None:
    p, i, d = 2.0, 0.5, 1.5
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "side": "right", "distance": 0.4, "speed": 0.7,
                       "p": p, "i": i, "d": d, "d_samples": 2}], car=FakeCar(right=0.40))
    m.start()
    assert car.speed_command == 0.7
    # Four ticks per ultrasonic sample (80 Hz machine, 20 Hz sensor): the law runs on new samples only.
    readings = [0.45, 0.47, 0.46]
    esum, eold, t_last = 0.0, 0.0, 0.0
    for k, r in enumerate(readings):
        car.new_sample(right=r)
        m.tick()
        now = m.now
        e = r - 0.4
        esum += e
        dt = now - t_last
        y = p * e + esum * i * dt + d * (e - eold) / dt
        eold, t_last = e, now
        # right wall: too far (e > 0) means steer right, i.e. negative steering
        assert car.steering == pytest.approx(max(-1.0, min(1.0, -y)))
        held = car.steering
        for _ in range(3):
            m.tick()
            assert car.steering == held  # held between samples
        assert m.now == pytest.approx((4 * k + 4) * DT)


def test_basic_follow_wall_left_steers_the_other_way_and_clamps() -> None:
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "side": "left", "distance": 0.4, "p": 50, "d": 0}],
                     car=FakeCar(left=0.4))
    m.start()
    car.new_sample(left=0.6)  # too far from the left wall: steer left (positive), clamped to 1
    m.tick()
    assert car.steering == 1.0
    car.new_sample(left=0.3)
    m.tick()
    assert car.steering == -1.0


def test_basic_follow_wall_has_no_derivative_kick_on_entry() -> None:
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "distance": 0.4, "p": 0, "i": 0, "d": 1}],
                     car=FakeCar(right=0.9))
    m.start()
    for _ in range(4):
        m.tick()
    car.new_sample(right=0.9)
    m.tick()
    assert car.steering == 0.0


def test_follow_wall_with_snap_takes_the_reading_square_to_the_wall() -> None:
    """Turned 25 degrees off a corridor that runs along the start heading, a far wall read 2.2 m away is
    2.2 * cos(25) m away: with snap the controller sees that, without it the askew reading."""
    def steer(**extra: Any) -> float:
        m, car = machine([{"id": "f", "type": "BasicFollowWall", "distance": 1.8, "p": 1.0, "i": 0, "d": 0,
                           **extra}], car=FakeCar(right=2.2))
        car.heading = math.radians(90 + 25)  # the corridor runs along 90 degrees from the start heading
        m.start()
        car.new_sample(right=2.2)
        m.tick()
        return car.steering

    assert steer() == pytest.approx(-0.4)
    assert steer(snap=90.0) == pytest.approx(-(2.2 * math.cos(math.radians(25)) - 1.8))
    m, car = machine([{"id": "f", "type": "FollowWall", "distance": "lane", "snap": 90.0}], car=FakeCar(right=2.2))
    car.heading = math.radians(-25)
    m.start()
    assert m.state("f").target == pytest.approx(2.2 * math.cos(math.radians(25)))  # the lane, square to the wall
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "distance": 0.4, "p": 1.0, "i": 0, "d": 0,
                       "snap": 90.0}], car=FakeCar(right=3.0))
    car.heading = math.radians(30)
    m.start()
    car.new_sample(right=3.0)  # no echo: the maximum stays the maximum
    m.tick()
    assert car.steering == pytest.approx(-1.0)


# -- FollowWall: door frames --------------------------------------------------------------------------
def follow_wall(**extra: Any) -> tuple[fsm.Machine, FakeCar]:
    state = {"id": "f", "type": "FollowWall", "distance": 0.4, "p": 2.0, "i": 0, "d": 0, **extra}
    m, car = machine([state], car=FakeCar(right=0.40))
    m.start()
    return m, car


def feed(m: fsm.Machine, car: FakeCar, reading: float, metres: float = 0.05) -> float:
    car.travel(metres)
    car.new_sample(right=reading)
    m.tick()
    return car.steering


def test_follow_wall_ignores_a_door_frame() -> None:
    m, car = follow_wall()
    assert feed(m, car, 0.40) == pytest.approx(0.0)
    for _ in range(18):  # a 0.9 m door frame, 5 cm deep: the readings jump by 5 cm
        assert feed(m, car, 0.45) == pytest.approx(0.0)
    assert feed(m, car, 0.40) == pytest.approx(0.0)
    assert feed(m, car, 0.41) == pytest.approx(-0.02)  # small changes are followed


def test_follow_wall_keeps_following_small_changes_inside_a_door_frame() -> None:
    m, car = follow_wall()
    feed(m, car, 0.45)  # jump in: ignored
    assert feed(m, car, 0.46) == pytest.approx(-0.02)  # 1 cm farther inside the frame: followed


def test_basic_follow_wall_does_react_to_the_door_frame() -> None:
    m, car = machine([{"id": "f", "type": "BasicFollowWall", "distance": 0.4, "p": 2.0, "i": 0, "d": 0}],
                     car=FakeCar(right=0.40))
    m.start()
    assert feed(m, car, 0.45) == pytest.approx(-0.1)


def test_follow_wall_accepts_a_jump_after_hold_metres() -> None:
    m, car = follow_wall(hold=0.5)
    feed(m, car, 0.50)
    for _ in range(9):
        assert feed(m, car, 0.50) == pytest.approx(0.0)
    assert feed(m, car, 0.50) == pytest.approx(-0.2)  # 0.5 m later the wall really moved


def test_follow_wall_takes_a_huge_jump_at_once() -> None:
    m, car = follow_wall()
    assert feed(m, car, 1.40) == pytest.approx(-1.0)  # a 1 m jump is no door frame (an opening): followed


def test_follow_wall_threshold_is_a_parameter() -> None:
    m, car = follow_wall(jump=0.1)
    assert feed(m, car, 0.45) == pytest.approx(-0.1)


# -- FollowWallRamp ---------------------------------------------------------------------------------------
def test_ramp_moves_the_target_linearly_and_finishes_at_the_end() -> None:
    m, car = machine([{"id": "r", "type": "FollowWallRamp", "distance": 0.8, "length": 2.0, "p": 1, "i": 0, "d": 0},
                      {"id": "end", "type": "Final"}],
                     [{"type": "Finished", "from": "r", "to": "end"}], car=FakeCar(right=0.4))
    m.start()
    ramp = m.state("r")
    for k in range(1, 20):
        feed(m, car, 0.4, metres=0.1)
        target = 0.4 + 0.4 * (0.1 * k) / 2.0
        assert ramp.target == pytest.approx(target)
        assert car.steering == pytest.approx(-(0.4 - target))  # reading below the moving target: steer away
    assert not m.finished
    feed(m, car, 0.4, metres=0.1)
    m.tick()
    assert m.finished and m.outcome == "succeeded"


def test_ramp_start_parameter_overrides_the_reading() -> None:
    m, car = machine([{"id": "r", "type": "FollowWallRamp", "distance": 1.0, "length": 1.0, "start": 0.5}],
                     car=FakeCar(right=0.4))
    m.start()
    assert m.state("r").target == 0.5


# -- Motor, Stop, ApproachPoint ---------------------------------------------------------------------------
def test_motor_drives_fixed_commands_and_finishes_after_its_distance() -> None:
    m, car = machine([{"id": "m", "type": "Motor", "speed": 0.5, "steering": -0.3, "distance": 1.0},
                      {"id": "end", "type": "Final"}], [{"type": "Finished", "from": "m", "to": "end"}])
    car.travel(5.0)  # the odometer does not start at 0
    m.start()
    assert (car.speed_command, car.steering) == (0.5, -0.3)
    for _ in range(9):
        car.travel(0.1)
        m.tick()
        assert not m.finished
    car.travel(0.1)
    m.tick()
    m.tick()
    assert m.finished


def test_stop_finishes_when_the_car_stands_still() -> None:
    m, car = machine([{"id": "s", "type": "Stop"}, {"id": "end", "type": "Final"}],
                     [{"type": "Finished", "from": "s", "to": "end"}])
    car.speed = 1.0
    m.start()
    assert car.speed_command == 0.0
    m.tick()
    assert not m.finished
    car.speed = 0.005
    m.tick()
    m.tick()
    assert m.finished


def test_approach_point_steers_towards_the_point_and_finishes_on_arrival() -> None:
    m, car = machine([{"id": "a", "type": "ApproachPoint", "x": 2.0, "y": 1.0, "speed": 0.4, "tolerance": 0.1},
                      {"id": "end", "type": "Final"}], [{"type": "Finished", "from": "a", "to": "end"}])
    car.x, car.y, car.heading = 1.0, 1.0, math.pi / 2  # facing +y: the point is at (0, 3)
    m.start()
    m.tick()
    assert car.steering > 0  # it is ahead and to the left
    assert car.speed_command == 0.4
    car.x, car.y = 0.05, 2.95
    m.tick()
    m.tick()
    assert m.finished and m.outcome == "succeeded"


def test_approach_point_behind_within_reach_is_missed() -> None:
    m, car = machine([{"id": "a", "type": "ApproachPoint", "x": 1.0},
                      {"id": "end", "type": "Final", "outcome": "missed"}],
                     [{"type": "Finished", "from": "a", "to": "end", "outcome": "missed"}])
    m.start()
    car.x = 1.5  # drove past it
    m.tick()
    m.tick()
    assert m.outcome == "missed"


# -- transitions ---------------------------------------------------------------------------------------------
def test_distance_counts_from_the_entry_of_its_source() -> None:
    m, car = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                     [{"type": "Distance", "from": "a", "to": "b", "distance": 0.5}])
    car.travel(10.0)
    m.start()
    car.travel(0.49)
    m.tick()
    assert not m.finished
    car.travel(0.01)
    m.tick()
    assert m.finished


@pytest.mark.parametrize("sensor", ["left", "right", "front"])
def test_sensor_level_below_and_above(sensor: str) -> None:
    for key, fire, hold in (("below", 0.5, 0.9), ("above", 0.9, 0.5)):
        m, car = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                         [{"type": "SensorLevel", "from": "a", "to": "b", "sensor": sensor, key: 0.7}],
                         car=FakeCar(left=hold, right=hold, front=hold))
        m.start()
        m.tick()
        assert not m.finished
        car.new_sample(**{sensor: fire})
        m.tick()
        assert m.finished, (sensor, key)


def test_sensor_level_samples_filters_single_outliers() -> None:
    m, car = machine([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                     [{"type": "SensorLevel", "from": "a", "to": "b", "sensor": "front", "below": 1.0,
                       "samples": 3}], car=FakeCar(front=3.0))
    m.start()
    for reading in (0.5, 3.0, 0.5, 0.5):
        car.new_sample(front=reading)
        for _ in range(4):
            m.tick()
        assert not m.finished
    car.new_sample(front=0.5)
    m.tick()
    assert m.finished


# -- bad parameters: located errors before the run -----------------------------------------------------------
@pytest.mark.parametrize("state, key, words", [
    ({"id": "f", "type": "FollowWall", "distance": 0}, "distance", "greater than 0"),
    ({"id": "f", "type": "FollowWall", "distance": -0.4}, "distance", "greater than 0"),
    ({"id": "f", "type": "BasicFollowWall", "side": "up"}, "side", "'left' or 'right'"),
    ({"id": "f", "type": "FollowWallRamp", "distance": 0.5, "length": 0}, "length", "greater than 0"),
    ({"id": "f", "type": "Motor", "speed": 0.5, "distance": 0}, "distance", "greater than 0"),
    ({"id": "f", "type": "Motor", "speed": 0.5, "steering": 2, "distance": 1}, "steering", "less than or equal"),
    ({"id": "f", "type": "FollowWall", "speed": "fast"}, "speed", "number"),
])
def test_senseless_state_parameters_are_located_errors(tmp_path: Any, state: dict[str, Any], key: str,
                                                        words: str) -> None:
    import json

    text = json.dumps({"initial": "f", "states": [state]}, indent=2)
    path = tmp_path / "m.json"
    path.write_text(text)
    with pytest.raises(DiagramError) as err:
        fsm.load(str(path), car=FakeCar())
    (problem,) = err.value.problems
    assert problem.pointer == f"/states/0/{key}"
    assert problem.line is not None and problem.column is not None
    assert words in problem.message


@pytest.mark.parametrize("transition, words", [
    ({"type": "SensorLevel", "from": "a", "to": "b", "sensor": "back", "below": 1}, "'left', 'right' or 'front'"),
    ({"type": "SensorLevel", "from": "a", "to": "b", "sensor": "front"}, "exactly one"),
    ({"type": "SensorLevel", "from": "a", "to": "b", "sensor": "front", "below": 1, "above": 2}, "exactly one"),
    ({"type": "Distance", "from": "a", "to": "b", "distance": 0}, "greater than 0"),
    ({"type": "Motor", "from": "a", "to": "b"}, "unknown transition type"),
])
def test_senseless_transition_parameters_are_errors(transition: dict[str, Any], words: str) -> None:
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
           "transitions": [transition]}
    with pytest.raises(DiagramError) as err:
        fsm.load(doc, car=FakeCar())
    assert any(words in p.message for p in err.value.problems), err.value


def test_motor_with_speed_zero_is_refused() -> None:
    with pytest.raises(DiagramError, match="never cover the distance"):
        fsm.load({"initial": "m", "states": [{"id": "m", "type": "Motor", "speed": 0, "distance": 1}]})


def test_finished_out_of_a_wall_follower_is_refused() -> None:
    doc = {"initial": "f", "states": [{"id": "f", "type": "FollowWall"}, {"id": "b", "type": "Final"}],
           "transitions": [{"type": "Finished", "from": "f", "to": "b"}]}
    with pytest.raises(DiagramError, match="can never finish"):
        fsm.load(doc)
