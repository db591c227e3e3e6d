"""The SVG drawing of a machine with its nesting, drawn here without Graphviz.

Boxes go where the diagram's ``layout`` put them (a converted UMLet diagram looks like the diagram), or where
the layered layout (:mod:`fsm.tools.graph.layout`) puts them; arrow labels are placed clear of boxes and of
each other.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import pairwise, product
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

from .buckets import Buckets
from .geometry import LABEL_GAP, segment_hits_box, segments_cross
from .includes import expander
from .labels import (
    BOX_MARGIN,
    FINAL_ICON,
    FONT,
    LABEL_FONT,
    SMALL_FONT,
    edge_label,
    final_text,
    fit,
    short_edge_label,
    state_label,
    text_width,
)
from .layout import REGION_HEAD, Edge, LevelLayout, Node, lay_out, region_name


def _box_size(node: Node) -> tuple[float, float]:
    """The size of a state box without a stored layout: its text fits."""
    st = node.doc
    if node.composite:
        w = text_width(str(st.get("id")), FONT, bold=True)
        if node.note is not None:
            w = max(w, text_width(node.note, SMALL_FONT))
        return max(120.0, _snap(w + 2 * BOX_MARGIN + 4)), 60.0 if node.parts else 70.0
    if st.get("type") == "Final":
        return max(120.0, _snap(FINAL_ICON + text_width(final_text(st), FONT) + BOX_MARGIN + 4)), 50.0
    name, sub = _state_lines(st)
    w = max(text_width(name, FONT), text_width(sub, SMALL_FONT))
    return max(120.0, _snap(w + 2 * BOX_MARGIN + 4)), 50.0 if sub else 40.0


def _state_lines(st: dict[str, Any]) -> tuple[str, str]:
    lines = state_label(st).split(" (", 1)
    return lines[0], ("(" + lines[1]) if len(lines) > 1 else ""


def _snap(v: float) -> float:
    return math.ceil(v / 10) * 10


def svg(doc: dict[str, Any], base: str | Path | None = None) -> str:
    """The machine drawn as SVG, with its regions and included machines.

    ``base``: the document's file (or its folder), to open its ``{"file": ...}`` includes; without it an included
    machine is drawn as a box naming its file.
    """
    def lines_of(st: dict[str, Any]) -> list[str]:
        return [state_label(st)]

    folder = None if base is None else Path(base).parent if Path(base).is_file() else Path(base)
    level = lay_out(doc, lines_of, expand=expander(folder), size=_box_size,
                    label_width=lambda tr: text_width(short_edge_label(tr), LABEL_FONT) + 4, drawing=True)
    scene = _Scene()
    scene.collect(level, None, ())
    scene.index()
    labels = _place_labels(scene)
    x0, y0, x1, y1 = _picture(level, [r for _, r, _ in labels] + scene.outside)
    m = 20
    width, height = x1 - x0 + 2 * m, y1 - y0 + 2 * m
    body: list[str] = []
    where: dict[int, str] = {}
    _draw(level, body, "", where)
    for e, r, lines in labels:
        _draw_label(e, r, lines, where.get(id(e), ""), body)
    title = escape(str(doc.get("name") or "machine"))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
            f'viewBox="{x0 - m:.0f} {y0 - m:.0f} {width:.0f} {height:.0f}" font-family="Helvetica, Arial, sans-serif" '
            f'font-size="{FONT}">\n<title>{title}</title>\n'
            '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="8" markerHeight="8" '
            'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#333"/></marker></defs>\n'
            f'<rect x="{x0 - m:.0f}" y="{y0 - m:.0f}" width="{width:.0f}" height="{height:.0f}" fill="white"/>\n'
            + "\n".join(body) + "\n</svg>\n")


def _picture(level: LevelLayout, texts: list[Rect]) -> tuple[float, float, float, float]:
    """Left, top, right and bottom of what is drawn: the level's boxes and arrows, and the ``texts`` beside them
    (arrow labels, the names of small final states)."""
    x0, y0, x1, y1 = level.bbox(labels=False)
    for rx, ry, rw, rh in texts:
        x0, y0, x1, y1 = min(x0, rx), min(y0, ry), max(x1, rx + rw), max(y1, ry + rh)
    return x0, y0, x1, y1


# -- edge labels -----------------------------------------------------------------------------------------------
Rect = tuple[float, float, float, float]
#: An arrow's segment, the id of its arrow (0: the initial marker's) and its bounding box.
Segment = tuple[tuple[float, float, float, float], int, float, float, float, float]


def _small_final(n: Node) -> bool:
    """A UMLet final pseudostate: a small circle, its id written beside it."""
    return n.doc.get("type") == "Final" and abs(n.w - n.h) < 1e-6 and n.w <= 40 and not n.composite


class _Scene:
    """Everything a label must keep clear of, and every arrow with the box it belongs in.

    Boxes, composites and arrow segments are kept in one grid (:class:`~fsm.tools.graph.buckets.Buckets`,
    numbered in that order), so a label's candidate place is checked against what lies near it only.
    """

    def __init__(self) -> None:
        self.boxes: list[Rect] = []  # state boxes, title bands, markers, texts beside small finals
        self.composites: list[tuple[Node, Rect]] = []
        self.edges: list[tuple[Edge, Rect | None, tuple[int, ...]]] = []
        self.segments: list[Segment] = []
        self.outside: list[Rect] = []  # texts drawn outside any box (for the picture's size)
        self.grid = Buckets()

    def collect(self, level: LevelLayout, container: Rect | None, ancestors: tuple[int, ...]) -> None:
        for n in level.nodes:
            if n.composite:
                self.composites.append((n, (n.x, n.y, n.w, n.h)))
                self.boxes.append((n.x, n.y, n.w, n.head))
                for p in n.parts:
                    if p.name is not None:
                        self.boxes.append((p.x, p.y, p.w, REGION_HEAD))
                    self.collect(p.level, (p.x, p.y, p.w, p.h), ancestors + (id(n),))
            elif _small_final(n):
                self.boxes.append((n.x, n.y, n.w, n.h))
                r = (n.x + n.w + 4, n.y + n.h / 2 - 9, text_width(str(n.doc.get("id")), FONT), 14.0)
                self.boxes.append(r)
                self.outside.append(r)
            else:
                self.boxes.append((n.x, n.y, n.w, n.h))
        if level.marker is not None:
            mw, mh = level.marker_size
            self.boxes.append((level.marker[0], level.marker[1], mw, mh))
            self._polyline(level.marker_points, 0)
        for e in level.edges:
            self.edges.append((e, container, ancestors))
            self._polyline(e.points, id(e))

    def _polyline(self, pts: list[list[float]], owner: int) -> None:
        for (ax, ay), (bx, by) in pairwise(pts):
            self.segments.append(((ax, ay, bx, by), owner, min(ax, bx), min(ay, by), max(ax, bx), max(ay, by)))

    def index(self) -> None:
        """Put everything collected into the grid: boxes, then composites, then segments."""
        for r in self.boxes:
            self.grid.add_rect(*r)
        for _n, r in self.composites:
            self.grid.add_rect(*r)
        for (ax, ay, bx, by), *_ in self.segments:
            self.grid.add_segment(ax, ay, bx, by)


def _area(a: Rect, b: Rect) -> float:
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0.0


def _point_at(pts: list[list[float]], s: float) -> tuple[float, float, float, float]:
    """The point at arc length ``s`` along ``pts`` and the unit direction there."""
    last = len(pts) - 2
    for i, ((ax, ay), (bx, by)) in enumerate(pairwise(pts)):
        seg = math.hypot(bx - ax, by - ay)
        if seg > 0 and (s <= seg or i == last):
            f = max(0.0, min(1.0, s / seg))
            return ax + (bx - ax) * f, ay + (by - ay) * f, (bx - ax) / seg, (by - ay) / seg
        s -= seg
    (ax, ay) = pts[0]
    return ax, ay, 1.0, 0.0


def _wrapped(text: str) -> list[str] | None:
    """``text`` in two lines of about equal width, broken at a space, or None."""
    spaces = [i for i, ch in enumerate(text) if ch == " "]
    if not spaces:
        return None
    best = min(spaces, key=lambda i: (abs(text_width(text[:i], LABEL_FONT) - text_width(text[i + 1:], LABEL_FONT)), i))
    return [text[:best], text[best + 1:]]


LINE_H = 14.0
_ALONG = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.12, 0.88)


def _label_shapes(text: str) -> list[tuple[list[str], float, float, float]]:
    """The ways to write a label: (lines, width, height, how much less good than one line); last, when there is
    no room for the others, its first word (the event type) and an ellipsis."""
    out = [([text], text_width(text, LABEL_FONT) + 4, LINE_H + 1, 0.0)]
    two = _wrapped(text)
    if two is not None:
        out.append((two, max(text_width(t, LABEL_FONT) for t in two) + 4, 2 * LINE_H + 1, 200.0))
        short = text.split(" ", 1)[0].rstrip(",") + " …"
        out.append(([short], text_width(short, LABEL_FONT) + 4, LINE_H + 1, 1000.0))
    return out


#: What a place closer than ``LABEL_GAP`` to another label costs: two labels that close read as one label, or as
#: labels of the same arrow (a few rings further out cost less).
NEAR_LABEL = 1200.0
#: What a label costs for each arrow running through it: more than any place near its arrow, less than a box.
CROSSED = 20000.0
#: Rings from this one on are tried only when every place beside the arrow lies across something: the label goes
#: round a point of its arrow in eight directions (``side`` is the direction), at growing distances.
COMPASS = 12
_DIRECTIONS = tuple((math.cos(k * math.pi / 4), math.sin(k * math.pi / 4)) for k in range(8))
#: The rings of candidate places: first those near the arrow (-1: on it), then further out, then around it.
_RINGS = ((-1, 0, 1, 2, 3), tuple(range(4, 12)), tuple(range(COMPASS, COMPASS + 8)))
#: A candidate place: what it costs before looking at the drawing, its number in the order the places are
#: listed (the first of equally good places wins), its ring, which ``_ALONG`` point, which label shape, which side.
Candidate = tuple[float, int, int, int, int, int]


@functools.lru_cache(maxsize=None)
def _candidates(worse: tuple[float, ...]) -> tuple[tuple[Candidate, ...], ...]:
    """For each group of rings, every candidate place for a label with shapes as much ``worse`` than the best,
    cheapest first: searched in this order, a label rarely has to look at more than a few places."""
    groups = []
    idx = 0
    for rings in _RINGS:
        group = []
        for ring, (ti, t), (si, bad) in product(rings, enumerate(_ALONG), enumerate(worse)):
            for side in _sides(ring):
                group.append((abs(t - 0.5) * 120 + max(ring, 0) * 250 + (0 if side == 1 else 15) + bad, idx,
                              ring, ti, si, side))
                idx += 1
        groups.append(tuple(sorted(group)))
    return tuple(groups)


def _sides(ring: int) -> Iterable[int]:
    """The sides of a ring's places: on the arrow (ring -1) one, beside it either side of it, round its point (from
    ``COMPASS`` on) eight directions."""
    if ring < 0:
        return (1,)
    return range(8) if ring >= COMPASS else (1, -1)


def _place_labels(scene: _Scene) -> list[tuple[Edge, Rect, list[str]]]:
    """A rectangle for every arrow's label, beside its arrow, clear of boxes and other labels where possible.

    Greedy, shortest arrow first: each label takes the cheapest of a set of candidate places along its arrow (see
    :func:`_best_place`), the labels placed before among what it keeps clear of.
    """
    placed = _Placed()
    out: list[tuple[Edge, Rect, list[str]]] = []
    for e, container, ancestors in sorted(scene.edges, key=lambda item: _length(item[0].points)):
        text = short_edge_label(e.doc)
        if not text or len(e.points) < 2:
            continue
        best = _best_place(_label_shapes(text), _Near(scene, placed, container, ancestors, id(e)), e.points)
        placed.add(best.rect)
        out.append((e, best.rect, best.lines))
    return out


@dataclass(slots=True)
class _Best:
    """The cheapest place found so far for one label: its cost, its candidate number (-1: none yet), its rectangle
    and the label's lines there."""
    cost: float = math.inf
    idx: int = -1
    rect: Rect = (0.0, 0.0, 0.0, 0.0)
    lines: list[str] = field(default_factory=list)


