"""``fsmctl graph``: draw a machine with its nesting as Mermaid, Graphviz DOT or SVG (no Graphviz needed)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .common import EXIT_OK, check_writable, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("graph", help="draw a machine (.json or .uxf) as mermaid, dot or svg")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--format", choices=("mermaid", "dot", "svg"), default="mermaid")
    p.add_argument("-o", "--output", metavar="OUT", default="-", help="where to write (default: standard output)")
    p.add_argument("--machine", metavar="NAME", help="for a .uxf holding several machines: which one")
    p.set_defaults(func=cmd_graph)


def cmd_graph(args: argparse.Namespace) -> int:
    from fsm.errors import DiagramError
    from fsm.loader import check, reader_for

    from .. import graph

    src = Path(args.file)
    if args.output != "-":
        check_writable(args.output)
    registry = registry_from(args)
    if src.suffix.lower() == ".uxf" or args.machine:
        from ..umlet.convert import convert_checked

        doc, _ = convert_checked(src, args.machine, registry)
    else:
        _spec, problems = check(str(src), registry=registry)
        errors = [p for p in problems if p.severity == "error"]
        if errors:
            raise DiagramError(errors)
        doc, _source = reader_for(src)(src)
    if args.format == "svg":
        text = graph.svg(doc, base=src)  # includes are drawn, read relative to the file
    else:
        text = {"mermaid": graph.mermaid, "dot": graph.dot}[args.format](doc)
    if args.output == "-":
        sys.stdout.write(text)
    else:
        from ..files import write_atomic

        write_atomic(args.output, text)
    return EXIT_OK
