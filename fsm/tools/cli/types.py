"""``fsmctl types``: every registered type with its parameters, defaults and one-line doc."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from fsm.model.errors import printable

from .common import EXIT_FAIL, EXIT_OK, Subcommands, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("types", help="list the registered state, transition and condition types with their parameters")
    p.add_argument("names", nargs="*", metavar="TYPE", help="only these types")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.set_defaults(func=cmd_types)


def cmd_types(args: argparse.Namespace) -> int:
    registry = registry_from(args)
    rows = [_row(kind, name, cls) for kind, name, cls in registry.every() if not args.names or name in args.names]
    unknown = [n for n in args.names if n not in {r["name"] for r in rows}]
    if unknown:
        hints = [f"{n!r}" + (f" (did you mean {', '.join(close)}?)" if (close := _suggest(registry, n)) else "")
                 for n in unknown]
        print(printable("fsmctl types: unknown type " + ", ".join(hints)), file=sys.stderr)
        return EXIT_FAIL
    if args.format == "json":
        print(json.dumps(rows, indent=2))
    else:
        _print_text(rows, every=not args.names)
    return EXIT_OK


def _print_text(rows: list[dict[str, Any]], every: bool) -> None:
    """The types as text, grouped by kind; after ``every`` type, what all of them take besides."""
    for heading, kind in (("States", "state"), ("Transitions", "transition"), ("Conditions", "condition")):
        group = [r for r in rows if r["kind"] == kind]
        if group:
            print(heading)
            for r in group:
                _print_type(r)
            print()
    if every:
        print("Every transition also takes: from, to, priority (default 0), preempt (default false), guard, set.")
        print("Every state also takes: set (on_enter, on_exit).")
        print("Every element may carry: description, layout. A condition is written in a guard or a Condition "
              "transition.")


def _row(kind: str, name: str, cls: Any) -> dict[str, Any]:
    """A type as ``--format json`` gives it: kind, name, the first line of its doc, its parameters."""
    from fsm.model.document import param_info

    doc = (cls.__doc__ or "").strip().splitlines()
    row = {"kind": kind, "name": name, "doc": doc[0] if doc else "", "params": param_info(cls.Params)}
    if kind == "state":
        row["can_finish"] = bool(cls.can_finish)
    return row


def _suggest(registry: Any, name: str) -> list[str]:
    return [close for kind in ("state", "transition", "condition") for close in registry.suggest(name, kind)]


def _print_type(r: dict[str, Any]) -> None:
    """A type and its parameters as text: each with its type, default (or required) and description."""
    finish = " [finishes]" if r.get("can_finish") else ""
    print(printable(f"  {r['name']}{finish}: {r['doc'] or '(no description: add a docstring)'}"))
    for prm in r["params"]:
        # no default ("null" in the JSON listing) is an optional parameter: left out, never written as null
        default = "required" if prm["required"] else "optional" if prm.get("default") is None else \
            f"default {json.dumps(prm.get('default'))}"
        desc = f"  {prm['description']}" if prm["description"] else ""
        print(printable(f"      {prm['name']}: {prm['type']} ({default}){desc}"))
