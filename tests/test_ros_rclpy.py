"""The bridge against real ROS 2: rclpy and Fast DDS from ROS 2 Jazzy's wheels (the ``rclpy`` extra), on localhost.

The other side is never ours: a plain rclpy node written here, with only rclpy and the message packages
(``from sensor_msgs.msg import Range``), is the robot that ``fsmctl run --ros --via rclpy`` drives, or the controller
that drives ``fsmctl sim --ros --via rclpy``. The robot node moves the simulator's car (fsm.sim.car.SimCar) for its
physics; everything it says on ROS 2 (messages, QoS, the clock) is written here.

Each test run has a ROS domain of its own (from the pid and the xdist worker) and discovery on localhost only
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, Jazzy's setting), so parallel runs do not meet."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from helpers import cli, finish

pytest.importorskip("rosbags")
rclpy = pytest.importorskip("rclpy")

REPO = Path(__file__).resolve().parent.parent
PROFILE = REPO / "fsm" / "ros" / "tral.profile.json"
CORNER = REPO / "diagrams" / "corner_turn.json"


def ros_domain() -> int:
    """A domain for this test run: Fast DDS takes 0-101 on Linux (its ports); 0 is everyone's default, left out."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").lstrip("gw")
    return 1 + (os.getpid() * 7 + (int(worker) if worker.isdigit() else 0)) % 100


DOMAIN = ros_domain()
ENV = {"ROS_DOMAIN_ID": str(DOMAIN), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}


