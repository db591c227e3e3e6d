"""The simulated TRAL car as a ROS 2 robot (``fsmctl sim --ros``): it publishes its sensors on the profile's topics
and obeys the commands it receives, so ``fsmctl run --ros`` in another process drives it as it would the real car.

Two ways to keep time:

- **real time** (the default): physics follows the wall clock; sensors are published at their rates; the newest
  command applies; like a real motor controller it brakes when no command came for :data:`COMMAND_TIMEOUT`.
- **lock-step** (``--lockstep``): the simulation's clock is published on the profile's clock topic (as ROS does
  with ``use_sim_time``); after publishing the sensors of time t and the clock, the simulator waits for the
  command of time t, applies it, and advances one tick. Nothing waits for the wall clock, so a 200 s lap takes
  as long as its round trips (seconds), and the run is the in-process run's, tick for tick, up to float32 rounding.

This is the only module of :mod:`fsm.ros` that loads the simulator (pymunk).
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from fsm.ros import messages as M
from fsm.ros.car import Log
from fsm.ros.profile import COMPRESSED, Binding, Profile
from fsm.ros.transport import Bus, PeerTimeout
from fsm.sim.car import PHYSICS_DT, SimCar
from fsm.sim.loop import GateLog
from fsm.sim.world import load_world

#: Seconds without a command after which the robot brakes by itself (real time).
COMMAND_TIMEOUT = 0.5
#: Lock-step: how often time 0's sensors and clock are sent again until the machine's first command (s).
RESEND = 0.25


def reliable(binding: Binding) -> Binding:
    """``binding`` sent reliably (lock-step)."""
    return binding.model_copy(update={"qos": binding.qos.model_copy(update={"reliability": "reliable"})})


class SimRobot:
    """The simulated car behind the profile's topics (see the module's docstring)."""

    def __init__(self, profile: Profile, link: Bus, world: str | os.PathLike[str], *, seed: int = 0,
                 noise: bool = True, lockstep: bool = False, log: Log | None = None) -> None:
        self.profile = profile
        self.link = link
        self.lockstep = lockstep
        self.log: Log = log or (lambda text: None)
        self.world_file = world
        self.car = SimCar(load_world(world), seed=seed, noise=noise)
        self.gates = GateLog(self.car.world) if self.car.world.gates else None
        self.dt = profile.dt
        # lock-step wants every message: a best-effort sensor dropped under load would be a silence in simulated time
        # (the machine holds the car), so there every topic is sent reliably, blocking rather than dropping
        self._pubs = {name: link.publisher(reliable(b) if lockstep else b)
                      for name, b in profile.inputs_bound().items()}
        self._clock_pub = link.publisher(reliable(profile.clock)) if lockstep else None
        self._cond = threading.Condition()
        self._command: tuple[float, float, float | None] | None = None
        self._commands = 0
        self._taken = 0
        self._command_wall = 0.0
        self.decode_failures = 0
        link.subscribe(profile.outputs.command, self._on_command)
        #: the machine's status says it finished (the simulator then ends too)
        self.finished = False
        #: how many commands the machine had sent when it said it finished (the last ones may still be on the way)
        self._expected = 0
        if profile.outputs.status is not None:
            link.subscribe(profile.outputs.status, self._on_status)
        self._sample = -1
        self._frame = -1
        self._next_pub: dict[str, float] = {}
        self.time = 0.0
        self.stopped = ""
        self._last_heading = (0.0, 0.0)

    # -- commands --------------------------------------------------------------------------------------------
    def _on_command(self, raw: bytes) -> None:
        try:
            message = M.decode(raw, self.profile.outputs.command.type)
        except M.DecodeError:
            self.decode_failures += 1
            return
        values = M.command_values(message, self.profile.car.wheelbase)
        with self._cond:
            self._command = values
            self._commands += 1
            self._command_wall = time.monotonic()
            self._cond.notify_all()

    def _on_status(self, raw: bytes) -> None:
        import json

        try:
            status = json.loads(M.decode(raw, self.profile.outputs.status.type).data)  # type: ignore[union-attr]
        except (M.DecodeError, ValueError, AttributeError):
            return
        if isinstance(status, dict) and status.get("finished"):
            with self._cond:
                self.finished = True
                sent = status.get("commands")
                if isinstance(sent, int):
                    self._expected = max(self._expected, sent)
                self._cond.notify_all()

    def _drain(self, quiet: float = 0.2, limit: float = 1.0) -> None:
        """After the machine said it finished: take the commands still on the way (its status and commands travel
        on different topics, and it sends a last zero-speed command as it exits) until every command the status
        counted arrived and none came for ``quiet`` s, at most ``limit`` s."""
        end = time.monotonic() + limit
        with self._cond:
            while True:
                now = time.monotonic()
                if now >= end or (self._commands >= self._expected and now - self._command_wall >= quiet):
                    break
                self._cond.wait(min(end - now, quiet))
            command = self._command
        if command is not None:
            self._apply(command)

    def _apply(self, command: tuple[float, float, float | None]) -> None:
        speed, angle, _stamp = command
        car = self.car
        car.set_speed(speed)
        car.set_steering(angle / car.max_steering_angle)

    # -- sensors ------------------------------------------------------------------------------------------------
    def _due(self, name: str, rate: float, t: float) -> bool:
        """Odometry, hall and camera at their rates (the ultrasonic ranges whenever the car took a sample)."""
        nxt = self._next_pub.get(name, 0.0)
        if t + 1e-9 < nxt:
            return False
        self._next_pub[name] = nxt + 1.0 / rate if nxt + 1.0 / rate > t else t + 1.0 / rate
        return True

    def publish_sensors(self, t: float, again: bool = False) -> None:
        """What is due at time ``t``; ``again``: the ranges and the camera frame even if already sent."""
        car = self.car
        inputs = self.profile.inputs_bound()
        max_range = self.profile.car.max_range
        if again:
            self._sample = self._frame = -1
            self._next_pub.clear()
        if car.sample != self._sample:
            self._sample = car.sample
            for name in ("left", "right", "front"):
                value = getattr(car, name)
                self._pubs[name].put(M.encode(M.range_message(t, f"us_{name}", value, max_range)))
        odo = inputs["odometry"]
        if self._due("odometry", odo.rate, t):
            x, y, th = car.pose()
            last_t, last_th = self._last_heading
            yaw_rate = (th - last_th) / (t - last_t) if t > last_t else 0.0
            self._last_heading = (t, th)
            self._pubs["odometry"].put(M.encode(M.odometry_message(t, x, y, th, car.speed, yaw_rate)))
        hall = inputs.get("hall")
        if hall is not None and self._due("hall", hall.rate, t):
            self._pubs["hall"].put(M.encode(M.counter_message(hall.type, car.hall)))
        camera = inputs.get("camera")
        if camera is not None and car.camera_frames != self._frame:
            self._frame = car.camera_frames
            self._pubs["camera"].put(M.encode(self._image_message(camera.type, t)))

    def _image_message(self, type_name: str, t: float) -> Any:
        import cv2
        import numpy as np

        frame = self.car.camera_frame()
        if frame is None:  # nothing in view: the simulator rendered nothing; send a plain grey frame
            cam = self.car.params.camera
            frame = np.full((cam.height, cam.width), 128, np.uint8)
        if type_name == COMPRESSED:
            ok, jpeg = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, 90])
            return M.compressed_image_message(t, jpeg.tobytes())
        return M.image_message(t, frame)

    # -- running ------------------------------------------------------------------------------------------------
    def wait_for_controller(self, timeout: float, stop: Any = None) -> None:
        """Wait for the machine's side: a peer, and (lock-step) its subscription to the clock; return early once
        ``stop()`` holds (Ctrl-C)."""
        self.link.wait_for_peer(timeout, what="`fsmctl run --ros`", stop=stop)
        if self._clock_pub is None:
            return
        end = time.monotonic() + timeout
        while not (self._clock_pub.matched() and all(p.matched() for p in self._pubs.values())):
            if stop is not None and stop():
                return
            if time.monotonic() >= end:
                raise PeerTimeout(f"a peer connected ({self.link.describe()}) but never subscribed to "
                                  f"{self.profile.clock.topic} and every input: run it with --lockstep and this "
                                  "profile too")
            time.sleep(0.005)

    def _physics_to(self, t: float) -> None:
        car = self.car
        while (car.steps + 1) * PHYSICS_DT <= t + 1e-9:
            car.step()
            if self.gates is not None:
                x, y, _ = car.true_pose()
                self.gates.update(car.time, x, y)

    def run_lockstep(self, duration: float, wait: float, stop: Any = None) -> str:
        """Publish, wait for the command of the tick, advance; until ``duration`` of simulated time, the
        controller gone (no command within ``wait`` s) or ``stop()``."""
        assert self._clock_pub is not None
        n = 0
        dt = self.dt
        while True:
            t = n * dt
            self.time = t
            self.publish_sensors(t)
            self._clock_pub.put(M.encode(M.clock_message(t)))
            command = self._first_command(wait, stop) if n == 0 else self._wait_command(t, wait, stop)
            if stop is not None and stop():
                self.car.emergency_stop()
                return "stopped"
            if command is None:
                if self.finished:
                    self._drain()
                self.car.emergency_stop()
                return "machine finished" if self.finished else "machine gone"
            self._apply(command)
            if t >= duration - 1e-9:
                return "limit"
            if stop is not None and stop():
                return "stopped"
            n += 1
            self._physics_to(n * dt)

    def _first_command(self, wait: float, stop: Any = None) -> tuple[float, float, float | None] | None:
        """The command of tick 0. A subscription the machine's side just declared may miss the first messages even
        once it matched, and then its side would wait for them forever: until the first command comes, time 0's
        sensors and clock are sent again every :data:`RESEND` s (the machine latches the newest; nothing moves)."""
        assert self._clock_pub is not None
        end = time.monotonic() + wait
        while True:
            command = self._wait_command(0.0, min(RESEND, max(0.0, end - time.monotonic())), stop)
            if command is not None or self.finished or time.monotonic() >= end or (stop is not None and stop()):
                return command
            self.publish_sensors(0.0, again=True)
            self._clock_pub.put(M.encode(M.clock_message(0.0)))

    def _wait_command(self, t: float, wait: float, stop: Any = None) -> tuple[float, float, float | None] | None:
        """The command of time ``t``; None after ``wait`` s, once the machine finished, or as soon as ``stop()``
        holds (Ctrl-C: looked at every 0.1 s)."""
        end = time.monotonic() + wait
        with self._cond:
            while True:
                c = self._command
                if c is not None and self._commands != self._taken and (c[2] is None or c[2] >= t - 1e-6):
                    self._taken = self._commands
                    return c
                left = end - time.monotonic()
                if left <= 0 or self.finished or (stop is not None and stop()):
                    return None
                self._cond.wait(min(left, 0.1))

    def run_realtime(self, duration: float, stop: Any = None) -> str:
        """Physics on the wall clock; sensors at their rates; the newest command applies."""
        t0 = time.monotonic()
        while True:
            t = time.monotonic() - t0
            if t >= duration:
                return "limit"
            if stop is not None and stop():
                return "stopped"
            if self.finished:
                self._drain()
                return "machine finished"
            self._physics_to(t)
            self.time = t
            with self._cond:
                command, fresh = self._command, self._commands != self._taken
                self._taken = self._commands
                last = self._command_wall
            if fresh and command is not None:
                self._apply(command)
            elif command is not None and time.monotonic() - last > COMMAND_TIMEOUT and self.car.speed_command:
                self.log(f"no command for {COMMAND_TIMEOUT:g} s at {t:.2f} s: the robot brakes")
                self.car.set_speed(0.0)
            self.publish_sensors(t)
            time.sleep(max(0.0, PHYSICS_DT - (time.monotonic() - t0 - t)))

    def summary(self) -> dict[str, Any]:
        car = self.car
        out: dict[str, Any] = {"world": str(self.world_file), "lockstep": self.lockstep,
                               "sim_time": round(self.time, 6), "distance_m": round(car.distance, 4),
                               "collisions": car.collisions,
                               "commands_received": self._commands, "decode_failures": self.decode_failures}
        if self.gates is not None:
            out.update(self.gates.metrics())
        return out

