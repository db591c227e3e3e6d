"""``fsmctl validate``: check documents; text, JSON or GitHub Actions annotations."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fsm.errors import Problem

from .common import EXIT_FAIL, EXIT_OK, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="check machine documents and world files (exit 1 if any is invalid)")
    p.add_argument("files", nargs="+", metavar="FILE")
    p.add_argument("--format", choices=("text", "json", "github"), default="text",
                   help="text (default), json, or github (GitHub Actions ::error annotations)")
    p.add_argument("--strict", action="store_true", help="treat warnings (unreachable states) as errors")
    p.add_argument("-q", "--quiet", action="store_true", help="print problems only")
    p.set_defaults(func=cmd_validate)


def cmd_validate(args: argparse.Namespace) -> int:
    from fsm.loader import check

    registry = registry_from(args)
    results = []
    for file in args.files:
        if is_world_file(file):
            problems = check_world(file)
        else:
            _spec, problems = check(file, registry=registry)
        if args.strict:
            for p in problems:
                p.severity = "error"
        valid = not any(p.severity == "error" for p in problems)
        results.append((file, valid, problems))
    invalid = sum(1 for _, valid, _ in results if not valid)
    if args.format == "json":
        print(json.dumps([{"file": f, "valid": v, "problems": [p.to_dict() for p in ps]} for f, v, ps in results],
                         indent=2))
    elif args.format == "github":
        for _, _, problems in results:
            for p in problems:
                print(github_annotation(p))
    else:
        for file, valid, problems in results:
            for p in problems:
                print(p, file=sys.stderr if p.severity == "error" else sys.stdout)
            if not args.quiet:
                errors = sum(1 for p in problems if p.severity == "error")
                warnings = len(problems) - errors
                state = "ok" if valid else f"{errors} error{'s' * (errors != 1)}"
                if warnings:
                    state += f", {warnings} warning{'s' * (warnings != 1)}"
                print(f"{file}: {state}")
    return EXIT_FAIL if invalid else EXIT_OK


def is_world_file(file: str) -> bool:
    """A JSON object with walls (or a world ``$schema``) and no states is a world for the simulated car."""
    path = Path(file)
    if path.suffix.lower() != ".json":
        return False
    try:
        data = json.loads(path.read_bytes())
    except (OSError, ValueError, RecursionError):
        return False  # the machine check reports it
    if not isinstance(data, dict) or {"states", "initial", "root"} & data.keys():
        return False
    schema = data.get("$schema")
    return "walls" in data or (isinstance(schema, str) and schema.endswith("world.schema.json"))


def check_world(file: str) -> list[Problem]:
    from fsm.errors import DiagramError
    from fsm.sim.world import load_world

    try:
        load_world(file)
    except DiagramError as exc:
        return exc.problems
    return []


def github_annotation(p: Problem) -> str:
    """A GitHub Actions workflow command (``::error file=...,line=...::message``)."""

    def prop(text: str) -> str:
        return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A").replace(":", "%3A").replace(",", "%2C")

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
