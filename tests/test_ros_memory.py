"""`run --ros` holds no per-message history (issue 37 item 3): the driver on a transport written here (a robot in
the same thread that answers each command with the next tick's sensors and clock, as lock-step does), measured with
tracemalloc: what 8,000 more ticks leave allocated stays under 100 KB. Deterministic: no network, no wall clock."""

from __future__ import annotations

import gc
import tracemalloc
from collections.abc import Callable
from typing import Any

import pytest

pytest.importorskip("rosbags")

from fsm.ros import messages as M  # noqa: E402
from fsm.ros.profile import DEFAULT_PROFILE_PATH, Binding, load_profile  # noqa: E402

#: Drives on for ever: the front never comes under 1 m and the odometry does not move.
ENDLESS = {"name": "endless", "initial": "go",
           "states": [{"id": "go", "type": "Motor", "speed": 0.5, "steering": 0, "distance": 1000},
                      {"id": "halt", "type": "Stop"}],
           "transitions": [{"type": "SensorLevel", "from": "go", "to": "halt", "sensor": "front", "below": 1.0}]}


class LoopbackRobot:
    """A :class:`fsm.ros.transport.Bus` whose robot answers each command at once with the next tick's sensors and
    clock (the same messages every tick but the clock), in the caller's thread."""

    def __init__(self, profile: Any) -> None:
        self.profile = profile
        self.callbacks: dict[str, Callable[[bytes], None]] = {}
        self.t = 0.0  # the time of the next answer
        hall = profile.inputs.hall.type if profile.inputs.hall is not None else "std_msgs/msg/Int32"
        self.sensors = {b.topic: M.encode(M.range_message(0.0, "us", 3.0, 4.0)) for b in
                        (profile.inputs.left, profile.inputs.right, profile.inputs.front)}
        self.sensors[profile.inputs.odometry.topic] = M.encode(M.odometry_message(0.0, 0, 0, 0, 0, 0))
        self.sensors[profile.inputs.hall.topic] = M.encode(M.counter_message(hall, 0))

    def describe(self) -> str:
        return "a loopback robot"

    def open(self) -> LoopbackRobot:
        return self

    def close(self) -> None:
        pass

    def wait_for_peer(self, timeout: float, what: str = "", stop: Any = None) -> None:
        pass

    def publisher(self, binding: Binding) -> Any:
        robot = self

        class Pub:
            def matched(self) -> bool:
                return True

            def put(self, payload: bytes) -> None:
                if binding.topic == robot.profile.outputs.command.topic:
                    robot.answer()

        return Pub()

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        self.callbacks[binding.topic] = callback

    def answer(self) -> None:
        """This tick's sensors, then its clock; the next answer is the next tick's."""
        for topic, raw in self.sensors.items():
            self.callbacks[topic](raw)
        self.callbacks[self.profile.clock.topic](M.encode(M.clock_message(self.t)))
        self.t += self.profile.dt


def test_run_ros_memory_stays_flat_over_8000_ticks() -> None:
    import json

    from fsm.loading.loader import compile as compile_plan
    from fsm.loading.reading import parse_json_bytes
    from fsm.ros.driver import ros_session
    from fsm.session.session import StopRules

    profile = load_profile(DEFAULT_PROFILE_PATH)
    data, _ = parse_json_bytes(json.dumps(ENDLESS).encode(), "endless.json")
    robot = LoopbackRobot(profile)
    session = ros_session(compile_plan(data), profile, robot, lockstep=True, log=lambda text: None)
    robot.answer()  # time 0: what prime latches; each command then brings the next tick's
    session.driver.prime(1)
    session.run(stop_rules=StopRules(max_ticks=2_000))
    gc.collect()
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    session.run(stop_rules=StopRules(max_ticks=8_000))
    gc.collect()
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename"))
    assert session.machine.ticks == 10_000 and not session.machine.finished
    assert session.driver.silences == 0 and session.driver.car.received()["front"] > 9_000
    assert grown < 100_000, [str(s) for s in after.compare_to(before, "lineno")[:5]]
