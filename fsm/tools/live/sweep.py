"""``fsmctl sweep ... --live``: a page listing the sweep's runs with their status, updated as they finish; a click
opens a finished run's trace in the live debugger's page (as ``fsmctl report TRACE --live`` does).

The sweep runs in the main thread as without ``--live`` (its pool, Ctrl-C, the files it writes); the page is
served from an event loop in a thread of its own, on 127.0.0.1 with a random token unless told otherwise (the
same rules as ``fsmctl run --live``). With ``--live`` every run writes its trace (``runs/<id>/trace.jsonl``): that is
what a click opens. A run's status is ``queued``, ``running`` (handed to a worker: the pool hands runs out in
order, one per free worker, so the runs after the finished ones, as many as there are workers, are the running
ones), ``done`` (with its outcome) or ``failed`` (it raised). A running run's page shows its trace as its worker
writes it (whole lines, read again four times a second, in chunks of the worker's file buffer), until it ends;
nothing can be steered from there (the run is in a worker process). With Ray on other machines the trace is not
here until the run has finished.

Routes (every one with the token): ``/`` the list, ``/runs.json`` the statuses, ``/run/ID/`` and ``/run/ID/ws`` a
run's page and stream (:class:`~fsm.tools.live.server.LiveServer`'s, built on the first visit).
"""

from __future__ import annotations

import asyncio
import json
import threading
from html import escape
from pathlib import Path
from typing import Any

from aiohttp import web

from fsm.model.errors import FsmError

from .addresses import allowed_hosts
from .server import HEADERS, LiveServer, Source, quiet_bad_requests, token_guard
from .stream import LineBuffer

#: How often (seconds) a running run's trace is read again for its page.
FOLLOW = 0.25
#: The statuses a run goes through.
STATUSES = ("queued", "running", "done", "failed")


class Board:
    """The runs of a sweep and their status, shared by the sweep (the main thread) and the page's thread."""

    def __init__(self, jobs: list[dict[str, Any]], out_dir: Path, workers: int) -> None:
        self.lock = threading.Lock()
        self.out_dir = out_dir
        self.workers = max(1, workers)
        self.order = [job["id"] for job in jobs]
        self.rows: dict[str, dict[str, Any]] = {
            job["id"]: {"id": job["id"], "params": job["params"], "seed": job["seed"],
                        "world": Path(job["world"]).name if job.get("world") else None, "status": "queued",
                        "outcome": None, "error": None, "seconds": None, "trace": False} for job in jobs}
        self.finished = False
        self.version = 0

    def start(self) -> None:
        """The pool has its runs: as many as there are workers are running."""
        with self.lock:
            self._hand_out()

    def record(self, rec: dict[str, Any], before: bool = False) -> None:
        """A run finished (``before``: in an earlier sweep of the same folder)."""
        with self.lock:
            row = self.rows.get(rec["id"])
            if row is None:
                return
            summary = rec.get("summary") or {}
            row["status"] = "done" if rec.get("ok") else "failed"
            row["outcome"] = summary.get("outcome") if rec.get("ok") else None
            row["error"] = None if rec.get("ok") else str(rec.get("error"))[:300]
            row["seconds"] = rec.get("seconds")
            row["trace"] = self.trace_path(rec["id"]).is_file()
            row["before"] = before
            if not before:
                self._hand_out()
            self.version += 1

    def end(self) -> None:
        """The sweep is over (finished or interrupted): what was not run stays queued."""
        with self.lock:
            for row in self.rows.values():
                if row["status"] == "running":
                    row["status"] = "queued"
            self.finished = True
            self.version += 1

    def _hand_out(self) -> None:
        running = sum(1 for row in self.rows.values() if row["status"] == "running")
        for run_id in self.order:
            if running >= self.workers:
                break
            row = self.rows[run_id]
            if row["status"] == "queued":
                row["status"] = "running"
                running += 1
        self.version += 1

    def trace_path(self, run_id: str) -> Path:
        return self.out_dir / "runs" / run_id / "trace.jsonl"

    def snapshot_row(self, run_id: str) -> dict[str, Any] | None:
        with self.lock:
            row = self.rows.get(run_id)
            return dict(row) if row is not None else None

    def snapshot(self) -> dict[str, Any]:
        with self.lock:
            rows = [dict(self.rows[run_id]) for run_id in self.order]
            counts = {s: sum(1 for r in rows if r["status"] == s) for s in STATUSES}
            return {"finished": self.finished, "version": self.version, "counts": counts, "runs": rows}


