"""``fsmctl run --ros --via rclpy --lifecycle``: the bridge as a ROS 2 managed node, driven by a plain rclpy client
that calls ``lifecycle_msgs/srv/ChangeState`` and ``GetState`` as ``ros2 lifecycle set`` or a lifecycle manager
(Nav2's, FlexBE's) would, against the plain rclpy robot of tests/test_ros_rclpy.py."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from helpers import finish

pytest.importorskip("rosbags")
pytest.importorskip("rclpy")
pytest.importorskip("lifecycle_msgs")

from test_ros_rclpy import CORNER, PlainRobot, answer, ask, fsmctl, ros_environment, stop_both, twist_profile  # noqa: E402,E501

__all__ = ["ros_environment"]  # the module's ROS domain (autouse)


class LifecycleClient:
    """ChangeState / GetState of the node ``node``, called from the robot's node (a plain rclpy client)."""

    def __init__(self, robot: PlainRobot, node: str) -> None:
        from lifecycle_msgs.srv import ChangeState, GetState

        self.change = robot.node.create_client(ChangeState, f"{node}/change_state")
        self.get = robot.node.create_client(GetState, f"{node}/get_state")

    def ready(self, timeout: float) -> bool:
        return bool(self.change.wait_for_service(timeout_sec=timeout) and self.get.wait_for_service(timeout_sec=5))

    def state(self) -> str:
        from lifecycle_msgs.srv import GetState

        return str(ask(lambda: self.get.call_async(GetState.Request())).current_state.label)  # sent again if lost

    def set(self, label: str) -> bool:
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        request = ChangeState.Request(transition=Transition(label=label))
        return bool(answer(self.change.call_async(request)).success)


def wait_for(what: str, condition: Any, timeout: float = 20) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, f"not within {timeout} s: {what}"
        time.sleep(0.01)


def listening_robot() -> tuple[PlainRobot, list[float]]:
    """The plain rclpy robot, started, and the forward speed of every command it has heard on /tral/cmd."""
    from geometry_msgs.msg import TwistStamped

    robot = PlainRobot(rate=80)
    speeds: list[float] = []
    robot.node.create_subscription(TwistStamped, "/tral/cmd", lambda m: speeds.append(m.twist.linear.x), 100)
    robot.start()
    return robot, speeds


def test_a_plain_client_configures_activates_deactivates_and_shuts_the_node_down(tmp_path: Path) -> None:
    machine = tmp_path / "corner.json"
    good = CORNER.read_text(encoding="utf-8")
    machine.write_text(good, encoding="utf-8")
    robot, speeds = listening_robot()
    client = LifecycleClient(robot, "/fsmctl_tral")
    run = fsmctl("run", str(machine), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy", "--lifecycle",
                 "--lockstep", "--summary", str(tmp_path / "summary.json"), "--trace", str(tmp_path / "trace.jsonl"))
    try:
        assert client.ready(30), "no lifecycle services"
        assert client.state() == "unconfigured"
        # not allowed from unconfigured: the standard refusal, and the node still answers
        assert client.set("activate") is False and client.state() == "unconfigured"
        # configure reads the document as it is now: broken, the transition fails with the located message
        machine.write_text(good.replace('"initial": "follow"', '"initial": "folow"'), encoding="utf-8")
        assert client.set("configure") is False and client.state() == "unconfigured"
        machine.write_text(good, encoding="utf-8")
        assert client.set("configure") is True and client.state() == "inactive"
        time.sleep(0.3)
        assert speeds == [], "an inactive node sends no command"
        robot.runner.start()
        assert client.set("activate") is True and client.state() == "active"
        wait_for("commands at speed", lambda: sum(1 for s in speeds if s > 0) >= 40)
        assert client.set("deactivate") is True and client.state() == "inactive"
        # the stop command was sent before the answer (it comes on its own topic, in its own time), and the command
        # of the tick that was running had zero speed too
        wait_for("the stop command", lambda: speeds[-1] == 0.0, 5)
        time.sleep(0.3)
        sent = len(speeds)
        assert speeds[-1] == 0.0
        time.sleep(0.3)
        assert len(speeds) == sent, "a deactivated node sends nothing more"
        assert client.set("activate") is True
        wait_for("commands at speed again", lambda: sum(1 for s in speeds[sent:] if s > 0) >= 20)
        assert client.set("shutdown") is True
        code, _out, err = finish(run, timeout=30)
    finally:
        stop_both(robot, run)
    assert code == 0, err
    assert "corner.json:" in err and "folow" in err and "configure failed" in err, err
    assert "unable to start transition activate from the current state unconfigured" in err
    assert "Traceback" not in err
    assert speeds[-1] == 0.0, "the run ends with the stop command"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["stopped"] == "stopped" and summary["ros"]["stop_commands"] >= 2
    assert summary["ticks"] >= 60 and summary["visited"][0] == "follow"
    lines = (tmp_path / "trace.jsonl").read_text().splitlines()
    assert json.loads(lines[0])["source"] == str(machine)


