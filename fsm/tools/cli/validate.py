"""``fsmctl validate``: check documents; text, JSON or GitHub Actions annotations."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fsm.model.errors import Problem, printable

from .common import EXIT_FAIL, EXIT_OK, Subcommands, input_name, read_inputs, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("validate", help="check machine documents and world files (exit 1 if any is invalid)")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="machines (.json, .uxf), world files, or the UMLet palette (valid when it is what "
                        "`fsmctl palette` generates); '-' reads one document from standard input")
    p.add_argument("--format", choices=("text", "json", "github"), default="text",
                   help="text (default), json, or github (GitHub Actions ::error annotations)")
    p.add_argument("--strict", action="store_true", help="treat warnings (unreachable states) as errors")
    p.add_argument("-q", "--quiet", action="store_true", help="print problems only")
    p.set_defaults(func=cmd_validate)


#: What one file's check gives: its name, whether it is valid, its problems.
Result = tuple[str, bool, list[Problem]]


def cmd_validate(args: argparse.Namespace) -> int:
    registry = registry_from(args)
    pre = read_inputs(args.files)
    results: list[Result] = []
    for file in args.files:
        name = input_name(file)
        problems = check_one(name, registry, pre)
        if args.strict:
            for p in problems:
                p.severity = "error"
        results.append((name, not any(p.severity == "error" for p in problems), problems))
    _PRINTERS[args.format](results, args.quiet)
    return EXIT_OK if all(valid for _, valid, _ in results) else EXIT_FAIL


def _print_json(results: list[Result], quiet: bool) -> None:
    print(json.dumps([{"file": f, "valid": v, "problems": [p.to_dict() for p in ps]} for f, v, ps in results],
                     indent=2))


def _print_github(results: list[Result], quiet: bool) -> None:
    """GitHub Actions' workflow commands: each problem an annotation on its file and line."""
    for _, _, problems in results:
        for p in problems:
            print(printable(github_annotation(p)))


def _print_text(results: list[Result], quiet: bool) -> None:
    """Each problem (errors on stderr), then each file's count of errors and warnings unless ``quiet``."""
    for file, valid, problems in results:
        for p in problems:
            print(p, file=sys.stderr if p.severity == "error" else sys.stdout)
        if quiet:
            continue
        errors = sum(1 for p in problems if p.severity == "error")
        warnings = len(problems) - errors
        state = "ok" if valid else f"{errors} error{'s' * (errors != 1)}"
        if warnings:
            state += f", {warnings} warning{'s' * (warnings != 1)}"
        print(printable(f"{file}: {state}"))


#: ``--format``: how the results are printed.
_PRINTERS: dict[str, Callable[[list[Result], bool], None]] = {
    "json": _print_json, "github": _print_github, "text": _print_text,
}


def check_one(name: str, registry: Any, pre: dict[str, bytes]) -> list[Problem]:
    """Every problem of one file: a world, a palette or a machine, told apart from the bytes read once."""
    from fsm.loading.loader import check
    from fsm.loading.reading import STDIN_NAME, parse_json_bytes, preloaded, read_file_bytes
    from fsm.model.errors import DiagramError

    path = Path(name)
    with preloaded(pre):
        try:
            raw = read_file_bytes(path)
        except DiagramError as exc:
            return exc.problems
    diagram = path.suffix.lower() == ".uxf" or (name == STDIN_NAME and raw.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] == b"<")
    if path.suffix.lower() == ".json" or (name == STDIN_NAME and not diagram):
        try:
            data, source = parse_json_bytes(raw, name, path.parent)
        except DiagramError as exc:
            return exc.problems
        if is_world(data):
            return check_world(data, name, source.locator)
        if is_scenario(data):
            return check_scenario(name, registry, pre)
        with preloaded({name: (data, source)}):
            return check(name, registry=registry)[1]
    if diagram:
        from ..umlet.palette import palette_problems

        palette = palette_problems(raw, name, registry)
        if palette is not None:
            return palette
    with preloaded({name: raw}):
        return check(name, registry=registry)[1]


def is_world(data: Any) -> bool:
    """A JSON object with walls (or a world ``$schema``) and no states is a world for the simulated car."""
    if not isinstance(data, dict) or {"states", "initial", "root"} & data.keys():
        return False
    schema = data.get("$schema")
    return "walls" in data or (isinstance(schema, str) and schema.endswith("world.schema.json"))


def is_scenario(data: Any) -> bool:
    """A JSON object with ``expect`` (or a scenario ``$schema``) and no states is a scenario for ``fsmctl test``."""
    if not isinstance(data, dict) or {"states", "initial", "root"} & data.keys():
        return False
    schema = data.get("$schema")
    return "expect" in data or (isinstance(schema, str) and schema.endswith("scenario.schema.json"))


def check_scenario(name: str, registry: Any, pre: dict[str, bytes]) -> list[Problem]:
    from fsm.loading.reading import preloaded
    from fsm.model.errors import DiagramError

    from ..scenario.model import load_scenario

    try:
        with preloaded(pre):
            loaded = load_scenario(name)
    except DiagramError as exc:
        return exc.problems
    return loaded.warnings


def is_world_file(file: str) -> bool:
    """Whether ``file`` holds a world (see :func:`is_world`); unreadable files are not worlds."""
    from fsm.loading.reading import parse_json_bytes, read_file_bytes
    from fsm.model.errors import DiagramError

    path = Path(file)
    if path.suffix.lower() != ".json":
        return False
    try:
        data, _source = parse_json_bytes(read_file_bytes(path), file)
    except DiagramError:
        return False
    return is_world(data)


def check_world(data: Any, name: str, locator: Any) -> list[Problem]:
    from fsm.model.errors import DiagramError
    from fsm.sim.world import parse_world

    try:
        parse_world(data, name, locator)
    except DiagramError as exc:
        return exc.problems
    return []


def github_annotation(p: Problem) -> str:
    """A GitHub Actions workflow command (``::error file=...,line=...::message``)."""

    def prop(text: str) -> str:
        return (text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A").replace(":", "%3A")
                .replace(",", "%2C"))

    def data(text: str) -> str:
        return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")

    props = [f"file={prop(p.file or '')}"]
    if p.line is not None:
        props.append(f"line={p.line}")
        if p.column is not None:
            props.append(f"col={p.column}")
    props.append("title=" + prop("fsmctl validate"))
    message = (f"{p.element}: " if p.element else "") + p.message
    if p.where:
        message += f" (diagram {p.where})"
    elif p.pointer:
        message += f" (at {p.pointer})"
    if p.hint:
        message += f"; {p.hint}"
    level = "error" if p.severity == "error" else "warning"
    return f"::{level} {','.join(props)}::{data(message)}"
