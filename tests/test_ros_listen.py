"""No stranger drives the car: `fsmctl sim --ros` listens on a free port it prints (never rmw_zenoh's 7447 unless
asked), and with the profile's `transport.user` (Zenoh's user/password authentication) a controller without the
password is refused, written here as a plain Zenoh session, while `fsmctl run --ros` with it drives."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from helpers import finish

zenoh = pytest.importorskip("zenoh")
pytest.importorskip("rosbags")

REPO = Path(__file__).resolve().parent.parent
PROFILE = REPO / "fsm" / "ros" / "tral.profile.json"
LAP = REPO / "diagrams" / "lap.json"


def start(*args: str, password: str | None = None) -> subprocess.Popen[str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.pop("FSM_ZENOH_PASSWORD", None)
    if password is not None:
        env["FSM_ZENOH_PASSWORD"] = password
    return subprocess.Popen([sys.executable, "-m", "fsm.tools.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)


def profile(tmp_path: Path, peer_timeout: float = 15, **transport: Any) -> Path:
    data = json.loads(PROFILE.read_text(encoding="utf-8"))
    data.pop("$schema")
    data["transport"].update(transport, via="zenoh", peer_timeout=peer_timeout)
    path = tmp_path / f"profile{peer_timeout:g}.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def printed_endpoint(sim: subprocess.Popen[str]) -> str:
    assert sim.stderr is not None
    line = sim.stderr.readline()
    found = re.search(r"listening on (tcp/127\.0\.0\.1:(\d+))", line)
    assert found, line
    assert found.group(2) != "7447"
    return found.group(1)


def plain_session(endpoint: str, **tls: Any) -> Any:
    """A plain Zenoh peer (no credentials; ``tls``: Zenoh's own transport/link/tls settings) connecting to
    ``endpoint``."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    if tls:
        conf.insert_json5("transport/link/tls", json.dumps(tls))
    return zenoh.open(conf)


def peers_of_a_stranger(endpoint: str, seconds: float, **tls: Any) -> int:
    """A plain Zenoh peer without credentials connects to ``endpoint``: how many peers it has after at most
    ``seconds``."""
    session = plain_session(endpoint, **tls)
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not list(session.info.peers_zid()):
            time.sleep(0.05)
        return len(list(session.info.peers_zid()))
    finally:
        session.close()


def test_sim_listens_on_a_free_port_it_prints_and_run_drives_it_there(tmp_path: Path) -> None:
    path = profile(tmp_path)
    sim = start("sim", "--ros", str(path), "--lockstep", "--summary", str(tmp_path / "sim.json"))
    try:
        endpoint = printed_endpoint(sim)
        assert peers_of_a_stranger(endpoint, 5) == 1, "without authentication anyone on the machine gets in"
        code, _out, err = finish(start("run", str(LAP), "--ros", str(path), "--lockstep", "--connect", endpoint,
                                       "--duration", "0.5"), timeout=60)
        assert code == 0, err
    finally:
        sim.send_signal(signal.SIGINT)
        finish(sim, timeout=30)


def test_a_controller_without_the_password_is_refused(tmp_path: Path) -> None:
    path = profile(tmp_path, user="car")
    sim = start("sim", "--ros", str(path), "--lockstep", "--summary", str(tmp_path / "sim.json"), password="s3cret")
    try:
        endpoint = printed_endpoint(sim)
        assert peers_of_a_stranger(endpoint, 2) == 0, "a peer without credentials is refused"
        impatient = profile(tmp_path, peer_timeout=2, user="car")
        code, _out, err = finish(start("run", str(LAP), "--ros", str(impatient), "--lockstep", "--connect", endpoint,
                                       "--duration", "0.5", "--summary", str(tmp_path / "run.json"),
                                       password="wrong"), timeout=60)
        assert code == 1 and "no peer reached" in err, err
        code, _out, err = finish(start("run", str(LAP), "--ros", str(path), "--lockstep", "--connect", endpoint,
                                       "--duration", "0.5", "--summary", str(tmp_path / "run.json"),
                                       password="s3cret"), timeout=60)
        assert code == 0, err
        assert json.loads((tmp_path / "run.json").read_text())["ros"]["commands"] >= 40
    finally:
        sim.send_signal(signal.SIGINT)
        code, _out, err = finish(sim, timeout=30)
    assert code == 130, err
    assert json.loads((tmp_path / "sim.json").read_text())["commands_received"] >= 40


def test_a_user_without_a_password_is_one_message(tmp_path: Path) -> None:
    code, out, err = finish(start("sim", "--ros", str(profile(tmp_path, user="car"))), timeout=60)
    assert code == 1 and out == ""
    assert err.strip().count("\n") == 0 and "FSM_ZENOH_PASSWORD" in err and "Traceback" not in err, err


#: rmw_zenoh's liveliness token (ros2/rmw_zenoh bfc065f, liveliness_utils.cpp): admin space, domain, zid, nid, id,
#: kind, enclave, namespace, node[, topic, type, hash, qos].
TOKEN = re.compile(r"^@ros2_lv/(\d+)/([0-9a-f]+)/(\d+)/(\d+)/(NN|MP|MS)/%/%/([A-Za-z0-9_]+)"
                   r"(?:/(%[^/]+)/([a-z_]+::msg::dds_::[A-Za-z0-9]+_)/(RIHS01_[0-9a-f]{64})/([^/]*))?$")


def test_the_bridge_declares_rmw_zenohs_liveliness_tokens(tmp_path: Path) -> None:
    """Read back with a plain Zenoh liveliness query, as rmw_zenoh's graph cache does at start."""
    path = profile(tmp_path, domain=7)
    sim = start("sim", "--ros", str(path))  # on the wall clock: the profile's QoS (lock-step sends reliably)
    try:
        endpoint = printed_endpoint(sim)
        session = plain_session(endpoint)
        try:
            keys: list[str] = []
            end = time.monotonic() + 10
            while len(keys) < 8 and time.monotonic() < end:
                keys = [str(reply.ok.key_expr) for reply in session.liveliness().get("@ros2_lv/7/**", timeout=2)
                        if reply.ok is not None]
        finally:
            session.close()
    finally:
        sim.send_signal(signal.SIGINT)
        finish(sim, timeout=30)
    parsed = [TOKEN.match(k) for k in keys]
    assert all(parsed), keys
    by_kind = {(m.group(5), m.group(7)): m for m in parsed if m is not None}
    node = by_kind[("NN", None)]
    assert node.group(1) == "7" and node.group(6) == "fsmctl_sim_tral" and node.group(4) == "0"
    front = by_kind[("MP", "%tral%ultrasonic%front")]
    assert front.group(8) == "sensor_msgs::msg::dds_::Range_" and front.group(10) == "2:2:,1:,:,:,,"
    assert front.group(2) == node.group(2), "one session: one zid"
    command = by_kind[("MS", "%tral%cmd")]
    assert command.group(8) == "ackermann_msgs::msg::dds_::AckermannDriveStamped_"
    assert command.group(10) == ":2:,1:,:,:,,"  # reliable: rmw_zenoh's default, left empty
    ids = [int(m.group(4)) for m in parsed if m is not None]
    assert len(ids) == len(set(ids)), "each entity its own id"