def test_cleanup_releases_the_topics_and_a_run_without_outputs_configures_again(tmp_path: Path) -> None:
    robot, speeds = listening_robot()
    client = LifecycleClient(robot, "/fsmctl_tral")
    run = fsmctl("run", str(CORNER), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy", "--lifecycle",
                 "--lockstep")
    try:
        assert client.ready(30), "no lifecycle services"
        assert client.set("configure") is True
        wait_for("the command publisher", lambda: robot.node.count_publishers("/tral/cmd") == 1)
        robot.runner.start()
        assert client.set("activate") is True
        wait_for("commands at speed", lambda: sum(1 for s in speeds if s > 0) >= 20)
        assert client.set("cleanup") is False, "cleanup is not a transition of active"
        assert client.set("deactivate") is True and client.set("cleanup") is True
        assert client.state() == "unconfigured"
        wait_for("the publisher gone", lambda: robot.node.count_publishers("/tral/cmd") == 0, 10)
        assert client.set("configure") is True and client.state() == "inactive"
        wait_for("the publisher back", lambda: robot.node.count_publishers("/tral/cmd") == 1, 10)
        assert client.set("shutdown") is True
        code, _out, err = finish(run, timeout=30)
    finally:
        stop_both(robot, run)
    assert code == 0, err
    assert "Traceback" not in err


def test_a_run_that_records_cannot_configure_another_machine_after_cleanup(tmp_path: Path) -> None:
    robot = PlainRobot(rate=80)
    robot.start()
    client = LifecycleClient(robot, "/fsmctl_tral")
    run = fsmctl("run", str(CORNER), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy", "--lifecycle",
                 "--summary", str(tmp_path / "summary.json"))
    try:
        assert client.ready(30), "no lifecycle services"
        assert client.set("configure") is True and client.set("cleanup") is True
        assert client.set("configure") is False and client.state() == "unconfigured"
        assert client.set("shutdown") is True
        code, _out, err = finish(run, timeout=30)
    finally:
        stop_both(robot, run)
    assert code == 0, err
    assert "start fsmctl again to configure another" in err
    assert json.loads((tmp_path / "summary.json").read_text())["stopped"] == "not started"


def test_ctrl_c_before_configure_ends_the_run_with_130_and_writes_nothing(tmp_path: Path) -> None:
    import signal

    run = fsmctl("run", str(CORNER), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy", "--lifecycle",
                 "--summary", str(tmp_path / "summary.json"))
    assert run.stderr is not None
    assert "a managed node, unconfigured" in run.stderr.readline()
    run.send_signal(signal.SIGINT)
    code, _out, err = finish(run, timeout=30)
    assert code == 130 and "interrupted with no machine configured: nothing to write" in err, err
    assert not (tmp_path / "summary.json").exists()


def test_a_deactivated_run_goes_on_where_it_was_paused() -> None:
    """The wall clock of a managed run: the time it was deactivated does not count (no burst of ticks after)."""
    from fsm.ros.lifecycle import HoldableClock

    clock = HoldableClock(0.01)
    clock.wait_for(0)
    clock.hold()
    time.sleep(0.2)
    clock.resume()
    assert clock.time_at(1) < 0.1


def test_lifecycle_needs_rclpy_and_a_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from helpers import cli

    code, _out, err = cli(capsys, "run", str(CORNER), "--ros", str(twist_profile(tmp_path)), "--via", "zenoh",
                          "--lifecycle")
    assert code == 2 and "--lifecycle" in err and "--via rclpy" in err
    code, _out, err = cli(capsys, "run", str(CORNER), "--lifecycle")
    assert code == 2 and "--lifecycle needs --ros PROFILE" in err
