"""States on the camera: ``ArucoGateApproach`` drives to the point in front of a gate, refining it as the gate comes
nearer; ``ArucoGateCenter`` lines the car up with a gate (square to it and centred) before ``Motor`` drives through.
It reads only ``ctx.car.camera()`` and odometry (``ctx.car.pose()``), never ground truth."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from pydantic import Field

from fsm.loading.registry import register_state
from fsm.model.params import StateParams
from fsm.transitions.markers import (
    APPROACH_BEFORE,
    GATE_VAR,
    WALL_MARGIN,
    approach_point,
    gate_to_odometry,
    mark_passed,
    remember_gates,
    select_gate,
    snap_heading,
)

from .driving import ApproachParams, ApproachPoint, CarState, clamp

if TYPE_CHECKING:
    from fsm.runtime.context import Context


def update_gate_var(ctx: Any, gate: Any) -> dict[str, Any]:
    """A fresh sighting of the gate being driven to replaces `gate` on the blackboard (odometry frame), keeping
    the corridor heading ArucoGateFound recorded for AlignHeading."""
    known = ctx.vars.get(GATE_VAR)
    fresh = gate_to_odometry(ctx.car, gate)
    if isinstance(known, dict) and "approach_heading" in known:
        fresh["approach_heading"] = known["approach_heading"]
    ctx.vars[GATE_VAR] = fresh
    return fresh


class GateApproachParams(ApproachParams):
    before: float = Field(default=APPROACH_BEFORE, ge=0, le=5,
                          description="The point to reach lies this far in front of the gate on its centre line, m "
                                      "(as ArucoGateFound's `before`).")
    wall_margin: float = Field(default=WALL_MARGIN, ge=0, le=3,
                               description="Keep the point this far from the walls the side sensors see (as "
                                           "ArucoGateFound's), m; 0: off.")
    snap: float | None = Field(default=None, gt=0, le=180,
                               description="The walls run along a multiple of this many degrees from the start "
                                           "heading (as ArucoGateFound's `snap`).")
    refine: float = Field(default=0.6, ge=0, le=5,
                          description="Refine the point from new camera frames while it is at least this far ahead, "
                                      "m (nearer, the gate leaves the camera's view and the last point is kept).")


@register_state
class ArucoGateApproach(ApproachPoint[GateApproachParams]):
    """Drives to the point `before` m in front of the gate ArucoGateFound found (handed by it, like ApproachPoint), and moves that point each time the camera sees the gate again while the point is still `refine` m ahead: a gate first seen 4 m away has a rough pose (its heading may be 10 degrees off), which gets better as the car comes nearer. The fresh pose also replaces `gate` on the blackboard for ArucoGateCenter. Finishes on arrival, or `missed` when the point falls behind."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_frame", "_ids")
    Params = GateApproachParams

    def __init__(self, id: str, params: GateApproachParams | None = None) -> None:
        super().__init__(id, params)
        self._frame = -1
        self._ids: tuple[int, ...] | None = None

    def on_enter(self, ctx: Context) -> None:
        super().on_enter(ctx)
        known = ctx.vars.get(GATE_VAR)
        self._ids = tuple(known["ids"]) if isinstance(known, dict) and known.get("ids") else None
        self._frame = -1

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        view = car.camera()
        if self._ids is not None and self._tx == self._tx and view is not None and view.frame != self._frame:
            self._frame = view.frame
            remember_gates(ctx, view)
            gate = select_gate(view, self._ids)
            if gate is not None and abs(gate.heading) < math.radians(80):
                p = self.params
                px, py = approach_point(car, gate, p.before, p.wall_margin, p.snap)
                if px >= p.refine:
                    self.aim(ctx, px, py)
                    update_gate_var(ctx, gate)
        super().tick(ctx)


