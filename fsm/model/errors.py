"""Errors a user can cause, each with a location, and the error of a state that fails at run time."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

#: What a terminal may act on: C0 controls, DEL, C1 controls (``\x9b`` starts a sequence as ``ESC [`` does), lone
#: surrogates (which cannot be encoded), and the characters that reorder or break what follows them on screen
#: (the bidirectional marks, embeddings, overrides and isolates of "Trojan Source", and the line and paragraph
#: separators); the second form keeps line feeds and tabs of multi-line output.
_REORDERING = "\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069\u2028\u2029"
_CONTROL = re.compile(f"[\x00-\x1f\x7f-\x9f\ud800-\udfff{_REORDERING}]")
_CONTROL_KEEP_LINES = re.compile(f"[\x00-\x08\x0b-\x1f\x7f-\x9f\ud800-\udfff{_REORDERING}]")


def escape_char(char: str) -> str:
    """One character as Python writes it in a string literal: ``\\x1b``, ``\\x9b``, ``\\ud800``."""
    code = ord(char)
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text: str, *, multiline: bool = False) -> str:
    """``text`` safe to print on a terminal: control characters are shown as ``\\x1b`` (``\\n`` and ``\\t``
    kept when ``multiline``), so an id or a message from a file cannot clear the screen or set the window title.

    Files keep the real characters (their format escapes them); only what is printed goes through this.
    """
    pattern = _CONTROL_KEEP_LINES if multiline else _CONTROL
    return pattern.sub(lambda m: escape_char(m.group()), text) if pattern.search(text) else text


@dataclass
class Problem:
    """One finding in a document: where it is, which element it concerns, what is wrong and how to fix it.

    ``pointer`` is a JSON pointer into ``file`` (``""`` is the whole document); ``line`` and ``column``
    are 1-based and filled in from the file's text when it is known.
    """

    message: str
    file: str | None = None
    pointer: str = ""
    line: int | None = None
    column: int | None = None
    element: str | None = None
    hint: str | None = None
    severity: str = "error"
    #: Where in a drawing, for documents converted from diagrams (``"x=480, y=460"``).
    where: str | None = None
    #: For a problem inside an expression: the 1-based column in the expression's text, so the line:column
    #: can point at the character in the file rather than at the key (see ``fsm.model.problems``).
    expr_column: int | None = field(default=None, repr=False, compare=False)

    @property
    def location(self) -> str:
        """``file:line:column`` (or as much of it as is known) followed by the JSON pointer."""
        parts = [self.file or "<document>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        loc = ":".join(parts)
        if self.where:
            loc += f" ({self.where})"
        if self.pointer:
            loc += f" at {self.pointer}"
        return loc

    @property
    def text(self) -> str:
        """The problem in one line, with the real characters of ids and messages (for files: JUnit, JSON)."""
        text = f"{self.location}: {self.severity}: "
        if self.element:
            text += f"{self.element}: "
        text += self.message
        if self.hint:
            text += f" ({self.hint})"
        return text

    def __str__(self) -> str:
        """The problem as printed: :attr:`text` with control characters escaped (see :func:`printable`)."""
        return printable(self.text)

    def to_dict(self) -> dict[str, object]:
        return {
            "severity": self.severity,
            "file": self.file,
            "line": self.line,
            "column": self.column,
            "pointer": self.pointer,
            "where": self.where,
            "element": self.element,
            "message": self.message,
            "hint": self.hint,
        }


class FsmError(Exception):
    """Base class of every error tral-fsm raises on purpose."""


@dataclass
class DiagramError(FsmError):
    """A document (JSON or diagram) that cannot become a machine; carries every problem found, not only the first."""

    problems: list[Problem] = field(default_factory=list)

    def __post_init__(self) -> None:
        super().__init__(self.__str__())

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "error"]

    def __str__(self) -> str:
        return "\n".join(str(p) for p in self.problems)


class RegistrationError(FsmError):
    """A state or transition class that cannot be registered (duplicate name, missing Params, ...)."""


class StateRuntimeError(FsmError):
    """An exception raised by user code inside a state or transition while the machine ran.

    Names the state path, the phase (``on_enter``, ``tick``, ``on_exit``, ``check``, ``action``) and the tick.
    """

    @classmethod
    def of(cls, state: Any, phase: str, ctx: Any, exc: BaseException) -> StateRuntimeError:
        """``exc`` raised in ``phase`` of ``state`` (an error already located is passed on as it is)."""
        if isinstance(exc, StateRuntimeError):
            return exc
        return cls(state.path, phase, ctx.tick, ctx.now, exc)

    def __init__(self, path: str, phase: str, tick: int, time: float, cause: BaseException) -> None:
        self.path = path
        self.phase = phase
        self.tick = tick
        self.time = time
        self.cause = cause
        self.file, self.line = user_frame(cause)
        where = f" (at {self.file}:{self.line})" if self.file else ""
        super().__init__(
            f"state '{path}' raised {type(cause).__name__} in {phase} at tick {tick} "
            f"(t={time:.4f} s): {cause}{where}"
        )


#: The folders of the engine that calls user code (a frame there is never the user's).
_ENGINE = ("runtime", "session", "sequencer", "loading", "model", "debug", "trace")


def user_frame(exc: BaseException) -> tuple[str | None, int | None]:
    """Where user code raised ``exc``: of the frames below the engine's last one (the hook it called first), the
    innermost outside the standard library, installed libraries and tral-fsm (its car, its built-in types), else
    the innermost outside the libraries, else that hook's; ``(None, None)`` when no frame is the user's."""
    import os
    import sysconfig
    import traceback

    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    engine = tuple(os.path.join(here, name) + os.sep for name in _ENGINE)
    frames = traceback.extract_tb(exc.__traceback__)
    last = max((i for i, f in enumerate(frames) if os.path.abspath(f.filename).startswith(engine)), default=-1)
    user = frames[last + 1:]
    if not user:
        return None, None
    libraries = tuple({sysconfig.get_paths()[k] + os.sep for k in ("stdlib", "platstdlib", "purelib", "platlib")})
    own = [f for f in user if not os.path.abspath(f.filename).startswith(libraries) and f.filename[:1] != "<"]
    outside = [f for f in own if not os.path.abspath(f.filename).startswith(here + os.sep)]  # not tral-fsm's car
    chosen = (outside or own or user)[-1 if (outside or own) else 0]
    return chosen.filename, chosen.lineno


class UsageError(FsmError):
    """A command-line usage error (exit status 2)."""


#: Set to 1 (or give ``fsmctl --traceback``) to print the whole traceback of any failure.
TRACEBACK_ENV = "FSM_TRACEBACK"


def traceback_wanted() -> bool:
    """Whether the user asked for whole tracebacks (``FSM_TRACEBACK=1``, which ``fsmctl --traceback`` sets)."""
    import os

    return os.environ.get(TRACEBACK_ENV, "") not in ("", "0")


def print_traceback(exc: BaseException, stream: Any = None) -> None:
    """The whole traceback of ``exc`` on ``stream`` (standard error), with the exceptions it was raised from, also
    those a ``raise ... from None`` hid: the user code's own frames are what this is asked for."""
    import sys
    import traceback

    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        seen.add(id(link))
        link.__suppress_context__ = False
        link = link.__cause__ or link.__context__
    traceback.print_exception(exc, file=stream or sys.stderr)
