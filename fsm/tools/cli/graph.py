"""``fsmctl graph``: draw a machine with its nesting as Mermaid, Graphviz DOT or SVG (no Graphviz needed)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import EXIT_OK, Subcommands, read_checked, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("graph", help="draw a machine (.json or .uxf) as mermaid, dot or svg")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--format", choices=("mermaid", "dot", "svg"), default="mermaid")
    p.add_argument("-o", "--output", metavar="OUT", default="-", help="where to write (default: standard output)")
    p.add_argument("--machine", metavar="NAME", help="for a .uxf holding several machines: which one")
    p.set_defaults(func=cmd_graph)


def cmd_graph(args: argparse.Namespace) -> int:
    from .. import graph
    from ..files import Outputs

    src = Path(args.file)
    outputs = Outputs()
    outputs.add(args.output, "-o")
    outputs.items[0].classify()
    try:
        registry = registry_from(args)
        if src.suffix.lower() == ".uxf" or args.machine:
            from ..umlet.convert import convert_checked

            doc, _ = convert_checked(src, args.machine, registry)  # reads the diagram once
            inputs = [str(src)]
        else:
            doc, inputs = read_checked(src, registry)
        outputs.open(inputs)
        if args.format == "svg":
            text = graph.svg(doc, base=src)  # includes are drawn, read relative to the file
        else:
            text = {"mermaid": graph.mermaid, "dot": graph.dot}[args.format](doc)
        outputs.items[0].write(text)
        outputs.commit()
    finally:
        outputs.discard()
    return EXIT_OK