class GateCenterParams(StateParams):
    ids: tuple[int, int] | None = Field(default=None, description="Left and right marker id of the gate (default: the "
                                                                  "gate ArucoGateFound found, else the nearest).")
    speed: float = Field(default=0.4, gt=0, le=2.0, description="Speed while lining up, m/s.")
    lookahead: float = Field(default=0.45, gt=0.05, le=5.0,
                             description="Steers towards the gate's centre line this far ahead, m.")
    angle: float = Field(default=3.0, gt=0, le=45, description="Aligned when the heading is within this of the "
                                                               "gate's, degrees.")
    offset: float = Field(default=0.04, gt=0, le=1.0, description="... and the car within this of the centre line, m.")
    near: float = Field(default=0.9, gt=0, le=5.0,
                        description="Finish aligned only this near the gate, m (so Motor's straight run through it "
                                    "is short and the remaining error small).")
    min_distance: float = Field(default=0.4, ge=0, le=5.0,
                                description="Finish (outcome `close`) when this near the gate without being "
                                            "aligned, m (Motor drives on from there).")
    clearance: float = Field(default=0.15, ge=0, le=1.0,
                             description="At `min_distance`: when the car, driving straight on, would cross the gate "
                                         "line nearer a post than this (m, from its centre: half the car's width "
                                         "and a margin), finish `wide` instead of `close`, so that the diagram can "
                                         "back off and line up again; 0: never.")


