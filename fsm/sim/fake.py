"""A scripted car for tests of states and transitions: readings are set by hand, commands are recorded.

Implements :class:`fsm.sim.io.CarIO` with plain attributes and no physics; stdlib only.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

from fsm.sim.io import CameraView, GateMemory

if TYPE_CHECKING:
    from fsm.vision.detector import Detection
    from fsm.vision.gates import Gate


class FakeCar:
    """Set ``left``/``right``/``front``/``distance``/``speed`` and call :meth:`new_sample`; read the commands back."""

    def __init__(self, *, left: float = 1.0, right: float = 0.4, front: float = 3.0,
                 wheelbase: float = 0.26, max_steering_angle: float = math.radians(24)) -> None:
        self.left, self.right, self.front = left, right, front
        self.sample = 0
        self.distance = 0.0
        self.hall = 0
        self.speed = 0.0
        self.steering = 0.0
        self.speed_command = 0.0
        self.wheelbase = wheelbase
        self.max_steering_angle = max_steering_angle
        self.x = self.y = self.heading = 0.0
        self.stopped = False
        self.commands: list[tuple[str, float]] = []
        self.view: CameraView | None = None
        self._frames = 0
        self.gate_memory = GateMemory()

    def see(self, detections: Iterable[Detection] = (), gates: Iterable[Gate] = (), time: float | None = None) -> None:
        """Script the camera: its next frame shows these detections and gates (a camera appears on first use)."""
        self._frames += 1
        self.view = CameraView(self._frames * 0.05 if time is None else time, self._frames, tuple(detections),
                               tuple(gates))
        self.gate_memory.update(self.pose(), self.view.gates)

    def new_sample(self, **readings: float) -> None:
        """New ultrasonic readings (only the ones given change) and a new sample number."""
        for name, value in readings.items():
            setattr(self, name, value)
        self.sample += 1

    def travel(self, metres: float) -> None:
        self.distance += metres
        self.hall = int(self.distance * 1500 / 1.60)

    def pose(self) -> tuple[float, float, float]:
        return self.x, self.y, self.heading

    def set_steering(self, value: float) -> None:
        self.steering = max(-1.0, min(1.0, float(value)))
        self.commands.append(("steering", self.steering))

    def set_speed(self, value: float) -> None:
        self.speed_command = float(value)
        self.commands.append(("speed", self.speed_command))

    def emergency_stop(self) -> None:
        self.stopped = True
        self.speed_command = 0.0
        self.speed = 0.0

    def camera(self) -> CameraView | None:
        return self.view
