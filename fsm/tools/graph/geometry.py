"""Plane geometry that the layout (routing arrows around boxes), the SVG renderer (placing labels) and the drawing's
quality metric share: a segment against a box, and two segments against each other. Boxes are ``(x, y, w, h)``,
segments ``(x0, y0, x1, y1)``."""

from __future__ import annotations

import math

Box = tuple[float, float, float, float]
Segment = tuple[float, float, float, float]

#: How close two labels of different arrows may stand before they seem to belong together (the label placer keeps
#: them this far apart where it can, the quality metric counts the pairs that are closer).
LABEL_GAP = 10.0
#: How close two parallel runs of different arrows may be (the router keeps its lanes this far apart, the metric
#: counts the runs that are closer).
SPACING = 16.0


def segment_hits_box(x0: float, y0: float, x1: float, y1: float, box: Box, shrink: float = 0.0) -> bool:
    """Whether the segment from (x0, y0) to (x1, y1) passes through the inside of ``box`` shrunk by ``shrink`` on
    every side (Liang-Barsky clipping; running along an edge or touching a corner does not count)."""
    x, y, w, h = box[0] + shrink, box[1] + shrink, box[2] - 2 * shrink, box[3] - 2 * shrink
    if w <= 0 or h <= 0:
        return False
    dx, dy = x1 - x0, y1 - y0
    lo, hi = 0.0, 1.0
    for p, q in ((-dx, x0 - x), (dx, x + w - x0), (-dy, y0 - y), (dy, y + h - y0)):
        if p == 0:
            if q <= 0:
                return False
            continue
        t = q / p
        if p < 0:
            lo = max(lo, t)
        else:
            hi = min(hi, t)
        if lo >= hi:
            return False
    return True


def segments_cross(a: Segment, b: Segment) -> bool:
    """Whether two segments cross (touching ends, or lying on one line, do not count)."""
    if max(a[0], a[2]) < min(b[0], b[2]) or max(b[0], b[2]) < min(a[0], a[2]) \
            or max(a[1], a[3]) < min(b[1], b[3]) or max(b[1], b[3]) < min(a[1], a[3]):
        return False
    return (_orient(b, a[0], a[1]) * _orient(b, a[2], a[3]) < 0
            and _orient(a, b[0], b[1]) * _orient(a, b[2], b[3]) < 0)


def parallel_gap(a: Segment, b: Segment, run: float) -> float:
    """How far apart two parallel segments run side by side for more than ``run`` (infinity when they are not
    parallel, or do not run side by side that long)."""
    ax, ay, bx, by = a
    dx, dy = bx - ax, by - ay
    la, lb = math.hypot(dx, dy), math.hypot(b[2] - b[0], b[3] - b[1])
    if la < 1e-9 or lb < 1e-9 or abs(dx * (b[3] - b[1]) - dy * (b[2] - b[0])) > 0.05 * la * lb:
        return math.inf
    t0 = ((b[0] - ax) * dx + (b[1] - ay) * dy) / la
    t1 = ((b[2] - ax) * dx + (b[3] - ay) * dy) / la
    if min(la, max(t0, t1)) - max(0.0, min(t0, t1)) <= run:
        return math.inf
    return min(abs(dx * (py - ay) - dy * (px - ax)) / la for px, py in ((b[0], b[1]), (b[2], b[3])))


def _orient(s: Segment, x: float, y: float) -> float:
    """Which side of the line through ``s`` the point is on (the sign of the cross product)."""
    return (s[2] - s[0]) * (y - s[1]) - (s[3] - s[1]) * (x - s[0])


__all__ = ["LABEL_GAP", "SPACING", "Box", "Segment", "parallel_gap", "segment_hits_box", "segments_cross"]
