"""Anyone's drive: bags and messages in the layouts of Humble, Jazzy and Kilted (written here with rosbags'
typestores, as those robots would), sensors-only bags ticked at the machine's rate, a cut MCAP, --from/--to."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("rosbags")

from fsm.ros import messages as M  # noqa: E402
from fsm.ros.car import RosCar  # noqa: E402
from fsm.ros.profile import DEFAULT_PROFILE_PATH, load_profile  # noqa: E402
from helpers import cli  # noqa: E402

#: Drive on until the front range is under 1 m, then stop.
BRAKE = {"name": "brake", "initial": "go",
         "states": [{"id": "go", "type": "Motor", "speed": 0.5, "steering": 0, "distance": 1000},
                    {"id": "halt", "type": "Stop"},
                    {"id": "done", "type": "Final", "outcome": "succeeded"}],
         "transitions": [{"type": "SensorLevel", "from": "go", "to": "halt", "sensor": "front", "below": 1.0},
                         {"type": "Finished", "from": "halt", "to": "done"}]}
#: A robot's wall clock (2026), not 1970: bags of real robots are stamped so.
EPOCH = 1_790_000_000.0


def store(layout: str) -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(getattr(Stores, f"ROS2_{layout.upper()}"))


def range_msg(ts: Any, t: float, value: float) -> Any:
    T = ts.types
    ns = round(t * 1e9)
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                      frame_id="us_front")
    fields = {"header": header, "radiation_type": 0, "field_of_view": 0.26, "min_range": 0.02, "max_range": 4.0,
              "range": value}
    if "variance" in [f[0] for f in ts.fielddefs["sensor_msgs/msg/Range"][1]]:
        fields["variance"] = 0.0
    return T["sensor_msgs/msg/Range"](**fields)


@pytest.mark.parametrize("layout", ["humble", "jazzy", "kilted"])
def test_a_range_in_each_distributions_layout_is_read(layout: str) -> None:
    ts = store(layout)
    raw = bytes(ts.serialize_cdr(range_msg(ts, 1.0, 0.75), "sensor_msgs/msg/Range"))
    car = RosCar(load_profile(DEFAULT_PROFILE_PATH))
    car.offer("front", raw)
    car.latch(0.0125)
    assert car.front == pytest.approx(0.75) and car.failures() == {}
    assert car.slots["front"].layout == ("jazzy" if layout == "kilted" else layout)  # Kilted's is Jazzy's


def test_bytes_of_no_layout_name_every_layout_tried() -> None:
    with pytest.raises(M.DecodeError, match="layouts of jazzy, humble"):
        M.decode(b"\x00\x01\x00\x00" + b"\x00" * 10, "sensor_msgs/msg/Range")


def profile_without_hall(folder: Path) -> Path:
    data = json.loads(DEFAULT_PROFILE_PATH.read_text(encoding="utf-8"))
    data.pop("$schema")
    del data["inputs"]["hall"]
    path = folder / "profile.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def write_drive(folder: Path, layout: str, seconds: float, storage: str = "mcap", approach: float = 0.5,
                front: Callable[[float], float] | None = None) -> Path:
    """A sensors-only drive as a robot of ``layout`` records it: the ranges at 20 Hz (front closing in at
    ``approach`` m/s from 3 m, or ``front(t)``), odometry at 80 Hz, stamped and logged on the robot's wall clock."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = store(layout)
    T = ts.types
    bag = folder / f"drive_{layout}_{storage}"
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(bag, version=8 if layout == "humble" else 9, storage_plugin=plugin) as writer:
        conns = {side: writer.add_connection(f"/tral/ultrasonic/{side}", "sensor_msgs/msg/Range", typestore=ts)
                 for side in ("left", "right", "front")}
        odom = writer.add_connection("/tral/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for k in range(round(seconds * 80)):
            t = EPOCH + k / 80
            ns = round(t * 1e9)
            if k % 4 == 0:
                for side, conn in conns.items():
                    closing = front(k / 80) if front is not None else max(0.3, 3.0 - approach * (k / 80))
                    value = closing if side == "front" else 0.5
                    writer.write(conn, ns, ts.serialize_cdr(range_msg(ts, t, value), "sensor_msgs/msg/Range"))
            stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                               orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                           w=1.0))
            import numpy as np

            vec = T["geometry_msgs/msg/Vector3"]
            msg = T["nav_msgs/msg/Odometry"](
                header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=vec(x=0.0, y=0.0, z=0.0),
                                                       angular=vec(x=0.0, y=0.0, z=0.0)),
                    covariance=np.zeros(36)))
            writer.write(odom, ns, ts.serialize_cdr(msg, "nav_msgs/msg/Odometry"))
    return bag


