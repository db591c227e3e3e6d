"""``fsmctl``: validate, run and inspect machine documents.

Exit status: 0 success, 1 a document or run failed (one located message per problem, no traceback),
2 command-line usage error. Each command lives in its own module of this package with a ``register``
function; heavy modules load only inside the commands that need them.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any

from fsm.errors import DiagramError, FsmError, RegistrationError, UsageError

from .common import EXIT_FAIL, EXIT_OK, EXIT_USAGE, version

#: The command modules, in the order ``fsmctl --help`` lists them.
COMMANDS = ("validate", "run", "types", "schema", "convert", "export", "palette", "graph", "detect")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> Any:  # argparse's usage errors: exit status 2, no traceback
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fsmctl", description="Validate, run and inspect tral-fsm machine documents.")
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import MODULE to register its state/transition types (repeatable)")
    parser.add_argument("--version", action="version", version="%(prog)s " + version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"fsmctl: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except DiagramError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return EXIT_FAIL
    except RegistrationError as exc:
        print(f"fsmctl: plugin error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except FsmError as exc:
        print(f"fsmctl: error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except BrokenPipeError:
        return EXIT_OK