def _beats(cost: float, idx: int, best: _Best) -> bool:
    """Whether a place that costs ``cost``, candidate number ``idx``, comes before ``best``: it is cheaper, or as
    cheap and listed first."""
    return cost < best.cost or cost == best.cost and idx < best.idx


def _best_place(shapes: list[tuple[list[str], float, float, float]], near: _Near, pts: list[list[float]]) -> _Best:
    """The cheapest of the candidate places along the arrow ``pts``, on either side of it and on it, in one line or
    two (further out only when the near places are all taken); of equally cheap places, the first in the order
    ring, point along the arrow, shape, side. When every place lies across something, the short form, where that
    is cheaper."""
    anchors = _anchors(pts)
    own = [(a[0], a[1], b[0], b[1]) for a, b in pairwise(pts)]
    best = _Best()
    _search(shapes[:2], _candidates(tuple(worse for *_, worse in shapes[:2])), best, near, anchors, own)
    if best.cost >= CROSSED and len(shapes) > 2:  # nowhere free: the short form, near its arrow
        short = _Best(best.cost)
        _search(shapes[2:], _candidates((shapes[2][3],)), short, near, anchors, own)
        if short.idx >= 0:  # found a place cheaper than the best of the long forms
            return short
    return best


def _length(pts: list[list[float]]) -> float:
    """An arrow's length along its points."""
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in pairwise(pts))


