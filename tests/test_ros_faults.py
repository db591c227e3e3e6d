"""Faults of the ROS 2 bridge that need no second process: the lock-step simulator sending time 0 again until the
machine's first command (a message lost while a subscription settles), the ``--bag`` folder rules, a bag whose name
was taken during the run, and how the transport (Zenoh or rclpy) is chosen."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from fsm.model.errors import FsmError, UsageError
from fsm.ros.profile import DEFAULT_PROFILE_PATH, Binding, Profile, load_profile
from fsm.tools.files import Output, check_new_folder

pytest.importorskip("rosbags")

REPO = Path(__file__).resolve().parent.parent


# -- lock-step: time 0 again until the first command ------------------------------------------------------------
class FakePublisher:
    def __init__(self, topic: str, bus: FakeBus) -> None:
        self.topic = topic
        self.bus = bus
        self.puts = 0

    def matched(self) -> bool:
        return True

    def put(self, payload: bytes) -> None:
        self.puts += 1
        self.bus.on_put(self.topic, self.puts)


class FakeBus:
    """A transport that loses nothing but answers with a command only once the front range came twice (as if the
    first one had been lost on the way)."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.pubs: dict[str, FakePublisher] = {}
        self.subs: dict[str, Callable[[bytes], None]] = {}

    def describe(self) -> str:
        return "nowhere"

    def open(self) -> FakeBus:
        return self

    def close(self) -> None:
        pass

    def wait_for_peer(self, timeout: float, what: str = "", stop: Callable[[], bool] | None = None) -> None:
        pass

    def publisher(self, binding: Binding) -> FakePublisher:
        self.pubs[binding.topic] = FakePublisher(binding.topic, self)
        return self.pubs[binding.topic]

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        self.subs[binding.topic] = callback

    def on_put(self, topic: str, count: int) -> None:
        from fsm.ros import messages as M

        if topic == self.profile.inputs.front.topic and count == 2:
            command = self.profile.outputs.command
            message = M.command_message(command.type, 0.0, 0.7, 0.0, self.profile.car.wheelbase)
            self.subs[command.topic](M.encode(message))


def test_lockstep_sends_time_zero_again_until_the_first_command() -> None:
    from fsm.ros.robot import SimRobot

    profile = load_profile(DEFAULT_PROFILE_PATH)
    bus = FakeBus(profile)
    robot = SimRobot(profile, bus, REPO / "diagrams" / "worlds" / "hallway.json", lockstep=True)
    why = robot.run_lockstep(duration=0.0, wait=30)
    assert why == "limit", "the command of tick 0 came (after the second front range) and was applied"
    assert robot.car.speed_command == pytest.approx(0.7)
    assert bus.pubs[profile.inputs.front.topic].puts == 2
    assert bus.pubs[profile.inputs.left.topic].puts == 2 and bus.pubs[profile.inputs.odometry.topic].puts == 2
    assert bus.pubs[profile.clock.topic].puts == 2


# -- --bag: a new folder ---------------------------------------------------------------------------------------------
def test_bag_folder_rules(tmp_path: Path) -> None:
    (tmp_path / "dir").mkdir()
    (tmp_path / "file").write_text("x")
    os.symlink(tmp_path / "dir", tmp_path / "link")
    os.symlink(tmp_path / "nowhere", tmp_path / "dangling")
    cases = {"dir": "is an existing folder", "file": "is an existing regular file", "link": "is a symbolic link",
             "dangling": "is a symbolic link", "missing/bag": "does not exist", "-": "a folder is needed",
             "": "a folder is needed", "file/bag": "a folder on the path is not a folder"}
    for name, words in cases.items():
        with pytest.raises(UsageError, match=words):
            check_new_folder(str(tmp_path / name) if name not in ("-", "") else name, "--bag")
    with pytest.raises(UsageError, match="is the input"):
        check_new_folder(str(tmp_path / "file"), "--bag", inputs=[tmp_path / "file"])
    trace = Output(str(tmp_path / "out"), "--trace")
    trace.classify()
    with pytest.raises(UsageError, match="names the same file as --trace"):
        check_new_folder(str(tmp_path / "out"), "--bag", outputs=[trace])
    assert check_new_folder(str(tmp_path / "new"), "--bag") == str(tmp_path / "new")


