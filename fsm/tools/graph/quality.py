"""How legible an SVG drawing (:func:`fsm.tools.graph.svg`) is: what overlaps what, counted on the picture.

Read from the SVG itself (the state groups with ``data-path``, the arrow polylines, the label rectangles), so it
measures any version of the drawing code the same way. Counted:

* ``box_overlaps``: pairs of state boxes that overlap, neither inside the other (a composite and its content
  do not count);
* ``edge_through_box``: (arrow, box) pairs where the arrow runs through the inside of a box that is not one of
  its ends (the boxes its first and last points lie on) nor a composite it is drawn in;
* ``label_box``: arrow labels over a state box, a composite's title band, or a composite they are not drawn in;
* ``label_label``: pairs of labels that overlap;
* ``label_stacked``: pairs of labels that do not overlap but stand closer than ``STACKED`` (they read as one
  label of two lines, whose arrows cannot be told apart);
* ``label_edge``: (label, arrow) pairs where the arrow runs through the label's rectangle (its own arrow too);
* ``edge_grazes_box``: (arrow, box) pairs where the arrow, not through the box, runs along its border closer than
  ``GRAZE`` (it looks as if it went in);
* ``crossings``: points where two arrows cross;
* ``along``: pairs of segments of two arrows that run on top of each other for some length;
* ``parallel_close``: pairs of segments of two arrows that run side by side, parallel, closer than ``SPACING`` (but
  not on top of each other) for more than ``RUN`` (they read as one thick arrow, or cannot be told apart);
* ``label_close``: pairs of labels closer than ``LABEL_GAP`` (stacked ones too): whose label is whose is unclear.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from xml.etree import ElementTree

from .buckets import Buckets
from .geometry import LABEL_GAP, SPACING, parallel_gap, segment_hits_box, segments_cross

NS = "{http://www.w3.org/2000/svg}"
Rect = tuple[float, float, float, float]
#: How deep into a box an arrow or label must reach to count (the border and a pixel or two of air do not).
TOLERANCE = 2.0
#: How close an arrow may run along a box that is not one of its ends.
GRAZE = 3.0
#: How close two labels may stand.
STACKED = 4.0
#: How long two parallel runs of arrows closer than ``SPACING`` may run side by side.
RUN = 12.0


@dataclass
class Quality:
    box_overlaps: int = 0
    edge_through_box: int = 0
    label_box: int = 0
    label_label: int = 0
    label_stacked: int = 0
    label_edge: int = 0
    edge_grazes_box: int = 0
    crossings: int = 0
    along: int = 0
    parallel_close: int = 0
    label_close: int = 0
    boxes: int = 0
    edges: int = 0
    labels: int = 0

    def row(self) -> tuple[int, ...]:
        return (self.boxes, self.edges, self.box_overlaps, self.edge_through_box, self.edge_grazes_box,
                self.label_box, self.label_label, self.label_stacked, self.label_close, self.label_edge,
                self.crossings, self.along, self.parallel_close)


@dataclass
class _Box:
    path: str
    rect: Rect
    band: Rect | None  # a composite's title band


def _f(el: ElementTree.Element, name: str) -> float:
    return float(el.get(name, "0"))


def _rect(el: ElementTree.Element | None) -> Rect | None:
    """The box of an SVG ``rect`` element (None: there is none)."""
    if el is None:
        return None
    return _f(el, "x"), _f(el, "y"), _f(el, "width"), _f(el, "height")


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


Point = tuple[float, float]
Seg = tuple[float, float, float, float]


@dataclass
class _Drawing:
    """What the counts look at, read from the SVG: state boxes, arrows (with the path they are drawn in), labels."""
    boxes: list[_Box]
    edges: list[tuple[str, list[Point]]]
    labels: list[tuple[str, Rect]]


def measure(svg_text: str) -> Quality:
    """The counts for one drawing."""
    d = _read(ElementTree.fromstring(svg_text))
    q = Quality(boxes=len(d.boxes), edges=len(d.edges), labels=len(d.labels))
    grid = Buckets()
    for b in d.boxes:
        grid.add_rect(*b.rect)
    q.box_overlaps = _box_overlaps(d.boxes, grid)
    segs, all_segs = _edges_against_boxes(d, grid, q)
    q.crossings, q.along, q.parallel_close = _crossings(segs, all_segs)
    q.label_box = sum(_label_on_box(d.boxes, grid, within, r) for within, r in d.labels)
    q.label_edge = sum(len({all_segs[j][0] for j in segs.near(r[0], r[1], r[0] + r[2], r[1] + r[3])
                            if segment_hits_box(*all_segs[j][1], r, TOLERANCE)}) for _, r in d.labels)
    q.label_label, q.label_stacked, q.label_close = _label_overlaps([r for _, r in d.labels])
    return q


def _box_of(g: ElementTree.Element, cls: list[str]) -> _Box | None:
    """A state's box (a rectangle, or the circle of a pseudostate), with a composite's title band."""
    r = _rect(g.find(NS + "rect"))
    if r is None:
        c = g.find(NS + "circle")
        if c is None:
            return None
        rad = _f(c, "r")
        r = (_f(c, "cx") - rad, _f(c, "cy") - rad, 2 * rad, 2 * rad)
    band = None
    if "composite" in cls:
        line = g.find(NS + "line")
        band = (r[0], r[1], r[2], (_f(line, "y1") - r[1]) if line is not None else r[3])
    return _Box(g.get("data-path") or g.get("data-id") or "", r, band)


def _classes(el: ElementTree.Element) -> list[str]:
    return (el.get("class") or "").split()


def _read(root: ElementTree.Element) -> _Drawing:
    d = _Drawing([], [], [])
    for g in root.iter(NS + "g"):
        cls = _classes(g)
        within = g.get("data-in") or ""  # the path of the composite an arrow or label is drawn in
        if "node" in cls or "pseudo" in cls:
            box = _box_of(g, cls)
            if box is not None:
                d.boxes.append(box)
        elif "level" in cls:
            d.edges += [(within, _points(pl)) for pl in g.iter(NS + "polyline") if "edge" in _classes(pl)]
        elif "label" in cls and (r := _rect(g.find(NS + "rect"))) is not None:
            d.labels.append((within, r))
    return d


def _box_overlaps(boxes: list[_Box], grid: Buckets) -> int:
    count = 0
    for i, a in enumerate(boxes):
        x, y, w, h = a.rect
        for j in grid.near(x, y, x + w, y + h):
            b = boxes[j]
            if j > i and not _inside(a.path, b.path) and not _inside(b.path, a.path) and _overlap(a.rect, b.rect):
                count += 1
    return count


def _edges_against_boxes(d: _Drawing, grid: Buckets, q: Quality) -> tuple[Buckets, list[tuple[int, Seg]]]:
    """Counts the arrows through and along boxes into ``q``; every arrow segment, numbered by its arrow."""
    segs = Buckets()
    all_segs: list[tuple[int, Seg]] = []
    for k, (within, pts) in enumerate(d.edges):
        if len(pts) < 2:
            continue
        ends = [b.path for b in d.boxes if _touches(pts[0], b.rect) or _touches(pts[-1], b.rect)]
        hit: set[int] = set()
        grazed: set[int] = set()
        for u, v in pairwise(pts):
            seg = (u[0], u[1], v[0], v[1])
            all_segs.append((k, seg))
            segs.add_segment(*seg)
            _segment_against_boxes(d.boxes, grid, seg, ends, within, hit, grazed)
        q.edge_through_box += len(hit)
        q.edge_grazes_box += len(grazed - hit)
    return segs, all_segs


def _segment_against_boxes(boxes: list[_Box], grid: Buckets, seg: Seg, ends: list[str], within: str,
                           hit: set[int], grazed: set[int]) -> None:
    """Add the boxes the arrow segment ``seg`` runs through to ``hit``, those it runs along to ``grazed``; not the
    arrow's own: its ``ends`` (the paths of the boxes its ends lie on), nor the composite it is drawn in."""
    for j in grid.near(min(seg[0], seg[2]) - GRAZE, min(seg[1], seg[3]) - GRAZE, max(seg[0], seg[2]) + GRAZE,
                       max(seg[1], seg[3]) + GRAZE):
        b = boxes[j]
        if j in hit or b.path in ends or (within and _inside(within, b.path)):
            continue
        if segment_hits_box(*seg, b.rect, TOLERANCE):
            hit.add(j)
        elif segment_hits_box(*seg, b.rect, -GRAZE):
            grazed.add(j)


