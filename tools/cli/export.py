"""``fsmctl export``: a machine document as a laid-out UMLet diagram that converts back to the same document."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import EXIT_OK, default_output, read_checked, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export", help="write a machine document as a UMLet diagram (.uxf)")
    p.add_argument("file", metavar="FILE.json", help="the machine document (checked first)")
    p.add_argument("-o", "--output", metavar="OUT.uxf",
                   help="where to write (default: FILE with the suffix .uxf, never FILE itself; '-' for standard output)")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from fsm.errors import UsageError

    from ..files import Outputs
    from ..umlet.writer import export

    src = Path(args.file)
    out = args.output or default_output(src, ".uxf")
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
