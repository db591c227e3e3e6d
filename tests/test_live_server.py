"""``fsmctl run --live``'s server and command line (issue 24, "Security and bad input"): the token on every request,
nothing served but the page, a foreign page's WebSocket refused, a port in use, options that do not go together,
Ctrl-C and the page's Stop keeping the trace and the outputs."""

from __future__ import annotations

import asyncio
import http.client
import json
import socket
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import pytest

from fsm.trace.replay import read_trace
from helpers import cli
from live_helpers import COUNTER, REPO, Live

pytest.importorskip("aiohttp")


@pytest.fixture
def counter(tmp_path: Path) -> Path:
    path = tmp_path / "counter.json"
    path.write_text(COUNTER)
    return path


def get(live: Live, path: str, method: str = "GET") -> tuple[int, str, dict[str, str]]:
    where = urlsplit(live.base)
    conn = http.client.HTTPConnection(where.hostname or "", where.port, timeout=10)
    conn.request(method, path)
    response = conn.getresponse()
    body = response.read().decode("utf-8", "replace")
    return response.status, body, dict(response.getheaders())


async def socket_talk(url: str, commands: list[dict[str, Any]], headers: dict[str, str] | None = None,
                      until: Any = None) -> list[Any]:
    import aiohttp

    got: list[Any] = []
    async with aiohttp.ClientSession() as session:
        async with session.ws_connect(url, headers=headers or {}) as ws:
            for command in commands:
                await ws.send_str(json.dumps(command))
            async for msg in ws:
                got.append(msg.data if msg.type == aiohttp.WSMsgType.TEXT else bytes(msg.data))
                if until is not None and until(got):
                    break
    return got


def test_the_page_needs_its_token_and_nothing_else_is_served(counter: Path, tmp_path: Path) -> None:
    live = Live(str(counter), "--paused")
    try:
        status, body, headers = get(live, f"/?token={live.token}")
        assert status == 200 and "connect-src 'self'" in body and "<img src=x onerror" not in body
        assert headers["X-Content-Type-Options"] == "nosniff" and headers["Cache-Control"] == "no-store"
        for path in ("/", "/?token=", "/?token=x" + live.token, "/ws", "/../../etc/passwd"):
            assert get(live, path)[0] == 403, path
        for path in ("/../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/assets/../pyproject.toml", "//etc/passwd",
                     "/fsm/session.py", "/report.js", "/..%2f..%2fpyproject.toml", "/index.html"):
            status, body, _ = get(live, f"{path}?token={live.token}")
            assert status in (403, 404), path
            assert "tral" not in body and "root:" not in body, path
        assert get(live, f"/?token={live.token}", "POST")[0] == 405
        ws = live.base.replace("http", "ws") + "/ws"
        import aiohttp

        for url, headers_ in ((ws, None), (f"{ws}?token={live.token}", {"Origin": "http://evil.example"})):
            with pytest.raises(aiohttp.WSServerHandshakeError) as info:
                asyncio.run(socket_talk(url, [], headers_))
            assert info.value.status == 403
    finally:
        live.close()


def test_the_stream_is_the_trace_and_stop_writes_the_outputs(counter: Path, tmp_path: Path) -> None:
    trace, summary = tmp_path / "t.jsonl", tmp_path / "s.json"
    live = Live(str(counter), "--paused", "--trace", str(trace), "--summary", str(summary))
    try:
        url = live.base.replace("http", "ws") + f"/ws?token={live.token}"
        got = asyncio.run(socket_talk(url, [{"cmd": "step", "id": 1, "n": 5}, {"cmd": "fly", "id": 2}],
                                      until=lambda g: any('"tick": 5' in m and '"paused"' in m for m in g
                                                          if isinstance(m, str))
                                      and any('"id": 2' in m for m in g if isinstance(m, str))))
        got += asyncio.run(socket_talk(url, [{"cmd": "input", "id": 3, "input": {"kind": "set", "values": {"n": 60}}},
                                             {"cmd": "step", "id": 4, "n": 3}, "not json"],  # type: ignore[list-item]
                                       until=lambda g: all(any(f'"id": {k}' in m for m in g if isinstance(m, str))
                                                           for k in (4, "null"))))
        texts = [json.loads(m) for m in got if isinstance(m, str)]
        assert texts[0] == {"kind": "hello", "live": True}
        header = json.loads(next(m for m in got if isinstance(m, bytes)).decode().splitlines()[0])
        assert header["type"] == "header" and header["name"] == "counter"
        answers = {t["id"]: t for t in texts if t["kind"] == "reply"}
        assert answers[1]["ok"] and not answers[2]["ok"] and "unknown command" in answers[2]["error"]
        assert not answers[None]["ok"] and "a command is a JSON object" in answers[None]["error"]
        assert answers[4]["ok"]  # taken at the same tick boundary as the input, before the run ended
        assert answers[3] == {"kind": "reply", "id": 3, "command": "input", "ok": True, "tick": 6, "text": "set n = 60"}
        asyncio.run(socket_talk(url, [{"cmd": "stop"}]))
        code, out, err = live.wait()
    finally:
        live.close()
    assert code == 0, err
    assert "outcome over after 6 ticks" in out  # the injection made the run take the other way
    read = read_trace(trace)
    assert read.end is not None and read.end["outcome"] == "over"
    assert [(i["tick"], i["text"]) for i in read.inputs] == [(6, "set n = 60")]
    assert json.loads(summary.read_text())["outcome"] == "over"


