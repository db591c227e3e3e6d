"""``fsmctl run ... --live``: the run in its own thread under a :class:`~fsm.debug.control.Controller`, the page served
from the main thread's event loop, and on the way out (the page's Stop, or Ctrl-C) the outputs the user named,
written as ``fsmctl run`` writes them (the trace is the run's last fork: it replays to the same end)."""

from __future__ import annotations

import argparse
import errno
import json
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fsm.model.errors import FsmError, UsageError, printable

from ..files import shown_path
from .addresses import is_loopback, usable_urls
from .stream import LineBuffer, TraceFile

#: The port the page is served on by default.
DEFAULT_PORT = 8765


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``fsmctl run``'s live options."""
    live = p.add_argument_group("the live debugger (a page in the browser: pause, step, breakpoints, injection, "
                                "rewind)")
    live.add_argument("--live", action="store_true",
                      help="serve the run's live page and print its URL; the run goes on until the page's Stop or "
                           "Ctrl-C (needs the 'live' extra: pip install 'tral-fsm[live]')")
    live.add_argument("--port", type=parse_port, default=None, metavar="N",
                      help=f"port of the live page (default {DEFAULT_PORT}; 0: any free port)")
    live.add_argument("--host", default=None, metavar="HOST",
                      help="address to listen on (default 127.0.0.1, this machine only; another address lets other "
                           "machines in, with the URL's token)")
    live.add_argument("--no-token", action="store_true",
                      help="serve the page without a token in its URL (refused unless --host is this machine)")
    live.add_argument("--speed", type=_speed, default=1.0, metavar="X|max",
                      help="pace of the live run: X times real time (0.01 to 10000, default 1) or 'max'")
    live.add_argument("--paused", action="store_true", help="start the live run paused at tick 0")
    live.add_argument("--rewind-horizon", type=parse_horizon, default=None, metavar="SECONDS",
                      help="how far back (simulated seconds) the live run can be rewound: its snapshots, inputs and "
                           "reloads are kept this long, so memory stays flat however long it runs (default 1800, "
                           "30 minutes; 'inf': back to the start, memory grows with the run; 0: no rewind)")
    live.add_argument("--reload", action=argparse.BooleanOptionalAction, default=None,
                      help="hot reload: when the machine's file (or an include) changes on disk, check it; show its "
                           "errors in the page, or swap the machine at the next tick keeping the variables and the "
                           "active states (default on: a live run drives the simulated car)")


def parse_port(text: str) -> int:
    """A port given on the command line (0 to 65535), for argparse."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"a port is 0 to 65535, got {value}")
    return value


def parse_horizon(text: str) -> float:
    """A rewind horizon given on the command line: seconds of simulated time, 0 or more, or ``inf``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds of simulated time or 'inf', got {text!r}") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"a rewind horizon is 0 or more seconds (or 'inf'), got {text}")
    return value


def _speed(text: str) -> float | None:
    if text.strip().lower() in ("max", "inf", "fastest"):
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or 'max', got {text!r}") from None
    if not 0.01 <= value <= 10000:
        raise argparse.ArgumentTypeError(f"a speed is 0.01 to 10000 x real time, or 'max'; got {text}")
    return value


def check_usage(args: argparse.Namespace) -> None:
    """What ``--live`` cannot be combined with, and the live options without ``--live`` (usage errors)."""
    if not args.live:
        given = [o for o, v in (("--port", args.port), ("--host", args.host), ("--no-token", args.no_token or None),
                                ("--paused", args.paused or None),
                                ("--rewind-horizon", getattr(args, "rewind_horizon", None)),
                                ("--reload" if args.reload else "--no-reload", args.reload)) if v is not None]
        if given:
            raise UsageError(f"{given[0]} is an option of the live debugger: add --live")
        return
    if args.video:
        raise UsageError("--video cannot be combined with --live (a rewind would cut the video); write the trace "
                         "with --trace and make the video with a run without --live")
    if args.trace == "-" or args.summary == "-":
        raise UsageError("with --live, standard output shows the page's URL: name a file for --trace and --summary")
    check_page_options(args)


def check_page_options(args: argparse.Namespace) -> None:
    """What any ``--live`` page needs (``fsmctl run --live`` and ``fsmctl sweep --live``): a token where other
    machines can reach it (a usage error), and aiohttp (a missing extra: exit status 1, as the other extras')."""
    if args.no_token and not is_loopback(args.host or "127.0.0.1"):
        raise UsageError(f"--no-token with --host {args.host}: a page other machines can reach needs its token; "
                         "drop --no-token (the URL printed carries it)")
    try:
        import aiohttp  # noqa: F401
    except ImportError:
        raise FsmError("--live needs aiohttp: pip install 'tral-fsm[live]'") from None


