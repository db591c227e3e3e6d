"""``fsmctl report TRACE -o run.html``: the offline HTML report of a run's trace (``fsmctl run --trace``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from fsm.model.errors import UsageError

from ..runs.args import read_trace_arg
from .common import EXIT_OK, Subcommands, default_output


def register(sub: Subcommands) -> None:
    p = sub.add_parser("report", help="write the HTML report of a run's trace (statechart, lanes, map, plots)",
                       description="Write one self-contained HTML file that replays a trace written by "
                                   "`fsmctl run --trace`: the statechart with the active path, state lanes, the map, "
                                   "sensor and command plots, camera frames, variables. It works offline.")
    p.add_argument("trace", metavar="TRACE.jsonl", help="the trace")
    p.add_argument("-o", "--output", metavar="OUT.html",
                   help="where to write (default: TRACE with the suffix .html; '-' for standard output)")
    live = p.add_argument_group("the live page")
    live.add_argument("--live", action="store_true",
                      help="serve the trace in the live debugger's page (as `fsmctl run --live` shows a run) and print "
                           "its URL, until Ctrl-C; needs the 'live' extra")
    live.add_argument("--port", type=int, default=None, metavar="N", help="port of the page (default 8765; 0: any)")
    live.add_argument("--host", default=None, metavar="HOST", help="address to listen on (default 127.0.0.1)")
    live.add_argument("--no-token", action="store_true", help="no token in the URL (this machine only)")
    p.set_defaults(func=cmd_report)


def write_from_trace(name: str, out: str, option: str, suffix: str, command: str, render: Any,
                     binary: bool = False) -> int:
    """Read the trace ``name`` and write ``render(trace)`` to ``out`` (checked before the trace is read, written
    atomically, nothing left behind on error); the trace's warnings go to standard error."""
    from ..files import Outputs

    outputs = Outputs()
    output = outputs.add(out, option, binary=binary, suffix=suffix)
    assert output is not None
    output.classify()
    try:
        outputs.open([name] if name != "-" else [])
        trace = read_trace_arg(name)
        for warning in trace.warnings:
            print(f"fsmctl {command}: warning: {warning}", file=sys.stderr)
        output.write(render(trace))
        outputs.commit()
    finally:
        outputs.discard()
    return EXIT_OK


def cmd_report(args: argparse.Namespace) -> int:
    from ..report import report_html

    if args.live:
        from ..live.runner import serve_trace

        if args.output:
            raise UsageError("-o writes the offline report; --live serves the trace instead: choose one")
        return serve_trace(args.trace, args)

    out = default_output(Path(args.trace), ".html") if args.output is None else args.output
    return write_from_trace(args.trace, out, "-o", ".html", "report", report_html)
