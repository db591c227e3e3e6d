"""The car interface: what states and transitions may read from and command to a car (simulated or real).

A Protocol, so the simulator (:class:`fsm.sim.car.SimCar`), the test double (:class:`fsm.sim.fake.FakeCar`)
and a hardware or ROS bridge implement it without inheriting from anything. Stdlib only.

Conventions: metres, seconds, radians inside the code; steering is normalised to [-1, 1] with
positive = left (counter-clockwise); ultrasonic readings are the latest sample (held between samples).

A car with a camera may also keep a :class:`GateMemory` as ``gate_memory`` (the simulator and the test double
do): where each gate was last seen, in the odometry frame, updated on every camera frame whatever state is
active. ``ArucoGateFound`` with ``memory`` drives to a gate from it when the gate is out of view.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

if TYPE_CHECKING:  # OpenCV: this module stays stdlib only at run time
    from fsm.vision.detector import Detection
    from fsm.vision.gates import Gate

#: The ultrasonic sensors of the TRAL car, by name.
SENSORS: tuple[str, ...] = ("left", "right", "front")
Side = Literal["left", "right"]
SensorName = Literal["left", "right", "front"]


@dataclass(frozen=True, slots=True)
class CameraView:
    """What the camera saw in its latest frame: the frame's ``time`` (s, the machine's clock), the markers
    detected in it (:class:`fsm.vision.Detection`, car frame) and the gates they make (:class:`fsm.vision.Gate`,
    nearest first). ``frame`` counts the frames taken so far (it changes when a new frame arrives)."""

    time: float
    frame: int
    detections: tuple[Detection, ...] = ()
    gates: tuple[Gate, ...] = ()

    def marker(self, marker_id: int) -> Detection | None:
        """The detection of ``marker_id`` in this frame, or ``None``."""
        for d in self.detections:
            if d.id == marker_id:
                return d
        return None


#: The view of a camera that has not taken a frame yet.
NO_VIEW = CameraView(0.0, 0)


def gate_in_odometry(pose: tuple[float, float, float], gate: Gate) -> dict[str, Any]:
    """A gate seen in the car frame (centre, heading; :class:`fsm.vision.Gate`) with the car at ``pose``
    (odometry) as an entry in the odometry frame: ids, centre ``x``/``y`` (m), ``heading`` (rad), ``width`` (m)."""
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    gx, gy = gate.center
    return {"ids": [int(gate.ids[0]), int(gate.ids[1])], "x": x + c * gx - s * gy, "y": y + s * gx + c * gy,
            "heading": th + gate.heading, "width": float(getattr(gate, "width", 0.0) or 0.0)}


class GateMemory:
    """Where each gate was last seen, in the odometry frame: a small landmark memory beside the camera.

    The car's interface feeds it every frame (:meth:`update` with the odometry pose at the frame), so a gate seen
    while the behaviour was busy with another one (approaching, lining up, driving through) is known when the
    camera has lost it. Sightings farther than ``max_range`` m or seen more than ``max_angle`` rad askew are too
    rough to drive to and are not kept. ``gates`` maps "left,right" ids to :func:`gate_in_odometry` entries (a
    dict given to the constructor is filled in place)."""

    __slots__ = ("gates", "max_range", "max_angle")

    def __init__(self, gates: dict[str, dict[str, Any]] | None = None, max_range: float = 6.0,
                 max_angle: float = math.radians(80)) -> None:
        self.gates: dict[str, dict[str, Any]] = {} if gates is None else gates
        self.max_range = max_range
        self.max_angle = max_angle

    def update(self, pose: tuple[float, float, float], gates: Iterable[Gate]) -> None:
        for g in gates:
            if g.distance <= self.max_range and abs(g.heading) < self.max_angle:
                self.gates[f"{int(g.ids[0])},{int(g.ids[1])}"] = gate_in_odometry(pose, g)


@runtime_checkable
class CarIO(Protocol):
    """The plant as states see it (``ctx.car``). States read its values and command it through its methods only,
    so a car may keep its values as plain attributes or as read-only properties."""

    @property
    def left(self) -> float:
        """Latest reading of the left ultrasonic sensor, m (the sensor's maximum range when there is no echo)."""
        ...

    @property
    def right(self) -> float:
        """Latest reading of the right ultrasonic sensor, m."""
        ...

    @property
    def front(self) -> float:
        """Latest reading of the front ultrasonic sensor, m."""
        ...

    @property
    def sample(self) -> int:
        """Number of ultrasonic samples so far; it changes when new readings arrive (about 20 Hz)."""
        ...

    @property
    def distance(self) -> float:
        """Travelled distance from the hall sensor, m."""
        ...

    @property
    def hall(self) -> int:
        """Travelled distance in raw hall units (1500 units per 1.60 m)."""
        ...

    @property
    def speed(self) -> float:
        """Measured speed in m/s (from the hall sensor)."""
        ...

    @property
    def steering(self) -> float:
        """The last steering command, in [-1, 1]."""
        ...

    @property
    def speed_command(self) -> float:
        """The last speed command in m/s (``speed`` is what the hall sensor measures)."""
        ...

    @property
    def wheelbase(self) -> float:
        """Distance between the axles, m (for controllers)."""
        ...

    @property
    def max_steering_angle(self) -> float:
        """The wheel angle at steering 1, rad."""
        ...

    def pose(self) -> tuple[float, float, float]:
        """Odometry: x, y (m) and heading (rad) in the car's odometry frame."""
        ...

    def set_steering(self, value: float) -> None:
        """Command the steering servo, normalised to [-1, 1] (clamped), positive = left."""
        ...

    def set_speed(self, value: float) -> None:
        """Command the speed in m/s (negative drives backwards); the car accelerates with its limit."""
        ...

    def emergency_stop(self) -> None:
        """Stop now: speed command 0 and the motor braked (called when a state fails)."""
        ...

    def camera(self) -> CameraView | None:
        """The latest camera detections (:class:`CameraView`), or ``None`` when the car has no camera."""
        ...


def sensor_value(car: Any, name: str) -> float:
    """The reading of ultrasonic sensor ``name`` (``left``, ``right``, ``front``)."""
    return float(getattr(car, name))
