"""``fsmctl palette``: the UMLet palette generated from the registry, so it is never stale."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .cli import EXIT_FAIL, EXIT_OK, check_writable, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("palette", help="write the UMLet palette of every registered state and transition type")
    p.add_argument("-o", "--output", metavar="OUT.uxf", default="-",
                   help="where to write (default: standard output); UMLet reads palettes from its palettes/ folder")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 unless OUT is up to date")
    p.set_defaults(func=cmd_palette)


def cmd_palette(args: argparse.Namespace) -> int:
    from .uxf_writer import palette

    text = palette(registry_from(args))
    if args.check:
        try:
            current = Path(args.output).read_text(encoding="utf-8")
        except OSError as exc:
            print(f"{args.output}: error: cannot read: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_FAIL
        if current != text:
            print(f"{args.output}: error: the palette is stale (run: fsmctl palette -o {args.output})",
                  file=sys.stderr)
            return EXIT_FAIL
        return EXIT_OK
    if args.output == "-":
        sys.stdout.write(text)
        return EXIT_OK
    check_writable(args.output)
    from .files import write_atomic

    write_atomic(args.output, text)
    return EXIT_OK