def test_ctrl_c_ends_the_server_and_keeps_the_trace(counter: Path, tmp_path: Path) -> None:
    trace = tmp_path / "t.jsonl"
    live = Live(str(counter), "--trace", str(trace), "--speed", "max")
    try:
        code, out, _err = live.interrupt()
    finally:
        live.close()
    assert code == 130
    assert read_trace(trace).end["interrupted"] is True  # type: ignore[index]


def test_ctrl_c_tells_a_page_the_runs_last_tick_and_that_it_stopped(counter: Path, tmp_path: Path) -> None:
    """A page watching a run that Ctrl-C stops gets the trace's last lines and a last status that says "stopped",
    then the bye (issue 33's tryout: the page went on saying "running tick 124" when the trace had 126)."""
    trace = tmp_path / "t.jsonl"
    live = Live(str(counter), "--trace", str(trace))
    got: list[Any] = []
    try:
        url = live.base.replace("http", "ws") + f"/ws?token={live.token}"
        listener = threading.Thread(target=lambda: got.extend(asyncio.run(socket_talk(url, []))), daemon=True)
        listener.start()
        time.sleep(0.5)  # the run, at real time, ends by itself after 2 s: stopped well before
        code, _out, _err = live.interrupt()
        listener.join(10)
    finally:
        live.close()
    assert code == 130
    texts = [json.loads(m) for m in got if isinstance(m, str)]
    statuses = [t for t in texts if t["kind"] == "status"]
    assert texts[-1]["kind"] == "bye" and "Ctrl-C" in texts[-1]["why"]
    end = read_trace(trace).end
    assert end is not None and statuses[-1]["state"] == "stopped" and statuses[-1]["tick"] == end["tick"], statuses
    lines = b"".join(m for m in got if isinstance(m, bytes)).decode().splitlines()
    written = trace.read_text().splitlines()
    assert lines == written[:len(lines)] and len(lines) >= len(written) - 1  # all but the end line, written after


