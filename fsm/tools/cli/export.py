"""``fsmctl export``: a machine document as a laid-out UMLet diagram that converts back to the same document."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .common import EXIT_OK, Subcommands, default_output, read_checked, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("export", help="write a machine document as a UMLet diagram (.uxf), or a trace as MCAP",
                       description="Write a machine document as a laid-out UMLet diagram; with --mcap, write a run's "
                                   "trace (fsmctl run --trace) as an MCAP file for Foxglove, Lichtblick, PlotJuggler "
                                   "and Rerun.")
    p.add_argument("file", metavar="FILE.json|TRACE.jsonl", help="the machine document (checked first), or the trace "
                                                                 "with --mcap")
    p.add_argument("-o", "--output", metavar="OUT.uxf",
                   help="where to write (default: FILE with the suffix .uxf, never FILE itself; '-' for standard "
                        "output)")
    p.add_argument("--mcap", metavar="OUT.mcap", help="FILE is a trace: write it as MCAP to OUT.mcap")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from fsm.model.errors import UsageError

    from ..files import Outputs
    from ..umlet.writer import export

    if args.mcap is not None:
        return _export_mcap(args)
    src = Path(args.file)
    # a trace without --mcap, or MCAP asked for with -o: read as a document, a trace fails with "invalid JSON:
    # Extra data" on its second line
    if str(args.output or "").lower().endswith(".mcap"):
        trace = src if src.suffix.lower() == ".jsonl" else "TRACE.jsonl"
        raise UsageError(f"export {src} -o {args.output}: -o writes a UMLet diagram; MCAP is written from a run's "
                         f"trace with --mcap (fsmctl export {trace} --mcap {args.output})")
    if src.suffix.lower() == ".jsonl":
        raise UsageError(f"export {src}: a run's trace is written as MCAP, named with --mcap (fsmctl export {src} "
                         f"--mcap {src.with_suffix('.mcap').name}); without it, export reads a machine document")
    out = default_output(src, ".uxf") if args.output is None else args.output
    if args.output is None and src.suffix.lower() == ".uxf":
        raise UsageError(f"export {src}: the default output is {src} itself, the diagram being read; "
                         "give -o OUT.uxf")
    outputs = Outputs()
    outputs.add(out, "-o")
    outputs.items[0].classify()
    try:
        registry = registry_from(args)
        document, inputs = read_checked(src, registry)
        outputs.open(inputs)
        text = export(document, registry)
        outputs.items[0].write(text)
        outputs.commit()
    finally:
        outputs.discard()
    return EXIT_OK


def _export_mcap(args: argparse.Namespace) -> int:
    import io

    from fsm.model.errors import UsageError

    from ..recording.mcap import write_mcap
    from .report import write_from_trace

    if args.output is not None:
        raise UsageError("export --mcap OUT.mcap names the output; -o is for the UMLet export")

    def render(trace: Any) -> bytes:
        buffer = io.BytesIO()
        write_mcap(trace, buffer)
        return buffer.getvalue()

    return write_from_trace(args.file, args.mcap, "--mcap", ".mcap", "export", render, binary=True)