def _crossings(segs: Buckets, all_segs: list[tuple[int, Seg]]) -> tuple[int, int, int]:
    """Points where two arrows cross, pairs of segments of two arrows on top of each other, and pairs that run
    side by side closer than ``SPACING``."""
    crossings = along = close = 0
    m = SPACING
    for i, (k, seg) in enumerate(all_segs):
        for j in segs.near(min(seg[0], seg[2]) - m, min(seg[1], seg[3]) - m, max(seg[0], seg[2]) + m,
                           max(seg[1], seg[3]) + m):
            k2, seg2 = all_segs[j]
            if j <= i or k2 == k:
                continue
            if segments_cross(seg, seg2):
                crossings += 1
            elif _along(seg, seg2):
                along += 1
            elif parallel_gap(seg, seg2, RUN) < SPACING:
                close += 1
    return crossings, along, close


def _label_on_box(boxes: list[_Box], grid: Buckets, within: str, r: Rect) -> bool:
    """Whether a label lies over a state box, a composite's title band, or a composite it is not drawn in."""
    for j in grid.near(r[0], r[1], r[0] + r[2], r[1] + r[3]):
        b = boxes[j]
        # in the composite it is drawn in, only the composite's title band is in a label's way
        if _overlap(r, b.band if b.band is not None and within and _inside(within, b.path) else b.rect):
            return True
    return False


def _label_overlaps(rects: list[Rect]) -> tuple[int, int, int]:
    """Pairs of labels that overlap, pairs that do not but stand closer than ``STACKED``, and pairs that do not
    overlap but stand closer than ``LABEL_GAP``."""
    placed = Buckets()
    for r in rects:
        placed.add_rect(*r)
    over = stacked = close = 0
    m = LABEL_GAP
    for i, r in enumerate(rects):
        for j in placed.near(r[0] - m, r[1] - m, r[0] + r[2] + m, r[1] + r[3] + m):
            if j <= i:
                continue
            if _overlap(r, rects[j]):
                over += 1
                continue
            stacked += _overlap(r, rects[j], -STACKED)
            close += _overlap(r, rects[j], -m)
    return over, stacked, close


HEADER = ("boxes", "arrows", "box/box", "arrow/box", "arrow along box", "label/box", "label/label", "labels stacked",
          f"labels < {LABEL_GAP:g} apart", "label/arrow", "crossings", "arrow along arrow",
          f"parallel runs < {SPACING:g} apart")


def table(rows: list[tuple[str, Quality | str]]) -> str:
    """A Markdown table of named measurements (a string instead: why there is none)."""
    out = ["| drawing | " + " | ".join(HEADER) + " |", "|---|" + "---:|" * len(HEADER)]
    for name, q in rows:
        cells = [str(v) for v in q.row()] if isinstance(q, Quality) else [q] + [""] * (len(HEADER) - 1)
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)
