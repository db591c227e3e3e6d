"""What the commands of a run share about their arguments: exit statuses, the registry with plugins, documents
and traces named on the command line (read by the reading rule), ``--set`` overrides, and Ctrl-C handling."""

from __future__ import annotations

import argparse
import sys
from typing import Any, TypeVar

from fsm.model.errors import DiagramError, UsageError

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
T = TypeVar("T")


def checked(problems: list[Any], result: T | None) -> T:
    """``result`` of a check, narrowed: a located :class:`DiagramError` with the check's errors instead (or, when
    there are none but ``result`` is missing, with all its problems)."""
    errors = [p for p in problems if p.severity == "error"]
    if errors or result is None:
        raise DiagramError(errors or problems)
    return result


def registry_from(args: argparse.Namespace) -> Any:
    """The registry with built-ins, installed plugins and the ``--plugin`` modules or files."""
    from fsm.loading.registry import default_registry

    return default_registry(tuple(args.plugin))


def read_inputs(files: list[str]) -> dict[str, bytes]:
    """``-`` in ``files`` read from standard input, once: ``{"<stdin>": bytes}`` to preload (or ``{}``)."""
    from fsm.loading.reading import STDIN_NAME, read_stdin_bytes

    if "-" not in files:
        return {}
    if sys.stdin is None or (sys.stdin.isatty() if hasattr(sys.stdin, "isatty") else False):
        raise UsageError("'-' reads a document from standard input, but standard input is a terminal; "
                         "pipe a document in (fsmctl validate - < machine.json)")
    return {STDIN_NAME: read_stdin_bytes()}


def input_name(file: str) -> str:
    """The name a file goes by inside the loader: ``<stdin>`` for ``-``."""
    from fsm.loading.reading import STDIN_NAME

    return STDIN_NAME if file == "-" else file


def read_trace_arg(name: str) -> Any:
    """The trace named on the command line, read by the reading rule (a regular file or '-' for standard input,
    at most FSM_MAX_INPUT_BYTES); a located error (exit 1) when it cannot be read or is none."""
    from fsm.loading.reading import STDIN_NAME, read_stdin_bytes
    from fsm.trace.replay import parse_trace, read_trace

    if name == "-":
        return parse_trace(read_stdin_bytes(), STDIN_NAME)
    return read_trace(name)


def apply_overrides(spec: Any, texts: list[str], file: str) -> Any:
    """``--set PATH.PARAM=VALUE``: each checked against the machine (a usage error, exit 2, otherwise)."""
    from ..sweep import overrides as O

    changes = []
    for text in texts:
        try:
            o = O.parse(text, several=False)
            O.check(spec, o)
        except O.OverrideError as exc:  # of the command line, not of the file: a usage error
            raise UsageError(str(exc)) from None
        changes.append(o.one(o.values[0]))
    return O.apply(spec, changes) if changes else spec


class Interrupts:
    """Ctrl-C (SIGINT) and SIGTERM during a run: the first asks the run to stop after the current tick, so
    everything written so far is whole and the outputs are still written; a second one during the run raises
    ``KeyboardInterrupt`` (a state that never returns). While the outputs are written, signals are noted and
    otherwise ignored, up to three: the files are finished first."""

    SIGNALS = ("SIGINT", "SIGTERM")

    def __init__(self) -> None:
        self.received: int | None = None
        self.count = 0
        self.writing = False
        self._old: dict[int, Any] = {}

    def __enter__(self) -> Interrupts:
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            for name in self.SIGNALS:
                num = getattr(signal, name, None)
                if num is not None:
                    self._old[num] = signal.signal(num, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        import signal

        for num, old in self._old.items():
            signal.signal(num, old)
        self._old.clear()

    def _handle(self, signum: int, frame: Any) -> None:
        self.count += 1
        if self.received is None:
            self.received = signum
            return
        if (not self.writing and self.count >= 2) or self.count >= 4:
            raise KeyboardInterrupt

    def stop(self) -> bool:
        return self.received is not None

    @property
    def interrupted(self) -> bool:
        return self.received is not None