def announce(host: str, port: int, token: str | None, out: Any) -> None:
    """Print the page's URL (``live: URL``; each interface's when ``host`` is all of them: ``0.0.0.0`` cannot be
    opened), and, when other machines can reach it, a warning saying so to standard error."""
    suffix = f"?token={token}" if token else ""
    for url in usable_urls(host, port, suffix):
        print(f"live: {url}", file=out, flush=True)
    if not is_loopback(host):
        print(f"fsmctl: warning: --host {host}: the page is reachable from other machines on the network; anyone "
              "with the URL (it carries the token) can steer the run. Use --host 127.0.0.1 to keep it on this "
              "machine", file=sys.stderr, flush=True)


class LiveRun:
    """One live run: builds its sessions (the first, and each rewind's before the first snapshot), keeps the trace
    being written (in a temporary file the run owns: :class:`~fsm.tools.live.stream.TraceFile`)."""

    def __init__(self, make_session: Callable[[], Any], make_recorder: Callable[[Any, LineBuffer], Any]) -> None:
        from .server import Source

        self.make_session = make_session
        self.make_recorder = make_recorder
        self.source = Source(LineBuffer())
        self.recorder: Any = None
        self.session = self.build()

    def build(self) -> Any:
        """A fresh session of the run, recording into a fresh trace file (which the pages switch to)."""
        session = self.make_session()
        buffer = TraceFile()
        self.recorder = session.record(self.make_recorder(session, buffer))
        self.source.buffer = buffer
        self.session = session
        return session

    def restored(self, session: Any) -> None:
        """A rewind restored a snapshot of ``session``: the pages switch to the trace it writes from now on."""
        self.session = session
        self.recorder = session.recorder
        self.source.buffer = session.recorder.out


def serve(source: Any, page: Callable[[dict[str, Any]], str], *, host: str, port: int, token: str | None,
          stop: Callable[[], bool], out: Any, watcher: Any = None) -> None:
    """Serve the live page of ``source`` until the page's Stop or ``stop()`` (Ctrl-C): listen first (a port in use
    is an error before the run starts), print the URL to ``out``, run the controller's loop (if any: a finished
    trace has none) in its own thread."""
    import asyncio  # here, not at the top: fsmctl's parser takes its options from this module (add_arguments)

    controller = source.controller
    header = json.loads(source.buffer.first_line())
    html = page(header)

    async def main() -> None:
        from .server import LiveServer

        server = LiveServer(source, html, token)
        try:
            bound = await server.start(host, port)
        except OSError as exc:
            raise listen_error(exc, host, port) from None
        announce(host, bound, token, out)
        until = "the run goes on until Stop in the page or Ctrl-C here" if controller else "serving the trace " \
                "until Ctrl-C here"
        print(f"live: {until}", file=out, flush=True)
        halt = threading.Event()
        thread = None
        watching = None
        if watcher is not None and controller is not None:
            def redraw(loaded: Any) -> None:  # the page served from now on draws the new machine
                server.page = page({**header, "machine": loaded.info.get("document")})

            def redrawn(document: dict[str, Any] | None) -> None:  # a rewind undid reloads: the machine now
                server.page = page(header if document is None else {**header, "machine": document})

            controller.machine_changed = redrawn
            watching = asyncio.create_task(watcher.run(controller, redraw))
            print(f"live: watching {', '.join(shown_path(f) for f in watcher.files)} (hot reload; --no-reload to "
                  "turn it off)", file=out, flush=True)
        if controller is not None:
            thread = threading.Thread(target=controller.loop, kwargs={"stop": lambda: halt.is_set() or stop()},
                                      name="fsm-live-run", daemon=True)
            thread.start()
        try:
            while (thread is None or thread.is_alive()) and not stop():
                await asyncio.sleep(0.05)
        finally:
            if watching is not None:
                watching.cancel()
            halt.set()
            if thread is not None:
                await asyncio.get_running_loop().run_in_executor(None, thread.join)
            if controller is not None and controller.quit:
                why = "the run was stopped from the page"
            elif controller is not None and stop():
                why = "the run was stopped by Ctrl-C where fsmctl runs"
            else:
                why = "the server was stopped by Ctrl-C where fsmctl runs"
            await server.close(why)

    asyncio.run(main())


