"""``fsmctl sweep ... --live`` (issue 24, deliverable 8): the page lists the sweep's runs with their status, asks
for its token, serves nothing else, and opens a finished run's trace in the live debugger's page, in Chromium."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from fsm.trace.replay import read_trace
from live_helpers import COUNTER, Live
from test_live_browser import CHROMIUM, _need_browser

#: Runs of the sweep (one at a time: a few seconds in all).
RUNS = 3


def _get(url: str) -> tuple[int, str]:
    try:
        with urllib.request.urlopen(url, timeout=10) as res:
            return res.status, res.read().decode("utf-8")
    except urllib.error.HTTPError as err:
        return err.code, err.read().decode("utf-8")


def _sweep(tmp_path: Path, *extra: str) -> Live:
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER, encoding="utf-8")
    return Live("--machine", str(machine), "--seeds", f"0:{RUNS}", "-j", "1", "-o", str(tmp_path / "out"), *extra,
                command="sweep", cwd=tmp_path)


def _finished(live: Live) -> dict[str, Any]:
    assert live.proc.stdout is not None
    while True:  # the lines after the URL: the plan, the closing line, then that the page stays
        line = live.proc.stdout.readline()
        assert line, live.proc.stderr.read() if live.proc.stderr else ""
        if line.startswith("live: the sweep has ended"):
            break
    code, text = _get(f"{live.base}/runs.json?token={live.token}")
    assert code == 200
    return json.loads(text)  # type: ignore[no-any-return]


def test_the_sweep_page_lists_the_runs_and_serves_only_them_with_the_token(tmp_path: Path) -> None:
    pytest.importorskip("aiohttp")
    live = _sweep(tmp_path)
    try:
        assert live.token
        data = _finished(live)
        assert data["finished"] and data["counts"] == {"queued": 0, "running": 0, "done": RUNS, "failed": 0}
        assert [(r["id"], r["status"], r["outcome"], r["trace"]) for r in data["runs"]] == \
            [(f"{i:04d}", "done", "done", True) for i in range(RUNS)]
        assert _get(f"{live.base}/runs.json")[0] == 403
        assert _get(f"{live.base}/run/0000/")[0] == 403
        assert _get(f"{live.base}/run/0000/?token=wrong")[0] == 403
        for path in ("/run/nope/", "/run/0000/../../counter.json", "/run/..%2F..%2Fcounter.json/", "/sweep.jsonl"):
            assert _get(f"{live.base}{path}?token={live.token}")[0] == 404, path
        code, page = _get(f"{live.base}/run/0000/?token={live.token}")
        assert code == 200 and "tral-fsm live" in page
        # another site's name (DNS rebinding) is refused, token or not (issue 33)
        import http.client
        from urllib.parse import urlsplit

        where = urlsplit(live.base)
        for headers in ({"Host": f"evil.example:{where.port}"}, {"Origin": "http://evil.example"}):
            conn = http.client.HTTPConnection(where.hostname or "", where.port, timeout=10)
            conn.request("GET", f"/run/0000/?token={live.token}", headers=headers)
            response = conn.getresponse()
            assert response.status == 403 and response.getheader("X-Frame-Options") == "DENY", headers
        # every run wrote its trace, which the page serves (and the run's key is the same as without --live)
        assert read_trace(tmp_path / "out" / "runs" / "0001" / "trace.jsonl").end is not None
    finally:
        code, out, err = live.interrupt()
    assert code == 0, err
    # run again without --live: every run finished before (the traces --live added did not change the runs' keys)
    import subprocess
    import sys

    again = subprocess.run([str(Path(sys.executable).with_name("fsmctl")), "sweep", "--machine",
                            str(tmp_path / "counter.json"), "--seeds", f"0:{RUNS}", "-o", str(tmp_path / "out")],
                           capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert "0 to run (" in again.stdout and f"{RUNS} finished before" in again.stdout


def test_live_options_without_live_and_a_port_in_use_are_refused(tmp_path: Path) -> None:
    import socket
    import subprocess
    import sys

    pytest.importorskip("aiohttp")
    exe = str(Path(sys.executable).with_name("fsmctl"))
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER, encoding="utf-8")
    base = [exe, "sweep", "--machine", str(machine), "-o", str(tmp_path / "out")]
    res = subprocess.run(base + ["--port", "0"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "--port is an option of the live page: add --live" in res.stderr
    assert "Traceback" not in res.stderr
    res = subprocess.run(base + ["--live", "--no-token", "--host", "0.0.0.0"], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2 and "needs its token" in res.stderr and "Traceback" not in res.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = subprocess.run(base + ["--live", "--port", str(port)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 1 and f"port {port} on 127.0.0.1 is in use" in res.stderr, res.stderr
    assert "Traceback" not in res.stderr and not (tmp_path / "out").exists()


def test_a_click_opens_a_finished_run_in_the_live_page(tmp_path: Path) -> None:
    _need_browser()
    from playwright.sync_api import sync_playwright

    live = _sweep(tmp_path)
    try:
        _finished(live)
        with sync_playwright() as pw:
            chromium = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
            context = chromium.new_context(viewport={"width": 1200, "height": 800})
            foreign: list[str] = []
            errors: list[str] = []

            def route(r: Any) -> None:
                if r.request.url.startswith(live.base + "/"):
                    r.continue_()
                else:
                    foreign.append(r.request.url)
                    r.abort()

            context.route("**/*", route)
            page = context.new_page()
            page.on("console", lambda m: errors.append(m.text) if m.type in ("error", "warning") else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(live.url)
            page.wait_for_selector("tr[data-run='0002'][data-status='done'] a.open")
            assert page.eval_on_selector_all("tr[data-run]", "rs => rs.map(r => r.dataset.status)") == ["done"] * RUNS
            assert "3 runs: 3 done" in page.inner_text("#summary")
            page.screenshot(path=str(tmp_path / "sweep-live.png"), full_page=True)
            page.click("tr[data-run='0001'] a.open")
            page.wait_for_url(f"{live.base}/run/0001/?token={live.token}")
            trace = read_trace(tmp_path / "out" / "runs" / "0001" / "trace.jsonl")
            last = trace.end["tick"] if trace.end and "tick" in trace.end else None
            # polled from here: the page's CSP forbids the string evaluation Playwright's wait_for_function polls with
            end = time.monotonic() + 30
            while not page.evaluate("!!(window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0)"):
                assert time.monotonic() < end, "the run's page never drew"
                time.sleep(0.05)
            shown = page.evaluate("window.tralReport.end()")
            assert shown > 0
            if last is not None:
                assert page.evaluate("window.tralReport.current().tick") == last
            page.screenshot(path=str(tmp_path / "sweep-run.png"))
            context.close()
            chromium.close()
        assert not foreign and not errors, (foreign, errors)
    finally:
        live.interrupt()


def test_a_running_run_is_followed_line_by_line_until_its_end(tmp_path: Path) -> None:
    """The page of a running run: the whole lines its worker has written, then each line as it comes (a line cut in
    the middle by the worker's file buffer waits for its end), until the trace's end line."""
    import asyncio
    import subprocess
    import sys

    pytest.importorskip("aiohttp")
    import aiohttp

    from fsm.tools.live.sweep import Board, SweepServer

    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER, encoding="utf-8")
    whole = tmp_path / "whole.jsonl"
    subprocess.run([str(Path(sys.executable).with_name("fsmctl")), "run", str(machine), "--trace", str(whole), "-q"],
                   check=True, timeout=60)
    lines = whole.read_text(encoding="utf-8").splitlines(keepends=True)
    assert len(lines) > 3 and '"type":"end"' in lines[-1]
    out = tmp_path / "out"
    trace = out / "runs" / "0000" / "trace.jsonl"
    trace.parent.mkdir(parents=True)
    board = Board([{"id": "0000", "params": {}, "seed": 0, "world": None},
                   {"id": "0001", "params": {}, "seed": 1, "world": None}], out, workers=1)
    board.start()
    assert [r["status"] for r in board.snapshot()["runs"]] == ["running", "queued"]
    server = SweepServer(board, "counter", "secret")
    port = server.start("127.0.0.1", 0)
    base = f"http://127.0.0.1:{port}"
    half = len(lines[1]) // 2

    async def client() -> bytes:
        got = b""
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{base}/run/0000/?token=secret") as res:
                assert res.status == 409  # no line yet
            trace.write_text(lines[0] + lines[1][:half], encoding="utf-8")
            async with http.get(f"{base}/run/0001/?token=secret") as res:
                assert res.status == 409 and "queued" in await res.text()
            async with http.get(f"{base}/run/0000/?token=secret") as res:
                assert res.status == 200
            async with http.ws_connect(f"{base}/run/0000/ws?token=secret", origin=base) as ws:
                async def until(text: bytes) -> None:
                    nonlocal got
                    while text not in got:
                        msg = await asyncio.wait_for(ws.receive(), 30)
                        if msg.type == aiohttp.WSMsgType.BINARY:
                            got += msg.data
                        assert msg.type in (aiohttp.WSMsgType.BINARY, aiohttp.WSMsgType.TEXT), msg

                await until(b'"type":"header"')
                assert got.count(b"\n") == 1  # the cut line is not sent
                with trace.open("a", encoding="utf-8") as f:
                    f.write(lines[1][half:] + "".join(lines[2:]))
                await until(b'"type":"end"')
        return got

    try:
        got = asyncio.run(client())
    finally:
        server.close()
    assert [json.loads(x) for x in got.decode("utf-8").splitlines()] == [json.loads(x) for x in lines]
    board.record({"id": "0000", "ok": True, "summary": {"outcome": "done"}, "seconds": 0.1})
    assert [(r["status"], r["outcome"], r["trace"]) for r in board.snapshot()["runs"]] == \
        [("done", "done", True), ("running", None, False)]
