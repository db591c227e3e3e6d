"""Diagram geometry for a machine document: the stored ``layout`` where there is one, a layered layout elsewhere.

Used by ``fsmctl export`` (UMLet) and ``fsmctl graph --format svg``. Coordinates are UMLet pixels at zoom 10.
Boxes of one level never come closer than ``GAP`` so that arrow ends attach to exactly one box again.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

GRID = 10
GAP_X, GAP_Y = 80, 80
PAD, PAD_TOP = 30, 50
MARKER = 20


@dataclass(eq=False)
class Node:
    doc: dict[str, Any]
    x: float = 0
    y: float = 0
    w: float = 120
    h: float = 40
    sub: LevelLayout | None = None
    placed: bool = False

    @property
    def id(self) -> str:
        return str(self.doc.get("id", ""))


@dataclass(eq=False)
class Edge:
    doc: dict[str, Any]
    src: Node
    dst: Node
    points: list[list[float]] = field(default_factory=list)


@dataclass(eq=False)
class LevelLayout:
    machine: dict[str, Any]
    nodes: list[Node]
    edges: list[Edge]
    marker: tuple[float, float] | None = None
    marker_points: list[list[float]] = field(default_factory=list)
    initial: Node | None = None
    marker_size: tuple[float, float] = (MARKER, MARKER)

    def bbox(self) -> tuple[float, float, float, float]:
        xs0 = [n.x for n in self.nodes] + ([self.marker[0]] if self.marker else [])
        ys0 = [n.y for n in self.nodes] + ([self.marker[1]] if self.marker else [])
        xs1 = [n.x + n.w for n in self.nodes] + ([self.marker[0] + MARKER] if self.marker else [])
        ys1 = [n.y + n.h for n in self.nodes] + ([self.marker[1] + MARKER] if self.marker else [])
        for e in self.edges:
            for px, py in e.points:
                xs0.append(px - 10)
                xs1.append(px + 10)
                ys0.append(py)
                ys1.append(py)
        if not xs0:
            return 0, 0, 0, 0
        return min(xs0), min(ys0), max(xs1), max(ys1)

    def shift(self, dx: float, dy: float) -> None:
        for n in self.nodes:
            n.x += dx
            n.y += dy
            if n.sub is not None:
                n.sub.shift(dx, dy)
        for e in self.edges:
            e.points = [[px + dx, py + dy] for px, py in e.points]
        if self.marker:
            self.marker = (self.marker[0] + dx, self.marker[1] + dy)
        self.marker_points = [[px + dx, py + dy] for px, py in self.marker_points]


def _snap(v: float) -> float:
    return math.ceil(v / GRID) * GRID


def text_size(lines: list[str]) -> tuple[float, float]:
    width = max((len(ln) for ln in lines), default=4)
    return max(120.0, _snap(width * 8 + 30)), max(40.0, _snap(len(lines) * 16 + 20))


def inline_machine(state: dict[str, Any]) -> dict[str, Any] | None:
    m = state.get("machine")
    if state.get("type") == "FSMState" and isinstance(m, dict) and "file" not in m and isinstance(m.get("states"), list):
        return m
    return None


def lay_out(machine: dict[str, Any], label_lines: Any) -> LevelLayout:
    """Positions for every state, initial marker and transition of ``machine`` and its inline sub-machines.

    ``label_lines(state)`` gives the text lines a state box shows (for its size).
    """
    nodes = []
    by_id: dict[str, Node] = {}
    for st in machine.get("states", []):
        if not isinstance(st, dict):
            continue
        node = Node(st)
        sub = inline_machine(st)
        if sub is not None:
            node.sub = lay_out(sub, label_lines)
        lay = st.get("layout") if isinstance(st.get("layout"), dict) else {}
        if all(isinstance(lay.get(k), (int, float)) for k in "xywh"):
            node.x, node.y, node.w, node.h = float(lay["x"]), float(lay["y"]), float(lay["w"]), float(lay["h"])
            node.placed = True
        else:
            node.w, node.h = text_size(label_lines(st))
        by_id.setdefault(node.id, node)
        nodes.append(node)
    level = LevelLayout(machine, nodes, [])
    level.initial = by_id.get(str(machine.get("initial")))
    _place(level, by_id)
    _fit_composites(level)
    for tr in machine.get("transitions", []):
        if not isinstance(tr, dict):
            continue
        src, dst = by_id.get(str(tr.get("from"))), by_id.get(str(tr.get("to")))
        if src is None or dst is None:
            continue
        level.edges.append(Edge(tr, src, dst))
    _route(level)
    return level


def _place(level: LevelLayout, by_id: dict[str, Node]) -> None:
    """Layered placement (breadth-first from the initial state) of the nodes without a stored layout."""
    todo = [n for n in level.nodes if not n.placed]
    for n in todo:  # composites without a layout: size from their content
        if n.sub is not None:
            x0, y0, x1, y1 = n.sub.bbox()
            n.w = max(n.w, _snap(x1 - x0 + 2 * PAD))
            n.h = max(n.h, _snap(y1 - y0 + PAD + PAD_TOP))
    if todo:
        depth: dict[str, int] = {}
        if level.initial is not None:
            depth[level.initial.id] = 0
            queue = deque([level.initial.id])
            edges: dict[str, list[str]] = {}
            for tr in level.machine.get("transitions", []):
                if isinstance(tr, dict):
                    edges.setdefault(str(tr.get("from")), []).append(str(tr.get("to")))
            while queue:
                cur = queue.popleft()
                for nxt in edges.get(cur, []):
                    if nxt not in depth and nxt in by_id:
                        depth[nxt] = depth[cur] + 1
                        queue.append(nxt)
        placed = [n for n in level.nodes if n.placed]
        top = max((n.y + n.h for n in placed), default=-GAP_Y) + GAP_Y
        top = max(top, MARKER + 40)
        rows: dict[int, list[Node]] = {}
        last = max(depth.values(), default=0) + 1
        for n in todo:
            rows.setdefault(depth.get(n.id, last), []).append(n)
        y = top
        left = min((n.x for n in placed), default=0.0)
        for r in sorted(rows):
            x = left
            for n in rows[r]:
                n.x, n.y = x, y
                if n.sub is not None:
                    x0, y0, _, _ = n.sub.bbox()
                    n.sub.shift(n.x + PAD - x0, n.y + PAD_TOP - y0)
                n.placed = True
                x += n.w + GAP_X
            y += max(n.h for n in rows[r]) + GAP_Y
    lay = level.machine.get("layout") if isinstance(level.machine.get("layout"), dict) else {}
    ini = lay.get("initial") if isinstance(lay.get("initial"), dict) else {}
    if level.initial is not None:
        if isinstance(ini.get("x"), (int, float)) and isinstance(ini.get("y"), (int, float)) and level.initial.placed \
                and all(n.placed for n in level.nodes) and not todo:
            level.marker = (float(ini["x"]), float(ini["y"]))
            if isinstance(ini.get("w"), (int, float)) and isinstance(ini.get("h"), (int, float)):
                level.marker_size = (float(ini["w"]), float(ini["h"]))
            pts = ini.get("points")
            if isinstance(pts, list) and len(pts) >= 2 and all(_is_point(p) for p in pts):
                level.marker_points = [[float(p[0]), float(p[1])] for p in pts]
        else:
            n = level.initial
            level.marker = (n.x + n.w / 2 - MARKER / 2, n.y - MARKER - 40)
        if not level.marker_points:
            mx, my = level.marker
            level.marker_points = _connect((mx, my, MARKER, MARKER), (level.initial.x, level.initial.y,
                                                                         level.initial.w, level.initial.h), 0)


def _fit_composites(level: LevelLayout) -> None:
    """A composite box must hold its content with a margin; grow it when it does not (never shrink it)."""
    for n in level.nodes:
        if n.sub is None or not n.sub.nodes:
            continue
        x0, y0, x1, y1 = _node_bbox(n.sub)
        if x0 < n.x or y0 < n.y:
            n.sub.shift(max(0, n.x + PAD - x0), max(0, n.y + PAD_TOP - y0))
            x0, y0, x1, y1 = _node_bbox(n.sub)
        if x1 > n.x + n.w:
            n.w = _snap(x1 - n.x + PAD)
        if y1 > n.y + n.h:
            n.h = _snap(y1 - n.y + PAD)


def _node_bbox(level: LevelLayout) -> tuple[float, float, float, float]:
    xs = [n.x for n in level.nodes] + ([level.marker[0]] if level.marker else [])
    ys = [n.y for n in level.nodes] + ([level.marker[1]] if level.marker else [])
    xe = [n.x + n.w for n in level.nodes] + ([level.marker[0] + MARKER] if level.marker else [])
    ye = [n.y + n.h for n in level.nodes] + ([level.marker[1] + MARKER] if level.marker else [])
    return min(xs), min(ys), max(xe), max(ye)


def _is_point(p: Any) -> bool:
    return isinstance(p, list) and len(p) == 2 and all(isinstance(v, (int, float)) for v in p)


def _route(level: LevelLayout) -> None:
    pair_count: dict[tuple[int, int], int] = {}
    for e in level.edges:
        lay = e.doc.get("layout") if isinstance(e.doc.get("layout"), dict) else {}
        pts = lay.get("points")
        if e.src.placed and e.dst.placed and isinstance(pts, list) and len(pts) >= 2 and all(_is_point(p) for p in pts) \
                and _stored(e.src) and _stored(e.dst):
            e.points = [[float(p[0]), float(p[1])] for p in pts]
            continue
        key = (min(id(e.src), id(e.dst)), max(id(e.src), id(e.dst)))
        k = pair_count.get(key, 0)
        pair_count[key] = k + 1
        a = (e.src.x, e.src.y, e.src.w, e.src.h)
        if e.src is e.dst:
            x, y, w, h = a
            off = 12 * k
            cy = y + h / 2
            e.points = [[x + w, cy - 8 - off / 2], [x + w + 40 + off, cy - 8 - off / 2],
                        [x + w + 40 + off, cy + 8 + off / 2], [x + w, cy + 8 + off / 2]]
        else:
            e.points = _connect(a, (e.dst.x, e.dst.y, e.dst.w, e.dst.h), k)


def _stored(n: Node) -> bool:
    lay = n.doc.get("layout")
    return isinstance(lay, dict) and all(isinstance(lay.get(k), (int, float)) for k in "xywh")


def _connect(a: tuple[float, float, float, float], b: tuple[float, float, float, float],
             k: int) -> list[list[float]]:
    """A straight arrow from box ``a``'s border to box ``b``'s border; the ``k``-th parallel one is offset."""
    ax, ay = a[0] + a[2] / 2, a[1] + a[3] / 2
    bx, by = b[0] + b[2] / 2, b[1] + b[3] / 2
    dx, dy = bx - ax, by - ay
    length = math.hypot(dx, dy) or 1.0
    nx, ny = -dy / length, dx / length
    off = (k + 1) // 2 * 14 * (1 if k % 2 else -1) if k else 0
    lim = min(a[2], a[3], b[2], b[3]) / 2 - 4
    off = max(-lim, min(lim, off))
    sx, sy = ax + nx * off, ay + ny * off
    tx, ty = bx + nx * off, by + ny * off
    p = _exit_point(a, sx, sy, tx, ty)
    q = _exit_point(b, tx, ty, sx, sy)
    return [[round(p[0]), round(p[1])], [round(q[0]), round(q[1])]]


def _exit_point(box: tuple[float, float, float, float], x: float, y: float, tx: float, ty: float) -> tuple[float, float]:
    """Where the segment from (x, y) inside ``box`` towards (tx, ty) leaves the box."""
    bx, by, bw, bh = box
    dx, dy = tx - x, ty - y
    t = 1.0
    if dx > 0:
        t = min(t, (bx + bw - x) / dx)
    elif dx < 0:
        t = min(t, (bx - x) / dx)
    if dy > 0:
        t = min(t, (by + bh - y) / dy)
    elif dy < 0:
        t = min(t, (by - y) / dy)
    return x + dx * t, y + dy * t
