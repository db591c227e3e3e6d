"""``fsmctl``: validate, run and inspect machine documents.

Exit status: 0 success, 1 a document or run failed (one located message per problem, no traceback),
2 command-line usage error. Each command lives in its own ``cmd_*`` module with a ``register``
function; heavy modules load only inside the commands that need them.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fsm.errors import DiagramError, FsmError, RegistrationError, UsageError

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2

#: The command modules, in the order ``fsmctl --help`` lists them.
COMMANDS = ("cmd_validate", "cmd_run", "cmd_types", "cmd_schema", "cmd_convert", "cmd_export", "cmd_palette", "cmd_graph")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> Any:  # argparse's usage errors: exit status 2, no traceback
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fsmctl", description="Validate, run and inspect tral-fsm machine documents.")
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import MODULE to register its state/transition types (repeatable)")
    parser.add_argument("--version", action="version", version="%(prog)s " + _version())
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


# -- shared helpers -----------------------------------------------------------------------------------
def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
    return value


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def signal_arg(text: str) -> tuple[str, bool, float]:
    """``NAME@T`` or ``NAME=0@T`` -> (name, value, time)."""
    name_value, sep, when = text.rpartition("@")
    if not sep or not name_value:
        raise argparse.ArgumentTypeError(f"expected NAME@T or NAME=0@T, got {text!r}")
    name, eq, value_text = name_value.partition("=")
    values = {"1": True, "true": True, "on": True, "high": True, "0": False, "false": False, "off": False, "low": False}
    if eq and value_text.lower() not in values:
        raise argparse.ArgumentTypeError(f"signal value must be 1/0/true/false, got {value_text!r}")
    try:
        at = float(when)
    except ValueError:
        raise argparse.ArgumentTypeError(f"signal time must be a number of seconds, got {when!r}") from None
    if not (at >= 0 and at != float("inf")) or not name:
        raise argparse.ArgumentTypeError(f"expected NAME@T with T >= 0, got {text!r}")
    return name, values[value_text.lower()] if eq else True, at


def _version() -> str:
    from fsm import __version__

    return __version__


def registry_from(args: argparse.Namespace) -> Any:
    """The registry with built-ins, installed plugins and the ``--plugin`` modules."""
    from fsm.registry import default_registry

    try:
        return default_registry(tuple(args.plugin))
    except ModuleNotFoundError as exc:
        raise UsageError(f"--plugin: no module named {exc.name!r}") from None
    except RegistrationError:
        raise
    except Exception as exc:  # a plugin that fails to import is the plugin's error, reported in one line
        raise FsmError(f"--plugin: importing failed: {type(exc).__name__}: {exc}") from None


def check_writable(path: str) -> None:
    directory = Path(path).parent
    if str(directory) and not directory.is_dir():
        raise UsageError(f"cannot write {path}: folder {directory} does not exist")


def emit_generated(text: str, *, output: str | None, check: str | None, command: str) -> int:
    """Write generated ``text`` to ``output`` (standard output for ``None`` or ``-``), or with ``check``
    compare it with that file and exit 1 when the file is stale, naming ``command`` to regenerate it."""
    if check:
        try:
            current = Path(check).read_text(encoding="utf-8")
        except OSError as exc:
            print(f"{check}: error: cannot read: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_FAIL
        if current != text:
            print(f"{check}: error: stale; regenerate it with `{command} -o {check}`", file=sys.stderr)
            return EXIT_FAIL
        return EXIT_OK
    if not output or output == "-":
        sys.stdout.write(text)
        return EXIT_OK
    from .files import write_atomic

    check_writable(output)
    write_atomic(output, text)
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