@pytest.fixture(scope="module", autouse=True)
def ros_environment() -> Iterator[None]:
    saved = {k: os.environ.get(k) for k in ENV}
    os.environ.update(ENV)
    yield
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def fsmctl(*args: str) -> subprocess.Popen[str]:
    env = dict(os.environ) | ENV
    env.pop("PYTHONPATH", None)
    return subprocess.Popen([sys.executable, "-m", "fsm.tools.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)


def twist_profile(folder: Path) -> Path:
    """The TRAL profile with a TwistStamped command (ackermann_msgs has no wheel)."""
    data = json.loads(PROFILE.read_text(encoding="utf-8"))
    data.pop("$schema")
    data["outputs"]["command"]["type"] = "geometry_msgs/msg/TwistStamped"
    data["transport"]["peer_timeout"] = 30
    path = folder / "twist.profile.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


class PlainNode:
    """An rclpy node in a context of its own, spun on a thread; the test's side of the graph."""

    def __init__(self, name: str) -> None:
        from rclpy.executors import SingleThreadedExecutor

        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=DOMAIN)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # shut down while spinning
            pass

    def start(self) -> None:
        self.thread.start()

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        if self.context.ok():
            self.context.shutdown()
        self.thread.join(timeout=2)


def answer(future: Any, timeout: float = 20) -> Any:
    """The result of a service call (rclpy's future), waited for at most ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while not future.done():
        assert time.monotonic() < end, "no answer from the machine's node"
        time.sleep(0.01)
    return future.result()


def ask(call: Callable[[], Any], timeout: float = 20, again_after: float = 2.0) -> Any:
    """The result of an idempotent service call, sent again while unanswered (at most ``timeout`` seconds in all).

    A service found by ``wait_for_service`` may not yet have matched the client's request writer: DDS drops a
    request written before that (volatile durability), and its future never completes. Under a loaded machine
    (the suite on two workers) that happened to a first ``list_parameters``."""
    end = time.monotonic() + timeout
    while True:
        future = call()
        again = min(end, time.monotonic() + again_after)
        while not future.done() and time.monotonic() < again:
            time.sleep(0.01)
        if future.done():
            return future.result()
        assert time.monotonic() < end, "no answer from the machine's node"


def stop_both(robot: Any, run: subprocess.Popen[str]) -> None:
    """The end of a test with a plain robot and fsmctl: the robot stops; fsmctl, if still running (the test failed),
    is killed and what it said printed."""
    robot.stop.set()
    robot.close()
    if run.poll() is None:
        run.kill()
        print(run.communicate()[1])


def stamp(t: float) -> Any:
    from builtin_interfaces.msg import Time

    ns = round(t * 1e9)
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class PlainRobot(PlainNode):
    """The car as a robot would serve it: Range per ultrasonic sensor (as sampled), Odometry and an Int32 hall count
    every tick, the simulation time on /clock after each tick's sensors (use_sim_time), and the newest TwistStamped
    command applied before the next tick. Time 0 is sent again until the first command (a late subscription)."""

    def __init__(self, rate: float) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Range
        from std_msgs.msg import Int32, String

        from fsm.sim.car import SimCar
        from fsm.sim.world import default_world, load_world

        super().__init__("plain_robot")
        self.car = SimCar(load_world(default_world(str(REPO))), seed=0)
        self.dt = 1.0 / rate
        best = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        reliable = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
        n = self.node
        self.ranges = {s: n.create_publisher(Range, f"/tral/ultrasonic/{s}", best) for s in ("left", "right", "front")}
        self.odom = n.create_publisher(Odometry, "/tral/odom", reliable)
        self.hall = n.create_publisher(Int32, "/tral/hall", reliable)
        self.clock = n.create_publisher(Clock, "/clock", reliable)
        self.cond = threading.Condition()
        self.command: tuple[float, float, float] | None = None
        self.commands = 0
        self.stop = threading.Event()
        n.create_subscription(TwistStamped, "/tral/cmd", self._on_command, reliable)
        self.statuses: list[str] = []
        n.create_subscription(String, "/tral/fsm/status", lambda m: self.statuses.append(m.data), 10)
        self.diagnostics: list[Any] = []
        self.active: list[str] = []
        n.create_subscription(DiagnosticArray, "/diagnostics", lambda m: self.diagnostics.append(m.status[0]), 10)
        n.create_subscription(String, "/tral/fsm/status/active", lambda m: self.active.append(m.data), 10)
        self.ticks = 0
        self.runner = threading.Thread(target=self.run, daemon=True)

    def _on_command(self, msg: Any) -> None:
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        with self.cond:
            self.command = (t, msg.twist.linear.x, msg.twist.angular.z)
            self.commands += 1
            self.cond.notify_all()

    def publish(self, t: float, sample: int) -> int:
        import math

        from nav_msgs.msg import Odometry
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Range
        from std_msgs.msg import Int32

        car = self.car
        if car.sample != sample:
            for side, pub in self.ranges.items():
                msg = Range(radiation_type=Range.ULTRASOUND, field_of_view=0.26, min_range=0.02, max_range=4.0,
                            range=float(getattr(car, side)))
                msg.header.stamp, msg.header.frame_id = stamp(t), f"us_{side}"
                pub.publish(msg)
        odo = Odometry()
        odo.header.stamp, odo.header.frame_id, odo.child_frame_id = stamp(t), "odom", "base_link"
        x, y, th = car.pose()
        odo.pose.pose.position.x, odo.pose.pose.position.y = x, y
        odo.pose.pose.orientation.z, odo.pose.pose.orientation.w = math.sin(th / 2), math.cos(th / 2)
        odo.twist.twist.linear.x = car.speed
        self.odom.publish(odo)
        self.hall.publish(Int32(data=int(car.hall)))
        self.clock.publish(Clock(clock=stamp(t)))
        return int(car.sample)

    def wait_command(self, t: float, timeout: float) -> tuple[float, float, float] | None:
        end = time.monotonic() + timeout
        with self.cond:
            while self.command is None or self.command[0] < t - 1e-6:
                left = end - time.monotonic()
                if left <= 0 or self.stop.is_set():
                    return None
                self.cond.wait(left)
            return self.command

    def run(self) -> None:
        import math

        from fsm.sim.car import PHYSICS_DT

        car, n, sample = self.car, 0, -1
        while not self.stop.is_set():
            t = n * self.dt
            sample = self.publish(t, sample)
            command = self.wait_command(t, 0.25 if n == 0 else 5.0)
            if command is None:
                if n == 0:
                    sample = -1  # again, until the machine's first command
                    continue
                return
            _t, speed, yaw_rate = command
            car.set_speed(speed)
            angle = math.atan(yaw_rate * 0.26 / speed) if abs(speed) > 1e-6 else 0.0
            car.set_steering(angle / car.max_steering_angle)
            n += 1
            self.ticks = n
            while (car.steps + 1) * PHYSICS_DT <= n * self.dt + 1e-9:
                car.step()


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("rclpy")


def test_run_drives_a_plain_rclpy_robot_to_the_in_process_outcome(folder: Path) -> None:
    profile = twist_profile(folder)
    code, _out, err = finish(fsmctl("run", str(CORNER), "--summary", str(folder / "inproc.json"), "--quiet"))
    assert code == 0, err
    expected = json.loads((folder / "inproc.json").read_text())
    robot = PlainRobot(rate=80)
    robot.start()
    try:
        run = fsmctl("run", str(CORNER), "--ros", str(profile), "--via", "rclpy", "--lockstep",
                     "--summary", str(folder / "ros.json"), "--bag", str(folder / "bag"))
        robot.runner.start()
        code, out, err = finish(run)
        topics = dict(robot.node.get_topic_names_and_types())
    finally:
        robot.stop.set()
        robot.close()
    assert code == 0, err
    got = json.loads((folder / "ros.json").read_text())
    assert "through rclpy" in err and f"ROS domain {DOMAIN}" in err
    assert got["outcome"] == expected["outcome"] == "succeeded"
    assert got["visited"] == expected["visited"]
    assert got["ticks"] == expected["ticks"], "lock-step against a plain node ticks as the in-process run"
    assert got["ros"]["decode_failures"] == {} and got["ros"]["silences"] == 0
    assert topics["/tral/cmd"] == ["geometry_msgs/msg/TwistStamped"]
    assert topics["/tral/fsm/status"] == ["std_msgs/msg/String"]
    last = json.loads(robot.statuses[-1])
    assert last["finished"] is True and last["outcome"] == "succeeded"
    # the same status as ROS's diagnostics and the active path as a plain String
    final = robot.diagnostics[-1]
    assert final.name == "fsmctl: tral" and final.level == b"\x00" and final.message == "finished: succeeded"
    assert {kv.key: kv.value for kv in final.values}["outcome"] == "succeeded"
    assert any(d.message == "active: follow" for d in robot.diagnostics)
    assert "turn/arc" in robot.active and robot.active[-1] == last["active"]
    assert robot.car.collisions == 0


def test_sim_over_rclpy_is_driven_by_a_plain_rclpy_controller(folder: Path) -> None:
    """The controller: on each /clock time it sends a TwistStamped of that time, 1 m/s straight on."""
    from geometry_msgs.msg import TwistStamped
    from nav_msgs.msg import Odometry
    from rclpy.qos import qos_profile_sensor_data
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Range
    from std_msgs.msg import Int32

    profile = twist_profile(folder)
    sim = fsmctl("sim", "--ros", str(profile), "--via", "rclpy", "--lockstep", "--duration", "2", "--wait", "30",
                 "--summary", str(folder / "sim.json"), "--no-noise", "--remap", "/tral/cmd:=/car1/cmd",
                 "--remap", "__node:=tral_sim", "--remap", "__ns:=/car1")
    controller = PlainNode("plain_controller")
    node = controller.node
    ranges: dict[str, float] = {}
    odometry: list[float] = []
    cmd = node.create_publisher(TwistStamped, "/car1/cmd", 1)  # remapped on the command line
    nodes: set[tuple[str, str]] = set()

    def on_clock(msg: Any) -> None:
        if not nodes:
            nodes.update(node.get_node_names_and_namespaces())
        out = TwistStamped()
        out.header.stamp = msg.clock
        out.twist.linear.x = 1.0
        cmd.publish(out)

    node.create_subscription(Clock, "/clock", on_clock, 1)
    node.create_subscription(Odometry, "/tral/odom", lambda m: odometry.append(m.pose.pose.position.x), 1)
    node.create_subscription(Int32, "/tral/hall", lambda m: None, 1)
    for side in ("left", "right", "front"):  # best effort, as the profile publishes them (sensor data)
        node.create_subscription(Range, f"/tral/ultrasonic/{side}",
                                 lambda m, s=side: ranges.__setitem__(s, m.range), qos_profile_sensor_data)
    controller.start()
    try:
        code, _out, err = finish(sim)
        topics = dict(node.get_topic_names_and_types())
    finally:
        controller.close()
    assert code == 0, err
    summary = json.loads((folder / "sim.json").read_text())
    assert summary["stopped"] == "limit" and summary["collisions"] == 0
    assert summary["commands_received"] >= 160  # one per tick of 2 s at 80 Hz
    assert summary["decode_failures"] == 0
    assert 1.0 < summary["distance_m"] < 2.2, summary  # 1 m/s after the car's acceleration
    assert odometry and odometry[-1] > odometry[0] + 0.8
    assert set(ranges) == {"left", "right", "front"} and all(0 < r <= 4.0 for r in ranges.values())
    assert topics["/tral/ultrasonic/front"] == ["sensor_msgs/msg/Range"]
    assert topics["/tral/odom"] == ["nav_msgs/msg/Odometry"]
    assert ("tral_sim", "/car1") in nodes


def test_the_node_takes_its_name_namespace_and_use_sim_time(tmp_path: Path) -> None:
    from fsm.ros.profile import load_profile, remapped
    from fsm.ros.rclpy_link import RclpyLink

    profile = remapped(load_profile(twist_profile(tmp_path)), ["__node:=driver", "__ns:=/car2",
                                                               "tral/ultrasonic/front:=/car2/front"])
    assert profile.inputs.front.topic == "/car2/front" and profile.inputs.left.topic == "/tral/ultrasonic/left"
    with RclpyLink(profile, sim_time=True) as link:
        assert link.node.get_name() == "driver" and link.node.get_namespace() == "/car2"
        assert link.node.get_parameter("use_sim_time").value is True
        assert "as node /car2/driver" in link.describe()
    with RclpyLink(load_profile(twist_profile(tmp_path))) as link:
        assert link.node.get_name() == "fsmctl_tral" and link.node.get_parameter("use_sim_time").value is False


def test_a_remapping_of_a_topic_no_binding_has_is_a_usage_error(capsys: pytest.CaptureFixture[str],
                                                                 tmp_path: Path) -> None:
    code, _out, err = cli(capsys, "sim", "--ros", str(twist_profile(tmp_path)), "--remap", "/tral/cmnd:=/x")
    assert code == 2 and "no binding of the profile has that topic" in err and "/tral/cmd" in err


def test_a_type_without_a_wheel_is_a_located_profile_error_offering_twist(
        capsys: pytest.CaptureFixture[str]) -> None:

    code, _out, err = cli(capsys, "sim", "--ros", str(PROFILE), "--via", "rclpy")
    assert code == 1
    assert "tral.profile.json:" in err and "/outputs/command/type" in err
    assert "ackermann_msgs has no wheel" in err and "geometry_msgs/msg/Twist" in err
    assert "Traceback" not in err


def test_rclpy_missing_is_one_message_naming_the_extra(capsys: pytest.CaptureFixture[str],
                                                       monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from fsm.ros import transport

    monkeypatch.setattr(transport, "rclpy_available", lambda: False)
    code, _out, err = cli(capsys, "run", str(CORNER), "--ros", str(twist_profile(tmp_path)), "--via", "rclpy")
    assert code == 1 and "Traceback" not in err
    assert err.count("\n") == 1 and "pip install 'tral-fsm[rclpy]'" in err, err


#: Waits for the input signal `go`; its variables are there to be read.
SIGNALLED = {"name": "sig", "initial": "wait", "inputs": ["go"], "vars": {"laps": 0, "mode": "idle", "gains": [1, 2]},
             "states": [{"id": "wait", "type": "Stop"}, {"id": "done", "type": "Final", "outcome": "succeeded"}],
             "transitions": [{"type": "Signal", "from": "wait", "to": "done", "signal": "go"}]}


def test_variables_are_read_only_parameters_and_the_documents_inputs_can_be_set(folder: Path) -> None:
    """A plain rclpy parameter client: reads the machine's variables, is refused setting one (with the reason),
    and sets the signal the document declares as an input, which ends the machine."""
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    machine = folder / "signalled.json"
    machine.write_text(json.dumps(SIGNALLED), encoding="utf-8")
    robot = PlainRobot(rate=80)
    robot.start()

    try:
        run = fsmctl("run", str(machine), "--ros", str(twist_profile(folder)), "--via", "rclpy", "--lockstep",
                     "--duration", "3600", "--summary", str(folder / "signalled.json.summary"))
        robot.runner.start()
        client = AsyncParameterClient(robot.node, "/fsmctl_tral")
        assert client.wait_for_services(timeout_sec=20)
        end = time.monotonic() + 20  # the node answers as soon as it exists, its parameters come a moment later
        while len(ask(lambda: client.list_parameters(prefixes=["vars"])).result.names) < 3:
            assert time.monotonic() < end, "the variables were never declared"
            time.sleep(0.05)
        values = ask(lambda: client.get_parameters(["vars.laps", "vars.mode", "vars.gains", "use_sim_time"])).values
        assert [values[0].integer_value, values[1].string_value, values[2].string_value] == [0, "idle", "[1,2]"]
        assert values[3].bool_value is True  # lock-step: the simulator's clock
        (refused,) = ask(lambda: client.set_parameters([Parameter("vars.laps", value=5)])).results
        assert refused.successful is False and "read-only" in refused.reason and "signals.go" in refused.reason
        (accepted,) = ask(lambda: client.set_parameters([Parameter("signals.go", value=True)])).results
        assert accepted.successful, accepted.reason
        code, _out, err = finish(run)
    finally:
        robot.stop.set()
        robot.close()
    assert code == 0, err
    summary = json.loads((folder / "signalled.json.summary").read_text())
    assert summary["outcome"] == "succeeded" and summary["visited"] == ["wait", "done"]


def test_the_executor_is_rclpys_events_executor_unless_the_environment_says_single(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The EventsExecutor (C++) spins the node by default: the SingleThreadedExecutor's Python wait sets put a
    p99 of 20 ms between message and machine (docs/performance.md). ``single`` stays available; a message still
    goes through either, and either closes at once."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.experimental import EventsExecutor  # noqa: F401 (the wheel has it)

    from fsm.ros.profile import load_profile
    from fsm.ros.rclpy_link import RclpyLink
    from fsm.ros.transport import TransportError

    profile = load_profile(twist_profile(tmp_path))
    for kind in ("events", "single"):
        monkeypatch.setenv("FSM_RCLPY_EXECUTOR", kind)
        got: list[bytes] = []
        with RclpyLink(profile) as link:
            assert isinstance(link._executor, SingleThreadedExecutor) is (kind == "single")
            link.subscribe(profile.outputs.command, got.append)
            pub = link.publisher(profile.outputs.command)
            end = time.monotonic() + 10
            while not got and time.monotonic() < end:
                pub.put(bytes.fromhex("000100000000000000000000") + bytes(48))
                time.sleep(0.05)
            started = time.monotonic()
        assert got and time.monotonic() - started < 1.5, kind
    monkeypatch.setenv("FSM_RCLPY_EXECUTOR", "fast")
    with pytest.raises(TransportError, match="FSM_RCLPY_EXECUTOR='fast': write events or single"):
        RclpyLink(profile).open()
