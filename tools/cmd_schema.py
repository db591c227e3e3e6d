"""``fsmctl schema``: print, write or check the JSON Schema generated from the registered types."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from .cli import EXIT_FAIL, EXIT_OK, check_writable, registry_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("schema", help="print the JSON Schema of machine documents")
    p.add_argument("-o", "--output", metavar="FILE", help="write it to FILE instead of standard output")
    p.add_argument("--check", metavar="FILE", help="exit 1 if FILE differs from the generated schema")
    p.set_defaults(func=cmd_schema)


def schema_text(registry: Any) -> str:
    from fsm.document import json_schema

    return json.dumps(json_schema(registry), indent=2, ensure_ascii=False) + "\n"


def cmd_schema(args: argparse.Namespace) -> int:
    text = schema_text(registry_from(args))
    if args.check:
        try:
            current = Path(args.check).read_text(encoding="utf-8")
        except OSError as exc:
            print(f"fsmctl: {args.check}: cannot read: {exc.strerror}", file=sys.stderr)
            return EXIT_FAIL
        if current != text:
            print(f"{args.check}: stale; regenerate it with `fsmctl schema -o {args.check}`", file=sys.stderr)
            return EXIT_FAIL
        return EXIT_OK
    if args.output:
        from .files import write_atomic

        check_writable(args.output)
        write_atomic(args.output, text)
    else:
        sys.stdout.write(text)
    return EXIT_OK
