"""How legible an SVG drawing (:func:`fsm.tools.graph.svg`) is: what overlaps what, counted on the picture.

Read from the SVG itself (the state groups with ``data-path``, the arrow polylines, the label rectangles), so it
measures any version of the drawing code the same way. Counted:

* ``box_overlaps``: pairs of state boxes that overlap, neither inside the other (a composite and its content
  do not count);
* ``edge_through_box``: (arrow, box) pairs where the arrow runs through the inside of a box that is not one of
  its ends (the boxes its first and last points lie on) nor a composite it is drawn in;
* ``label_box``: arrow labels over a state box, a composite's title band, or a composite they are not drawn in;
* ``label_label``: pairs of labels that overlap;
* ``label_edge``: (label, arrow) pairs where the arrow runs through the label's rectangle (its own arrow too);
* ``edge_grazes_box``: (arrow, box) pairs where the arrow, not through the box, runs along its border closer than
  ``GRAZE`` (it looks as if it went in);
* ``crossings``: points where two arrows cross;
* ``along``: pairs of segments of two arrows that run on top of each other for some length.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from xml.etree import ElementTree

from .buckets import Buckets
from .geometry import segment_hits_box, segments_cross

NS = "{http://www.w3.org/2000/svg}"
Rect = tuple[float, float, float, float]
#: How deep into a box an arrow or label must reach to count (the border and a pixel or two of air do not).
TOLERANCE = 2.0
#: How close an arrow may run along a box that is not one of its ends.
GRAZE = 3.0


@dataclass
class Quality:
    box_overlaps: int = 0
    edge_through_box: int = 0
    label_box: int = 0
    label_label: int = 0
    label_edge: int = 0
    edge_grazes_box: int = 0
    crossings: int = 0
    along: int = 0
    boxes: int = 0
    edges: int = 0
    labels: int = 0

    def row(self) -> tuple[int, ...]:
        return (self.boxes, self.edges, self.box_overlaps, self.edge_through_box, self.edge_grazes_box,
                self.label_box, self.label_label, self.label_edge, self.crossings, self.along)


@dataclass
class _Box:
    path: str
    rect: Rect
    band: Rect | None  # a composite's title band


def _f(el: ElementTree.Element, name: str) -> float:
    return float(el.get(name, "0"))


def _points(el: ElementTree.Element) -> list[tuple[float, float]]:
    out = []
    for pt in (el.get("points") or "").split():
        x, y = pt.split(",")
        out.append((float(x), float(y)))
    return out


def _inside(a: str, b: str) -> bool:
    """Whether path ``a`` is ``b`` or inside it."""
    return a == b or a.startswith(b + "/")


def _overlap(a: Rect, b: Rect, tol: float = TOLERANCE) -> bool:
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return w > tol and h > tol


def _touches(p: tuple[float, float], r: Rect, tol: float = 4.0) -> bool:
    return r[0] - tol <= p[0] <= r[0] + r[2] + tol and r[1] - tol <= p[1] <= r[1] + r[3] + tol


def _along(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Whether two segments lie on one line and share more than a few units of it."""
    ax, ay, bx, by = a
    dx, dy = bx - ax, by - ay
    length = (dx * dx + dy * dy) ** 0.5
    if length < 1e-9:
        return False
    for px, py in ((b[0], b[1]), (b[2], b[3])):
        if abs(dx * (py - ay) - dy * (px - ax)) / length > 0.5:
            return False  # an end of b is off a's line
    t0 = ((b[0] - ax) * dx + (b[1] - ay) * dy) / length
    t1 = ((b[2] - ax) * dx + (b[3] - ay) * dy) / length
    return bool(min(length, max(t0, t1)) - max(0.0, min(t0, t1)) > 4)


