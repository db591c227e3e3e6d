"""``fsmctl``: validate, run and inspect machine documents.

Exit status: 0 success, 1 a document or run failed (one located message per problem, no traceback),
2 command-line usage error, 130 a run stopped by Ctrl-C or SIGTERM (its outputs are still written). Each
command lives in its own module of this package with a ``register`` function; heavy modules load only inside
the commands that need them.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any

from fsm.model.errors import DiagramError, FsmError, RegistrationError, UsageError, printable

from .common import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, version

#: The command modules, in the order ``fsmctl --help`` lists them.
COMMANDS = ("validate", "run", "test", "sweep", "report", "types", "schema", "convert", "export", "palette", "graph",
            "detect", "sim", "replay", "explain")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> Any:  # argparse's usage errors: exit status 2, no traceback
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fsmctl", description="Validate, run and inspect tral-fsm machine documents.")
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE|FILE.py",
                        help="import MODULE (installed, or in the current folder) or load FILE.py to register its "
                             "state/transition types (repeatable)")
    parser.add_argument("--version", action="version", version="%(prog)s " + version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        return _interrupted()
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"fsmctl: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except DiagramError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return EXIT_FAIL
    except RegistrationError as exc:
        from fsm.loading.registry import PluginError

        print(printable(exc.located()) if isinstance(exc, PluginError) else f"fsmctl: plugin error: {_one_line(exc)}",
              file=sys.stderr)
        return EXIT_FAIL
    except FsmError as exc:
        print(f"fsmctl: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_FAIL
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_OK
    except KeyboardInterrupt:
        return _interrupted()
    except OSError as exc:  # the system refused something the checks could not foresee (a disk that filled up)
        from ..files import os_reason

        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(printable(f"fsmctl: error:{where} {os_reason(exc)}"), file=sys.stderr)
        return EXIT_FAIL
    except MemoryError:
        print("fsmctl: error: out of memory", file=sys.stderr)
        return EXIT_FAIL


def _one_line(exc: BaseException) -> str:
    """The error's message on one line, safe for a terminal (a file name or id cannot drive it)."""
    return printable(" ".join(str(exc).split()))


def _interrupted() -> int:
    print("fsmctl: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _quiet_stdout() -> None:
    """After a reader closed the pipe: point standard output at /dev/null so exiting flushes nothing into it."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass
