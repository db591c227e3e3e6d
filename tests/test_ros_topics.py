"""TopicQuiet (fsm/transitions/topics.py) on a car whose readings come from topics (fsm.ros.car.RosCar, fed by hand
through ``offer`` as Zenoh would): a monitor watching silence fires, the car is commanded to stop, and a car without
topics never goes quiet."""

from __future__ import annotations

from typing import Any

import pytest

pytest.importorskip("rosbags")

import fsm
from fsm.ros import messages as M
from fsm.ros.car import RosCar
from fsm.ros.profile import DEFAULT_PROFILE_PATH, load_profile
from fsm.sim.fake import FakeCar

MACHINE = {
    "initial": "drive",
    "states": [
        {"id": "drive", "type": "Sequence", "steps": [{"id": "go", "type": "Motor", "speed": 0.5, "distance": 100}],
         "monitors": [{"condition": {"type": "TopicQuiet", "input": "front", "seconds": 0.3},
                       "exception": "halt", "behavior": "abortOwner"}],
         "exceptions": [{"id": "halt", "type": "Sequence", "steps": [{"id": "brake", "type": "Stop"}]}]},
    ],
}


def feed(car: RosCar, t: float, front: bool = True) -> None:
    for name in ("left", "right") + (("front",) if front else ()):
        car.offer(name, M.encode(M.range_message(t, name, 1.0, 4.0)))
    car.offer("odometry", M.encode(M.odometry_message(t, 0.0, 0.0, 0.0, 0.5, 0.0)))
    car.offer("hall", M.encode(M.counter_message("std_msgs/msg/Int32", int(t * 100))))


def test_a_silent_range_fires_the_monitor_and_a_garbled_one_is_silence() -> None:
    logged: list[str] = []
    car = RosCar(load_profile(DEFAULT_PROFILE_PATH), log=logged.append)
    machine: Any = fsm.load(MACHINE, car=car)
    fired: list[str] = []

    class Watch(fsm.Listener):
        def on_monitor(self, ctx: Any, owner: Any, monitor: Any) -> None:
            fired.append(owner.path)

    machine.add_listener(Watch())
    car.latch(0.0)
    machine.start()
    for n in range(1, 81):
        t = n * machine.dt
        feed(car, t, front=t < 0.4)
        if t >= 0.4:
            car.offer("front", b"\x00\x01\x00\x00garbage")  # counted, logged once, silence to the machine
        car.latch(t)
        machine.tick()
        if fired:
            break
    assert fired == ["drive"], "the monitor fired once, on the silent front sensor"
    assert 0.4 + 0.3 < machine.now <= 0.4 + 0.3 + 2 * machine.dt
    assert car.speed_command == 0.0
    assert car.failures()["front"] >= 20
    assert len([line for line in logged if "'front'" in line]) == 1


def test_a_car_without_topics_never_goes_quiet() -> None:
    car = FakeCar()
    machine: Any = fsm.load(MACHINE, car=car)
    fsm.run(machine, max_ticks=200)
    assert car.speed_command == 0.5


def test_never_heard_counts_from_the_start_and_unbound_inputs_never_quiet() -> None:
    car = RosCar(load_profile(DEFAULT_PROFILE_PATH))
    assert car.input_time("front") == 0.0 and car.input_time("camera") is None
    car.latch(1.0)
    assert car.silent_inputs(1.0) == ["left", "right", "front", "odometry", "hall"]
