"""The live server: one page and one WebSocket, on aiohttp, for a run the controller drives in its own thread.

Routes: ``GET /`` (the page) and ``GET /ws`` (the stream), both only with the run's token (``?token=``); every
other path is 404, so nothing but the page is ever served (no file is read from disk after the start). Every
request, with a token or without, must name the server by one of its own addresses (``Host``) and come from none
or one of its own pages (``Origin``): a page elsewhere whose name was made to point at 127.0.0.1 (DNS rebinding)
is refused. Every answer carries a Content-Security-Policy, ``X-Frame-Options`` and ``nosniff``.

The stream to a page: the trace's lines as binary messages (UTF-8 JSON lines, exactly what the trace file gets),
and text messages (JSON) for the rest: ``hello`` (first: the page reads the trace from its start), ``status``
(the controller's snapshot), ``reply`` (to the page's own commands), ``hit``, ``rewound``, ``reset`` (the trace
starts again: after a rewind), and ``bye`` (the server ends: the run is over; a socket that closes without it is
a dropped connection, which the page reconnects). A page that cannot keep up
gets fewer, larger messages: each page is sent at most :data:`MAX_RATE` times a second whatever was written
meanwhile, so a slow page never holds the run back. Commands from a page are JSON text messages
``{"cmd": NAME, "id": N, ...arguments}`` (see :mod:`fsm.debug.control`).
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
import math
import secrets
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from aiohttp import WSMsgType, web
from aiohttp.http_exceptions import HttpProcessingError, LineTooLong

from fsm.debug.control import Controller

from .addresses import allowed_hosts, origin_allowed
from .stream import LineBuffer

#: Messages a page gets per second at most (the page redraws at most as often).
MAX_RATE = 30
#: ... and while the run goes as fast as possible (the page redraws a few times a second then: every message it
#: gets costs the browser processor time that the run's core shares)
FAST_RATE = 5
#: The largest command a page may send (bytes).
MAX_COMMAND = 64 * 1024
#: Commands a page may send.
COMMANDS = ("pause", "resume", "step", "step_transition", "speed", "stop", "break", "unbreak", "input", "rewind",
            "why", "watch", "unwatch", "watched", "watch_values")
#: What every answer carries: no caching, no sniffing, no referrer, nothing loaded from elsewhere.
#: The page's Content-Security-Policy: nothing from elsewhere, no frame around it, its own WebSocket only.
CSP = ("default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'; "
       "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'")
HEADERS = {"Cache-Control": "no-store", "X-Content-Type-Options": "nosniff", "Referrer-Policy": "no-referrer",
           "X-Frame-Options": "DENY", "Content-Security-Policy": CSP}


def dumps(message: dict[str, Any]) -> str:
    """``message`` as JSON for a page: what JSON cannot say (inf, nan: a watch expression's value) as text."""
    try:
        return json.dumps(message, allow_nan=False, default=str)
    except ValueError:
        return json.dumps(_finite(message), allow_nan=False, default=str)


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def new_token() -> str:
    """A random token for the page's URL (128 bits)."""
    return secrets.token_urlsafe(16)


def token_guard(token: Callable[[], str | None], hosts: Callable[[], set[str] | None]) -> Any:
    """An aiohttp middleware, before anything else is looked at: the request's ``Host`` must be one of ``hosts()``
    (the server's own names: another one is a page of another site that made its name point here, DNS
    rebinding), its ``Origin``, if any, one of them too, and its query must carry ``token()`` (``None``: none
    asked); each refused with 403. A path that is not served is a short 404, never aiohttp's page."""

    @web.middleware
    async def guard(request: web.Request, handler: Callable[[web.Request], Any]) -> web.StreamResponse:
        own = hosts()
        if own is None or request.headers.get("Host", "").lower() not in own:
            return web.Response(status=403, text="forbidden: this server answers its own address only; open the URL "
                                "fsmctl printed\n", headers=HEADERS)
        if not origin_allowed(request.headers.get("Origin"), own):
            return web.Response(status=403, text="forbidden: a page of another site\n", headers=HEADERS)
        expected = token()
        if expected is not None:
            given = request.query.get("token", "")
            if not hmac.compare_digest(given.encode("utf-8", "replace"), expected.encode("utf-8")):
                return web.Response(status=403, text="forbidden: open the URL fsmctl printed (it carries the token)\n",
                                    headers=HEADERS)
        try:
            response: web.StreamResponse = await handler(request)
        except web.HTTPNotFound:
            return web.Response(status=404, text="not found: this server serves its pages and nothing else\n",
                                headers=HEADERS)
        except web.HTTPMethodNotAllowed:
            return web.Response(status=405, text="method not allowed\n", headers=HEADERS)
        return response

    return guard


class _OneLine(logging.Filter):
    """aiohttp's report of a request it could not read (a line or a header over the limit, bytes that are no
    HTTP): one line per request, without the traceback."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if not isinstance(exc, HttpProcessingError):
            return True
        if isinstance(exc, LineTooLong):
            what = "a request line or header longer than the limit (8190 bytes)"
        else:
            what = (str(exc.message).split(":")[0] or type(exc).__name__)[:100]
        text = f"live: refused a request it cannot read: {what} (answered {exc.code})"
        record.msg, record.args, record.exc_info, record.exc_text = text, (), None, None
        return True


def quiet_bad_requests() -> None:
    """Make aiohttp report a request it cannot read in one line (see :class:`_OneLine`), printed to standard error
    (once per process)."""
    logger = logging.getLogger("aiohttp.server")
    if any(isinstance(f, _OneLine) for f in logger.filters):
        return
    logger.addFilter(_OneLine())
    if not logger.handlers:
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("%(message)s"))
        logger.addHandler(handler)
        logger.propagate = False


@dataclass
class Source:
    """What the pages watch: the trace being written (a rewind starts a new one) and the controller driving the
    run (``None`` for a finished run's trace, shown as it is)."""

    buffer: LineBuffer
    controller: Controller | None = None


@dataclass
class _Client:
    ws: web.WebSocketResponse
    number: int
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    outbox: list[dict[str, Any]] = field(default_factory=list)
    #: what this page has been sent: the trace buffer and how far into it, the last status's number
    buffer: LineBuffer | None = None
    cursor: int = 0
    seq: int = -1
    sender: asyncio.Task[None] | None = None


class LiveServer:
    """Serves ``page`` and the stream of ``source`` with ``token`` (``None``: no token asked, loopback only)."""

    def __init__(self, source: Source, page: str, token: str | None) -> None:
        self.source = source
        self.page = page
        self.token = token
        self.clients: dict[int, _Client] = {}
        self.app = web.Application(client_max_size=MAX_COMMAND)
        self.app.router.add_get("/", self.serve_page)
        self.app.router.add_get("/ws", self.serve_socket)
        #: the Host values answered (known once listening; a sweep's page checks its own)
        self.hosts: set[str] | None = None
        self.app.middlewares.append(token_guard(lambda: self.token, lambda: self.hosts))
        self.runner: web.AppRunner | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake: asyncio.Event | None = None
        self._waking = False
        self._numbers = 0
        self._pump: asyncio.Task[None] | None = None
        self._closing = False

    # -- starting and stopping ----------------------------------------------------------------------------------------
    async def start(self, host: str, port: int) -> int:
        """Listen on ``host``:``port`` (0: any free port); the port listened on. ``OSError`` when it cannot."""
        quiet_bad_requests()
        self.runner = web.AppRunner(self.app, access_log=None, handle_signals=False)
        await self.runner.setup()
        site = web.TCPSite(self.runner, host, port, reuse_address=False)
        try:
            await site.start()
        except BaseException:
            await self.runner.cleanup()
            raise
        addresses = self.runner.addresses
        bound = addresses[0][1] if addresses else port
        self.hosts = allowed_hosts(host, int(bound))
        self.begin()
        return int(bound)

    def begin(self) -> None:
        """Start streaming (called by :meth:`start`; alone when another app routes its requests here, as the
        sweep's page does with :meth:`serve_page` and :meth:`serve_socket`). In the event loop that serves."""
        self._loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        controller = self.source.controller
        if controller is not None:
            controller.notify = self._notify
        self._pump = asyncio.create_task(self._pump_loop())

    async def close(self, why: str = "the server has stopped") -> None:
        """Tell every page that the run has ended and ``why`` (a ``bye``: a socket that merely closes is a page's
        cue to reconnect), close their sockets and stop listening."""
        controller = self.source.controller
        if controller is not None:
            controller.notify = None
        self._closing = True
        if self._pump is not None:  # ended (a cancel that wait_for swallows still ends it: the flag)
            self._pump.cancel()
            await asyncio.wait({self._pump}, timeout=1.0)
        bye = json.dumps({"kind": "bye", "why": why})
        for client in list(self.clients.values()):
            if client.sender is not None:  # this page's last lines and status come from here, then the bye
                client.sender.cancel()
                await asyncio.wait({client.sender}, timeout=1.0)
            try:
                await asyncio.wait_for(self._flush(client), 1.0)
                await asyncio.wait_for(client.ws.send_str(bye), 1.0)
            except (ConnectionError, RuntimeError, asyncio.TimeoutError):
                pass  # that page has gone already
            await client.ws.close(message=b"the run has ended")
        if self.runner is not None:
            await self.runner.cleanup()

    # -- requests -----------------------------------------------------------------------------------------------------
    async def serve_page(self, request: web.Request) -> web.StreamResponse:
        """The page (its token already checked)."""
        return web.Response(text=self.page, content_type="text/html", charset="utf-8", headers=HEADERS)

    async def serve_socket(self, request: web.Request) -> web.StreamResponse:
        """The page's stream (its token, Host and Origin already checked; an Origin of another site than the Host
        it came to is refused here too)."""
        if not origin_allowed(request.headers.get("Origin"), {request.host.lower()}):
            return web.Response(status=403, text="forbidden: a page of another site\n", headers=HEADERS)
        # no per-message deflate: the stream is mostly the trace's lines, which compressing cost the server's thread
        # (the run's core, under the interpreter's lock) about half a microsecond a tick and the page as much again
        # to inflate, to save bandwidth that loopback and a local network do not lack
        ws = web.WebSocketResponse(heartbeat=30, max_msg_size=MAX_COMMAND, compress=False)
        await ws.prepare(request)
        self._numbers += 1
        client = _Client(ws, self._numbers)
        self.clients[client.number] = client
        if self._wake is not None:
            self._wake.set()  # the pump looks at the run at its page rate again
        sender = client.sender = asyncio.create_task(self._send_loop(client))
        try:
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    self._command(client, msg.data)
                elif msg.type == WSMsgType.ERROR:
                    break
        finally:
            self.clients.pop(client.number, None)
            sender.cancel()
        return ws

    def _command(self, client: _Client, text: str) -> None:
        """A page's command, checked for shape here and for sense by the controller (between ticks)."""
        try:
            data = json.loads(text)
        except ValueError:
            data = None
        if not isinstance(data, dict) or not isinstance(data.get("cmd"), str):
            self._tell(client, {"kind": "reply", "id": None, "ok": False,
                                "error": 'a command is a JSON object {"cmd": NAME, ...}'})
            return
        name, number = data.pop("cmd"), data.pop("id", None)
        controller = self.source.controller
        if controller is None:
            self._tell(client, {"kind": "reply", "id": number, "command": name, "ok": False,
                                "error": "this page shows a finished run's trace: there is no run to steer"})
            return
        if name not in COMMANDS:
            self._tell(client, {"kind": "reply", "id": number, "command": name, "ok": False,
                                "error": f"unknown command (one of {', '.join(COMMANDS)})"})
            return
        controller.send(name, data, (client.number, number))

    def _tell(self, client: _Client, message: dict[str, Any]) -> None:
        client.outbox.append(message)
        client.wake.set()

    # -- the stream ---------------------------------------------------------------------------------------------------
    def _notify(self) -> None:
        """From the run's thread: something new to send (coalesced: one wake-up pending at a time). A running run's
        progress alone wakes nobody: the pump looks at :data:`MAX_RATE` times a second anyway, and waking this
        thread after every chunk of ticks (hundreds of times a second) takes the interpreter from the run each time;
        a pause, a reply or a notice wakes the pages at once."""
        if self._waking or not self.clients or self._loop is None:
            return
        controller = self.source.controller
        if controller is not None and not getattr(controller, "urgent", True):  # (a stand-in may not say)
            return
        self._waking = True
        try:
            self._loop.call_soon_threadsafe(self._woken)
        except RuntimeError:  # the loop has closed: the server is stopping
            pass

    def _woken(self) -> None:
        self._waking = False
        if self._wake is not None:
            self._wake.set()

    async def _pump_loop(self) -> None:
        """Hand the controller's messages to the pages they are for, and wake the pages' senders."""
        assert self._wake is not None
        while not self._closing:
            try:
                # no page, or a running run (whose pages' senders look at it at their own rate): once a second, else
                # MAX_RATE times (what the run said meanwhile is for nobody, or picked up by the senders)
                await asyncio.wait_for(self._wake.wait(), 1 / MAX_RATE if self.clients and not _running(
                    self.source.controller) else 1.0)
            except asyncio.TimeoutError:
                pass
            self._wake.clear()
            self._dispatch()
            for client in self.clients.values():
                client.wake.set()

    def _dispatch(self) -> None:
        """Move the controller's messages (replies, notices) to the outboxes of the pages they are for."""
        controller = self.source.controller
        if controller is None:
            return
        while controller.messages:
            message = controller.messages.popleft()
            target = message.get("id")
            if message.get("kind") == "reply" and isinstance(target, tuple):
                client = self.clients.get(target[0])
                if client is not None:
                    client.outbox.append({**message, "id": target[1]})
            else:
                for client in self.clients.values():
                    client.outbox.append(message)

    async def _send_loop(self, client: _Client) -> None:
        """Send a page what is new, at most :data:`MAX_RATE` times a second: the trace's new lines, the messages
        for it, the status when it changed."""
        loop = asyncio.get_running_loop()
        ws = client.ws
        try:
            await ws.send_str(json.dumps({"kind": "hello", "live": self.source.controller is not None}))
            while not ws.closed:
                started = loop.time()
                snapshot = await self._flush(client)
                await asyncio.sleep(_pause_before_next(snapshot, loop.time() - started))
                if snapshot is not None and snapshot.get("state") == "running":
                    client.wake.clear()  # a running run: looked at again at the page's rate, woken or not
                    continue
                await client.wake.wait()
                client.wake.clear()
        except (ConnectionError, asyncio.CancelledError, RuntimeError):
            return


    async def _flush(self, client: _Client) -> dict[str, Any] | None:
        """Send ``client`` what it has not had: the trace's new lines, the messages for it, the status if it
        changed. Gives the status looked at (``None`` for a finished run's trace)."""
        ws = client.ws
        controller = self.source.controller
        snapshot = controller.snapshot if controller is not None else None
        # what the run said before this status goes first (a step's reply before the status after it): the sender
        # no longer waits between two sends while the run is paused, so it does not wait for the pump
        self._dispatch()
        current = self.source.buffer
        if current is not client.buffer:
            if client.buffer is not None:  # a rewind: the page starts again, and is told the status again after
                client.seq = -1
                await ws.send_str('{"kind":"reset"}')
            client.buffer, client.cursor = current, 0
        text, client.cursor = current.since(client.cursor)
        if text:
            await ws.send_bytes(text.encode("utf-8"))
        outbox, client.outbox = client.outbox, []
        for message in _batched(outbox):
            await ws.send_str(dumps(message))
        if snapshot is not None and snapshot.get("seq") != client.seq:
            client.seq = snapshot["seq"]
            await ws.send_str(json.dumps({"kind": "status", **snapshot}, allow_nan=False, default=str))
        return snapshot


def _batched(messages: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``messages`` with each run of ``watched`` ones (one per status published: hundreds a second at full speed)
    sent as one, rows in order: one encoding and one message per send, not per chunk of ticks."""
    out: list[dict[str, Any]] = []
    for message in messages:
        if message.get("kind") == "watched" and out and out[-1].get("kind") == "watched":
            out[-1] = {"kind": "watched", "rows": out[-1]["rows"] + message["rows"]}
        else:
            out.append(message)
    return out


def _running(controller: Controller | None) -> bool:
    return controller is not None and controller.snapshot.get("state") == "running"


def _pause_before_next(snapshot: dict[str, Any] | None, spent: float) -> float:
    """How long a page's sender waits before it looks again: a running run's pages get at most :data:`MAX_RATE`
    messages a second (:data:`FAST_RATE` at full speed); a paused or ended run's, at once: what it sends then is
    the answer to a click (a step, a rewind), and a click is answered as fast as the page can draw."""
    if snapshot is None or snapshot.get("state") != "running":
        return 0.0
    fast = snapshot.get("speed") is None
    return max(0.0, 1 / (FAST_RATE if fast else MAX_RATE) - spent)
