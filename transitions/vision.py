"""Transitions on the camera: ``ArucoGateFound`` (a gate within range) and ``ArucoMarkerFound`` (a marker id within
range: the report's "behaviour by id"). They read only ``ctx.car.camera()`` (what the detector found in pixels)
and the car's odometry, never the simulator's ground truth."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from pydantic import Field, model_validator

from fsm.params import TransitionParams
from fsm.registry import register_transition
from fsm.transition import Transition

if TYPE_CHECKING:
    from fsm.context import Context

#: The blackboard variable where ArucoGateFound leaves the gate it found (odometry frame) for the next states.
GATE_VAR = "gate"


def gate_to_odometry(car: Any, gate: Any) -> dict[str, Any]:
    """A gate seen in the car frame as a blackboard entry in the odometry frame: ids, centre x/y (m), heading (rad)."""
    x, y, th = car.pose()
    c, s = math.cos(th), math.sin(th)
    gx, gy = gate.center
    return {"ids": [int(gate.ids[0]), int(gate.ids[1])], "x": x + c * gx - s * gy, "y": y + s * gx + c * gy,
            "heading": th + gate.heading}


def select_gate(view: Any, ids: tuple[int, int] | None) -> Any | None:
    """The nearest gate of a camera view (with the given left/right ids, when given)."""
    if view is None:
        return None
    if ids is None:
        return view.gates[0] if view.gates else None
    for g in view.gates:
        if tuple(g.ids) == tuple(ids):
            return g
    left, right = view.marker(ids[0]), view.marker(ids[1])
    if left is None or right is None:
        return None
    from fsm.vision.gates import Gate  # the default pairing may have matched these markers otherwise

    return Gate.from_markers(left, right)


def clamp_to_walls(car: Any, y: float, margin: float) -> float:
    """A lateral offset (car frame, left positive) kept ``margin`` inside the walls the side sensors read now (the
    car drives along them); readings at the sensor's maximum are no wall."""
    if margin <= 0:
        return y
    top = max(0.0, car.left - margin) if car.left < 2.9 else None
    bottom = -max(0.0, car.right - margin) if car.right < 2.9 else None
    if top is not None and y > top:
        y = top
    if bottom is not None and y < bottom:
        y = bottom
    return y


class _CameraTransition(Transition):
    __slots__ = ("_frame", "_count")
    needs_car = True

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self._frame = -1
        self._count = 0

    def on_source_enter(self, ctx: Context) -> None:
        self._frame = -1
        self._count = 0

    def check(self, ctx: Context) -> bool:
        view = ctx.car.camera()
        if view is None or view.frame == self._frame:
            return self._count >= self.params.frames  # type: ignore[attr-defined]
        self._frame = view.frame
        self._count = self._count + 1 if self.seen(view) else 0
        return self._count >= self.params.frames  # type: ignore[attr-defined]

    def seen(self, view: Any) -> bool:
        raise NotImplementedError


@register_transition
class ArucoGateFound(_CameraTransition):
    """Fires when the camera sees a gate (two markers; with `ids`, that gate) whose centre is within `range` and which the car faces (|heading| <= `max_angle`), in `frames` frames in a row. Hands the target state (ApproachPoint) the point `before` metres in front of the gate, and leaves the gate on the blackboard (`gate`, odometry frame) for ArucoGateCenter."""

    __slots__ = ("_gate",)

    class Params(TransitionParams):
        ids: list[int] | None = Field(default=None, min_length=2, max_length=2,
                                     description="Left and right marker id of the gate "
                                                                      "(default: any two markers a gate width apart).")
        range: float = Field(default=2.5, gt=0, le=20, description="Fire when the gate centre is this near, m.")
        min_range: float = Field(default=0.0, ge=0, le=20, description="... and at least this far, m.")
        max_angle: float = Field(default=60.0, gt=0, le=90,
                                 description="Only gates the car faces: |gate heading| at most this, degrees.")
        before: float = Field(default=1.0, ge=0, le=5,
                              description="Distance of the approach point handed to the target, in front of the "
                                          "gate on its centre line, m.")
        frames: int = Field(default=2, ge=1, le=100, description="Consecutive camera frames the gate must be seen in.")
        wall_margin: float = Field(
            default=0.35, ge=0, le=3,
            description="Keep the handed point at least this far from the walls the side ultrasonic sensors see "
                        "(a gate turned towards a wall would put it into the wall), m; 0: off.")

        @model_validator(mode="after")
        def _range(self) -> "ArucoGateFound.Params":
            if self.ids is not None and self.ids[0] == self.ids[1]:
                raise ValueError("a gate needs two different marker ids")
            if self.min_range >= self.range:
                raise ValueError(f"min_range ({self.min_range}) must be below range ({self.range})")
            return self

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self._gate: Any = None

    def seen(self, view: Any) -> bool:
        p = self.params
        gate = select_gate(view, p.ids)  # type: ignore[attr-defined]
        ok = (gate is not None and p.min_range <= gate.distance <= p.range  # type: ignore[attr-defined]
              and abs(gate.heading) <= math.radians(p.max_angle))  # type: ignore[attr-defined]
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
            px, py = gate.point_before(self.params.before)  # type: ignore[attr-defined]
            py = clamp_to_walls(ctx.car, py, self.params.wall_margin)  # type: ignore[attr-defined]
            setter(ctx, px, py, gate.heading)


@register_transition
class ArucoMarkerFound(_CameraTransition):
    """Fires when the camera sees the marker with id `marker` within `range` metres, in `frames` frames in a row (the report's "behaviour by id": one transition per id)."""

    __slots__ = ()

    class Params(TransitionParams):
        marker: int = Field(ge=0, le=4095, description="ArUco id of the marker.")
        range: float = Field(default=1.5, gt=0, le=20, description="Fire when the marker is this near (from the "
                                                                   "car's centre, horizontally), m.")
        frames: int = Field(default=2, ge=1, le=100, description="Consecutive camera frames the marker must be seen in.")

    def seen(self, view: Any) -> bool:
        d = view.marker(self.params.marker)  # type: ignore[attr-defined]
        return d is not None and d.distance <= self.params.range  # type: ignore[attr-defined]
