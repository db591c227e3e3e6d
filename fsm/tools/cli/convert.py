"""``fsmctl convert``: a UMLet diagram (``.uxf``, or TRAL's xml2json JSON of one) -> a checked machine document."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fsm.model.errors import DiagramError, Problem

from .common import EXIT_FAIL, EXIT_OK, Subcommands, default_output, registry_from

if TYPE_CHECKING:
    from ..files import Outputs


def register(sub: Subcommands) -> None:
    p = sub.add_parser("convert", help="convert a UMLet diagram (.uxf) to a machine document (.json)")
    p.add_argument("file", metavar="IN.uxf", help="the diagram (.uxf, or the JSON xml2json made of one)")
    p.add_argument("-o", "--output", metavar="OUT.json",
                   help="where to write (default: IN with the suffix .json; '-' for standard output)")
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 unless OUT already holds what IN converts to (for CI)")
    p.add_argument("--machine", metavar="NAME", help="the machine to convert when the diagram holds several")
    p.add_argument("--format", choices=("text", "github"), default="text",
                   help="how to print problems: text (default) or github (Actions annotations)")
    p.set_defaults(func=cmd_convert)


def cmd_convert(args: argparse.Namespace) -> int:
    from ..files import Outputs

    src = Path(args.file)
    out = args.output
    if out is None:
        out = default_output(src, ".json")
    outputs = Outputs()
    if not args.check:
        outputs.add(out, "-o")
        outputs.items[0].classify()
        outputs.open([src])  # same file as the diagram (an xml2json .json next to itself), unwritable folder
    try:
        return _convert(args, src, out, outputs)
    finally:
        outputs.discard()


def _convert(args: argparse.Namespace, src: Path, out: str, outputs: Outputs) -> int:
    from ..umlet.convert import convert_checked, dumps

    registry = registry_from(args)
    palette = _palette_problems(src, registry)
    if palette is not None:  # the palette is a sheet of templates: checked against the registry, never converted
        if not args.check:
            palette = palette or [Problem("this is the UMLet palette (a template of every type), not a machine: "
                                          "there is nothing to convert", str(src), line=1, column=1,
                                          hint="draw a machine with its templates and convert that diagram")]
        report(palette, args.format)
        return EXIT_FAIL if palette else EXIT_OK
    try:
        doc, warnings = convert_checked(src, args.machine, registry)
    except DiagramError as exc:
        report(exc.problems, args.format)
        return EXIT_FAIL
    report(warnings, args.format)
    text = dumps(doc)
    if args.check:
        return check_output(src, out, doc, args.format)
    outputs.items[0].write(text)
    outputs.commit()
    return EXIT_OK


def _palette_problems(src: Path, registry: object) -> list[Problem] | None:
    """``None`` unless ``src`` is the palette; then what is wrong with it (``[]``: it is what ``fsmctl palette``
    generates)."""
    from fsm.loading.reading import read_file_bytes

    from ..umlet.palette import palette_problems

    if src.suffix.lower() != ".uxf":
        return None
    try:
        raw = read_file_bytes(src, "diagram")
    except DiagramError:
        return None  # convert_checked reports why it cannot be read
    return palette_problems(raw, str(src), registry)


def check_output(src: Path, out: str, doc: dict[str, Any], fmt: str) -> int:
    if out == "-":
        report([Problem("--check needs a file to compare with, not '-'", str(src))], fmt)
        return EXIT_FAIL
    hint = f"run: fsmctl convert {src} -o {out}"
    from fsm.loading.reading import read_file_bytes

    if not Path(out).exists() and not Path(out).is_symlink():
        report([Problem(f"{out} does not exist, but {src} converts to a machine", out, hint=hint)], fmt)
        return EXIT_FAIL
    try:
        committed = json.loads(read_file_bytes(Path(out), "committed").decode("utf-8"))
    except DiagramError as exc:
        report(exc.problems, fmt)
        return EXIT_FAIL
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        report([Problem(f"cannot read the committed document: {exc}", out, hint=hint)], fmt)
        return EXIT_FAIL
    if committed != doc:
        report([Problem(f"out of date: differs from what {src} converts to ({first_difference(committed, doc)})",
                        out, line=1, column=1, hint=hint)], fmt)
        return EXIT_FAIL
    print(f"{out}: up to date with {src}")
    return EXIT_OK


def first_difference(a: object, b: object, path: str = "") -> str:
    """Where the committed document ``a`` first differs from what the diagram converts to (``b``), in words."""
    found = None
    if isinstance(a, dict) and isinstance(b, dict):
        found = _dict_difference(a, b, path)
    elif isinstance(a, list) and isinstance(b, list):
        found = _list_difference(a, b, path)
    return found or f"{path or '/'} differs"


def _dict_difference(a: dict[Any, Any], b: dict[Any, Any], path: str) -> str | None:
    for key in list(a) + [k for k in b if k not in a]:
        if key not in a:
            return f"{path}/{key} is missing"
        if key not in b:
            return f"{path}/{key} is not in the diagram"
        if a[key] != b[key]:
            return first_difference(a[key], b[key], f"{path}/{key}")
    return None


def _list_difference(a: list[Any], b: list[Any], path: str) -> str | None:
    for i, (x, y) in enumerate(zip(a, b, strict=False)):
        if x != y:
            return first_difference(x, y, f"{path}/{i}")
    return f"{path or '/'} has {len(a)} items, the diagram {len(b)}" if len(a) != len(b) else None


def report(problems: list[Problem], fmt: str) -> None:
    if fmt == "github":
        from .validate import github_annotation

        for p in problems:
            print(github_annotation(p))
        return
    for p in problems:
        print(p, file=sys.stderr if p.severity == "error" else sys.stdout)