class SweepServer:
    """The sweep's page and its runs' pages, served by an event loop in a thread of its own."""

    def __init__(self, board: Board, name: str, token: str | None) -> None:
        self.board = board
        self.name = name
        self.token = token
        self.runs: dict[str, LiveServer] = {}
        self.followers: list[asyncio.Task[None]] = []
        self.app = web.Application(client_max_size=64 * 1024)
        self.hosts: set[str] | None = None  # the Host values answered, once listening
        self.app.middlewares.append(token_guard(lambda: self.token, lambda: self.hosts))
        self.app.router.add_get("/", self._list)
        self.app.router.add_get("/runs.json", self._statuses)
        self.app.router.add_get("/run/{id}", self._run_page)
        self.app.router.add_get("/run/{id}/", self._run_page)
        self.app.router.add_get("/run/{id}/ws", self._run_socket)
        self.loop: asyncio.AbstractEventLoop | None = None
        self.thread: threading.Thread | None = None
        self._stopped: asyncio.Event | None = None

    # -- starting and stopping ----------------------------------------------------------------------------------------
    def start(self, host: str, port: int) -> int:
        """Listen in a thread of its own; the port listened on. ``OSError`` (from this thread) when it cannot."""
        ready = threading.Event()
        result: dict[str, Any] = {}

        async def main() -> None:
            self.loop = asyncio.get_running_loop()
            self._stopped = asyncio.Event()
            quiet_bad_requests()
            runner = web.AppRunner(self.app, access_log=None, handle_signals=False)
            await runner.setup()
            site = web.TCPSite(runner, host, port, reuse_address=False)
            try:
                await site.start()
            except OSError as exc:
                result["error"] = exc
                await runner.cleanup()
                ready.set()
                return
            result["port"] = runner.addresses[0][1] if runner.addresses else port
            self.hosts = allowed_hosts(host, int(result["port"]))
            ready.set()
            try:
                await self._stopped.wait()
            finally:
                for task in self.followers:
                    task.cancel()
                for server in self.runs.values():
                    await server.close()
                await runner.cleanup()

        self.thread = threading.Thread(target=asyncio.run, args=(main(),), name="fsm-sweep-live", daemon=True)
        self.thread.start()
        ready.wait()
        if "error" in result:
            self.thread.join()
            raise result["error"]
        return int(result["port"])

    def close(self) -> None:
        if self.loop is not None and self._stopped is not None and self.thread is not None:
            try:
                self.loop.call_soon_threadsafe(self._stopped.set)
            except RuntimeError:  # the loop has ended
                pass
            self.thread.join(timeout=5)

    # -- requests -----------------------------------------------------------------------------------------------------
    async def _list(self, request: web.Request) -> web.StreamResponse:
        return web.Response(text=list_page(self.name), content_type="text/html", charset="utf-8", headers=HEADERS)

    async def _statuses(self, request: web.Request) -> web.StreamResponse:
        return web.Response(text=json.dumps(self.board.snapshot(), allow_nan=False, default=str),
                            content_type="application/json", headers=HEADERS)

    def _server(self, run_id: str) -> LiveServer | web.Response:
        """The page of a run (built on the first visit), or why there is none yet. A finished run's trace is served
        as the trace reader accepts it; a running one's as its worker has written it so far (whole lines), followed
        until its end."""
        server = self.runs.get(run_id)
        if server is not None:
            return server
        row = self.board.snapshot_row(run_id)
        if row is None:
            raise web.HTTPNotFound()
        if row["status"] == "queued":
            return _text(409, f"run {run_id} is queued: its page opens once it runs")
        path = self.board.trace_path(run_id)
        if row["status"] == "running":
            return self._follow(run_id, path)
        if not path.is_file():
            return _text(404, f"run {run_id} has no trace ({path} is missing: it finished in an earlier sweep "
                              "without --live or --trace)")
        from fsm.trace.replay import read_trace

        try:
            trace = read_trace(path)
        except (FsmError, ValueError) as exc:
            return _text(422, f"run {run_id}: its trace cannot be read: {exc}")
        buffer = LineBuffer()
        for line in [trace.header, *trace.inputs, *trace.reloads, *trace.events, *trace.keyframes, *trace.samples,
                     *trace.frames, *([trace.end] if trace.end else [])]:
            buffer.write(json.dumps(line, separators=(",", ":")) + "\n")
        return self._open(run_id, trace.header, buffer)

    def _open(self, run_id: str, header: dict[str, Any], buffer: LineBuffer) -> LiveServer:
        from .page import live_page

        server = LiveServer(Source(buffer), live_page(header, f"{self.name} run {run_id}"), self.token)
        server.begin()
        self.runs[run_id] = server
        return server

    def _follow(self, run_id: str, path: Path) -> LiveServer | web.Response:
        """A running run's page: the whole lines of its trace so far, then what its worker adds (read again every
        :data:`FOLLOW` s, by the reading rule) until the trace's end line, or the run is over and nothing more comes."""
        follower = TraceFollower(path)
        try:
            follower.read()
        except FsmError as exc:
            return _text(409, f"run {run_id} is running; its trace cannot be read yet ({exc}): try again")
        if follower.header is None:
            return _text(409, f"run {run_id} is running and its trace has no line yet (a run on another machine "
                              "with Ray is not seen here): try again in a moment")
        server = self._open(run_id, follower.header, follower.buffer)

        async def follow() -> None:
            while not follower.ended:
                await asyncio.sleep(FOLLOW)
                over = (self.board.snapshot_row(run_id) or {}).get("status") not in ("queued", "running")
                try:
                    grew = follower.read()
                except FsmError:
                    return
                if over and not grew:
                    return

        self.followers.append(asyncio.create_task(follow()))
        return server

    async def _run_page(self, request: web.Request) -> web.StreamResponse:
        run_id = request.match_info["id"]
        if not request.path.endswith("/"):  # the page's stream is next to it: /run/ID/ws
            query = f"?token={self.token}" if self.token else ""
            raise web.HTTPFound(f"/run/{run_id}/{query}")
        server = self._server(run_id)
        if isinstance(server, web.Response):
            return server
        return await server.serve_page(request)

    async def _run_socket(self, request: web.Request) -> web.StreamResponse:
        server = self._server(request.match_info["id"])
        if isinstance(server, web.Response):
            return server
        return await server.serve_socket(request)


