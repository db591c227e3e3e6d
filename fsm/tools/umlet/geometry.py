"""Diagram geometry at UMLet's reference zoom (10): boxes, a grid index, nesting, and endpoint attachment.

UMLet stores no ids in relations; an endpoint belongs to the element whose border it is close to. The
rule here is UMLet's own first (``Stickables``: distance to the border < 9 px at zoom 10; old elements:
< the grid size, which is 10 px at zoom 10), then a lenient one for real diagrams: at most one grid unit
from the border, or inside a box that holds no other boxes (a simple state or pseudostate). The interior of
a composite state or a frame attaches nothing: an arrow ending there, far from every border, would otherwise
silently leave or enter the composite (UMLet measures the distance to the border only). Among candidates
the innermost box wins, then the nearest.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

#: UMLet: ``SharedConstants.DEFAULT_GRID_SIZE - 1``; strict ``<``.
STICK_NEW = 9.0
#: Old elements: ``stickingPolygon.isConnected(point, gridSize)``; the grid size is 10 px at zoom 10.
STICK_OLD = 10.0
#: The lenient rule: inside, or this close to the border (one grid unit at zoom 10), inclusive.
LENIENT = 10.0
_CELL = 160.0
_MAX_CELLS = 400


@dataclass(eq=False)
class Box:
    """A rectangle element (state, pseudostate, frame) at zoom 10, with its place in the nesting tree."""

    elem: Any  # RawElement
    role: str  # state | frame | initial | final | unsupported | note | comment
    x: float
    y: float
    w: float
    h: float
    container: bool = False
    parent: Box | None = None
    children: list[Box] = field(default_factory=list)
    depth: int = 0

    @property
    def area(self) -> float:
        return self.w * self.h

    @property
    def simple(self) -> bool:
        """A box whose interior counts for the lenient rule: no frame, and no boxes drawn inside it (notes
        aside)."""
        return self.role != "frame" and not any(c.role != "note" for c in self.children)

    def contains_box(self, other: Box) -> bool:
        return (self.x <= other.x and self.y <= other.y and other.x + other.w <= self.x + self.w
                and other.y + other.h <= self.y + self.h and other.area < self.area)

    def border_distance(self, px: float, py: float) -> tuple[float, bool]:
        """Distance from the point to the rectangle's border, and whether the point is inside."""
        x0, y0, x1, y1 = self.x, self.y, self.x + self.w, self.y + self.h
        inside = x0 <= px <= x1 and y0 <= py <= y1
        if inside:
            return min(px - x0, x1 - px, py - y0, y1 - py), True
        dx = max(x0 - px, 0.0, px - x1)
        dy = max(y0 - py, 0.0, py - y1)
        return math.hypot(dx, dy), False


class Grid:
    """A uniform grid of cells; each box is listed in the cells its (widened) rectangle touches.

    Boxes spanning more than ``_MAX_CELLS`` cells (huge frames) are kept in one list checked by every query,
    so building and querying stay linear in the number of boxes for ordinary diagrams.
    """

    def __init__(self, boxes: Iterable[Box], margin: float) -> None:
        self.cells: dict[tuple[int, int], list[Box]] = {}
        self.big: list[Box] = []
        for b in boxes:
            cx0 = math.floor((b.x - margin) / _CELL)
            cy0 = math.floor((b.y - margin) / _CELL)
            cx1 = math.floor((b.x + b.w + margin) / _CELL)
            cy1 = math.floor((b.y + b.h + margin) / _CELL)
            if (cx1 - cx0 + 1) * (cy1 - cy0 + 1) > _MAX_CELLS:
                self.big.append(b)
                continue
            for cx in range(cx0, cx1 + 1):
                for cy in range(cy0, cy1 + 1):
                    self.cells.setdefault((cx, cy), []).append(b)

    def near(self, px: float, py: float) -> list[Box]:
        found = self.cells.get((math.floor(px / _CELL), math.floor(py / _CELL)), [])
        return found + self.big if self.big else found


def nest(boxes: list[Box]) -> None:
    """Parent of each box: the smallest container box that contains it (UMLet stores no hierarchy)."""
    grid = Grid([b for b in boxes if b.container], 0.0)
    for b in boxes:
        b.parent = _smallest_container(b, grid)
    for b in boxes:
        if b.parent is not None:
            b.parent.children.append(b)
    for b in boxes:
        _set_depth(b)


def _smallest_container(b: Box, grid: Grid) -> Box | None:
    """The smallest container (other than ``b``) that holds ``b``, or ``None``."""
    best: Box | None = None
    for c in grid.near(b.x, b.y):
        if c is not b and c.contains_box(b) and (best is None or c.area < best.area):
            best = c
    return best


def _set_depth(b: Box) -> None:
    """The nesting depth of ``b`` and of its containers that have none yet, iteratively (no recursion limit on
    deep nesting)."""
    chain = []
    node = b
    while node.depth == 0 and (parent := node.parent) is not None:
        chain.append(node)
        node = parent
    base = node.depth
    for n in reversed(chain):
        base += 1
        n.depth = base


@dataclass
class Attachment:
    box: Box | None
    rule: str  # "umlet", "lenient", "none", "ambiguous"
    others: list[Box] = field(default_factory=list)
    distance: float = 0.0


class Attacher:
    """Finds the box an endpoint belongs to."""

    def __init__(self, boxes: list[Box]) -> None:
        self.boxes = boxes
        self.grid = Grid(boxes, LENIENT + 1)

    def attach(self, px: float, py: float, old: bool) -> Attachment:
        threshold = STICK_OLD if old else STICK_NEW
        strict: list[tuple[Box, float]] = []
        lenient: list[tuple[Box, float]] = []
        for b in self.grid.near(px, py):
            d, inside = b.border_distance(px, py)
            if d < threshold:
                strict.append((b, d))
            elif inside and b.simple:
                lenient.append((b, 0.0))
            elif d <= LENIENT:
                lenient.append((b, d))
        for rule, cands in (("umlet", strict), ("lenient", lenient)):
            if cands:
                return _closest(rule, cands)
        return Attachment(None, "none")

    def nearest(self, px: float, py: float) -> tuple[Box | None, float]:
        best: Box | None = None
        best_d = math.inf
        for b in self.boxes:
            d, _ = b.border_distance(px, py)
            if d < best_d:
                best, best_d = b, d
        return best, best_d


def _closest(rule: str, cands: list[tuple[Box, float]]) -> Attachment:
    """Among the candidate boxes (with their distances) the innermost closest one, found by ``rule``; several as
    close: ambiguous."""
    deepest = max(b.depth for b, _ in cands)
    cands = [(b, d) for b, d in cands if b.depth == deepest]
    best = min(d for _, d in cands)
    winners = [b for b, d in cands if d - best < 1e-9]
    if len(winners) > 1:
        return Attachment(None, "ambiguous", winners, best)
    return Attachment(winners[0], rule, [], best)
