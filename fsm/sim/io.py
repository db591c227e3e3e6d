"""The car interface: what states and transitions may read from and command to a car (simulated or real).

A Protocol, so the simulator (:class:`fsm.sim.car.SimCar`), the test double (:class:`fsm.sim.fake.FakeCar`)
and a hardware or ROS bridge implement it without inheriting from anything. Stdlib only.

Conventions: metres, seconds, radians inside the code; steering is normalised to [-1, 1] with
positive = left (counter-clockwise); ultrasonic readings are the latest sample (held between samples).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Protocol, runtime_checkable

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
    detections: tuple[Any, ...] = ()
    gates: tuple[Any, ...] = ()

    def marker(self, marker_id: int) -> Any | None:
        """The detection of ``marker_id`` in this frame, or ``None``."""
        for d in self.detections:
            if d.id == marker_id:
                return d
        return None


#: The view of a camera that has not taken a frame yet.
NO_VIEW = CameraView(0.0, 0)


@runtime_checkable
class CarIO(Protocol):
    """The plant as states see it (``ctx.car``)."""

    #: Latest ultrasonic readings in metres (the sensor's maximum range when there is no echo).
    left: float
    right: float
    front: float
    #: Number of ultrasonic samples so far; it changes when new readings arrive (about 20 Hz).
    sample: int
    #: Travelled distance from the hall sensor: metres, and raw hall units (1500 units per 1.60 m).
    distance: float
    hall: int
    #: Measured speed in m/s (from the hall sensor); the last steering command in [-1, 1].
    speed: float
    steering: float
    #: The last speed command in m/s (``speed`` is what the hall sensor measures).
    speed_command: float
    #: Geometry controllers may need: wheelbase (m) and the wheel angle at steering 1 (rad).
    wheelbase: float
    max_steering_angle: float

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