def _anchors(pts: list[list[float]]) -> list[tuple[float, float, float, float]]:
    """The points of an arrow a label may stand at (``_ALONG`` its length), each with the unit normal pointing
    right of a downward arrow and above a rightward one."""
    length = _length(pts)
    anchors = []
    for t in _ALONG:
        px, py, dx, dy = _point_at(pts, t * length)
        nx, ny = dy, -dx
        if nx < 0 or (nx == 0 and ny > 0):
            nx, ny = -nx, -ny
        anchors.append((px, py, nx, ny))
    return anchors


def _search(shapes: list[tuple[list[str], float, float, float]], groups: tuple[tuple[Candidate, ...], ...],
            best: _Best, near: _Near, anchors: list[tuple[float, float, float, float]],
            own: list[tuple[float, float, float, float]]) -> None:
    """The cheapest of the candidate places into ``best``, searched group by group (a group further out only while
    every place so far lies across something)."""
    for group in groups:
        for cand in group:
            if not _beats(cand[0], cand[1], best):
                break  # this place and all after it cost at least as much as the best one
            _consider(cand, shapes, best, near, anchors, own)
        if best.cost < CROSSED:
            break


def _consider(cand: Candidate, shapes: list[tuple[list[str], float, float, float]], best: _Best, near: _Near,
              anchors: list[tuple[float, float, float, float]], own: list[tuple[float, float, float, float]]) -> None:
    """Candidate ``cand`` into ``best`` when it comes before it. A place on its own arrow (ring -1) is not measured
    when what that alone costs (``CROSSED``) already makes it no better; the measure stops where it would be."""
    base, idx, ring, ti, si, side = cand
    lines, w, h, _ = shapes[si]
    anchor = anchors[ti]
    r = _candidate_rect(anchor, w, h, ring, side)
    if ring < 0 and not _beats(base + CROSSED, idx, best) and any(segment_hits_box(*sg, r) for sg in own):
        return
    limit = best.cost - base
    if idx < best.idx:  # as good as the best one would do: it comes first
        limit = math.nextafter(limit, math.inf)
    cost = base + near.cost(r, (anchor[0], anchor[1]), limit)
    if _beats(cost, idx, best):
        best.cost, best.idx, best.rect, best.lines = cost, idx, r, lines


def _candidate_rect(anchor: tuple[float, float, float, float], w: float, h: float, ring: int, side: int) -> Rect:
    """Where a ``w`` x ``h`` label stands for a candidate: on its arrow's point (ring -1), beside it on ``side``
    of the arrow, a step further out each ring, or (from ``COMPASS`` on) round the point in direction ``side``."""
    px, py, nx, ny = anchor
    if ring >= COMPASS:  # round the point: past the label's own half size, then a step a ring
        sx, sy = _DIRECTIONS[side]
        d = 4 + abs(sx) * w / 2 + abs(sy) * h / 2 + (ring - COMPASS) * (LINE_H + 2)
    else:
        sx, sy = nx * side, ny * side
        d = 0.0 if ring < 0 else 4 + abs(sx) * w / 2 + abs(sy) * h / 2 + ring * (LINE_H + 2) * 0.75
    cx, cy = px + sx * d, py + sy * d
    return round(cx - w / 2, 1), round(cy - h / 2, 1), w, h


class _Placed:
    """The labels placed so far, in a grid."""

    def __init__(self) -> None:
        self.rects: list[Rect] = []
        self.grid = Buckets()

    def add(self, r: Rect) -> None:
        self.rects.append(r)
        self.grid.add_rect(*r)


class _Near:
    """What one arrow's label must keep clear of: boxes, composites it is not inside of, other labels and arrows."""

    def __init__(self, scene: _Scene, placed: _Placed, container: Rect | None, ancestors: tuple[int, ...],
                 owner: int) -> None:
        self.scene, self.placed, self.container, self.ancestors, self.owner = \
            scene, placed, container, ancestors, owner
        self.inner = None if container is None else \
            (container[0] + 2, container[1] + 2, container[2] - 4, container[3] - 4)

    def cost(self, r: Rect, anchor: tuple[float, float], limit: float) -> float:
        """How bad a place ``r`` for a label is; stops counting once it is worse than ``limit``: over a label placed
        before, over a box (or out of its composite), across an arrow, or with an arrow between it and its own."""
        rx, ry, rw, rh = r
        air = (rx - 2, ry - 2, rx + rw + 2, ry + rh + 2)  # with a little air around it
        cost = self._on_labels(air)
        if cost >= limit:
            return cost
        ax, ay = anchor
        x0, y0, x1, y1 = air
        # one look into the grid for the boxes (near the place) and the segments (between the place and its arrow)
        found = self.scene.grid.near(x0 if x0 < ax else ax, y0 if y0 < ay else ay, x1 if x1 > ax else ax,
                                     y1 if y1 > ay else ay)
        k, on_boxes = self._on_boxes(found, air)
        cost += on_boxes
        cost += self._outside(r)
        if cost >= limit:
            return cost
        return self._on_arrows(found, k, r, anchor, cost, limit)

    def _outside(self, r: Rect) -> float:
        """What the part of place ``r`` outside the composite the label is drawn in costs (none outside any)."""
        if self.inner is None:
            return 0.0
        outside = r[2] * r[3] - _area(r, self.inner)
        return 1e5 + outside * 10 if outside > 0.01 else 0.0

    def _on_labels(self, air: Rect) -> float:
        """Over a label placed before; or closer to one than ``LABEL_GAP`` (``air`` is 2 px larger than the label),
        which reads as one label of two lines, or as labels of one arrow."""
        x0, y0, x1, y1 = air
        cost = 0.0
        placed = self.placed.rects
        m = LABEL_GAP - 2 + 0.5
        for i in self.placed.grid.near(x0 - m, y0 - m, x1 + m, y1 + m):
            ox, oy, ow, oh = placed[i]
            ox1, oy1 = ox + ow, oy + oh
            w = (x1 if x1 < ox1 else ox1) - (x0 if x0 > ox else ox)
            h = (y1 if y1 < oy1 else oy1) - (y0 if y0 > oy else oy)
            if w > 0 and h > 0:
                cost += 1e6 + w * h * 100
            elif w > -m and h > -m:
                cost += NEAR_LABEL
        return cost

    def _on_boxes(self, found: list[int], air: Rect) -> tuple[int, float]:
        """The cost of the boxes and composites (not the label's own) among ``found``, which lists them first; and
        how many of ``found`` they are."""
        x0, y0, x1, y1 = air
        scene = self.scene
        boxes, composites = scene.boxes, scene.composites
        n_boxes = len(boxes)
        n_obstacles = n_boxes + len(composites)
        k = 0
        cost = 0.0
        for i in found:
            if i >= n_obstacles:
                break
            k += 1
            if i < n_boxes:
                ox, oy, ow, oh = boxes[i]
            else:
                n, (ox, oy, ow, oh) = composites[i - n_boxes]
                if id(n) in self.ancestors:
                    continue
            ox1, oy1 = ox + ow, oy + oh
            w = (x1 if x1 < ox1 else ox1) - (x0 if x0 > ox else ox)
            h = (y1 if y1 < oy1 else oy1) - (y0 if y0 > oy else oy)
            if w > 0 and h > 0:
                cost += 1e5 + w * h * 10
        return k, cost

    def _on_arrows(self, found: list[int], k: int, r: Rect, anchor: tuple[float, float], cost: float,
                   limit: float) -> float:
        """``cost`` plus the arrows among ``found`` (from ``k`` on) across the label or between it and its arrow."""
        scene = self.scene
        rx, ry, rw, rh = r
        rx1, ry1 = rx + rw, ry + rh
        leader, lx0, ly0, lx1, ly1 = _leader(anchor, rx, ry, rx1, ry1)
        segments = scene.segments
        n_obstacles = len(scene.boxes) + len(scene.composites)
        owner = self.owner
        for j in range(k, len(found)):
            seg, of, sx0, sy0, sx1, sy1 = segments[found[j] - n_obstacles]
            if not (sx1 < rx or sx0 > rx1 or sy1 < ry or sy0 > ry1) and segment_hits_box(*seg, r):
                cost += CROSSED  # a label across an arrow (its own too) reads as belonging to it
            elif of != owner and not (sx1 < lx0 or sx0 > lx1 or sy1 < ly0 or sy0 > ly1) and segments_cross(leader, seg):
                cost += 3000  # another arrow runs between this label and its arrow
            if cost >= limit:
                break
        return cost


def _leader(anchor: tuple[float, float], rx: float, ry: float, rx1: float, ry1: float,
            ) -> tuple[tuple[float, float, float, float], float, float, float, float]:
    """The line from a label's point on its arrow to the nearest point of its rectangle (``rx``..``rx1``,
    ``ry``..``ry1``), and that line's left, top, right and bottom."""
    ax, ay = anchor
    cx = rx if ax < rx else rx1 if ax > rx1 else ax
    cy = ry if ay < ry else ry1 if ay > ry1 else ay
    lx0, lx1 = (ax, cx) if ax <= cx else (cx, ax)
    ly0, ly1 = (ay, cy) if ay <= cy else (cy, ay)
    return (ax, ay, cx, cy), lx0, ly0, lx1, ly1


# -- drawing ---------------------------------------------------------------------------------------------------
def _text(x: float, y: float, text: str, size: float, anchor: str = "middle", extra: str = "") -> str:
    size_attr = "" if size == FONT else f' font-size="{size:g}"'
    return (f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}"{size_attr}{extra}>{escape(text)}</text>')


def _region_prefix(n: Node, path: str, i: int) -> str:
    """The state path under which part ``i`` of composite ``n`` (at ``path``) has its states, as the loader names
    them: a ``Parallel`` region adds its machine's name (else ``region<i+1>``), other composites nothing."""
    if n.doc.get("type") != "Parallel":
        return path
    return f"{path}/{region_name(n.parts[i].level.machine, i)}"


