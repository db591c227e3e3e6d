"""The ROS 2 I/O profile (fsm/ros/profile.py): the shipped TRAL profile, the committed schema, and located errors for
an unknown message type, a wrong field, a topic bound twice, before anything connects."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from fsm.model.errors import DiagramError
from fsm.ros.profile import (
    DEFAULT_PROFILE_PATH,
    PROFILE_SCHEMA_PATH,
    load_profile,
    normalise_type,
    profile_schema_text,
)


def default_data() -> dict[str, Any]:
    data: dict[str, Any] = json.loads(DEFAULT_PROFILE_PATH.read_text(encoding="utf-8"))
    return data


def problems_of(tmp_path: Path, data: Any, text: str | None = None) -> list[Any]:
    path = tmp_path / "p.json"
    path.write_text(text if text is not None else json.dumps(data, indent=2), encoding="utf-8")
    with pytest.raises(DiagramError) as err:
        load_profile(path)
    return err.value.problems


def test_the_tral_profile_loads() -> None:
    p = load_profile(DEFAULT_PROFILE_PATH)
    assert p.dt == pytest.approx(0.0125)
    assert list(p.inputs_bound()) == ["left", "right", "front", "odometry", "hall"]
    assert p.outputs.command.type == "ackermann_msgs/msg/AckermannDriveStamped"
    assert p.transport.multicast is False and p.transport.mode == "peer"


def test_committed_profile_schema_is_current_and_accepts_the_tral_profile() -> None:
    assert PROFILE_SCHEMA_PATH.read_text(encoding="utf-8") == profile_schema_text(), \
        "regenerate it: python -m fsm.ros.profile --schema fsm/schema/ros_profile.schema.json"
    schema = json.loads(PROFILE_SCHEMA_PATH.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    jsonschema.validate(default_data(), schema)


def test_unknown_message_type_is_located_with_a_suggestion(tmp_path: Path) -> None:
    data = default_data()
    data["inputs"]["left"]["type"] = "sensor_msgs/msg/Rnage"
    (p,) = problems_of(tmp_path, data)
    assert p.pointer == "/inputs/left/type" and p.line is not None and p.column is not None
    assert "unknown message type 'sensor_msgs/msg/Rnage'" in p.message and "sensor_msgs/msg/Range" in (p.hint or "")


def test_a_type_that_cannot_carry_the_input(tmp_path: Path) -> None:
    data = default_data()
    data["inputs"]["front"]["type"] = "nav_msgs/Odometry"  # short form is accepted, but not for a range
    (p,) = problems_of(tmp_path, data)
    assert p.pointer == "/inputs/front/type" and "'front' cannot be carried by nav_msgs/msg/Odometry" in p.message


def test_wrong_field_and_unknown_key(tmp_path: Path) -> None:
    data = default_data()
    data["inputs"]["hall"]["field"] = "count"
    data["outputs"]["command"]["topc"] = "/x"
    problems = problems_of(tmp_path, data)
    assert [p.pointer for p in problems] == ["/inputs/hall/field", "/outputs/command/topc"]
    assert "has no field 'count'" in problems[0].message and "data" in (problems[0].hint or "")
    assert problems[1].message == "unknown key 'topc'" and "'topic'" in (problems[1].hint or "")


def test_topic_bound_twice_names_the_first_binding(tmp_path: Path) -> None:
    data = default_data()
    data["outputs"]["status"]["topic"] = "tral/odom"  # the same topic without the leading slash
    (p,) = problems_of(tmp_path, data)
    assert p.pointer == "/outputs/status/topic" and "bound twice: already by /inputs/odometry" in p.message


def test_every_problem_at_once_in_file_order(tmp_path: Path) -> None:
    data = default_data()
    data["inputs"]["right"]["max_silence"] = -1
    data["inputs"]["left"]["topic"] = "2bad//topic"
    data["transport"]["connect"] = "tcp/127.0.0.1:7447"
    problems = problems_of(tmp_path, data)
    assert len(problems) == 3
    assert [p.line for p in problems] == sorted(p.line for p in problems)


def test_bad_json_and_repeated_keys_are_located(tmp_path: Path) -> None:
    (p,) = problems_of(tmp_path, None, text='{"inputs": {,}}')
    assert "invalid JSON" in p.message and p.line == 1
    problems = problems_of(tmp_path, None, text='{"name": "a",\n "name": "b", "inputs": {}, "outputs": {}}')
    assert any("duplicate key 'name'" in p.message and p.line == 2 for p in problems)
    assert any("missing required key 'left'" in p.message for p in problems)  # and the rest, all at once


def test_normalise_type() -> None:
    assert normalise_type("sensor_msgs/Range") == "sensor_msgs/msg/Range"
    assert normalise_type("sensor_msgs/msg/Range") == "sensor_msgs/msg/Range"


@pytest.mark.parametrize("command", [["run", "diagrams/lap.json"], ["sim"]])
def test_fsmctl_reports_a_bad_profile_before_connecting(tmp_path: Path, command: list[str]) -> None:
    data = default_data()
    data["inputs"]["left"]["type"] = "sensor_msgs/msg/Rnage"
    data["outputs"]["command"]["topic"] = "/tral/ultrasonic/right"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data, indent=2), encoding="utf-8")
    repo = Path(__file__).resolve().parent.parent
    proc = subprocess.run([sys.executable, "-m", "fsm.tools.cli", *command, "--ros", str(bad)], capture_output=True,
                          text=True, timeout=60, cwd=repo)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2
    assert lines[0].startswith(f"{bad}:") and "/inputs/left/type" in lines[0]
    assert "/outputs/command/topic" in lines[1] and "bound twice" in lines[1]


def test_fsmctl_run_ros_usage_errors(tmp_path: Path) -> None:
    repo = Path(__file__).resolve().parent.parent
    cases = [(["--ros", str(DEFAULT_PROFILE_PATH), "--world", "x.json"], "--world is for the in-process simulator"),
             (["--bag", str(tmp_path / "b")], "--bag needs --ros"),
             (["--ros", str(DEFAULT_PROFILE_PATH), "--bag", str(tmp_path)], "is an existing folder"),
             (["--ros", str(DEFAULT_PROFILE_PATH), "--connect", "127.0.0.1:7447"], "not a Zenoh endpoint")]
    for extra, words in cases:
        proc = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "run", "diagrams/lap.json", *extra],
                              capture_output=True, text=True, timeout=60, cwd=repo)
        assert proc.returncode == 2 and words in proc.stderr and "Traceback" not in proc.stderr, (extra, proc.stderr)
