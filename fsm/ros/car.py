"""RosCar: the car interface (:class:`fsm.sim.io.CarIO`) with readings from ROS 2 topics and commands kept for the
driver to publish.

Messages arrive on Zenoh's threads; each is decoded there and kept as its input's newest. Before each tick the
driver calls :meth:`RosCar.latch` on the loop's thread: the newest message of each input becomes the car's values,
all at once, so a tick sees one consistent car. A message that does not decode is counted, reported once per topic
and otherwise ignored: to the machine it is silence. :meth:`RosCar.input_time` says when each input was last
latched (machine time), which :class:`fsm.transitions.topics.TopicQuiet` and the driver's safety stop read.

The same class reads a recorded drive (:mod:`fsm.ros.replay`): there :meth:`offer` is called with the bag's
messages instead of Zenoh's.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from fsm.ros import messages as M
from fsm.ros.profile import ODOMETRY, RANGE, Profile
from fsm.sim.io import NO_VIEW, CameraView, GateMemory

#: An odometry step longer than the car's top speed times the time since the last sample, times this, plus
#: :data:`JUMP_SLACK` m, is a jump (a reset, a glitch), not travel.
JUMP_MARGIN = 1.5
JUMP_SLACK = 0.05
#: Where problems of the inputs are reported (one line each): standard error unless the caller says otherwise.
Log = Callable[[str], None]


class Slot:
    """The newest message of one input: written on a Zenoh thread, taken on the loop's thread."""

    __slots__ = ("name", "type", "message", "raw", "count", "taken", "failures", "layout")

    def __init__(self, name: str, type_name: str) -> None:
        self.name = name
        self.type = type_name
        self.message: Any = None
        self.raw: bytes = b""
        self.count = 0
        self.taken = 0
        self.failures = 0
        #: the distribution layout the messages were last read in (tried first)
        self.layout: str | None = None


