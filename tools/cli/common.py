"""What the commands share: exit statuses, argument types, the registry with plugins, generated files."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from fsm.errors import FsmError, RegistrationError, UsageError

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


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


def version() -> str:
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
    from ..files import write_atomic

    check_writable(output)
    write_atomic(output, text)
    return EXIT_OK


