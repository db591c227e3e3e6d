"""Problems: the collector every load stage (and a type's hooks) reports into, and how problems get their
line:column.

A stage never raises for a document problem: it adds a located :class:`~fsm.model.errors.Problem` and goes on, so a
user sees every problem of a file at once. The collector remembers which source each problem came from and,
at the end, fills in line and column with one scan per file.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

from fsm.model.errors import Problem

if TYPE_CHECKING:
    from fsm.model.document import Source


def place(problems: list[Problem], locator: Any) -> None:
    """Fill in line, column (and drawing position) of ``problems`` from one call of a source's ``locator``;
    a pointer that is not found takes the position of its nearest enclosing element."""
    if locator is None:
        return
    wanted: set[str] = set()
    for p in problems:
        parts = p.pointer.split("/")
        wanted.update("/".join(parts[:k]) for k in range(1, len(parts) + 1))
    found = locator(wanted)
    for p in problems:
        parts = p.pointer.split("/")
        for k in range(len(parts), 0, -1):
            pos = found.get("/".join(parts[:k]))
            if pos is not None:
                p.line, p.column = pos[0], pos[1]
                if len(pos) > 2 and p.where is None:
                    p.where = pos[2]
                break


class Problems:
    """The problems found so far, each with the source (file) it belongs to."""

    __slots__ = ("items", "_sources", "_seen")

    def __init__(self) -> None:
        self.items: list[Problem] = []
        self._sources: dict[int, Source] = {}
        self._seen: set[tuple[object, ...]] = set()

    def add(self, message: str, source: Source, pointer: str, *, element: str | None = None,
            hint: str | None = None, severity: str = "error", expr_column: int | None = None) -> Problem:
        """Report ``message`` at ``pointer`` in ``source``; returns the problem (a caller may refine it)."""
        problem = Problem(message, source.name, pointer, element=element, hint=hint, severity=severity,
                          expr_column=expr_column)
        self.extend([problem], source)
        return problem

    def extend(self, problems: list[Problem], source: Source | None = None) -> None:
        """Take problems made elsewhere (a reader, pydantic's errors); ``source`` locates them later. A problem
        already reported (the same file, place and message: a part of the document parsed twice, as a sequence
        called twice is) is reported once."""
        for problem in problems:
            key = (problem.file, problem.pointer, problem.line, problem.column, problem.message, problem.severity)
            if key in self._seen:
                continue
            self._seen.add(key)
            if source is not None:
                self._sources[id(problem)] = source
            self.items.append(problem)

    @property
    def has_errors(self) -> bool:
        return any(p.severity == "error" for p in self.items)

    def __len__(self) -> int:
        return len(self.items)

    def located(self) -> list[Problem]:
        """Every problem with line and column filled in where its file's text is known, sorted by place."""
        by_source: dict[int, tuple[Source, list[Problem]]] = {}
        for problem in self.items:
            source = self._sources.get(id(problem))
            if source is None or source.locator is None or problem.line is not None:
                continue
            by_source.setdefault(id(source), (source, []))[1].append(problem)
        for source, problems in by_source.values():
            place(problems, source.locator)
            if source.text is not None:
                for problem in problems:
                    _expression_column(problem, source.text)
        return sorted(self.items, key=lambda p: (p.file or "", p.line or 0, p.column or 0))


_MEMBER_VALUE = re.compile(r'"(?:[^"\\]|\\.)*"\s*:\s*"')


def _expression_column(problem: Problem, text: str) -> None:
    """Move a problem in an expression from its key to the character in the JSON string (when it has no
    escapes before that character, so file columns and expression columns agree)."""
    col = problem.expr_column
    if col is None or problem.line is None or problem.column is None or problem.where is not None:
        return
    lines = text.split("\n", problem.line)
    if len(lines) < problem.line:
        return
    line = lines[problem.line - 1]
    m = _MEMBER_VALUE.match(line, problem.column - 1)
    if m is None:
        return
    value = line[m.end():m.end() + col - 1]
    if "\\" in value or '"' in value or len(value) < col - 1:
        return
    problem.column = m.end() + col


__all__ = ["Problems", "place"]
