"""``fsmctl watch TRACE EXPR... [--from TICK] [--to TICK] [--csv]``: watch expressions' values after every tick of a
run, from its trace, by re-simulation.

The run is built again from its trace's header and recorded inputs, as ``fsmctl explain`` does
(:func:`fsm.tools.cli.explain.rebuild`), and run to the range's last tick; the expressions (the document's language:
variables, ``signal_NAME``, ``car_NAME``) are evaluated after each tick of the range
(:func:`fsm.debug.resim.rows_between`, what the live page's watch plot is given). The re-simulation is checked
against the trace: the states active at the last tick must be those the trace says, or the command says where they
part.
"""

from __future__ import annotations

import argparse
import csv
import sys
from typing import Any

from fsm.model.errors import FsmError

from .common import EXIT_OK, Subcommands


def register(sub: Subcommands) -> None:
    p = sub.add_parser("watch", help="print watch expressions' values after every tick of a run, by re-simulating "
                                     "its trace",
                       description="For each tick from --from to --to of a run's trace: the values of the "
                                   "expressions (the document's expression language: variables, signal_NAME, "
                                   "car_NAME readings) after that tick, computed by re-simulating the run from its "
                                   "trace, as fsmctl explain and the live page's watch plot do. A table, or CSV.")
    p.add_argument("trace", metavar="TRACE.jsonl", help="the trace (fsmctl run --trace; '-' for standard input)")
    p.add_argument("exprs", nargs="+", metavar="EXPR", help="an expression, e.g. car_front or 'n * 2 > 3'")
    p.add_argument("--from", dest="first", type=int, default=0, metavar="TICK", help="the first tick (default 0: the "
                                                                                    "start)")
    p.add_argument("--to", dest="last", type=int, default=None, metavar="TICK", help="the last tick (default: the "
                                                                                   "trace's last)")
    p.add_argument("--csv", action="store_true",
                   help="print CSV (tick, time, one column per expression; numbers with every digit)")
    p.set_defaults(func=cmd_watch)


def watch_trace(trace: Any, texts: list[str], first: int, last: int | None) -> tuple[float, Any]:
    """The run's tick (s) and the :class:`~fsm.debug.resim.Rows` of ``texts`` for ticks ``first`` to ``last`` of
    ``trace`` (default: its last tick), by re-simulation, checked against the trace."""
    from fsm.debug.breakpoints import BreakpointError
    from fsm.debug.resim import Rows, rows_between
    from fsm.debug.watch import compile_watch, row_function

    from .explain import check_active, rebuild, signal_names

    end = trace.last_tick
    last = end if last is None else last
    for flag, tick in (("--from", first), ("--to", last)):
        if not 0 <= tick <= end:
            raise FsmError(f"{flag} {tick}: the trace's ticks are 0 to {end}; choose one of them")
    if first > last:
        raise FsmError(f"--from {first} is after --to {last}")
    session = rebuild(trace)
    session.start()
    signals = signal_names(trace, session)
    watches = []
    for k, text in enumerate(texts, 1):
        try:
            watches.append(compile_watch(text, session.machine, signals))
        except BreakpointError as exc:
            raise FsmError(f"expression {k} {text!r}, column {exc.column}: {exc.message}") from None
    rows = rows_between(session, row_function(watches), first, last, Rows(first, last))
    if rows.stopped is not None:
        raise FsmError(f"{trace.name}: the re-simulated run stopped short of tick {last}: {rows.stopped}; it is not "
                       "the run the trace recorded (a world or machine file changed since?)")
    check_active(trace, session, last, "a world or machine file changed since?")
    return session.dt, rows


def _shown(value: Any, exact: bool = False) -> str:
    """A value as the table shows it (6 significant digits), or as CSV keeps it (``exact``: every digit)."""
    if isinstance(value, float):
        return repr(value) if exact else f"{value:.6g}"
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def cmd_watch(args: argparse.Namespace) -> int:
    from fsm.model.errors import printable

    from ..runs.args import read_trace_arg

    trace = read_trace_arg(args.trace)
    for warning in trace.warnings:
        print(printable(f"fsmctl watch: warning: {warning}"), file=sys.stderr)
    dt, rows = watch_trace(trace, args.exprs, args.first, args.last)
    table = [[str(tick), f"{tick * dt:.4f}", *(printable(_shown(v, args.csv)) for v in row)]
             for tick, row in zip(rows.ticks, rows.rows, strict=True)]
    head = ["tick", "time", *(printable(text) for text in args.exprs)]
    if args.csv:
        writer = csv.writer(sys.stdout, lineterminator="\n")
        writer.writerow(head)
        writer.writerows(table)
        return EXIT_OK
    widths = [max(len(r[k]) for r in [head, *table]) for k in range(len(head))]
    for r in [head, *table]:
        print("  ".join(cell.rjust(w) for cell, w in zip(r, widths, strict=True)).rstrip())
    return EXIT_OK
