"""Transitions on the camera: ``ArucoGateFound`` (a gate within range) and ``ArucoMarkerFound`` (a marker id within
range: the report's "behaviour by id"). They read only ``ctx.car.camera()`` (what the detector found in pixels)
and the car's odometry, never the simulator's ground truth."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from pydantic import Field, model_validator

from fsm.loading.registry import register_transition
from fsm.model.params import TransitionParams
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.state import State

#: The blackboard variable where ArucoGateFound leaves the gate it found (odometry frame) for the next states.
GATE_VAR = "gate"
#: Gates seen so far (ArucoGateFound with `memory`, ArucoGateCenter): "left,right" ids -> pose in the odometry frame.
SEEN_VAR = "gates_seen"
#: Gates lined up with and driven through (ArucoGateCenter): a list of [left, right] ids.
PASSED_VAR = "gates_passed"
#: Defaults of the point in front of a gate, shared by ArucoGateFound and ArucoGateApproach: its distance before
#: the gate and its margin to the walls, m.
APPROACH_BEFORE = 1.0
WALL_MARGIN = 0.35


def gate_to_odometry(car: Any, gate: Any) -> dict[str, Any]:
    """A gate seen in the car frame as a blackboard entry in the odometry frame: ids, centre x/y (m), heading (rad)."""
    from fsm.sim.io import gate_in_odometry  # here, not at the top: loading a machine imports no fsm.sim

    return gate_in_odometry(car.pose(), gate)


def remember_gates(ctx: Any, view: Any) -> None:
    """Keep the latest pose (odometry frame) of every gate seen on the blackboard (`gates_seen`), so that a gate
    seen while the car was busy with another one can be driven to when it is out of view. A car with a
    ``gate_memory`` (fed on every camera frame, whatever state is active) is copied; otherwise the gates of this
    view are added, kept by the same rule (:class:`~fsm.sim.io.GateMemory`)."""
    memory = getattr(ctx.car, "gate_memory", None)
    if memory is not None:
        if memory.gates and ctx.vars.get(SEEN_VAR) != memory.gates:
            ctx.vars[SEEN_VAR] = {key: dict(entry) for key, entry in memory.gates.items()}
        return
    if view is not None and view.gates:
        from fsm.sim.io import GateMemory  # as in gate_to_odometry

        GateMemory(ctx.vars.setdefault(SEEN_VAR, {})).update(ctx.car.pose(), view.gates)


def mark_passed(ctx: Any, ids: Any) -> None:
    """Record a gate (left, right ids) as passed, so ArucoGateFound with `memory` never goes for it again."""
    if ids is None:
        return
    passed = ctx.vars.setdefault(PASSED_VAR, [])
    entry = [int(ids[0]), int(ids[1])]
    if entry not in passed:
        passed.append(entry)


def was_passed(ctx: Any, ids: Any) -> bool:
    return [int(ids[0]), int(ids[1])] in ctx.vars.get(PASSED_VAR, [])


class RememberedGate:
    """A gate from the blackboard (`gates_seen`) in the car frame: what ArucoGateFound hands on, like a seen Gate."""

    __slots__ = ("ids", "center", "heading", "width")

    def __init__(self, car: Any, entry: dict[str, Any]) -> None:
        x, y, th = car.pose()
        dx, dy = entry["x"] - x, entry["y"] - y
        c, s = math.cos(th), math.sin(th)
        self.ids = (int(entry["ids"][0]), int(entry["ids"][1]))
        self.center = (c * dx + s * dy, -s * dx + c * dy)
        h = entry["heading"] - th
        self.heading = math.atan2(math.sin(h), math.cos(h))
        self.width = float(entry.get("width") or 0.0)  # 0: not measured (an entry written by an older car)

    @property
    def distance(self) -> float:
        return math.hypot(*self.center)

    def point_before(self, distance: float = 1.0) -> tuple[float, float]:
        return (self.center[0] - distance * math.cos(self.heading),
                self.center[1] - distance * math.sin(self.heading))


def select_gate(view: Any, ids: Sequence[int] | None, skip: Any = None) -> Any | None:
    """The nearest gate of a camera view (with the given left/right ids, when given; without ids, the nearest one
    for which ``skip(ids)`` is not true)."""
    if view is None:
        return None
    if ids is None:
        for g in view.gates:
            if skip is None or not skip(g.ids):
                return g
        return None
    for g in view.gates:
        if tuple(g.ids) == tuple(ids):
            return g
    left, right = view.marker(ids[0]), view.marker(ids[1])
    if left is None or right is None:
        return None
    from fsm.vision.gates import Gate  # the default pairing may have matched these markers otherwise

    return Gate.from_markers(left, right)


def clamp_to_walls(car: Any, x: float, y: float, margin: float, keep: tuple[float, float] | None = None,
                   corridor: float = 0.0) -> tuple[float, float]:
    """A point (car frame, x ahead, y left) kept ``margin`` inside the walls the side sensors read now; readings
    at the sensor's maximum are no wall. ``corridor``: the walls' direction in the car frame (rad; 0: the car
    drives along them): the readings are turned into distances square to the walls, and the point is moved
    square to them. ``keep``: a point known to lie in the corridor (a gate's centre): the point is never moved
    past it across the corridor (when the walls' direction is only assumed, the readings describe the walls
    beside the car, not metres ahead)."""
    if margin <= 0:
        return x, y
    c, s = math.cos(corridor), math.sin(corridor)
    u, v = x * c + y * s, -x * s + y * c  # along and across the corridor
    kv = None if keep is None else -keep[0] * s + keep[1] * c
    square = abs(c)
    top = max(0.0, car.left * square - margin) if car.left < 2.9 else None
    bottom = -max(0.0, car.right * square - margin) if car.right < 2.9 else None
    if top is not None and v > top:
        v = top if kv is None else max(top, min(v, kv))
    if bottom is not None and v < bottom:
        v = bottom if kv is None else min(bottom, max(v, kv))
    return u * c - v * s, u * s + v * c


def snap_heading(heading: float, snap: float) -> float:
    """``heading`` (rad, odometry) rounded to a multiple of ``snap`` degrees from the start heading: the corridor's
    direction in a loop whose corridors all are (90 in a rectangular one)."""
    step = math.radians(snap)
    return round(heading / step) * step


def approach_point(car: Any, gate: Any, before: float, margin: float, snap: float | None) -> tuple[float, float]:
    """The point ``before`` m in front of ``gate`` (car frame), kept ``margin`` inside the walls the side sensors
    read (:func:`clamp_to_walls`); ``snap``: the walls run along multiples of this many degrees from the start
    heading (odometry), else along the car."""
    px, py = gate.point_before(before)
    corridor = 0.0
    if snap is not None:
        th = car.pose()[2]
        corridor = snap_heading(th, snap) - th
        corridor = math.atan2(math.sin(corridor), math.cos(corridor))
    return clamp_to_walls(car, px, py, margin, keep=gate.center, corridor=corridor)


class ArucoGateFoundParams(TransitionParams):
    ids: list[int] | None = Field(default=None, min_length=2, max_length=2,
                                  description="Left and right marker id of the gate "
                                              "(default: any two markers a gate width apart).")
    range: float = Field(default=2.5, gt=0, le=20, description="Fire when the gate centre is this near, m.")
    min_range: float = Field(default=0.0, ge=0, le=20, description="... and at least this far, m.")
    max_angle: float = Field(default=60.0, gt=0, le=90,
                             description="Only gates the car faces: |gate heading| at most this, degrees.")
    before: float = Field(default=APPROACH_BEFORE, ge=0, le=5,
                          description="Distance of the approach point handed to the target, in front of the "
                                      "gate on its centre line, m.")
    frames: int = Field(default=2, ge=1, le=100, description="Consecutive camera frames the gate must be seen in.")
    wall_margin: float = Field(
        default=WALL_MARGIN, ge=0, le=3,
        description="Keep the handed point at least this far from the walls the side ultrasonic sensors see "
                    "(a gate turned towards a wall would put it into the wall), but never past the gate's centre (the "
                    "readings describe the walls beside the car, not metres ahead), m; 0: off.")
    snap: float | None = Field(
        default=None, gt=0, le=180,
        description="The walls run along a multiple of this many degrees from the start heading (90 in a "
                    "rectangular loop): the wall margin is then kept square to them, also when the car is turned "
                    "(default: the car is taken to drive along the walls).")
    memory: bool = Field(
        default=False,
        description="Remember gates (odometry): skip gates already passed, and fire at once on a gate seen "
                    "earlier, not passed and now out of view, that lies ahead within range.")

    @model_validator(mode="after")
    def _range(self) -> ArucoGateFoundParams:
        if self.ids is not None and self.ids[0] == self.ids[1]:
            raise ValueError("a gate needs two different marker ids")
        if self.min_range >= self.range:
            raise ValueError(f"min_range ({self.min_range}) must be below range ({self.range})")
        return self


class ArucoMarkerFoundParams(TransitionParams):
    marker: int = Field(ge=0, le=4095, description="ArUco id of the marker.")
    range: float = Field(default=1.5, gt=0, le=20, description="Fire when the marker is this near (from the "
                                                               "car's centre, horizontally), m.")
    frames: int = Field(default=2, ge=1, le=100, description="Consecutive camera frames the marker must be seen in.")


class ArucoMarkerUnpairedParams(TransitionParams):
    range: float = Field(default=4.5, gt=0, le=20, description="Only markers this near (from the car's centre, "
                                                               "horizontally), m.")
    frames: int = Field(default=2, ge=1, le=100, description="Consecutive camera frames the marker must be seen in.")


#: The parameters of a camera transition: each has `frames`.
CP = TypeVar("CP", bound=ArucoGateFoundParams | ArucoMarkerFoundParams | ArucoMarkerUnpairedParams)


class _CameraTransition(Transition[CP]):
    __slots__ = ("_frame", "_count")
    needs_car = True

    def __init__(self, params: CP, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self._frame = -1
        self._count = 0

    def on_source_enter(self, ctx: Context) -> None:
        self._frame = -1
        self._count = 0

    def holds(self, ctx: Context) -> bool:
        view = ctx.car.camera()
        if view is None or view.frame == self._frame:
            return self._count >= self.params.frames
        self._frame = view.frame
        self._count = self._count + 1 if self.seen(view, ctx) else 0
        return self._count >= self.params.frames

    def seen(self, view: Any, ctx: Context) -> bool:
        raise NotImplementedError


@register_transition
class ArucoGateFound(_CameraTransition[ArucoGateFoundParams]):
    """Fires when the camera sees a gate (two markers; with `ids`, that gate) whose centre is within `range` and which the car faces (|heading| <= `max_angle`), in `frames` frames in a row. Hands the target state (ApproachPoint) the point `before` metres in front of the gate, and leaves the gate on the blackboard (`gate`, odometry frame) for ArucoGateCenter. With `memory`, gates already passed (ArucoGateCenter marks them) are never chosen again, and a gate seen earlier but now out of the camera's view (e.g. while the car was busy with the gate before it) fires at once when it lies ahead within range, its centre at least `before` (and 0.5 m) ahead. Gates are remembered from every camera frame (the car's `gate_memory`), whatever state is active."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_gate",)
    Params = ArucoGateFoundParams

    def __init__(self, params: ArucoGateFoundParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self._gate: Any = None

    def holds(self, ctx: Context) -> bool:
        if not self.params.memory:
            return super().holds(ctx)
        view = ctx.car.camera()
        if view is not None and view.frame != self._frame:
            remember_gates(ctx, view)
        if super().holds(ctx):
            return True
        gate = self._remembered(ctx)
        if gate is None:
            return False
        self._gate = gate
        return True

    def _usable(self, gate: Any) -> bool:
        p = self.params
        return (gate is not None and p.min_range <= gate.distance <= p.range
                and abs(gate.heading) <= math.radians(p.max_angle))

    def _remembered(self, ctx: Context) -> Any | None:
        """The nearest gate seen earlier, not passed, within range and at least `before` (0.5 m at least) ahead:
        nearer than its approach point the car may still line up with it (ArucoGateCenter backs off when not)."""
        p = self.params
        best = None
        for entry in ctx.vars.get(SEEN_VAR, {}).values():
            if was_passed(ctx, entry["ids"]) or (p.ids is not None
                                                 and list(p.ids) != list(entry["ids"])):
                continue
            gate = RememberedGate(ctx.car, entry)
            if self._usable(gate) and gate.center[0] >= max(p.before, 0.5):
                if best is None or gate.distance < best.distance:
                    best = gate
        return best

    def seen(self, view: Any, ctx: Context) -> bool:
        p = self.params
        skip = (lambda ids: was_passed(ctx, ids)) if p.memory else None
        gate = select_gate(view, p.ids, skip)
        if gate is not None and skip is not None and skip(gate.ids):
            gate = None
        ok = self._usable(gate)
        self._gate = gate if ok else None
        return ok

    def action(self, ctx: Context) -> None:
        gate = self._gate
        if gate is None:
            return
        found = gate_to_odometry(ctx.car, gate)
        found["approach_heading"] = ctx.car.pose()[2]  # the corridor's direction, for AlignHeading after the gate
        ctx.vars[GATE_VAR] = found
        setter = getattr(self.target, "set_target", None)
        if setter is not None and getattr(self.target, "accepts_target", False):
            p = self.params
            px, py = approach_point(ctx.car, gate, p.before, p.wall_margin, p.snap)
            setter(ctx, px, py, gate.heading)


@register_transition
class ArucoMarkerFound(_CameraTransition[ArucoMarkerFoundParams]):
    """Fires when the camera sees the marker with id `marker` within `range` metres, in `frames` frames in a row (the report's "behaviour by id": one transition per id)."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ()
    Params = ArucoMarkerFoundParams

    def seen(self, view: Any, ctx: Context) -> bool:
        d = view.marker(self.params.marker)
        return d is not None and d.distance <= self.params.range


@register_transition
class ArucoMarkerUnpaired(_CameraTransition[ArucoMarkerUnpairedParams]):
    """Fires when the camera sees, within `range`, a marker that makes no gate with another marker in view and belongs to no gate seen before or passed, in `frames` frames in a row: one post of a gate whose other post is out of the camera's view (near a wall, at the edge of the field of view), so the gate has never been seen whole. Route it to a state that gives the camera a wider look (backing off)."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ()
    Params = ArucoMarkerUnpairedParams

    def seen(self, view: Any, ctx: Context) -> bool:
        remember_gates(ctx, view)
        known = {int(i) for g in view.gates for i in g.ids}
        known.update(int(i) for entry in ctx.vars.get(SEEN_VAR, {}).values() for i in entry["ids"])
        known.update(int(i) for ids in ctx.vars.get(PASSED_VAR, []) for i in ids)
        return any(d.id not in known and d.distance <= self.params.range
                   for d in view.detections)