def _draw(level: LevelLayout, body: list[str], prefix: str, where: dict[int, str]) -> None:
    """The SVG of ``level``; each state's group carries ``data-path``, its state path in a running machine, and
    the level's initial marker and arrows are in a group whose ``data-in`` is the path of the composite they are
    drawn in (for a viewer that folds composites); ``where`` gets that path for each arrow (for its label)."""
    for n in level.nodes:
        st = n.doc
        path = f"{prefix}/{st.get('id')}" if prefix else str(st.get("id"))
        attrs = f" data-id={quoteattr(str(st.get('id')))} data-path={quoteattr(path)}"
        if n.composite:
            _draw_composite(n, attrs, body)
            for i, p in enumerate(n.parts):
                _draw(p.level, body, _region_prefix(n, path, i), where)
        elif st.get("type") == "Final":
            _draw_final(n, attrs, body)
        else:
            _draw_state(n, attrs, body)
    _draw_arrows(level, body, prefix, where)


def _draw_label(e: Edge, r: Rect, lines: list[str], prefix: str, body: list[str]) -> None:
    """An arrow's label in its rectangle, in a group naming where its arrow is drawn and its ends; the whole
    label on hover when it is shortened or wrapped."""
    rx, ry, rw, rh = r
    body.append(f'<g class="label" data-in={quoteattr(prefix)}{_ends(e, prefix)}>')
    full = edge_label(e.doc)
    if lines != [full]:
        body.append(f"<title>{escape(full)}</title>")
    body.append(f'<rect class="label" x="{rx:.1f}" y="{ry:.1f}" width="{rw:.1f}" height="{rh:.1f}" fill="white" '
                'fill-opacity="0.85"/>')
    for i, line in enumerate(lines):
        body.append(f'<text class="label" x="{rx + 2:.1f}" y="{ry + 11 + i * LINE_H:.1f}" font-size="{LABEL_FONT}" '
                    f'fill="#1a4d80">{escape(line)}</text>')
    body.append("</g>")