@pytest.mark.parametrize("extra, words", [
    (["--bag", "diagrams/lap.json"], "--bag diagrams/lap.json: is the input diagrams/lap.json"),
    (["--bag", "{tmp}/x", "--trace", "{tmp}/x"], "names the same file as --trace"),
    (["--bag", "{tmp}/link"], "is a symbolic link"),
])
def test_fsmctl_run_refuses_a_bag_folder_before_connecting(tmp_path: Path, extra: list[str], words: str) -> None:
    os.symlink(tmp_path, tmp_path / "link")
    args = [a.format(tmp=tmp_path) for a in extra]
    proc = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "run", "diagrams/lap.json", "--ros",
                           str(DEFAULT_PROFILE_PATH), "--via", "zenoh", *args], capture_output=True, text=True,
                          timeout=60, cwd=REPO)
    assert proc.returncode == 2, proc.stderr
    assert words in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link"], "nothing written"


def test_a_bag_whose_name_was_taken_during_the_run_is_kept_aside(tmp_path: Path) -> None:
    from fsm.ros import messages as M
    from fsm.ros.bag import BagError, BagRecorder, read_bag

    profile = load_profile(DEFAULT_PROFILE_PATH)
    bag = BagRecorder(tmp_path / "bag", profile)
    bag.write("front", M.encode(M.range_message(0.0, "us_front", 1.0, 4.0)), 0.0)
    (tmp_path / "bag").mkdir()  # someone else's folder, empty: a rename would silently replace it
    with pytest.raises(BagError, match="was kept as") as err:
        bag.commit()
    assert list((tmp_path / "bag").iterdir()) == []
    kept = Path(str(err.value).rsplit(" ", 1)[-1])
    assert kept.parent == tmp_path and [m[0] for m in read_bag(kept)] == ["/tral/ultrasonic/front"]


# -- the transport: Zenoh, or rclpy where it can be imported --------------------------------------------------------
def test_the_transport_is_rclpy_only_when_it_can_be_imported(monkeypatch: pytest.MonkeyPatch) -> None:
    from fsm.ros import transport
    from fsm.ros.rclpy_link import RclpyLink

    profile = load_profile(DEFAULT_PROFILE_PATH)
    assert profile.transport.via == "auto"
    monkeypatch.setattr(transport, "rclpy_available", lambda: False)
    assert transport.resolve_via(profile) == "zenoh"
    assert isinstance(transport.open_bus(profile), transport.Link)
    monkeypatch.setattr(transport, "rclpy_available", lambda: True)
    assert transport.resolve_via(profile) == "rclpy" and transport.resolve_via(profile, "zenoh") == "zenoh"
    bus = transport.open_bus(profile)
    assert isinstance(bus, RclpyLink) and bus.node is None, "chosen, not opened"
    assert "through rclpy" in bus.describe()
    # Zenoh endpoints on the command line mean Zenoh under auto; with rclpy named they are an error
    assert isinstance(transport.open_bus(profile, connect=["tcp/127.0.0.1:7447"]), transport.Link)
    with pytest.raises(FsmError, match="--connect/--listen are Zenoh endpoints"):
        transport.open_bus(profile, connect=["tcp/127.0.0.1:7447"], via="rclpy")
    pinned = profile.model_copy(update={"transport": profile.transport.model_copy(update={"via": "zenoh"})})
    assert isinstance(transport.open_bus(pinned), transport.Link)


