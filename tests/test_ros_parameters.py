"""The parameters of the machine's states (the document's and ``--set``'s) as ROS 2 parameters of the bridge's node,
read, described and set by a plain rclpy parameter client (``rclpy.parameter_client``, as ``ros2 param`` uses)
against the plain rclpy robot of tests/test_ros_rclpy.py."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from helpers import cli, finish

pytest.importorskip("rosbags")
pytest.importorskip("rclpy")

from test_ros_rclpy import PlainRobot, ask, fsmctl, ros_environment, stop_both, twist_profile  # noqa: E402

__all__ = ["ros_environment"]  # the module's ROS domain (autouse)

#: Stands until the signal `go`, then drives 1 m (1.5 with the test's --set) at the speed its Motor says.
DRIVE = {"name": "drive", "initial": "wait", "inputs": ["go"],
         "states": [{"id": "wait", "type": "Stop"},
                    {"id": "drive", "type": "Motor", "speed": 0.5, "distance": 1.0},
                    {"id": "done", "type": "Final", "outcome": "succeeded"}],
         "transitions": [{"type": "Signal", "from": "wait", "to": "drive", "signal": "go"},
                         {"type": "Finished", "from": "drive", "to": "done"}]}


def test_state_parameters_are_typed_read_only_unless_tunable_and_set_between_ticks(tmp_path: Path) -> None:
    from geometry_msgs.msg import TwistStamped
    from rcl_interfaces.msg import ParameterType
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    machine = tmp_path / "drive.json"
    machine.write_text(json.dumps(DRIVE), encoding="utf-8")
    robot = PlainRobot(rate=80)
    speeds: list[float] = []
    robot.node.create_subscription(TwistStamped, "/tral/cmd", lambda m: speeds.append(m.twist.linear.x), 100)
    robot.start()
    run = fsmctl("run", str(machine), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy", "--lockstep",
                 "--tunable", "drive.speed", "--set", "drive.distance=1.5", "--duration", "3600",
                 "--summary", str(tmp_path / "summary.json"))
    try:
        robot.runner.start()
        client = AsyncParameterClient(robot.node, "/fsmctl_tral")
        assert client.wait_for_services(timeout_sec=30)
        # the node answers as soon as it exists; the machine's parameters come with the session, a moment later
        end = time.monotonic() + 20
        while len(ask(lambda: client.list_parameters(prefixes=["states"])).result.names) < 2:
            assert time.monotonic() < end, "the states' parameters were never declared"
            time.sleep(0.05)
        names = ask(lambda: client.list_parameters(prefixes=["states"])).result.names
        assert {"states.drive.speed", "states.drive.distance"} <= set(names)
        both = ["states.drive.speed", "states.drive.distance"]
        speed, distance = ask(lambda: client.describe_parameters(both)).descriptors
        assert speed.type == distance.type == ParameterType.PARAMETER_DOUBLE
        assert speed.read_only is False and "writable" in speed.description and "Motor" in speed.description
        assert distance.read_only is True and "set with --set" in distance.description
        values = ask(lambda: client.get_parameters(both)).values
        assert [values[0].double_value, values[1].double_value] == [0.5, 1.5]

        (refused,) = ask(lambda: client.set_parameters([Parameter("states.drive.distance", value=2.0)])).results
        assert refused.successful is False and "read-only" in refused.reason
        (invalid,) = ask(lambda: client.set_parameters([Parameter("states.drive.speed", value=5.0)])).results
        assert invalid.successful is False and "not valid for state drive (Motor)" in invalid.reason, invalid.reason
        (accepted,) = ask(lambda: client.set_parameters([Parameter("states.drive.speed", value=0.8)])).results
        assert accepted.successful, accepted.reason
        (go,) = ask(lambda: client.set_parameters([Parameter("signals.go", value=True)])).results
        assert go.successful, go.reason
        code, _out, err = finish(run)
    finally:
        stop_both(robot, run)
    assert code == 0, err
    assert "drive.speed set from outside" in err
    assert 0.8 in speeds and 0.5 not in speeds, "the Motor drove at the speed set from outside"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["outcome"] == "succeeded"
    assert [p["parameter"] for p in summary["ros"]["parameters_set"]] == ["states.drive.speed"]
    assert summary["ros"]["parameters_set"][0]["value"] == 0.8


def test_a_tunable_that_names_nothing_is_a_usage_error(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    machine = tmp_path / "drive.json"
    machine.write_text(json.dumps(DRIVE), encoding="utf-8")
    profile = str(twist_profile(tmp_path))
    code, _out, err = cli(capsys, "run", str(machine), "--ros", profile, "--via", "rclpy", "--tunable", "drive.sped")
    assert code == 2 and "--tunable drive.sped" in err and "did you mean 'speed'" in err, err
    code, _out, err = cli(capsys, "run", str(machine), "--ros", profile, "--via", "zenoh", "--tunable", "drive.speed")
    assert code == 2 and "--via rclpy" in err