class RosCar:
    """The car interface over ROS 2 topics (see the module's docstring)."""

    def __init__(self, profile: Profile, *, log: Log | None = None, on_stop: Callable[[], None] | None = None) -> None:
        car = profile.car
        self.profile = profile
        self.log: Log = log or (lambda text: None)
        #: called by :meth:`emergency_stop` (the driver publishes a zero-speed command at once)
        self.on_stop = on_stop
        self.wheelbase = car.wheelbase
        self.max_steering_angle = math.radians(car.max_steering_angle)
        self._max_speed = car.max_speed
        self._units = car.hall_units_per_m
        self._max_range = car.max_range
        self.left = self.right = self.front = car.max_range
        self.sample = 0
        self.distance = 0.0
        self.hall = 0
        self.speed = 0.0
        self.steering = 0.0
        self.speed_command = 0.0
        self.stopped = False
        self._pose = (0.0, 0.0, 0.0)
        self._last_xy: tuple[float, float] | None = None
        self._last_odometry = 0.0
        odometry = profile.inputs.odometry
        self._odometry_period = 1.0 / odometry.rate if odometry is not None else profile.dt
        #: odometry samples that moved farther than the car can (ignored for distance), and readings dropped (NaN)
        self.odometry_jumps = 0
        self.dropped: dict[str, int] = {}
        self._has_hall = profile.inputs.hall is not None
        self._hall0: int | None = None
        self.slots: dict[str, Slot] = {name: Slot(name, b.type) for name, b in profile.inputs_bound().items()}
        self._times: dict[str, float] = {}
        self._lock = threading.Lock()
        self._view: CameraView | None = None
        self.gate_memory: GateMemory | None = None
        self._detector: Any = None
        if profile.inputs.camera is not None:
            self._view = NO_VIEW
            self.gate_memory = GateMemory()
        #: the time of the latest latch (machine time)
        self.now = 0.0

    # -- arriving messages (any thread) ----------------------------------------------------------------------
    def offer(self, name: str, raw: bytes) -> None:
        """A message of input ``name`` arrived: decode it and keep it as the newest (a bad one is counted)."""
        slot = self.slots[name]
        try:
            message, slot.layout = M.decode_layout(raw, slot.type, slot.layout)
        except M.DecodeError as exc:
            with self._lock:
                slot.failures += 1
                first = slot.failures == 1
            if first:
                self.log(f"input '{name}' ({self.profile.inputs_bound()[name].topic}): a message failed to decode "
                         f"and is treated as silence (further failures are only counted): {exc}")
            return
        with self._lock:
            slot.message = message
            slot.raw = raw
            slot.count += 1

    def subscriber(self, name: str) -> Callable[[bytes], None]:
        return lambda raw: self.offer(name, raw)

    # -- the tick's readings (the loop's thread) -----------------------------------------------------------------
    def latch(self, now: float) -> list[tuple[str, bytes]]:
        """Take the newest message of every input that has a new one as the car's values at machine time ``now``;
        returns what was taken (input name, CDR bytes) for the recorder."""
        self.now = now
        taken: list[tuple[str, bytes]] = []
        with self._lock:
            fresh = [(s.name, s.message, s.raw) for s in self.slots.values() if s.count != s.taken]
            for s in self.slots.values():
                s.taken = s.count
        new_sample = False
        for name, message, raw in fresh:
            if message.__msgtype__ == RANGE:
                value = self._range(message)
                if value is None:  # NaN: a dropped reading, counted; the input stays as silent as it was
                    self.dropped[name] = self.dropped.get(name, 0) + 1
                    continue
                setattr(self, name, value)
                new_sample = True
            elif message.__msgtype__ == ODOMETRY:
                self._odometry(message, now)
            elif name == "hall":
                self._counter(message)
            elif name == "camera" and not self._image(message, now):
                continue  # an image that does not decode is silence
            self._times[name] = now
            taken.append((name, raw))
        if new_sample:
            self.sample += 1
        return taken

    def _range(self, message: Any) -> float | None:
        """A Range's reading as REP 117 means it: -inf or under the message's ``min_range`` is "too close to
        measure" (the reading becomes ``min_range``); +inf or over ``max_range`` (the message's or the profile's)
        is "nothing in range" (the profile's ``max_range``); NaN is no reading at all (None)."""
        value = float(message.range)
        if value != value:
            return None
        low = float(message.min_range)
        low = low if math.isfinite(low) and low >= 0 else 0.0
        if value < low:  # -inf included
            return min(low, self._max_range)
        high = float(message.max_range)
        if value > self._max_range or (math.isfinite(high) and high > low and value > high):  # +inf included
            return self._max_range
        return value

    def _odometry(self, message: Any, now: float) -> None:
        p = message.pose.pose
        x, y = float(p.position.x), float(p.position.y)
        if not (math.isfinite(x) and math.isfinite(y)):
            self.dropped["odometry"] = self.dropped.get("odometry", 0) + 1
            return
        self._pose = (x, y, M.quaternion_yaw(p.orientation))
        speed = float(message.twist.twist.linear.x)
        self.speed = speed if math.isfinite(speed) else 0.0
        last, self._last_xy = self._last_xy, (x, y)
        last_time, self._last_odometry = self._last_odometry, now
        if last is None:
            return
        step = math.hypot(x - last[0], y - last[1])
        # farther than the car can go between two samples (at its top speed, with a margin): a reset or a glitch
        limit = self._max_speed * max(now - last_time, self._odometry_period) * JUMP_MARGIN + JUMP_SLACK
        if step > limit:
            self.odometry_jumps += 1
            if self.odometry_jumps == 1:
                self.log(f"input 'odometry': at {now:.3f} s the pose jumped {step:.3g} m, more than the car can travel "
                         f"in one sample ({limit:.3g} m): ignored for distance (further jumps are only counted)")
            return
        if not self._has_hall:  # the travelled distance from the odometry's path
            self.distance += step
            self.hall = int(self.distance * self._units)

    def _counter(self, message: Any) -> None:
        value = int(message.data)
        if self._hall0 is None:
            self._hall0 = value  # the counter of a car that has been driving before: distance from here
        self.hall = value - self._hall0
        self.distance = self.hall / self._units

    def _image(self, message: Any, now: float) -> bool:
        """Detect markers in a camera image; False when its pixels do not decode (counted, logged once)."""
        try:
            image = M.image_pixels(message)
        except M.DecodeError as exc:
            slot = self.slots["camera"]
            slot.failures += 1
            if slot.failures == 1:
                self.log(f"input 'camera': an image failed to decode and is treated as silence: {exc}")
            return False
        detector = self._detector or self._make_detector()
        detections = tuple(detector.detect(image))
        gates: tuple[Any, ...] = ()
        if len(detections) > 1:
            from fsm.vision.gates import find_gates

            gates = tuple(find_gates(detections))
        frame = (self._view.frame if self._view is not None else 0) + 1
        self._view = CameraView(now, frame, detections, gates)
        if gates and self.gate_memory is not None:
            self.gate_memory.update(self._pose, gates)
        return True

    def _make_detector(self) -> Any:
        from fsm.vision.camera import CameraModel, CameraMount
        from fsm.vision.detector import MarkerDetector

        cam = self.profile.inputs.camera
        assert cam is not None
        path = self.profile.calibration_path()
        if path is not None:
            from fsm.vision.calibration import load_calibration

            model = load_calibration(path)
        else:
            model = CameraModel.from_intrinsics(cam.width, cam.height, cam.fx)
        x, y, z, yaw, pitch = cam.mount
        mount = CameraMount(x=x, y=y, height=z, yaw=math.radians(yaw), pitch=math.radians(pitch))
        self._detector = MarkerDetector(model, dictionary=cam.dictionary, marker_size=cam.marker_size, mount=mount,
                                        track=True)
        return self._detector

    # -- silence ----------------------------------------------------------------------------------------------
    def input_time(self, name: str) -> float | None:
        """Machine time at which input ``name`` was last latched: 0 when it never was (silence counts from the
        start), None when the profile does not bind it."""
        if name not in self.slots:
            return None
        return self._times.get(name, 0.0)

    def silent_inputs(self, now: float) -> list[str]:
        """The inputs silent longer than the profile allows at machine time ``now`` (never heard counts from 0)."""
        out = []
        for name, binding in self.profile.inputs_bound().items():
            last = self._times.get(name, 0.0)
            if now - last > binding.max_silence + 1e-9:
                out.append(name)
        return out

    def failures(self) -> dict[str, int]:
        return {name: s.failures for name, s in self.slots.items() if s.failures}

    def received(self) -> dict[str, int]:
        return {name: s.count for name, s in self.slots.items()}

    # -- CarIO ----------------------------------------------------------------------------------------------
    def pose(self) -> tuple[float, float, float]:
        return self._pose

    def set_steering(self, value: float) -> None:
        value = float(value)
        if not value == value:
            raise ValueError("steering command is NaN")
        self.steering = -1.0 if value < -1.0 else 1.0 if value > 1.0 else value

    def set_speed(self, value: float) -> None:
        value = float(value)
        if not value == value:
            raise ValueError("speed command is NaN")
        m = self._max_speed
        self.speed_command = -m if value < -m else m if value > m else value

    def emergency_stop(self) -> None:
        self.speed_command = 0.0
        self.stopped = True
        if self.on_stop is not None:
            self.on_stop()

    def camera(self) -> CameraView | None:
        return self._view

    @property
    def collisions(self) -> int:
        """A real car does not know it collided (``fsmctl run --expect`` counts none)."""
        return 0
