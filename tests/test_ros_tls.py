"""Zenoh over TLS (the profile's ``transport.tls``): a throwaway CA and certificates made here with the system's
``openssl``; plain Zenoh sessions configured in the test (not through the project) are the other peers. A peer that
trusts the right CA connects; one that trusts another CA, one speaking plain TCP, and (with mutual TLS) one without
a certificate the CA signed are refused."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from helpers import finish

pytest.importorskip("zenoh")
pytest.importorskip("rosbags")
if shutil.which("openssl") is None:
    pytest.skip("no openssl to make the test's certificates", allow_module_level=True)

from test_ros_listen import peers_of_a_stranger  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
PROFILE = REPO / "fsm" / "ros" / "tral.profile.json"
LAP = REPO / "diagrams" / "corner_turn.json"


def openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True, timeout=30)


def make_ca(folder: Path, name: str) -> None:
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
            "-keyout", f"{name}.key", "-out", f"{name}.pem", "-days", "2", "-subj", f"/CN={name}",
            "-addext", "basicConstraints=critical,CA:TRUE", "-addext", "keyUsage=critical,keyCertSign,cRLSign",
            cwd=folder)


def make_cert(folder: Path, name: str, ca: str) -> None:
    """A certificate for 127.0.0.1 and localhost, for servers and clients, signed by ``ca``."""
    (folder / f"{name}.ext").write_text("basicConstraints=CA:FALSE\nsubjectAltName=IP:127.0.0.1,DNS:localhost\n"
                                        "extendedKeyUsage=serverAuth,clientAuth\n", encoding="utf-8")
    openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-keyout", f"{name}.key",
            "-out", f"{name}.csr", "-subj", f"/CN={name}", cwd=folder)
    openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey", f"{ca}.key", "-CAcreateserial",
            "-out", f"{name}.pem", "-days", "2", "-extfile", f"{name}.ext", cwd=folder)


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("pki")
    make_ca(folder, "ca")
    make_ca(folder, "other_ca")
    make_cert(folder, "car", "ca")
    make_cert(folder, "laptop", "ca")
    make_cert(folder, "stranger", "other_ca")
    return folder


def tls_profile(folder: Path, **tls: Any) -> Path:
    data = json.loads(PROFILE.read_text(encoding="utf-8"))
    data.pop("$schema")
    data["transport"].update(via="zenoh", peer_timeout=3, tls={"ca": "ca.pem", **tls})
    path = folder / f"tls{len(list(folder.glob('tls*.json')))}.profile.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def listening(profile: Path) -> Any:
    from fsm.ros.profile import load_profile
    from fsm.ros.transport import Link, free_endpoint

    loaded = load_profile(profile)
    endpoint = free_endpoint(profile=loaded)
    assert endpoint.startswith("tls/127.0.0.1:")
    return Link(loaded, listen=[endpoint]).open(), endpoint


def test_a_peer_with_the_right_ca_connects_and_others_are_refused(pki: Path) -> None:
    link, endpoint = listening(tls_profile(pki, certificate="car.pem", key="car.key"))
    try:
        assert peers_of_a_stranger(endpoint, 10, root_ca_certificate=str(pki / "ca.pem")) == 1
        other = str(pki / "other_ca.pem")
        assert peers_of_a_stranger(endpoint, 2, root_ca_certificate=other) == 0, "another CA: refused"
        tcp = "tcp/" + endpoint.split("/", 1)[1]
        assert peers_of_a_stranger(tcp, 2) == 0, "plain TCP to the TLS port: refused"
    finally:
        link.close()


def test_mutual_tls_refuses_a_peer_without_a_certificate_the_ca_signed(pki: Path) -> None:
    link, endpoint = listening(tls_profile(pki, certificate="car.pem", key="car.key", mutual=True))
    ca = str(pki / "ca.pem")
    try:
        assert peers_of_a_stranger(endpoint, 2, root_ca_certificate=ca) == 0, "no client certificate: refused"
        assert peers_of_a_stranger(endpoint, 2, root_ca_certificate=ca, enable_mtls=True,
                     connect_certificate=str(pki / "stranger.pem"),
                     connect_private_key=str(pki / "stranger.key")) == 0, "a certificate another CA signed: refused"
        assert peers_of_a_stranger(endpoint, 10, root_ca_certificate=ca, enable_mtls=True,
                     connect_certificate=str(pki / "laptop.pem"), connect_private_key=str(pki / "laptop.key")) == 1
    finally:
        link.close()


def test_sim_over_tls_is_driven_by_run_with_the_right_ca(pki: Path, tmp_path: Path) -> None:
    """The commands: ``sim --ros`` listens on a free TLS port it prints; ``run --ros --connect`` drives it."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    sim = subprocess.Popen([sys.executable, "-m", "fsm.tools.cli", "sim", "--ros",
                            str(tls_profile(pki, certificate="car.pem", key="car.key", mutual=True)), "--lockstep"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env)
    try:
        assert sim.stderr is not None
        line = sim.stderr.readline()
        assert "listening on tls/127.0.0.1:" in line, line
        endpoint = line.split("listening on ", 1)[1].split(";")[0].strip()
        laptop = tls_profile(pki, certificate="laptop.pem", key="laptop.key", mutual=True)
        code, _out, err = finish(subprocess.Popen(
            [sys.executable, "-m", "fsm.tools.cli", "run", str(LAP), "--ros", str(laptop), "--lockstep", "--connect",
             endpoint, "--duration", "0.5", "--summary", str(tmp_path / "run.json")],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO, env=env), timeout=60)
        assert code == 0, err
        assert json.loads((tmp_path / "run.json").read_text())["ros"]["commands"] >= 40
    finally:
        sim.send_signal(signal.SIGINT)
        finish(sim, timeout=30)


def test_tls_mistakes_are_one_message(pki: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from helpers import cli

    missing = tls_profile(pki, certificate="nowhere.pem", key="car.key")
    code, _out, err = cli(capsys, "sim", "--ros", str(missing))
    assert code == 1 and "transport.tls.certificate" in err and "nowhere.pem: no such file" in err, err
    plain = tls_profile(pki, certificate="car.pem", key="car.key")
    code, _out, err = cli(capsys, "sim", "--ros", str(plain), "--listen", "tcp/127.0.0.1:0")
    assert code == 1 and "not a TLS endpoint" in err and "tls/HOST:PORT" in err, err
    half = tls_profile(pki, certificate="car.pem")
    code, _out, err = cli(capsys, "sim", "--ros", str(half))
    assert code == 1 and "/transport/tls" in err and "certificate and key go together" in err, err
    assert "Traceback" not in err
