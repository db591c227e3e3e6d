"""ArUco gates: two markers side by side; the car drives between them.

A gate's pose comes from the *positions* of its two markers, never from one marker's rotation (that
rotation flips beyond about 2 m, the planar ambiguity of ``solvePnP``): the centre is their midpoint, the
width their distance, and the heading is the direction to drive through, perpendicular to the line
from the right to the left marker. All in the car frame (x forward, y left, m; heading in rad, 0 =
straight ahead, left positive), so a heading of 0 means the car is square to the gate.

Which markers make a gate (:class:`GateRule`): given ``pairs`` of ``(left id, right id)`` (a world's
gates, or a diagram that names its gate), only those. Otherwise any two markers whose distance is a
plausible gate width (``min_width`` .. ``max_width``), nearest pairs first, each marker in one gate
at most; left is the marker on the left as seen from the car, so the heading points away from it.
``ids`` restricts which markers may be gate posts (e.g. to keep signal markers 5 and 7 out).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from fsm.vision.detector import Detection


@dataclass(frozen=True, slots=True)
class GateRule:
    """How detected markers are paired into gates (see the module docstring)."""

    pairs: Sequence[tuple[int, int]] | None = None
    ids: Collection[int] | None = None
    min_width: float = 0.3
    max_width: float = 1.5

    def __post_init__(self) -> None:
        for left, right in self.pairs or ():
            if left == right:
                raise ValueError(f"a gate needs two different marker ids, got ({left}, {right})")
        if not 0 <= self.min_width < self.max_width:
            raise ValueError(f"need 0 <= min_width < max_width, got {self.min_width}, {self.max_width}")


@dataclass(frozen=True, slots=True)
class Gate:
    """A gate seen from the car: its two markers and its pose in the car frame."""

    left: Detection
    right: Detection
    center: tuple[float, float]
    heading: float
    width: float

    @classmethod
    def from_markers(cls, left: Detection, right: Detection) -> Gate:
        lx, ly = left.position[0], left.position[1]
        rx, ry = right.position[0], right.position[1]
        vx, vy = lx - rx, ly - ry
        width = math.hypot(vx, vy)
        return cls(left, right, ((lx + rx) / 2, (ly + ry) / 2), math.atan2(-vx, vy), width)

    @property
    def ids(self) -> tuple[int, int]:
        return self.left.id, self.right.id

    @property
    def distance(self) -> float:
        """Horizontal distance from the car frame's origin to the gate centre, m."""
        return math.hypot(*self.center)

    @property
    def bearing(self) -> float:
        return math.atan2(self.center[1], self.center[0])

    def point_before(self, distance: float = 1.0) -> tuple[float, float]:
        """The point ``distance`` metres in front of the gate on its centre line (the report's approach point)."""
        return (self.center[0] - distance * math.cos(self.heading),
                self.center[1] - distance * math.sin(self.heading))

    def offset(self) -> float:
        """Signed distance of the car frame's origin from the gate's centre line, m (positive: the car is
        left of the line, looking through the gate)."""
        cx, cy = self.center
        return -(-cx * math.sin(self.heading) + cy * math.cos(self.heading))

    def to_dict(self) -> dict[str, Any]:
        return {"ids": list(self.ids), "center": [round(v, 4) for v in self.center],
                "heading_deg": round(math.degrees(self.heading), 3), "width": round(self.width, 4),
                "distance": round(self.distance, 4), "bearing_deg": round(math.degrees(self.bearing), 3)}


def find_gates(detections: Iterable[Detection], rule: GateRule | None = None) -> list[Gate]:
    """The gates among ``detections``, nearest first."""
    rule = rule or GateRule()
    markers = [d for d in detections if rule.ids is None or d.id in rule.ids]
    gates: list[Gate] = []
    if rule.pairs is not None:
        by_id: dict[int, Detection] = {}
        for d in markers:  # a duplicated id: keep the nearer one
            if d.id not in by_id or d.distance < by_id[d.id].distance:
                by_id[d.id] = d
        for left_id, right_id in rule.pairs:
            if left_id in by_id and right_id in by_id:
                gates.append(Gate.from_markers(by_id[left_id], by_id[right_id]))
    else:
        candidates = []
        for i, a in enumerate(markers):
            for b in markers[i + 1:]:
                sep = math.hypot(a.position[0] - b.position[0], a.position[1] - b.position[1])
                if rule.min_width <= sep <= rule.max_width:
                    candidates.append((sep, a, b))
        candidates.sort(key=lambda c: c[0])
        used: set[int] = set()
        for _sep, a, b in candidates:
            if id(a) in used or id(b) in used:
                continue
            used.update((id(a), id(b)))
            # left is the marker further counter-clockwise as seen from the car
            cross = a.position[0] * b.position[1] - a.position[1] * b.position[0]
            left, right = (b, a) if cross > 0 else (a, b)
            gates.append(Gate.from_markers(left, right))
    gates.sort(key=lambda g: g.distance)
    return gates
