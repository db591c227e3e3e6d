"""What the commands share: argument types and generated files; the exit statuses, the registry with plugins, inputs
and Ctrl-C handling come from :mod:`fsm.tools.runs.args` (shared with the live debugger and the ROS 2 bridge)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Protocol

from fsm.model.errors import UsageError

from ..runs.args import EXIT_FAIL as EXIT_FAIL
from ..runs.args import EXIT_INTERRUPTED as EXIT_INTERRUPTED
from ..runs.args import EXIT_OK as EXIT_OK
from ..runs.args import EXIT_USAGE as EXIT_USAGE
from ..runs.args import Interrupts as Interrupts
from ..runs.args import checked
from ..runs.args import input_name as input_name
from ..runs.args import read_inputs as read_inputs
from ..runs.args import registry_from as registry_from


def whole_number(low: int, high: int | None = None, high_text: str | None = None) -> Any:
    """An argparse type: a whole number >= ``low`` (and <= ``high``, shown as ``high_text``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if high is None and value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        if high is not None and not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be between {low} and {high_text or high}, got {text}")
        return value

    return parse


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


def bounded_float(low: float, high: float, what: str) -> Any:
    """An argparse type: a finite number in [low, high] (``--fps``, ``--video-speed``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not (low <= value <= high):
            raise argparse.ArgumentTypeError(f"{what} must be between {low:g} and {high:g}, got {text}")
        return value

    return parse


def default_output(src: Path, suffix: str) -> str:
    """``src`` with another suffix: the default output of convert and export (a usage error without a name)."""
    if not src.name or src.name in (".", ".."):
        raise UsageError(f"{str(src)!r} is not a file name; name the input file (and -o OUT{suffix})")
    return str(src.with_suffix(suffix))


def read_checked(src: Path, registry: Any) -> tuple[dict[str, Any], list[str]]:
    """The machine document of ``src`` (read once: the check takes the bytes already read) and every file it
    was read from (for the same-as-input check of outputs); a :class:`DiagramError` when it has errors."""
    from fsm.loading.loader import check, machine_files
    from fsm.loading.reading import preloaded, reader_for
    from fsm.model.errors import DiagramError

    try:
        document = reader_for(src)(src)
    except DiagramError:
        document = None  # the check below reports why, with the loader's own words
    with preloaded({str(src): document} if document is not None else {}):
        spec, problems = check(str(src), registry=registry)
    return checked(problems, document)[0], machine_files(spec) + [str(src)]


def emit_generated(text: str, *, output: str | None, check: str | None, command: str, registry: Any = None) -> int:
    """Write generated ``text`` to ``output`` (standard output for ``None`` or ``-``), or with ``check``
    compare it with that file and exit 1 when the file is stale, naming ``command`` to regenerate it (and the
    installed plugins of ``registry`` whose types it now holds)."""
    installed = sorted(set(getattr(registry, "installed_by", {}).values()))
    why = (f" (it now has the types of the installed plugin(s) {', '.join(installed)}; FSM_NO_ENTRY_POINTS=1 "
           "leaves them out)") if installed else ""
    if check == "-":
        raise UsageError("--check compares with a file; name it (standard output cannot be compared)")
    if check == "":
        raise UsageError("--check: empty file name")
    if check is not None:
        from fsm.loading.reading import read_file_bytes
        from fsm.model.errors import DiagramError

        try:
            current = read_file_bytes(Path(check), "generated").decode("utf-8", errors="replace")
        except DiagramError as exc:
            for p in exc.problems:
                print(p, file=sys.stderr)
            return EXIT_FAIL
        if current != text:
            print(f"{check}: error: stale; regenerate it with `{command} -o {check}`{why}", file=sys.stderr)
            return EXIT_FAIL
        return EXIT_OK
    from ..files import write_output

    write_output("-" if output is None else output, text, "-o")
    return EXIT_OK


class Subcommands(Protocol):
    """What ``ArgumentParser.add_subparsers()`` returns, as each command's ``register(sub)`` adds its parser to it
    (argparse keeps its class private)."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...