def measure(svg_text: str) -> Quality:
    """The counts for one drawing."""
    root = ElementTree.fromstring(svg_text)
    boxes: list[_Box] = []
    edges: list[tuple[str, list[tuple[float, float]]]] = []
    labels: list[tuple[str, Rect]] = []
    for g in root.iter(NS + "g"):
        cls = (g.get("class") or "").split()
        if "node" in cls or "pseudo" in cls:
            path = g.get("data-path") or g.get("data-id") or ""
            rect = g.find(NS + "rect")
            if rect is not None:
                r = (_f(rect, "x"), _f(rect, "y"), _f(rect, "width"), _f(rect, "height"))
            else:
                c = g.find(NS + "circle")
                if c is None:
                    continue
                rad = _f(c, "r")
                r = (_f(c, "cx") - rad, _f(c, "cy") - rad, 2 * rad, 2 * rad)
            band = None
            if "composite" in cls:
                line = g.find(NS + "line")
                band = (r[0], r[1], r[2], (_f(line, "y1") - r[1]) if line is not None else r[3])
            boxes.append(_Box(path, r, band))
        elif "level" in cls:
            within = g.get("data-in") or ""
            for pl in g.iter(NS + "polyline"):
                if "edge" in (pl.get("class") or "").split():
                    edges.append((within, _points(pl)))
        elif "label" in cls:
            rect = g.find(NS + "rect")
            if rect is not None:
                labels.append((g.get("data-in") or "", (_f(rect, "x"), _f(rect, "y"), _f(rect, "width"),
                                                         _f(rect, "height"))))
    q = Quality(boxes=len(boxes), edges=len(edges), labels=len(labels))
    grid = Buckets()
    for b in boxes:
        grid.add_rect(*b.rect)
    for i, a in enumerate(boxes):
        x, y, w, h = a.rect
        for j in grid.near(x, y, x + w, y + h):
            b = boxes[j]
            if j > i and not _inside(a.path, b.path) and not _inside(b.path, a.path) and _overlap(a.rect, b.rect):
                q.box_overlaps += 1
    segs = Buckets()
    all_segs: list[tuple[int, tuple[float, float, float, float]]] = []
    for k, (within, pts) in enumerate(edges):
        if len(pts) < 2:
            continue
        ends = [b.path for b in boxes if _touches(pts[0], b.rect) or _touches(pts[-1], b.rect)]
        hit, grazed = set(), set()
        for u, v in pairwise(pts):
            seg = (u[0], u[1], v[0], v[1])
            all_segs.append((k, seg))
            segs.add_segment(*seg)
            for j in grid.near(min(u[0], v[0]) - GRAZE, min(u[1], v[1]) - GRAZE, max(u[0], v[0]) + GRAZE,
                               max(u[1], v[1]) + GRAZE):
                b = boxes[j]
                if j in hit or b.path in ends or (within and _inside(within, b.path)):
                    continue
                if segment_hits_box(*seg, b.rect, TOLERANCE):
                    hit.add(j)
                elif segment_hits_box(*seg, b.rect, -GRAZE):
                    grazed.add(j)
        q.edge_through_box += len(hit)
        q.edge_grazes_box += len(grazed - hit)
    for i, (k, seg) in enumerate(all_segs):
        for j in segs.near(min(seg[0], seg[2]), min(seg[1], seg[3]), max(seg[0], seg[2]), max(seg[1], seg[3])):
            k2, seg2 = all_segs[j]
            if j > i and k2 != k and segments_cross(seg, seg2):
                q.crossings += 1
            elif j > i and k2 != k and _along(seg, seg2):
                q.along += 1
    for within, r in labels:
        for j in grid.near(r[0], r[1], r[0] + r[2], r[1] + r[3]):
            b = boxes[j]
            if b.band is not None and within and _inside(within, b.path):
                if _overlap(r, b.band):
                    q.label_box += 1
                    break
            elif _overlap(r, b.rect):
                q.label_box += 1
                break
    for _, r in labels:
        crossed = {all_segs[j][0] for j in segs.near(r[0], r[1], r[0] + r[2], r[1] + r[3])
                   if segment_hits_box(*all_segs[j][1], r, TOLERANCE)}
        q.label_edge += len(crossed)
    placed = Buckets()
    for _, r in labels:
        placed.add_rect(*r)
    for i, (_, r) in enumerate(labels):
        for j in placed.near(r[0], r[1], r[0] + r[2], r[1] + r[3]):
            if j > i and _overlap(r, labels[j][1]):
                q.label_label += 1
    return q


HEADER = ("boxes", "arrows", "box/box", "arrow/box", "arrow along box", "label/box", "label/label", "label/arrow",
          "crossings", "arrow along arrow")


def table(rows: list[tuple[str, Quality | str]]) -> str:
    """A Markdown table of named measurements (a string instead: why there is none)."""
    out = ["| drawing | " + " | ".join(HEADER) + " |", "|---|" + "---:|" * len(HEADER)]
    for name, q in rows:
        cells = [str(v) for v in q.row()] if isinstance(q, Quality) else [q] + [""] * (len(HEADER) - 1)
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)