@register_state
class ArucoGateCenter(CarState[GateCenterParams]):
    """Lines the car up with a gate: drives slowly along the gate's centre line (pure pursuit on it, from camera and odometry) until it is square to the gate and centred, then finishes (`succeeded`); `close` when it got near the gate first, `wide` when it got near so far off the centre line that driving on would hit a post (the gate's width is measured by the camera; route it to a short reverse and back here), `lost` when it never had a gate. Finishing (`succeeded` or `close`) marks the gate passed on the blackboard (`gates_passed`), and every gate it sees is remembered (`gates_seen`) for ArucoGateFound with `memory`."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_gate", "_frame", "_ids")
    Params = GateCenterParams
    can_finish = True
    outcomes = ("succeeded", "close", "wide", "lost")
    accepts_target = True

    def __init__(self, id: str, params: GateCenterParams | None = None) -> None:
        super().__init__(id, params)
        self._gate: dict[str, Any] | None = None
        self._frame = -1
        self._ids: tuple[int, ...] | None = None

    def set_target(self, ctx: Context, x: float, y: float, heading: float | None = None) -> None:
        """A point on the gate's centre line (car frame) and the gate's heading: the line to line up with."""
        if heading is None:
            return
        px, py, th = ctx.car.pose()
        c, s = math.cos(th), math.sin(th)
        self._gate = {"ids": None, "x": px + c * x - s * y, "y": py + s * x + c * y, "heading": th + heading}

    def on_enter(self, ctx: Context) -> None:
        p = self.params
        known = ctx.vars.get(GATE_VAR)
        self._ids = tuple(p.ids) if p.ids is not None else None
        if self._gate is None and isinstance(known, dict):
            if self._ids is None or list(self._ids) == known.get("ids"):
                self._gate = dict(known)
        if self._ids is None and self._gate is not None and self._gate.get("ids"):
            self._ids = tuple(self._gate["ids"])
        if self._ids is None and isinstance(known, dict) and known.get("ids"):  # handed by ArucoGateFound
            self._ids = tuple(known["ids"])
        self._frame = -1
        self._update(ctx)

    def on_exit(self, ctx: Context) -> None:
        self._gate = None

    def _update(self, ctx: Context) -> None:
        """A new camera frame with the gate: its pose replaces the one kept in the odometry frame (nearer is better)."""
        car = ctx.car
        view = car.camera()
        if view is None or view.frame == self._frame:
            return
        self._frame = view.frame
        remember_gates(ctx, view)
        gate = select_gate(view, self._ids)
        if gate is not None and abs(gate.heading) < math.radians(80):
            self._gate = update_gate_var(ctx, gate)

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        p = self.params
        self._update(ctx)
        gate = self._gate
        if gate is None:
            car.set_speed(0.0)
            if not self.finished:
                self.finish("lost")
            return
        x, y, th = car.pose()
        h = gate["heading"]
        ux, uy = math.cos(h), math.sin(h)
        dx, dy = x - gate["x"], y - gate["y"]
        along = dx * ux + dy * uy  # < 0 before the gate
        lateral = -dx * uy + dy * ux  # > 0: left of the centre line
        err = math.atan2(math.sin(th - h), math.cos(th - h))
        if not self.finished:
            if (-along <= p.near and abs(lateral) <= p.offset
                    and abs(err) <= math.radians(p.angle)):
                self.finish()
                mark_passed(ctx, self._ids)
            elif -along <= p.min_distance:
                # where the car would cross the gate line driving straight on
                at_line = lateral + (-along) * math.tan(max(-1.2, min(1.2, err)))
                width = gate.get("width")
                if p.clearance > 0 and width and abs(at_line) > width / 2 - p.clearance:
                    self.finish("wide")
                else:
                    self.finish("close")
                    mark_passed(ctx, self._ids)
        # pure pursuit towards a point on the centre line, lookahead ahead of the car's projection on it
        a = along + p.lookahead
        cx, cy = gate["x"] + ux * a, gate["y"] + uy * a
        c, s = math.cos(th), math.sin(th)
        fx, fy = c * (cx - x) + s * (cy - y), -s * (cx - x) + c * (cy - y)
        dist = math.hypot(fx, fy)
        alpha = math.atan2(fy, fx)
        delta = math.atan2(2.0 * car.wheelbase * math.sin(alpha), dist)
        car.set_steering(clamp(delta / car.max_steering_angle))
        car.set_speed(p.speed)


class AlignHeadingParams(StateParams):
    speed: float = Field(default=0.5, gt=0, le=2.0, description="Speed while turning, m/s.")
    offset: float = Field(default=0.0, ge=-180, le=180,
                          description="Heading to reach relative to the one the car had when the gate was found, "
                                      "degrees (left positive).")
    tolerance: float = Field(default=5.0, gt=0, le=45, description="Finished within this of the heading, degrees.")
    gain: float = Field(default=2.5, gt=0, le=100, description="Steering per radian of heading error.")
    snap: float | None = Field(
        default=None, gt=0, le=180,
        description="Round the heading to reach to a multiple of this many degrees from the start heading (90 in a "
                    "rectangular loop, whose corridors all are: the heading when the gate was found may be off "
                    "the corridor's, e.g. right after a corner).")


@register_state
class AlignHeading(CarState[AlignHeadingParams]):
    """After a gate: turns back to the heading the car had when ArucoGateFound fired (odometry), i.e. along the corridor whose wall it was following, plus `offset`; finishes within `tolerance` (at once when no gate was found)."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_target",)
    Params = AlignHeadingParams
    can_finish = True

    def __init__(self, id: str, params: AlignHeadingParams | None = None) -> None:
        super().__init__(id, params)
        self._target: float | None = None

    def on_enter(self, ctx: Context) -> None:
        gate = ctx.vars.get(GATE_VAR)
        base = gate.get("approach_heading") if isinstance(gate, dict) else None
        snap = self.params.snap
        if base is not None and snap is not None:
            base = snap_heading(base, snap)
        self._target = None if base is None else base + math.radians(self.params.offset)

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        p = self.params
        if self._target is None:
            if not self.finished:
                self.finish()
            return
        th = car.pose()[2]
        err = math.atan2(math.sin(self._target - th), math.cos(self._target - th))
        if not self.finished and abs(err) <= math.radians(p.tolerance):
            self.finish()
        car.set_steering(clamp(p.gain * err))
        car.set_speed(p.speed)