class TraceFollower:
    """A trace a worker is writing, read again and again: its whole JSON lines go to ``buffer`` once each."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.buffer = LineBuffer()
        self.header: dict[str, Any] | None = None
        self.offset = 0
        self.ended = False

    def read(self) -> bool:
        """Take the lines added since the last read; whether there were any (an ``FsmError`` if unreadable)."""
        from fsm.loading.reading import read_file_bytes

        data = read_file_bytes(self.path, "trace")
        cut = data.rfind(b"\n") + 1
        if cut <= self.offset:
            return False
        lines = []
        for raw in data[self.offset:cut].splitlines():
            try:
                line = json.loads(raw)
            except ValueError:
                self.ended = True  # a damaged trace: what came before it is shown
                break
            if not isinstance(line, dict):
                self.ended = True
                break
            if self.header is None:
                self.header = line
            self.ended = self.ended or line.get("type") == "end"
            lines.append(json.dumps(line, separators=(",", ":")) + "\n")
        self.offset = cut
        if lines:
            self.buffer.write("".join(lines))
        return bool(lines)


def _text(status: int, text: str) -> web.Response:
    return web.Response(status=status, text=text + "\n", headers=HEADERS)


def list_page(name: str) -> str:
    """The sweep's page: a table of the runs that asks ``runs.json`` for their status twice a second (every string
    from the sweep goes through textContent)."""
    return _LIST.replace("__TITLE__", escape(f"{name} — tral-fsm sweep, live"))


_LIST = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>__TITLE__</title>
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; style-src 'unsafe-inline'; \
script-src 'unsafe-inline'; connect-src 'self'">
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body { font: 14px system-ui, sans-serif; margin: 1.5em; color: #222; }
h1 { font-size: 1.3em; } table { border-collapse: collapse; } th, td { padding: 3px 10px; text-align: left; }
tr:nth-child(even) { background: #f4f4f4; } .queued { color: #888; } .running { color: #b60; font-weight: bold; }
.done { color: #162; } .failed { color: #b00; font-weight: bold; } #summary { margin: .6em 0 1em; }
</style></head>
<body><h1 id="title"></h1><div id="summary">connecting…</div>
<table><thead><tr><th>run</th><th>parameters</th><th>world</th><th>seed</th><th>status</th><th>outcome</th>
<th>seconds</th><th>page</th></tr></thead><tbody id="runs"></tbody></table>
<script>
(function () {
  "use strict";
  var token = new URLSearchParams(location.search).get("token") || "";
  var query = token ? "?token=" + encodeURIComponent(token) : "";
  var seen = -1;
  document.getElementById("title").textContent = document.title;
  function cell(tr, text, cls) {
    var td = document.createElement("td"); td.textContent = text == null ? "" : String(text);
    if (cls) td.className = cls;
    tr.appendChild(td); return td;
  }
  function show(data) {
    var c = data.counts, body = document.getElementById("runs");
    document.getElementById("summary").textContent = data.runs.length + " runs: " + c.done + " done, " + c.failed +
      " failed, " + c.running + " running, " + c.queued + " queued" + (data.finished ? " (the sweep has ended)" : "");
    document.body.dataset.finished = String(data.finished);
    body.textContent = "";
    data.runs.forEach(function (r) {
      var tr = document.createElement("tr"); tr.dataset.run = r.id; tr.dataset.status = r.status;
      cell(tr, r.id);
      cell(tr, Object.keys(r.params).map(function (k) { return k + "=" + JSON.stringify(r.params[k]); }).join(" "));
      cell(tr, r.world); cell(tr, r.seed); cell(tr, r.status + (r.before ? " (before)" : ""), r.status);
      cell(tr, r.status === "failed" ? r.error : r.outcome); cell(tr, r.seconds);
      var td = cell(tr, "");
      if (r.status === "running" || ((r.status === "done" || r.status === "failed") && r.trace)) {
        var a = document.createElement("a"); a.className = "open";
        a.textContent = r.status === "running" ? "watch" : "open";
        a.href = "run/" + encodeURIComponent(r.id) + "/" + query; td.appendChild(a);
      }
      body.appendChild(tr);
    });
  }
  function poll() {
    fetch("runs.json" + query, {cache: "no-store"}).then(function (res) {
      if (!res.ok) throw new Error(res.status);
      return res.json();
    }).then(function (data) {
      if (data.version !== seen) { seen = data.version; show(data); }
      setTimeout(poll, 500);
    }).catch(function () {
      document.getElementById("summary").textContent = "the sweep's server has ended; what is shown stays";
    });
  }
  poll();
})();
</script></body></html>
"""