def test_a_port_in_use_is_one_message_naming_it(counter: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, _out, err = cli(capsys, "run", str(counter), "--live", "--port", str(port), "--trace",
                              str(tmp_path / "t.jsonl"))
    assert code == 1
    assert err.strip() == (f"fsmctl: error: --port {port}: port {port} on 127.0.0.1 is in use (another program "
                                "listens there); choose another with --port N, or --port 0 for any free one")
    assert not (tmp_path / "t.jsonl").exists()


@pytest.mark.parametrize("args, words", [
    (["--live", "--host", "0.0.0.0", "--no-token"], "needs its token"),
    (["--port", "9000"], "--port is an option of the live debugger: add --live"),
    (["--no-reload"], "--no-reload is an option of the live debugger: add --live"),
    (["--live", "--video", "v.mp4"], "--video cannot be combined with --live"),
    (["--live", "--trace", "-"], "name a file for --trace"),
    (["--live", "--speed", "0"], "a speed is 0.01 to 10000"),
    (["--live", "--port", "70000"], "a port is 0 to 65535"),
])
def test_options_that_do_not_go_together_are_usage_errors(args: list[str], words: str,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = cli(capsys, "run", str(REPO / "diagrams" / "hallway_lap.json"), *args)
    assert code == 2 and words in err


def test_a_paused_runs_pages_are_answered_at_once_a_running_runs_at_the_page_rate() -> None:
    """Issue 33 (click to redraw): while paused, what a page is sent answers a click (a step, a rewind), so its sender
    does not wait out the page rate (1/30 s) before the step's status; while running it does (1/5 s as fast as
    possible). Measured end to end by benchmarks/bench_live.py, not timed here."""
    from fsm.tools.live.server import FAST_RATE, MAX_RATE, _pause_before_next

    assert _pause_before_next({"state": "paused", "speed": 1.0}, 0.0) == 0.0
    assert _pause_before_next({"state": "ended", "speed": None}, 0.0) == 0.0
    assert _pause_before_next(None, 0.0) == 0.0
    assert _pause_before_next({"state": "running", "speed": 1.0}, 0.0) == pytest.approx(1 / MAX_RATE)
    assert _pause_before_next({"state": "running", "speed": None}, 0.05) == pytest.approx(1 / FAST_RATE - 0.05)
    assert _pause_before_next({"state": "running", "speed": 1.0}, 1.0) == 0.0


def counted_calls(owner: Any, method: str) -> list[int]:
    """Count the calls of ``owner.method`` from now on (it still runs): the one-element list holds the count."""
    calls = [0]
    original = getattr(owner, method)

    def counting() -> None:
        calls[0] += 1
        original()

    setattr(owner, method, counting)
    return calls


def test_a_running_runs_progress_wakes_no_one_and_the_stream_is_not_deflated() -> None:
    """Issue 33 (the page's cost per tick): a status is published after every chunk of ticks, hundreds of times a
    second at full speed; only a pause, a reply or a notice wakes the server's thread for it, a running run's pages
    are sent what is new at their own rate. The stream is sent as it is: a client that offers per-message deflate
    (aiohttp's, as browsers do) gets none, so neither side compresses the trace. A reply still comes at once."""
    import threading
    import time

    import aiohttp

    from fsm.debug.control import Controller
    from fsm.sim import simulate
    from fsm.tools.live.page import live_page
    from fsm.tools.live.server import FAST_RATE, LiveServer, Source
    from fsm.tools.live.stream import LineBuffer
    from fsm.tools.recording import run_recorder

    lap, world = REPO / "diagrams" / "hallway_lap.json", REPO / "diagrams" / "worlds" / "hallway.json"
    session = simulate(str(lap), world=world)
    buffer = LineBuffer()
    session.record(run_recorder(buffer, str(lap), session.car, world_file=world))
    session.start()
    controller = Controller(session, speed=None, paused=True, snapshot_period=None)
    controller.send("watch", {"expr": "car_front"})
    server = LiveServer(Source(buffer, controller), live_page(json.loads(buffer.first_line()), lap.name), None)
    wakes = counted_calls(server, "_woken")
    published = counted_calls(controller, "_publish")

    async def main() -> tuple[str | None, list[tuple[float, Any]], float]:
        port = await server.start("127.0.0.1", 0)
        runner = threading.Thread(target=controller.loop, daemon=True)
        runner.start()
        got: list[tuple[float, Any]] = []
        try:
            async with aiohttp.ClientSession() as client, client.ws_connect(
                    f"http://127.0.0.1:{port}/ws", compress=15) as ws:
                extensions = ws._response.headers.get("Sec-WebSocket-Extensions")
                await ws.send_str(json.dumps({"cmd": "resume", "id": 1}))
                paused_at = 0.0
                async for msg in ws:
                    now = time.monotonic()
                    data = json.loads(msg.data) if msg.type == aiohttp.WSMsgType.TEXT else None
                    got.append((now, data))
                    if data and data.get("kind") == "status" and data["tick"] > 4000 and not paused_at:
                        await ws.send_str(json.dumps({"cmd": "pause", "id": 2}))
                        paused_at = now
                    if data and data.get("kind") == "reply" and data["id"] == 2:
                        return extensions, got, now - paused_at
        finally:
            controller.send("stop")
            runner.join(10)
            await server.close()
        raise AssertionError("no reply to pause")

    extensions, got, reply_s = asyncio.run(main())
    assert extensions is None  # offered, not taken
    running = [t for t, m in got if m is None or m.get("kind") == "status" and m.get("state") == "running"]
    span = running[-1] - running[0]
    assert published[0] > 10 and wakes[0] < published[0] / 4, (wakes, published)
    assert len(running) <= 3 * (FAST_RATE * span + 2), (len(running), span)  # trace and status per send at most
    assert reply_s < 5.0  # at once, not after the run (a reply wakes the pages; loose: the machine may be busy)
    watched = [m for _t, m in got if m is not None and m.get("kind") == "watched"]
    rows = [row for m in watched for row in m["rows"]]
    assert len(rows) > 2 * len(watched)  # a row per status published, a message per send
    assert [t for t, _v in rows] == sorted({t for t, _v in rows})
