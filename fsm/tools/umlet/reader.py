"""The UMLet reader: a ``.uxf`` diagram (or TRAL's ``xml2json`` JSON of one) -> machine documents.

``UMLState`` boxes are states (type and parameters under ``--``: ``"type": "FollowWall"`` then ``key=value``
lines, see :mod:`~fsm.tools.umlet.text`), ``UMLSpecialState`` ``type=initial``/``type=final`` the initial marker
and final states, ``Relation`` with an arrowhead the transitions (a dashed arrow from a ``UMLNote`` is the
note's anchor); boxes drawn inside a state box or a ``UMLFrame`` form its sub-machine. A diagram without any
``UMLState`` takes its ``UMLClass`` boxes as the states (students draw machines so); other boxes (class boxes
among state boxes, generic boxes, boxes of zero size) are ignored, and an arrow ending at one names it. Endpoints
attach geometrically (:mod:`fsm.tools.umlet.geometry`). Every element that cannot be placed is reported with its
kind, label, file line:column and diagram coordinates, all at once. Importing this module registers the reader for
``.uxf`` files with the loader.

The work is done in three steps, one module each: :mod:`~fsm.tools.umlet.scene` (what each box is and which
machine level it is drawn in), :mod:`~fsm.tools.umlet.relations` (arrows -> transitions and initial states),
:mod:`~fsm.tools.umlet.documents` (the machine documents). :mod:`fsm.tools.umlet.writer` writes what this reads.

**Parallel states.** A state box of type ``Parallel`` (``"type": "Parallel"``, and ``join=all|any``) holds one
``UMLFrame`` per region. The frame's title is the region's name; inside it are the region's states, its initial
pseudostate and its transitions, drawn like any machine. The regions are ordered by their frames' left
edges (left to right; frames with the same left edge top to bottom). A frame titled ``file=PATH`` that holds
nothing is the region ``{"file": PATH}``, included from another file. Arrows stay inside one region, or end
at the Parallel box's own border; a region is left through a Final state. A ``Parallel`` box with nothing
inside may instead give its regions as ``regions=[...]`` (JSON).

**Machine notes.** A ``UMLNote`` whose first line is ``machine`` holds the keys of the machine it is drawn
in: the diagram's own machine when it is outside every box, else the sub-machine of the composite state or
the region of the frame that holds it. After a ``--`` line come ``key=value`` lines, one per key: ``name``,
``$schema``, ``description`` (texts, written as they are, or as a JSON string) and ``vars`` (a JSON object).
A compartment (after another ``--``) that does not start with one of these keys is free text: the
description. ``elementstyle=wordwrap`` and other style lines are ignored. Example::

    machine
    --
    name=lane_change
    $schema=../fsm/schema/machine.schema.json
    --
    Passes a box standing against the right-hand wall.
    elementstyle=wordwrap

The name of the diagram's machine is the note's ``name=``; without it, the title of the machine's frame; a
diagram without a machine note is named after its file (a diagram holding several machines: each is named
after its frame's title, or its first state). A region is named by its frame's title; an inline
sub-machine only has a name when its note gives one.
"""

from __future__ import annotations

from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fsm.loading.reading import register_reader
from fsm.model.document import Source
from fsm.model.errors import DiagramError, Problem

from .documents import Documents
from .relations import Relations
from .scene import Scene
from .source import RawDiagram, RawElement, describe, parse_raw, read_raw, where

__all__ = ["Converted", "PRESELECTED", "convert_bytes", "convert_file", "convert_raw", "describe", "read_uxf",
           "several_machines_problem", "where"]


# -- results ------------------------------------------------------------------------------------------------
@dataclass
class Converted:
    """What a diagram converts to: one document per machine, with element positions for error messages."""

    diagram: RawDiagram
    machines: list[dict[str, Any]]
    names: list[str]
    #: per machine: JSON pointer -> the raw element it came from
    origins: list[dict[str, RawElement]]

    def locator(self, machine: int) -> Any:
        origins = self.origins[machine]

        def locate(pointers: set[str]) -> dict[str, tuple[int, int, str]]:
            out: dict[str, tuple[int, int, str]] = {}
            for ptr in pointers:
                elem = origins.get(ptr)
                if elem is not None and elem.line is not None:
                    out[ptr] = (elem.line, elem.column or 1, where(elem))
            return out

        return locate

    def coordinates(self, machine: int, pointer: str) -> str | None:
        """Diagram coordinates of the element a pointer falls in (longest known prefix)."""
        origins = self.origins[machine]
        parts = pointer.split("/")
        for k in range(len(parts), 0, -1):
            elem = origins.get("/".join(parts[:k]))
            if elem is not None:
                return where(elem)
        return None


# -- the reader hook ------------------------------------------------------------------------------------------
#: ``(resolved path, Converted, machine index)`` set by ``fsmctl convert --machine`` while the loader checks
#: the diagram it already read, so the reader neither reads it twice nor refuses a multi-machine file.
PRESELECTED: ContextVar[tuple[Path, Any, int] | None] = ContextVar("PRESELECTED", default=None)


def read_uxf(path: Path) -> tuple[dict[str, Any], Source]:
    """The loader's reader for ``.uxf``: one machine document, or a DiagramError naming every problem."""
    pre = PRESELECTED.get()
    if pre is not None and pre[0] == path.resolve():
        _, conv, index = pre
        return conv.machines[index], source_for(conv, index, path)
    conv = convert_file(path)
    if len(conv.machines) > 1:
        raise DiagramError([several_machines_problem(conv)])
    return conv.machines[0], source_for(conv, 0, path)


def source_for(conv: Converted, index: int, path: Path) -> Source:
    return Source(name=str(path), directory=path.parent, text=conv.diagram.text, locator=conv.locator(index))


def several_machines_problem(conv: Converted, hint: str | None = None) -> Problem:
    listing = "; ".join(f"'{n}' ({_machine_where(m)})" for n, m in zip(conv.names, conv.machines, strict=True))
    return Problem(f"the diagram holds {len(conv.machines)} separate machines: {listing}", conv.diagram.name,
                   line=1, column=1,
                   hint=hint or "convert one with `fsmctl convert FILE.uxf --machine NAME`, "
                                "or draw each machine in its own file")


def _machine_where(doc: dict[str, Any]) -> str:
    lay = (doc.get("layout") or {}).get("initial") or {}
    if "x" in lay:
        return f"initial marker at x={lay['x']}, y={lay['y']} (zoom 10)"
    return "diagram"


def convert_file(path: Path) -> Converted:
    return convert_raw(read_raw(path))


def convert_bytes(data: bytes, name: str = "<diagram>") -> Converted:
    return convert_raw(parse_raw(data, name))


def convert_raw(raw: RawDiagram) -> Converted:
    """The machine documents of a diagram, or a DiagramError naming every problem (sorted by place)."""
    scene = Scene(raw)
    scene.build()
    Relations(scene).run()
    docs = Documents(scene)
    docs.run()
    if scene.problems:
        raise DiagramError(sorted(scene.problems, key=lambda p: (p.line or 0, p.column or 0)))
    return Converted(raw, docs.docs, docs.names, docs.origins)




def cache_key(path: Path) -> tuple[str, str | None]:
    """What besides the diagram's text decides what :func:`read_uxf` makes of it (the machine chosen), and its
    text when it was read already (the plan cache hashes it)."""
    pre = PRESELECTED.get()
    if pre is not None and pre[0] == path.resolve():
        return f"machine {pre[2]}", pre[1].diagram.text
    return "the only machine", None


register_reader(".uxf", read_uxf, cache_key)