def _draw_composite(n: Node, attrs: str, body: list[str]) -> None:
    """A composite's box: its title (and note) in a band, its parts' compartments."""
    st = n.doc
    body.append(f'<g class="node composite"{attrs}>')
    body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="12" '
                'fill="#f4f7fb" stroke="#4a6d94" stroke-width="1.5"/>')
    avail = n.w - 2 * BOX_MARGIN
    top = n.y if n.parts else n.y + max(0.0, (n.h - n.head) / 2)  # no content: the text in the middle
    title, size = fit(str(st.get("id")), avail, FONT, bold=True)
    body.append(_text(n.x + n.w / 2, top + 18, title, size, extra=' font-weight="bold"'))
    if n.note is not None:
        note, nsize = fit(n.note, avail, SMALL_FONT)
        colour = "#a33" if n.note_error else "#666"
        body.append(_text(n.x + n.w / 2, top + 32, note, nsize, extra=f' font-style="italic" fill="{colour}"'))
    _draw_parts(n, body)
    body.append("</g>")


def _draw_parts(n: Node, body: list[str]) -> None:
    """A composite's compartments: a line under its title band, a dashed line between two regions, each region's
    name."""
    if n.parts:
        body.append(f'<line x1="{n.x:.0f}" y1="{n.y + n.head:.0f}" x2="{n.x + n.w:.0f}" '
                    f'y2="{n.y + n.head:.0f}" stroke="#4a6d94"/>')
    for i, p in enumerate(n.parts):
        if i:
            body.append(f'<line x1="{p.x:.0f}" y1="{p.y:.0f}" x2="{p.x:.0f}" y2="{p.y + p.h:.0f}" '
                        'stroke="#4a6d94" stroke-dasharray="6,4"/>')
        if p.name is not None:
            name, psize = fit(p.name, p.w - 2 * BOX_MARGIN, LABEL_FONT)
            body.append(_text(p.x + p.w / 2, p.y + 16, name, psize, extra=' font-style="italic" fill="#4a6d94"'))


