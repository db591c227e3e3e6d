"""``fsmctl palette``: the UMLet palette generated from the registry, so it is never stale."""

from __future__ import annotations

import argparse

from .common import Subcommands, emit_generated, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("palette", help="write the UMLet palette of every registered state and transition type")
    p.add_argument("-o", "--output", metavar="OUT.uxf", default="-",
                   help="where to write (default: standard output); UMLet reads palettes from its palettes/ folder")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 unless OUT is up to date")
    p.set_defaults(func=cmd_palette)


def cmd_palette(args: argparse.Namespace) -> int:
    from ..umlet.palette import palette

    registry = registry_from(args)
    text = palette(registry)
    return emit_generated(text, output=args.output, check=args.output if args.check else None,
                          command="fsmctl palette", registry=registry)
