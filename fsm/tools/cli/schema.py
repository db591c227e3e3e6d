"""``fsmctl schema``: print, write or check the JSON Schema generated from the registered types."""

from __future__ import annotations

import argparse
import json
from typing import Any

from .common import Subcommands, emit_generated, registry_from


def register(sub: Subcommands) -> None:
    p = sub.add_parser("schema", help="print the JSON Schema of machine documents")
    p.add_argument("-o", "--output", metavar="FILE", help="write it to FILE instead of standard output")
    p.add_argument("--check", metavar="FILE", help="exit 1 if FILE differs from the generated schema")
    p.set_defaults(func=cmd_schema)


def schema_text(registry: Any) -> str:
    from fsm.model.document import json_schema

    return json.dumps(json_schema(registry), indent=2, ensure_ascii=False) + "\n"


def cmd_schema(args: argparse.Namespace) -> int:
    registry = registry_from(args)
    return emit_generated(schema_text(registry), output=args.output, check=args.check, command="fsmctl schema",
                          registry=registry)
