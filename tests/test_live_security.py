"""The live page cannot be driven from outside (issue 33, "Security"): the headers every answer carries, Host and
Origin checked on every request and WebSocket with a token or without one (DNS rebinding), ``--host 0.0.0.0``
printing addresses other machines can open and a warning, and a request too long to read refused in one line."""

from __future__ import annotations

import asyncio
import http.client
import socket
import time
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from fsm.tools.live.addresses import allowed_hosts, interface_addresses, origin_allowed
from live_helpers import COUNTER, Live

pytest.importorskip("aiohttp")


@pytest.fixture
def counter(tmp_path: Path) -> Path:
    path = tmp_path / "counter.json"
    path.write_text(COUNTER)
    return path


def request(live: Live, path: str, headers: dict[str, str]) -> tuple[int, dict[str, str]]:
    where = urlsplit(live.base)
    conn = http.client.HTTPConnection(where.hostname or "", where.port, timeout=10)
    conn.putrequest("GET", path, skip_host=True)
    for key, value in headers.items():
        conn.putheader(key, value)
    conn.endheaders()
    response = conn.getresponse()
    response.read()
    return response.status, dict(response.getheaders())


async def steer(url: str, headers: dict[str, str]) -> str:
    import aiohttp

    async with aiohttp.ClientSession() as session:
        async with session.ws_connect(url, headers=headers) as ws:
            await ws.send_str('{"cmd": "step", "id": 1, "n": 1}')
            async for msg in ws:
                if msg.type == aiohttp.WSMsgType.TEXT and '"reply"' in msg.data:
                    return str(msg.data)
    return ""


@pytest.mark.parametrize("token", [True, False])
def test_host_and_origin_of_another_site_are_refused_with_or_without_a_token(counter: Path, token: bool) -> None:
    import aiohttp

    live = Live(str(counter), "--paused", *(() if token else ("--no-token",)))
    try:
        port = urlsplit(live.base).port
        query = f"/?token={live.token}" if token else "/"
        own = f"127.0.0.1:{port}"
        status, headers = request(live, query, {"Host": own})
        assert status == 200
        assert "frame-ancestors 'none'" in headers["Content-Security-Policy"]
        assert headers["X-Frame-Options"] == "DENY" and headers["X-Content-Type-Options"] == "nosniff"
        assert request(live, query, {"Host": f"localhost:{port}"})[0] == 200
        for bad in ({"Host": f"evil.example:{port}"}, {"Host": "evil.example"},
                    {"Host": own, "Origin": f"http://evil.example:{port}"}, {"Host": own, "Origin": "null"}):
            status, headers = request(live, query, bad)
            assert status == 403, bad
            assert headers["X-Frame-Options"] == "DENY"  # a refusal carries the headers too
        assert request(live, query, {})[0] in (400, 403)  # no Host at all
        ws = f"ws://127.0.0.1:{port}/ws" + (f"?token={live.token}" if token else "")
        for bad in ({"Host": f"evil.example:{port}", "Origin": f"http://evil.example:{port}"},
                    {"Origin": f"http://evil.example:{port}"}):
            with pytest.raises(aiohttp.WSServerHandshakeError) as info:
                asyncio.run(steer(ws, bad))
            assert info.value.status == 403
        assert '"ok": true' in asyncio.run(steer(ws, {"Origin": f"http://{own}"}))  # the page's own: it steers
    finally:
        live.close()


def test_a_request_too_long_to_read_is_refused_in_one_line(counter: Path) -> None:
    live = Live(str(counter), "--paused")
    try:
        where = urlsplit(live.base)
        for head in (b"GET /" + b"a" * 100_000 + b" HTTP/1.1\r\nHost: x\r\n\r\n",
                     b"GET / HTTP/1.1\r\nHost: x\r\nX-Long: " + b"b" * 100_000 + b"\r\n\r\n"):
            with socket.create_connection((where.hostname, where.port), timeout=10) as s:
                s.sendall(head)
                answer = s.recv(200)
            assert answer.split(b" ")[1].startswith(b"4"), answer
        time.sleep(0.3)
        code, out, err = live.interrupt()
        assert "Traceback" not in err, err
        refused = [line for line in err.splitlines() if "refused a request" in line]
        assert len(refused) == 2 and all(len(line) < 200 for line in refused), err
    finally:
        live.close()


def test_listening_on_every_interface_prints_addresses_that_open_and_a_warning(counter: Path) -> None:
    live = Live(str(counter), "--paused", "--host", "0.0.0.0")
    try:
        urls = [live.url]
        assert live.proc.stdout is not None
        while True:
            line = live.proc.stdout.readline()
            if not line.startswith("live: http"):
                break
            urls.append(line.split(" ", 1)[1].strip())
        assert not any("0.0.0.0" in url for url in urls)
        assert any("127.0.0.1" in url for url in urls) and all(f"?token={live.token}" in url for url in urls)
        for url in urls:  # each opens (this machine is on each of its interfaces)
            where = urlsplit(url)
            conn = http.client.HTTPConnection(where.hostname or "", where.port, timeout=10)
            conn.request("GET", f"/?{where.query}")
            assert conn.getresponse().status == 200, url
        code, out, err = live.interrupt()
        assert "reachable from other machines" in err and "Traceback" not in err
    finally:
        live.close()


def test_the_names_a_server_answers() -> None:
    assert allowed_hosts("127.0.0.1", 8765) >= {"127.0.0.1:8765", "localhost:8765", "[::1]:8765"}
    assert "evil.example:8765" not in allowed_hosts("0.0.0.0", 8765)
    assert {f"{a}:8765" if ":" not in a else f"[{a}]:8765" for a in interface_addresses()} <= allowed_hosts(
        "0.0.0.0", 8765)
    assert "127.0.0.1" in allowed_hosts("127.0.0.1", 80)  # a browser leaves port 80 out
    hosts = allowed_hosts("127.0.0.1", 1234)
    assert origin_allowed(None, hosts) and origin_allowed("http://localhost:1234", hosts)
    assert not origin_allowed("http://localhost:1235", hosts) and not origin_allowed("null", hosts)


def test_what_json_cannot_say_reaches_a_page_as_text() -> None:
    from fsm.tools.live.server import dumps

    assert dumps({"kind": "watched", "rows": [[3, [float("inf"), 1.5, float("nan")]]]}) == \
        '{"kind": "watched", "rows": [[3, ["inf", 1.5, "nan"]]]}'


def test_a_page_other_machines_reach_needs_its_token(capsys: pytest.CaptureFixture[str], counter: Path) -> None:
    from helpers import cli

    code, out, err = cli(capsys, "run", str(counter), "--live", "--host", "0.0.0.0", "--no-token")
    assert code == 2 and out == ""
    assert "--no-token with --host 0.0.0.0: a page other machines can reach needs its token" in err


def test_live_without_its_extra_says_what_to_install(capsys: pytest.CaptureFixture[str], counter: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """A missing extra is not a mistake in the command line: exit status 1, as ``--backend ray`` and the ROS
    commands give without theirs, and the pip line that installs it."""
    from helpers import cli

    monkeypatch.setitem(__import__("sys").modules, "aiohttp", None)  # what an install without the extra finds
    code, out, err = cli(capsys, "run", str(counter), "--live")
    assert code == 1 and out == "" and "--live needs aiohttp: pip install 'tral-fsm[live]'" in err
