"""Diagram -> checked machine document: the UMLet reader plus the loader's checks, located in the diagram.

Used by ``fsmctl convert`` (and ``export``/``graph`` on ``.uxf`` input). Loader problems point into the
converted document; here they get the ``.uxf`` line:column and the diagram coordinates of their element.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fsm.loading.loader import check as check_file
from fsm.model.errors import DiagramError, Problem

from . import reader

if TYPE_CHECKING:
    from .reader import Converted


def convert_checked(path: Path, machine: str | None = None, registry: Any = None,
                    check: bool = True) -> tuple[dict[str, Any], list[Problem]]:
    """The machine document of ``path`` (one machine, or the one named ``machine``) and its problems.

    Raises :class:`DiagramError` when the diagram cannot be read or its document has errors. The checks
    are the loader's own (``fsm.loading.loader.check`` through the ``.uxf`` reader hook), so they locate problems
    in the ``.uxf`` file; here they also get the diagram coordinates of their element.
    """
    conv = reader.convert_file(path)
    index = select(conv, machine)
    doc = conv.machines[index]
    if not check:
        return doc, []
    token = reader.PRESELECTED.set((path.resolve(), conv, index))
    try:
        _spec, problems = check_file(str(path), registry=registry)
    finally:
        reader.PRESELECTED.reset(token)
    for p in problems:
        if p.file == str(path):
            coords = conv.coordinates(index, p.pointer)
            if coords:
                p.element = f"{p.element} ({coords})" if p.element else f"element at {coords}"
    if any(p.severity == "error" for p in problems):
        raise DiagramError(problems)
    return doc, problems


def select(conv: Converted, machine: str | None) -> int:
    if machine is None:
        if len(conv.machines) > 1:
            raise DiagramError([reader.several_machines_problem(conv)])
        return 0
    if machine in conv.names:
        return conv.names.index(machine)
    names = ", ".join(f"'{n}'" for n in conv.names)
    raise DiagramError([Problem(f"no machine named '{machine}' in the diagram", conv.diagram.name, line=1,
                                column=1, hint=f"its machines: {names}")])


def dumps(doc: dict[str, Any]) -> str:
    """The JSON text ``convert`` writes: two-space indent, UTF-8 kept readable, a final newline."""
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"
