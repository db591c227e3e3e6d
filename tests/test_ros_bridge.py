"""The ROS 2 bridge end to end, on localhost only (peer mode, explicit tcp/127.0.0.1 endpoints on a free port, no
router, no multicast): ``fsmctl sim --ros`` in one process, ``fsmctl run --ros`` in another.

The lap runs in lock-step (the simulator publishes its clock and waits for each tick's command), so one lap of the
hallway (lap.json: about 60 s of simulated time) takes a few seconds; the safety tests run on the wall clock."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from helpers import finish

pytest.importorskip("zenoh")
pytest.importorskip("rosbags")

REPO = Path(__file__).resolve().parent.parent
PROFILE = REPO / "fsm" / "ros" / "tral.profile.json"
LAP = REPO / "diagrams" / "lap.json"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def driving(run: subprocess.Popen[str]) -> None:
    """Wait until ``fsmctl run`` says the robot answered and the machine drives."""
    assert run.stderr is not None
    line = run.stderr.readline()
    assert "driving" in line, line


def fsmctl(*args: str) -> list[str]:
    return [sys.executable, "-m", "fsm.tools.cli", *args]


def start(*args: str) -> subprocess.Popen[str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.Popen(fsmctl(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
                            env=env)


def profile_with(tmp_path: Path, peer_timeout: float = 15, **safety: Any) -> Path:
    data = json.loads(PROFILE.read_text(encoding="utf-8"))
    data.pop("$schema")
    if safety:
        data["safety"] = safety
    data["transport"]["peer_timeout"] = peer_timeout
    path = tmp_path / "profile.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def lap(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """One lap of the hallway driven over Zenoh in lock-step, recorded as trace and bag."""
    folder = tmp_path_factory.mktemp("lap")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = start("sim", "--ros", str(PROFILE), "--lockstep", "--listen", endpoint, "--summary",
                str(folder / "sim.json"), "--wait", "20")
    t0 = time.monotonic()
    run = start("run", str(LAP), "--ros", str(PROFILE), "--lockstep", "--connect", endpoint, "--expect", "succeeded",
                "--trace", str(folder / "trace.jsonl"), "--summary", str(folder / "run.json"), "--bag",
                str(folder / "bag"))
    code, out, err = finish(run)
    took = time.monotonic() - t0
    sim_code, _sim_out, sim_err = finish(sim)
    yield {"folder": folder, "code": code, "out": out, "err": err, "sim_code": sim_code, "sim_err": sim_err,
           "took": took}


def test_the_hallway_lap_succeeds_over_zenoh_with_no_collision(lap: dict[str, Any]) -> None:
    assert lap["code"] == 0, lap["err"]
    assert lap["sim_code"] == 0, lap["sim_err"]
    sim = json.loads((lap["folder"] / "sim.json").read_text())
    run = json.loads((lap["folder"] / "run.json").read_text())
    assert run["outcome"] == "succeeded" and run["ros"]["lockstep"] is True
    assert sim["collisions"] == 0 and sim["stopped"] == "machine finished"
    assert sim["distance_m"] > 40  # a whole lap of the 20 m x 10 m loop
    assert run["ros"]["decode_failures"] == {} and run["ros"]["silences"] == 0
    assert sim["commands_received"] == run["ros"]["commands"]
    assert lap["took"] < 60, f"lock-step keeps the lap fast ({lap['took']:.1f} s)"


def test_the_bag_and_the_trace_carry_the_same_times(lap: dict[str, Any]) -> None:
    from fsm.ros import messages as M
    from fsm.ros.bag import read_bag
    from fsm.trace.replay import read_trace

    bag = read_bag(lap["folder"] / "bag")
    topics = {t for t, *_ in bag}
    assert topics == {"/tral/ultrasonic/left", "/tral/ultrasonic/right", "/tral/ultrasonic/front", "/tral/odom",
                      "/tral/hall", "/tral/cmd", "/tral/fsm/status"}
    assert (lap["folder"] / "bag" / "metadata.yaml").is_file()
    assert next((lap["folder"] / "bag").glob("*.mcap")).stat().st_size > 0
    trace = read_trace(lap["folder"] / "trace.jsonl")
    commands = [(ns, raw) for t, typ, ns, raw in bag if t == "/tral/cmd"]
    # one command per tick at the tick's machine time (and the final stop at the last tick's time)
    assert commands[0][0] == 0
    end_time = trace.end["time"] if trace.end else None
    assert commands[-1][0] == round(end_time * 1e9)
    assert trace.dt is not None and commands[1][0] == round(trace.dt * 1e9)
    last = M.decode(commands[-1][1], "ackermann_msgs/msg/AckermannDriveStamped")
    assert last.drive.speed == 0.0 and M.stamp_seconds(last) == pytest.approx(end_time)
    statuses = [json.loads(M.decode(raw, "std_msgs/msg/String").data) for t, typ, ns, raw in bag
                if t == "/tral/fsm/status"]
    assert statuses[-1]["finished"] is True and statuses[-1]["outcome"] == "succeeded"


def test_no_peer_is_one_message_naming_the_endpoint(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    t0 = time.monotonic()
    code, out, err = finish(start("run", str(LAP), "--ros", str(profile_with(tmp_path, 1)), "--connect", endpoint,
                                  "--summary", str(tmp_path / "s.json")), timeout=60)
    assert code == 1
    assert err.strip().count("\n") == 0 and endpoint in err and "no peer reached within 1 s" in err, err
    assert time.monotonic() - t0 < 20
    assert not (tmp_path / "s.json").exists()


QUIET = {
    "initial": "drive",
    "states": [
        {"id": "drive", "type": "Sequence",
         "steps": [{"id": "go", "type": "Motor", "speed": 0.3, "distance": 50}],
         "monitors": [{"condition": {"type": "TopicQuiet", "input": "any", "seconds": 0.3},
                       "exception": "halt", "behavior": "abortOwner"}],
         "exceptions": [{"id": "halt", "type": "Sequence", "steps": [{"id": "brake", "type": "Stop"}]}]},
    ],
}


def test_publisher_killed_mid_run_silence_monitor_stop_and_trace_kept(tmp_path: Path) -> None:
    machine = tmp_path / "quiet.json"
    machine.write_text(json.dumps(QUIET), encoding="utf-8")
    profile = profile_with(tmp_path, stop_after=0.6)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = start("sim", "--ros", str(profile), "--listen", endpoint, "--wait", "20")
    run = start("run", str(machine), "--ros", str(profile), "--connect", endpoint, "--duration", "20",
                "--trace", str(tmp_path / "t.jsonl"), "--summary", str(tmp_path / "s.json"), "--bag",
                str(tmp_path / "bag"))
    driving(run)
    time.sleep(0.6)
    sim.kill()  # the robot's process dies: no more messages, no goodbye
    finish(sim)
    code, out, err = finish(run, timeout=60)
    assert code == 1, err
    assert "silent longer than the profile allows" in err and "stopped:" in err
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["stopped"] == "silence" and summary["ros"]["monitors_fired"] == 1
    # one silence, the kill's; on a loaded machine (CI beside other suites) the simulator may also stall past the
    # 0.6 s once before it, which the run logs as an episode that ended ("every input is back") and counts too
    assert summary["ros"]["silences"] == 1 + err.count("every input is back"), err
    assert summary["ros"]["zero_speed_commands"] > 0
    lines = (tmp_path / "t.jsonl").read_text().splitlines()
    assert json.loads(lines[-1])["type"] == "end"
    assert any("halt" in line for line in lines)  # the exception sequence ran
    from fsm.ros import messages as M
    from fsm.ros.bag import read_bag

    speeds = [M.decode(raw, "ackermann_msgs/msg/AckermannDriveStamped").drive.speed
              for t, typ, ns, raw in read_bag(tmp_path / "bag") if t == "/tral/cmd"]
    assert max(speeds) == pytest.approx(0.3) and speeds[-1] == 0.0
    assert all(s == 0.0 for s in speeds[-40:])  # stopped: zero speed while silent, until the run ended


def test_ctrl_c_sends_the_stop_first_then_writes_the_outputs_and_exits_130(tmp_path: Path) -> None:
    machine = tmp_path / "quiet.json"
    machine.write_text(json.dumps(QUIET), encoding="utf-8")
    profile = profile_with(tmp_path)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = start("sim", "--ros", str(profile), "--listen", endpoint, "--wait", "20", "--summary",
                str(tmp_path / "sim.json"))
    run = start("run", str(machine), "--ros", str(profile), "--connect", endpoint, "--duration", "20",
                "--summary", str(tmp_path / "s.json"), "--bag", str(tmp_path / "bag"))
    driving(run)
    time.sleep(0.6)
    run.send_signal(signal.SIGINT)
    code, out, err = finish(run, timeout=60)
    sim.send_signal(signal.SIGINT)
    sim_code, _o, sim_err = finish(sim, timeout=60)
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in out
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["interrupted"] is True and summary["ros"]["stop_commands"] >= 1
    from fsm.ros import messages as M
    from fsm.ros.bag import read_bag

    commands = [M.decode(raw, "ackermann_msgs/msg/AckermannDriveStamped").drive.speed
                for t, typ, ns, raw in read_bag(tmp_path / "bag") if t == "/tral/cmd"]
    assert commands[-1] == 0.0 and max(commands) == pytest.approx(0.3)
    assert sim_code == 130, sim_err


def test_replay_of_the_recorded_lap_decides_the_same_at_every_tick(lap: dict[str, Any]) -> None:
    folder = lap["folder"]
    code, out, err = finish(start("replay", str(folder / "bag"), "--machine", str(LAP), "--profile", str(PROFILE),
                                  "--summary", str(folder / "replay.json"), "--trace", str(folder / "replay.jsonl"),
                                  "--expect-same"))
    assert code == 0, err
    summary = json.loads((folder / "replay.json").read_text())
    run = json.loads((folder / "run.json").read_text())
    assert summary["replay"]["divergence"] is None
    assert summary["replay"]["compared"] == summary["replay"]["ticks"] == run["ticks"] + 1  # tick 0 too
    assert summary["outcome"] == "succeeded" and summary["ticks"] == run["ticks"]
    assert f"the same decisions as the recorded drive at all {run['ticks'] + 1} ticks compared" in out


def test_replay_with_a_changed_machine_names_the_first_divergence(lap: dict[str, Any]) -> None:
    from fsm.trace.replay import read_trace

    folder = lap["folder"]
    code, out, err = finish(start("replay", str(folder / "bag"), "--machine", str(LAP), "--profile", str(PROFILE),
                                  "--set", "right_slow.speed=0.3", "--summary", str(folder / "changed.json"),
                                  "--expect-same"))
    assert code == 1, err
    trace = read_trace(folder / "trace.jsonl")
    entered = next(e["tick"] for e in trace.events if "right_slow" in json.dumps(e.get("active")))
    divergence = json.loads((folder / "changed.json").read_text())["replay"]["divergence"]
    assert divergence["tick"] == entered
    assert divergence["recorded"]["active"] == divergence["replayed"]["active"] == "right_slow"
    assert divergence["replayed"]["speed"] == pytest.approx(0.3)
    assert f"first divergence at tick {entered} (" in out