def replay(capsys: pytest.CaptureFixture[str], folder: Path, bag: Path, *extra: str) -> tuple[int, str, str, Any]:
    machine = folder / "brake.json"
    machine.write_text(json.dumps(BRAKE), encoding="utf-8")
    summary = folder / f"{bag.name}.summary.json"
    if summary.exists():
        summary.unlink()
    code, out, err = cli(capsys, "replay", str(bag), "--machine", str(machine), "--profile",
                         str(profile_without_hall(folder)), "--summary", str(summary), *extra)
    return code, out, err, json.loads(summary.read_text()) if summary.exists() else None


@pytest.mark.parametrize(("layout", "storage"), [("humble", "sqlite3"), ("jazzy", "mcap"), ("kilted", "mcap")])
def test_a_sensors_only_drive_of_each_distribution_replays_on_the_machines_rate(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, layout: str, storage: str) -> None:
    bag = write_drive(tmp_path, layout, 6.0, storage)
    code, out, err, summary = replay(capsys, tmp_path, bag)
    assert code == 0, err
    assert "no commands on /tral/cmd: ticked at 80 Hz" in out
    assert summary["outcome"] == "succeeded" and summary["visited"] == ["go", "halt", "done"]
    assert summary["ros"]["decode_failures"] == {}
    assert summary["replay"]["commands_recorded"] is False
    # the front range is under 1 m from 4.05 s on (20 Hz): the machine brakes at the first tick after it
    assert summary["sim_time"] == pytest.approx(EPOCH + 4.05 + 2 / 80, abs=0.03)


def test_from_and_to_replay_a_part_of_the_drive(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bag = write_drive(tmp_path, "jazzy", 6.0)
    code, _out, err, summary = replay(capsys, tmp_path, bag, "--to", "3")
    assert code == 0, err
    assert summary["finished"] is False and summary["visited"] == ["go"]
    assert summary["replay"]["ticks"] == pytest.approx(3 * 80, abs=2)
    code, _out, err, summary = replay(capsys, tmp_path, bag, "--from", "4.5")
    assert code == 0, err
    assert summary["visited"] == ["go", "halt", "done"]
    assert summary["replay"]["ticks"] <= 4
    code, _out, err = cli(capsys, "replay", str(bag), "--machine", str(tmp_path / "brake.json"), "--profile",
                          str(tmp_path / "profile.json"), "--from", "3", "--to", "2")
    assert code == 2 and "--to 2 must be after --from 3" in err


def test_a_cut_mcap_replays_up_to_its_last_whole_chunk_with_a_warning(capsys: pytest.CaptureFixture[str],
                                                                       tmp_path: Path) -> None:
    bag = write_drive(tmp_path, "jazzy", 40.0, approach=0.05)  # about 3 MiB: chunks of 1 MiB
    (mcap,) = bag.glob("*.mcap")
    size = mcap.stat().st_size
    with open(mcap, "r+b") as f:  # the recorder was killed: no index, no footer, half a chunk
        f.truncate(int(size * 0.6))
    code, _out, err, summary = replay(capsys, tmp_path, bag)
    assert code == 0, err
    warning = [line for line in err.splitlines() if "warning" in line]
    assert len(warning) == 1 and mcap.name in warning[0] and "cut off at byte" in warning[0]
    assert "last whole chunk (1 chunks, up to log time" in warning[0]
    ticks = summary["replay"]["ticks"]
    assert 80 * 5 < ticks < 80 * 30, "up to the last whole chunk, not the whole drive nor nothing"
    assert summary["ros"]["decode_failures"] == {}


def test_a_bag_without_the_profiles_inputs_names_them_and_its_topics(capsys: pytest.CaptureFixture[str],
                                                                      tmp_path: Path) -> None:
    bag = write_drive(tmp_path, "jazzy", 1.0)
    machine = tmp_path / "brake.json"
    machine.write_text(json.dumps(BRAKE), encoding="utf-8")
    code, _out, err = cli(capsys, "replay", str(bag), "--machine", str(machine), "--profile",
                          str(DEFAULT_PROFILE_PATH))  # binds /tral/hall too
    assert code == 1 and "no messages on /tral/hall (hall)" in err and "/tral/odom" in err


def test_minus_inf_in_a_recorded_humble_drive_brakes(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """REP 117: -inf is too close to measure, so the 'front below 1.0 m' rule fires on it (it read as 4 m)."""
    bag = write_drive(tmp_path, "humble", 2.0, front=lambda t: -math.inf if t >= 1.0 else 3.0)
    code, _out, err, summary = replay(capsys, tmp_path, bag)
    assert code == 0, err
    assert summary["visited"] == ["go", "halt", "done"]
    assert summary["sim_time"] == pytest.approx(EPOCH + 1.0 + 2 / 80, abs=0.03)