def serve_trace(name: str, args: argparse.Namespace) -> int:
    """``fsmctl report TRACE --live``: a finished run's trace in the live page (the same page, nothing to steer),
    until Ctrl-C. What is served is what the trace reader accepted (a damaged tail is left out, with its warning)."""
    from ..runs.args import EXIT_INTERRUPTED, EXIT_OK, Interrupts, read_trace_arg
    from .page import live_page
    from .server import Source, new_token

    if args.no_token and not is_loopback(args.host or "127.0.0.1"):
        raise UsageError(f"--no-token with --host {args.host}: a page other machines can reach needs its token")
    trace = read_trace_arg(name)
    for warning in trace.warnings:
        print(printable(f"fsmctl report: warning: {warning}"), file=sys.stderr)
    buffer = LineBuffer()
    for line in [trace.header, *trace.inputs, *trace.reloads, *trace.events, *trace.keyframes, *trace.samples,
                 *trace.frames, *([trace.end] if trace.end else [])]:
        buffer.write(json.dumps(line, separators=(",", ":")) + "\n")
    interrupts = Interrupts()
    with interrupts:
        serve(Source(buffer), lambda header: live_page(header, Path(name).name), host=args.host or "127.0.0.1",
              port=args.port if args.port is not None else DEFAULT_PORT, token=None if args.no_token else new_token(),
              stop=interrupts.stop, out=sys.stdout)
    return int(EXIT_INTERRUPTED if interrupts.interrupted else EXIT_OK)


def listen_error(exc: OSError, host: str, port: int) -> FsmError:
    """Why the page cannot be served on ``host``:``port``, said as the flag to change."""
    if exc.errno == errno.EADDRINUSE:
        return FsmError(f"--port {port}: port {port} on {host} is in use (another program listens there); choose "
                        "another with --port N, or --port 0 for any free one")
    if exc.errno == errno.EADDRNOTAVAIL or isinstance(exc, OSError) and exc.errno in (errno.EINVAL, -2, -3, -5):
        return FsmError(f"--host {host}: no address of this machine; use 127.0.0.1, or an address it has")
    if exc.errno == errno.EACCES:
        return FsmError(f"--port {port}: not allowed to listen on port {port} (ports below 1024 need root); "
                        "choose one above 1024")
    return FsmError(f"--host {host} --port {port}: cannot listen there ({printable(exc.strerror or str(exc))})")


def run_live(args: argparse.Namespace, file: str, make_session: Callable[[], Any],
             make_recorder: Callable[[Any, LineBuffer], Any], signals: list[str], outputs: Any, trace_out: Any,
             summary_out: Any, plot_out: Any, report_out: Any, watcher: Any = None) -> int:
    """The live run of ``fsmctl run --live`` (see the module docstring); its exit status."""
    from fsm.debug.control import DEFAULT_HORIZON, Controller
    from fsm.model.errors import StateRuntimeError

    from ..runs.args import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, Interrupts
    from .page import live_page
    from .server import new_token

    run = LiveRun(make_session, make_recorder)
    out = sys.stdout
    try:
        run.session.start()
    except StateRuntimeError:
        pass  # the controller says so in the page, where the run can be rewound
    horizon = args.rewind_horizon if getattr(args, "rewind_horizon", None) is not None else DEFAULT_HORIZON
    controller = Controller(run.session, factory=run.build, speed=args.speed, paused=args.paused, signals=signals,
                            fresh=make_session, horizon=horizon, on_restore=run.restored)
    run.source.controller = controller
    host = args.host or "127.0.0.1"
    port = args.port if args.port is not None else DEFAULT_PORT
    token = None if args.no_token else new_token()
    interrupts = Interrupts()
    with interrupts:
        serve(run.source, lambda header: live_page(header, Path(file).name), host=host, port=port, token=token,
              stop=interrupts.stop, out=out, watcher=watcher)
        interrupts.writing = True
        session = controller.session
        interrupted = interrupts.interrupted
        result = session.summary()
        if controller.error is not None:
            result["error"] = {"message": controller.error}
        if interrupted:
            result["interrupted"] = True
        session.finish(**({"interrupted": True} if interrupted else {}),
                       **({"error": result["error"]} if "error" in result else {}))
        text = run.source.buffer.text()
        if trace_out is not None:
            trace_out.write(text)
        if report_out is not None:
            from fsm.trace.replay import parse_trace

            from ..report import report_html

            report_out.write(report_html(parse_trace(text.encode("utf-8"), args.trace or file)))
        if plot_out is not None and session.driver is not None:
            from fsm.sim.loop import Simulation
            from fsm.sim.render import plot_png

            if isinstance(session.driver, Simulation):
                plot_out.write(plot_png(session.driver))
        if summary_out is not None:
            summary_out.write(json.dumps(result, indent=2) + "\n")
        outputs.commit()
    if not args.quiet:
        from ..recording import end_lines

        recorder = session.recorder
        print("\n".join(end_lines(file, session.machine, recorder, interrupted=interrupted)), file=out)
    if interrupted:
        return int(EXIT_INTERRUPTED)
    return int(EXIT_FAIL if controller.error is not None else EXIT_OK)
