"""``fsmctl export``: a machine document as a laid-out UMLet diagram that converts back to the same document."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import EXIT_OK, check_writable, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export", help="write a machine document as a UMLet diagram (.uxf)")
    p.add_argument("file", metavar="FILE.json", help="the machine document (checked first)")
    p.add_argument("-o", "--output", metavar="OUT.uxf",
                   help="where to write (default: FILE with the suffix .uxf; '-' for standard output)")
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from fsm.errors import DiagramError
    from fsm.loader import check, reader_for

    from ..umlet.writer import export

    src = Path(args.file)
    out = args.output or str(src.with_suffix(".uxf"))
    if out != "-":
        check_writable(out)
    registry = registry_from(args)
    _spec, problems = check(str(src), registry=registry)
    errors = [p for p in problems if p.severity == "error"]
    if errors:
        raise DiagramError(errors)
    doc, _source = reader_for(src)(src)
    text = export(doc, registry)
    if out == "-":
        print(text, end="")
    else:
        from ..files import write_atomic

        write_atomic(out, text)
    return EXIT_OK
