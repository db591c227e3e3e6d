"""Safety of readings from a car on ROS 2: REP 117's meanings of a Range's infinities and NaN, and odometry that jumps
farther than the car can travel (a reset, a glitch)."""

from __future__ import annotations

import math
from typing import Any

import pytest

pytest.importorskip("rosbags")

from fsm.ros import messages as M  # noqa: E402
from fsm.ros.car import RosCar  # noqa: E402
from fsm.ros.profile import DEFAULT_PROFILE_PATH, load_profile  # noqa: E402


def profile(hall: bool = True) -> Any:
    p = load_profile(DEFAULT_PROFILE_PATH)
    if not hall:
        p = p.model_copy(update={"inputs": p.inputs.model_copy(update={"hall": None})})
    return p


def front(car: RosCar, value: float, t: float, min_range: float = 0.02) -> None:
    car.offer("front", M.encode(M.range_message(t, "us_front", value, 4.0, min_range=min_range)))
    car.latch(t)


@pytest.mark.parametrize(("value", "reads"), [
    (-math.inf, 0.02),   # too close to measure: min_range
    (0.01, 0.02),        # under min_range: too close
    (-0.5, 0.02),
    (math.inf, 4.0),     # nothing in range: the profile's max_range
    (4.5, 4.0),          # over max_range
    (0.8, 0.8),
])
def test_a_range_reads_as_rep_117_means_it(value: float, reads: float) -> None:
    car = RosCar(profile())
    front(car, value, 0.0125)
    assert car.front == pytest.approx(reads, abs=1e-6)
    assert car.input_time("front") == 0.0125 and car.sample == 1
    assert car.front < 1.0 or reads == 4.0, "a 'front below 1.0 m' rule fires on -inf"


def test_a_range_over_the_sensors_own_max_is_nothing_in_range() -> None:
    car = RosCar(profile())
    car.offer("front", M.encode(M.range_message(0.1, "us_front", 3.5, 3.0)))  # a 3 m sensor
    car.latch(0.1)
    assert car.front == 4.0


def test_nan_is_a_dropped_reading_that_counts_toward_silence() -> None:
    p = profile()
    car = RosCar(p)
    front(car, 0.7, 0.0)
    silence = p.inputs.front.max_silence
    t = 0.0
    while t < silence + 0.1:
        t += 0.05
        front(car, math.nan, t)
    assert car.front == pytest.approx(0.7), "the last real reading stays"
    assert car.dropped["front"] >= 6 and car.input_time("front") == 0.0
    assert "front" in car.silent_inputs(t)
    front(car, 0.6, t + 0.05)
    assert "front" not in car.silent_inputs(t + 0.05)


def odometry(car: RosCar, x: float, t: float) -> None:
    car.offer("odometry", M.encode(M.odometry_message(t, x, 0.0, 0.0, 1.0, 0.0)))
    car.latch(t)


def test_an_odometry_jump_of_1_km_is_flagged_and_ignored_for_distance() -> None:
    logged: list[str] = []
    car = RosCar(profile(hall=False), log=logged.append)
    x, t = 0.0, 0.0
    for _ in range(80):  # 1 s at 1 m/s, 80 Hz
        odometry(car, x, t)
        x, t = x + 1.0 / 80, t + 1.0 / 80
    assert car.distance == pytest.approx(79 / 80)
    odometry(car, x + 1000.0, t)  # the odometry was reset, or glitched
    assert car.odometry_jumps == 1 and car.distance == pytest.approx(79 / 80)
    assert car.pose()[0] == pytest.approx(x + 1000.0), "the pose is what the car says"
    odometry(car, x + 1000.0 + 1.0 / 80, t + 1.0 / 80)  # and on from the new origin
    assert car.distance == pytest.approx(80 / 80) and car.odometry_jumps == 1
    assert len(logged) == 1 and "jumped 1e+03 m" in logged[0]


def test_a_fast_car_after_a_pause_of_odometry_is_not_a_jump() -> None:
    """0.5 s without odometry at 2 m/s: a 1 m step is travel, not a jump."""
    car = RosCar(profile(hall=False))
    odometry(car, 0.0, 0.0)
    odometry(car, 1.0, 0.5)
    assert car.odometry_jumps == 0 and car.distance == pytest.approx(1.0)


def test_commands_and_bags_are_stamped_in_ros_time_on_the_wall_clock(tmp_path: Any) -> None:
    """A real robot drops stale commands: a run on the wall clock stamps them (and the bag) in ROS time, not from
    1970; lock-step keeps the simulator's /clock."""
    import time

    from fsm.ros.bag import BagRecorder, read_bag
    from fsm.ros.driver import RosDriver

    class Quiet:
        def matched(self) -> bool:
            return True

        def put(self, payload: bytes) -> None:
            sent.append(payload)

    class Bus:
        def __init__(self, profile: Any) -> None:
            self.profile = profile

        def publisher(self, binding: Any) -> Quiet:
            return Quiet()

        def subscribe(self, binding: Any, callback: Any) -> None:
            pass

        def wait_for_peer(self, timeout: float, what: str = "", stop: Any = None) -> None:
            pass

        def describe(self) -> str:
            return "here"

    sent: list[bytes] = []
    p = profile()
    bag = BagRecorder(tmp_path / "bag", p)
    driver = RosDriver(p, Bus(p), bag=bag)  # type: ignore[arg-type]
    for side in ("left", "right", "front"):  # every input came
        driver.car.offer(side, M.encode(M.range_message(0.0, "us", 1.0, 4.0)))
    driver.car.offer("odometry", M.encode(M.odometry_message(0.0, 0, 0, 0, 0, 0)))
    driver.car.offer("hall", M.encode(M.counter_message("std_msgs/msg/Int32", 0)))
    before = time.time()
    driver.prime(1)
    driver._publish_command(2.0, 0.5)
    bag.commit()
    stamp = M.stamp_seconds(M.decode(sent[-1], p.outputs.command.type))
    assert before <= driver.time_offset <= time.time()
    assert stamp == pytest.approx(driver.time_offset + 2.0, abs=1e-6)
    (command,) = [m for m in read_bag(tmp_path / "bag") if m[0] == "/tral/cmd"]
    assert command[2] == pytest.approx((driver.time_offset + 2.0) * 1e9, abs=1e3)
    lockstep = RosDriver(p, Bus(p), lockstep=True)  # type: ignore[arg-type]
    assert lockstep.time_offset == 0.0