def test_rclpy_missing_is_not_an_import_error_until_used(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where rclpy cannot be imported the module loads, and opening the link says what to do."""
    from fsm.ros import rclpy_link
    from fsm.ros.rclpy_link import RclpyLink

    def no_rclpy(name: str) -> object:
        raise ImportError(f"No module named {name!r}")

    monkeypatch.setattr(rclpy_link, "_module", no_rclpy)
    bus = RclpyLink(load_profile(DEFAULT_PROFILE_PATH))
    with pytest.raises(FsmError, match=r"rclpy cannot be imported .*tral-fsm\[rclpy\].*--via zenoh"):
        bus.open()


def test_the_profile_via_key_is_checked(tmp_path: Path) -> None:
    from fsm.model.errors import DiagramError

    text = DEFAULT_PROFILE_PATH.read_text(encoding="utf-8").replace('"keys": "rmw_zenoh"',
                                                                    '"keys": "rmw_zenoh", "via": "dds"')
    path = tmp_path / "p.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DiagramError) as err:
        load_profile(path)
    (problem,) = err.value.problems
    assert problem.pointer == "/transport/via" and problem.line is not None


# -- Ctrl-C while waiting for the robot ------------------------------------------------------------------------------
def test_ctrl_c_while_waiting_for_the_robot_exits_130_with_the_outputs(tmp_path: Path) -> None:
    """The robot never answers (a plain TCP listener stands at the endpoint); Ctrl-C ends the wait at once instead of
    after the profile's 60 s peer timeout, and the summary is written."""
    import json
    import signal
    import socket

    data = json.loads(DEFAULT_PROFILE_PATH.read_text(encoding="utf-8"))
    data.pop("$schema")
    data["transport"]["peer_timeout"] = 60
    profile = tmp_path / "p.json"
    profile.write_text(json.dumps(data), encoding="utf-8")
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        server.settimeout(60)
        port = server.getsockname()[1]
        env = dict(os.environ)
        env.pop("PYTHONPATH", None)
        command = [sys.executable, "-m", "fsm.tools.cli", "run", "diagrams/lap.json", "--ros", str(profile), "--via",
                   "zenoh", "--connect", f"tcp/127.0.0.1:{port}", "--summary", str(tmp_path / "s.json")]
        run = subprocess.Popen(command, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            conn, _addr = server.accept()  # the run is connecting: Ctrl-C is the run's to handle from here
            conn.close()
            run.send_signal(signal.SIGINT)
            out, err = run.communicate(timeout=40)
        finally:
            if run.poll() is None:
                run.kill()
                run.communicate()
    assert run.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in out
    summary = json.loads((tmp_path / "s.json").read_text(encoding="utf-8"))
    assert summary["interrupted"] is True and summary["stopped"] == "not started" and summary["ticks"] == 0


def test_a_folder_as_the_profile_is_one_plain_message(tmp_path: Path) -> None:
    from fsm.model.errors import DiagramError

    with pytest.raises(DiagramError) as err:
        load_profile(tmp_path)
    (problem,) = err.value.problems
    assert problem.message == "is a directory, not an I/O profile file"


# -- a message that does not decode, through the driver ----------------------------------------------------------------
DRIVE = {"initial": "go", "states": [{"id": "go", "type": "Motor", "speed": 0.3, "distance": 50}]}


def test_undecodable_messages_are_counted_logged_once_and_stop_the_car_as_silence(tmp_path: Path) -> None:
    """Garbled bytes on the front range's topic from 0.4 s on: the driver counts them, logs one line for the topic
    and, once the front input has been silent longer than its max_silence (0.25 s), commands zero speed."""
    import json

    from fsm.loading.loader import compile as compile_plan
    from fsm.ros import messages as M
    from fsm.ros.driver import ros_session
    from fsm.session.session import StopRules

    machine = tmp_path / "drive.json"
    machine.write_text(json.dumps(DRIVE), encoding="utf-8")
    profile = load_profile(DEFAULT_PROFILE_PATH)
    bus = FakeBus(profile)
    sent: list[bytes] = []
    logged: list[str] = []
    session = ros_session(compile_plan(machine), profile, bus, lockstep=True, log=logged.append,
                          stop=StopRules(max_ticks=80))
    command = bus.pubs[profile.outputs.command.topic]
    command.put = sent.append  # type: ignore[method-assign]
    topics = {name: b.topic for name, b in profile.inputs_bound().items()}

    def feed(t: float) -> None:
        for name in ("left", "right", "front"):
            raw = M.encode(M.range_message(t, name, 2.0, 4.0))
            bus.subs[topics[name]](b"\x00\x01garbled" if name == "front" and t >= 0.4 else raw)
        bus.subs[topics["odometry"]](M.encode(M.odometry_message(t, 0.3 * t, 0.0, 0.0, 0.3, 0.0)))
        bus.subs[topics["hall"]](M.encode(M.counter_message("std_msgs/msg/Int32", int(t * 280))))

    bus.subs[profile.clock.topic](M.encode(M.clock_message(1000.0)))  # lock-step never waits
    feed(0.0)
    assert session.driver.prime(5)
    session.every(profile.dt, lambda s: feed(s.now + profile.dt))
    session.run()
    metrics = session.driver.metrics()["ros"]
    assert metrics["decode_failures"]["front"] >= 30 and metrics["silences"] == 1
    assert len([line for line in logged if "failed to decode" in line]) == 1
    assert any("silent longer than the profile allows: front" in line for line in logged)
    speeds = [(M.stamp_seconds(m), m.drive.speed) for m in (M.decode(raw, profile.outputs.command.type)
                                                             for raw in sent)]
    assert all(v == pytest.approx(0.3) for t, v in speeds if 0.1 < t < 0.6), "driving while front is fresh"
    assert speeds[-1][1] == 0.0 and all(v == 0.0 for t, v in speeds if t > 0.4 + 0.25 + 2 * profile.dt)