def _draw_final(n: Node, attrs: str, body: list[str]) -> None:
    """A final state: a UMLet final pseudostate (a small circle, its id beside it), or a box with the icon."""
    if _small_final(n):
        _draw_pseudo_final(n, attrs, body)
        return
    st = n.doc
    cy = n.y + n.h / 2
    body.append(f'<g class="node final"{attrs}>')
    body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" '
                'fill="#eef6ee" stroke="#333" stroke-width="3"/>')
    body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="7" fill="white" stroke="#333"/>')
    body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="4" fill="#333"/>')
    left, right = n.x + FINAL_ICON, n.x + n.w - BOX_MARGIN
    text = final_text(st)
    if text_width(text, FONT - 1.5) > right - left and " → " in text and n.h >= 44:
        first, second = text.split(" → ", 1)
        a, sa = fit(first, right - left, FONT)
        b, sb = fit("→ " + second, right - left, FONT)
        size = min(sa, sb)
        body.append(_text((left + right) / 2, cy - 3, a, size))
        body.append(_text((left + right) / 2, cy + size, b, size))
    else:
        t, size = fit(text, right - left, FONT)
        body.append(_text((left + right) / 2, cy + size / 3, t, size))
    body.append("</g>")


def _draw_pseudo_final(n: Node, attrs: str, body: list[str]) -> None:
    """A UMLet final pseudostate: a bull's eye, its id beside it."""
    cx, cy = n.x + n.w / 2, n.y + n.h / 2
    r = n.w / 2
    body.append(f'<g class="pseudo"{attrs}>')
    body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{r:.1f}" fill="white" stroke="#333"/>')
    body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{max(r - 4, 2):.1f}" fill="#333"/>')
    body.append(f'<text x="{cx + r + 4:.0f}" y="{cy + 4:.0f}" fill="#555">{escape(str(n.doc.get("id")))}</text>')
    body.append("</g>")


def _draw_state(n: Node, attrs: str, body: list[str]) -> None:
    """A simple state's box: its name, and its type under it."""
    body.append(f'<g class="node"{attrs}>')
    body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" '
                'fill="#fffbe6" stroke="#333" stroke-width="1.2"/>')
    name, sub = _state_lines(n.doc)
    avail = n.w - 2 * BOX_MARGIN
    cx, cy = n.x + n.w / 2, n.y + n.h / 2
    if sub:
        t, size = fit(name, avail, FONT)
        body.append(_text(cx, cy - 2, t, size))
        t, size = fit(sub, avail, SMALL_FONT)
        body.append(_text(cx, cy + 12, t, size, extra=' fill="#666"'))
    else:
        t, size = fit(name, avail, FONT)
        body.append(_text(cx, cy + size / 3, t, size))
    body.append("</g>")


def _ends(e: Edge, prefix: str) -> str:
    """An arrow's (and its label's) ``data-from`` and ``data-to``: the state paths of its two ends (a viewer's "fit"
    shows a state with its arrows and their labels)."""
    def path(n: Node) -> str:
        return f"{prefix}/{n.id}" if prefix else n.id

    return f" data-from={quoteattr(path(e.src))} data-to={quoteattr(path(e.dst))}"


def _draw_arrows(level: LevelLayout, body: list[str], prefix: str, where: dict[int, str]) -> None:
    """The level's initial marker and arrows, in one group that names the composite they are drawn in."""
    body.append(f'<g class="level" data-in={quoteattr(prefix)}>')
    if level.marker is not None:
        mx, my = level.marker
        w, h = level.marker_size
        body.append(f'<circle cx="{mx + w / 2:.0f}" cy="{my + h / 2:.0f}" r="{min(w, h) / 2 - 2:.1f}" fill="#333"/>')
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in level.marker_points)
        body.append(f'<polyline points="{pts}" fill="none" stroke="#333" marker-end="url(#arrow)"/>')
    for e in level.edges:
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in e.points)
        dash = ' stroke-dasharray="5,3"' if e.doc.get("preempt") else ""
        body.append(f'<polyline class="edge"{_ends(e, prefix)} points="{pts}" fill="none" stroke="#333"{dash} '
                    'stroke-linejoin="round" marker-end="url(#arrow)"/>')
        where[id(e)] = prefix
    body.append("</g>")
