"""The simulated TRAL car: a pymunk world, a bicycle model on a dynamic body, ultrasonic and hall sensors.

Model (for users: docs/car.md): each physics step (0.01 s) the steering servo moves towards its command (as it was
``latency`` ago) with a rate limit once the command is outside its dead band, the speed towards its command with
acceleration limits; the bicycle model at the centre of gravity (mid-wheelbase) gives the body's velocity and yaw
rate, which are set on a *dynamic* pymunk body, so walls push back through real contacts and every new contact
counts as a collision. The ultrasonic sensors take, at their own rate, the nearest echo inside their cone (the
"beam" model; "rays" casts a few rays instead), lose echoes that meet a flat surface too obliquely, add seeded
Gaussian noise, dropouts and outliers, and round to the sensor's resolution. The hall sensor counts wheel travel.
"""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

import pymunk

from fsm.sim.io import NO_VIEW, CameraView, GateMemory
from fsm.sim.world import World, world_markers

try:  # pymunk's own cffi binding: the same C calls as Space.*_query_*, without building result objects
    from pymunk._chipmunk import ffi as _ffi
    from pymunk._chipmunk import lib as _lib
except ImportError:  # pragma: no cover - other pymunk builds: the public API (about half as fast)
    _ffi = _lib = None
if _lib is not None:  # the calls of a physics step, bound once (a lookup on the cffi module costs as much as a call)
    _get_angle, _get_position = _lib.cpBodyGetAngle, _lib.cpBodyGetPosition
    _set_velocity, _set_angular_velocity, _space_step = (_lib.cpBodySetVelocity, _lib.cpBodySetAngularVelocity,
                                                         _lib.cpSpaceStep)

#: Physics step, seconds (fixed, independent of the machine's tick).
PHYSICS_DT = 0.01
WALL, CAR = 1, 2
#: Walls are this thick on each side of their lines (pymunk segments' radius), m.
WALL_RADIUS = 0.005
#: the beam model files the walls by where the sensor is (square cells of this side, m) and where it looks (this
#: many sectors of directions): see :class:`BeamIndex`
BEAM_CELL = 0.5
BEAM_SECTORS = 32
#: Radius of the posts markers stand on (physical obstacles), m.
POST_RADIUS = 0.02
#: Markers farther than this from the camera are never rendered (they would be a few pixels), m.
CAMERA_RANGE = 8.0
#: Ultrasonic rays start this far behind their mount (inside the body), so a wall touching the sensor is seen.
RAY_BACK = 0.05
#: Tyre grip: the largest force (as a multiple of the car's weight) that drives the body after the model.
GRIP = 2.0
_CAR_GROUP = 1

#: Where a ray hit first: the fraction of the ray's length, and the normal (x, y) of the surface hit.
Hit = tuple[float, float, float]
#: A ray query: from (ax, ay) to (bx, by), the first :data:`Hit` or None.
RayQuery = Callable[[float, float, float, float], "Hit | None"]
#: A nearest-point query: the distance from (px, py) in a space to its nearest shape within max_d (inf if none).
NearestQuery = Callable[[pymunk.Space, float, float, float], float]


def build_space(world: World, doors: bool = True) -> pymunk.Space:
    """A pymunk space with the world's walls and obstacles as static shapes (collision type ``WALL``)."""
    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    # pymunk's default slop (0.1) assumes pixels; in metres it let the car sink 10 cm into a wall.
    space.collision_slop = 0.001
    static = space.static_body
    shapes: list[pymunk.Shape] = []
    for a, b in world.segments(doors=doors):
        seg = pymunk.Segment(static, a, b, WALL_RADIUS)
        shapes.append(seg)
    for ob in world.obstacles:
        if ob.type == "circle":
            assert ob.center is not None and ob.radius is not None
            shapes.append(pymunk.Circle(static, ob.radius, ob.center))
    for _id, mx, my, _z, _facing, _size, post in world_markers(world):
        if post:  # the post a marker stands on: hitting it is a collision
            shapes.append(pymunk.Circle(static, POST_RADIUS, (mx, my)))
    for s in shapes:
        s.collision_type = WALL
        s.friction = 0.6
        s.elasticity = 0.0
    space.add(*shapes)
    return space


class _Sensor:
    """One ultrasonic sensor: its mount and its rays in the car frame."""

    __slots__ = ("name", "mx", "my", "rays")

    def __init__(self, name: str, mx: float, my: float, angle: float, cone: float, n: int) -> None:
        self.name = name
        self.mx, self.my = mx, my
        if n == 1:
            offsets = [0.0]
        else:
            offsets = [-cone / 2 + cone * k / (n - 1) for k in range(n)]
        # The centre ray first: ties go to it.
        offsets.sort(key=abs)
        self.rays = tuple((math.cos(angle + o), math.sin(angle + o)) for o in offsets)


class SimCar:
    """The car in a pymunk world; implements :class:`fsm.sim.io.CarIO`.

    ``noise=False`` turns off ultrasonic noise and outliers (the geometry stays). The noise is drawn
    from ``random.Random(seed)``, so a seed gives the same run, bit for bit.

    A snapshot of a run (:mod:`fsm.session.snapshot`) copies the car's plain attributes; the world, the walls, the
    pymunk objects and the sensor queries are shared (``__snapshot_skip__``), and the bodies' and joints' state is
    kept by :meth:`__snapshot__` (only while no contact is cached: :meth:`snapshot_ready`).
    """

    #: what a snapshot shares: built from the world and the car's parameters, never changed by a run (the beam
    #: index is a cache whose contents do not depend on when it was filled)
    __snapshot_skip__ = ("world", "params", "space", "_nominal", "body", "shape", "control", "_c", "_query",
                         "sensors", "_beam", "_beam_index", "_by_name", "_outline", "_ray", "_nearest", "_markers",
                         "_specs", "_joints", "_mem")
    #: what a snapshot reads and restores, by name (reading ``__dict__`` would cost CPython 3.11 the fast path of
    #: every attribute of the car from then on); a test checks that it names every attribute the car sets
    __snapshot_fields__ = (
        "rng", "noise", "wheelbase", "max_steering_angle", "length", "width", "_pose", "_pose_step", "_apart",
        "collisions", "contact_steps", "_touching", "_cmd_steer", "_cmd_speed", "_servo", "_moving", "_v", "_offset",
        "_rate_dt", "_half_band", "_lag", "_pending", "_servo_cmd", "_acc_dt", "_dec_dt", "_max_speed", "_delta",
        "_k_beta", "_k_w", "_w", "_units", "_travel", "_min_r", "_max_r", "_cos_inc", "_sd0", "_sd1", "_outliers",
        "_dropouts", "_half", "_tan_half", "_res", "sensor_every", "left", "right", "front", "sample", "distance",
        "hall", "speed", "steering", "steps", "time", "min_clearance", "_half_diagonal", "_odo_scale", "_odo_offset",
        "_odo_hall", "_odo_delta", "_odo_tan", "_odo_beta", "_odo_cos", "_odo", "_view", "_frame", "_cam",
        "camera_frames", "rendered_frames", "gate_memory", "camera_every", "_cam_seed")

    def __init__(self, world: World, *, seed: int = 0, noise: bool = True) -> None:
        p = world.car
        us = p.ultrasonic
        self.world = world
        self.params = p
        self.space = build_space(world)
        self._nominal: pymunk.Space | None = None
        self.rng = random.Random(seed)
        self.noise = noise
        # geometry
        self.wheelbase = p.wheelbase
        self.max_steering_angle = math.radians(p.max_steering_angle)
        self.length, self.width = p.length, p.width
        # body
        moment = pymunk.moment_for_box(p.mass, (p.length, p.width))
        self.body = pymunk.Body(p.mass, moment)
        self._pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._pose_step = -1  # the step in which sense() read _pose
        self.body.position = (world.start.x, world.start.y)
        self.body.angle = math.radians(world.start.heading)
        self.shape = pymunk.Poly.create_box(self.body, (p.length, p.width), 0.0)
        self.shape.collision_type = CAR
        self.shape.friction = 0.6
        self.shape.filter = pymunk.ShapeFilter(group=_CAR_GROUP)
        # The bicycle model drives a kinematic control body; a pivot and a gear joint with finite forces drag
        # the car after it (pymunk's tank demo). Contacts are hard constraints, so walls stop the car and
        # turn it, where setting the car's velocity directly each step would push it through them.
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = self.body.position
        self.control.angle = self.body.angle
        pivot = pymunk.PivotJoint(self.control, self.body, (0, 0), (0, 0))
        pivot.max_bias = 0.0
        pivot.max_force = GRIP * p.mass * 9.81
        gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
        gear.max_bias = 0.0
        gear.max_force = GRIP * p.mass * 9.81 * p.wheelbase / 2
        self.space.add(self.body, self.shape, self.control, pivot, gear)
        self._joints = (pivot, gear)
        self._apart = -1_000  # the physics step in which the car last left a wall
        #: The chipmunk handles of the body, the control body and the space: a physics step and a pose read call
        #: chipmunk through pymunk's cffi binding directly (the same C calls as pymunk's properties and
        #: ``Space.step``, without their Python wrappers, which cost a third of a step); None on other builds.
        self._c: tuple[Any, Any, Any] | None = None
        if _lib is not None:
            self._c = (self.body._body, self.control._body, self.space._space)
        #: The body's angle and position and the control body's velocity and angular velocity as chipmunk keeps
        #: them, read and written in its memory (see :func:`_body_fields`), and the space: what ``cpBodyGetAngle``,
        #: ``cpBodyGetPosition``, ``cpBodySetVelocity`` and ``cpBodySetAngularVelocity`` read and write, without a
        #: call (each releases and takes the GIL and converts its arguments); None where the layout is not found.
        self._mem: tuple[Any, Any, Any, Any, Any] | None = None
        if self._c is not None:
            fields = _body_fields(self._c[0], self._c[1])
            self._mem = None if fields is None else (*fields, self._c[2])
        self._query = pymunk.ShapeFilter(group=_CAR_GROUP)
        self.collisions = 0
        self.contact_steps = 0
        self._touching = 0
        self.space.on_collision(CAR, WALL, begin=self._begin, separate=self._separate)
        # actuators
        self._cmd_steer = 0.0
        self._cmd_speed = 0.0
        self._servo = 0.0
        self._moving = False
        self._v = 0.0
        self._offset = p.steering_offset
        self._rate_dt = p.servo_rate * PHYSICS_DT
        self._half_band = p.servo.dead_band / 2
        #: Commands wait this many physics steps before the servo acts on them (its latency).
        self._lag = round(p.servo.latency / PHYSICS_DT)
        self._pending: deque[tuple[int, float]] = deque()
        self._servo_cmd = 0.0  # the command the servo acts on (the latest one at least `latency` old)
        self._acc_dt = p.acceleration * PHYSICS_DT
        self._dec_dt = p.deceleration * PHYSICS_DT
        self._max_speed = p.max_speed
        self._delta: float | None = None
        self._k_beta = 0.0
        self._k_w = 0.0
        self._w = 0.0  # the control body's angular velocity, as last set
        self._units = p.hall_units_per_m
        self._travel = 0.0
        # sensors
        self.sensors = [
            _Sensor(name, m.x, m.y, math.radians(m.angle), math.radians(us.cone), us.rays)
            for name, m in sorted(us.mounts.items(), key=lambda kv: ("left", "right", "front").index(kv[0]))
        ]
        self._min_r, self._max_r = us.min_range, us.max_range
        self._cos_inc = math.cos(math.radians(us.max_incidence))
        self._sd0 = us.noise if noise else 0.0
        self._sd1 = us.noise_rel if noise else 0.0
        self._outliers = us.outliers if noise else 0.0
        self._dropouts = us.dropouts if noise else 0.0
        self._beam: tuple[list[tuple[float, ...]], list[tuple[float, float, float]]] | None = None
        self._beam_index: BeamIndex | None = None
        if us.model == "beam":
            self._half = math.radians(us.cone) / 2
            self._tan_half = math.tan(self._half)
            circles = [(ob.center[0], ob.center[1], ob.radius) for ob in world.obstacles
                       if ob.type == "circle" and ob.center is not None and ob.radius is not None]
            circles += [(mx, my, POST_RADIUS) for _id, mx, my, _z, _f, _s, post in world_markers(world) if post]
            segments: list[tuple[float, ...]] = [
                (a[0], a[1], b[0], b[1], min(a[0], b[0]), max(a[0], b[0]), min(a[1], b[1]), max(a[1], b[1]))
                for a, b in world.segments()]
            self._beam = (segments, circles)
            self._beam_index = BeamIndex(segments, us.max_range + WALL_RADIUS, self._half)
        self._res = us.resolution
        self.sensor_every = max(1, round(1.0 / (us.rate * PHYSICS_DT)))
        # public state (CarIO)
        self.left = self.right = self.front = us.max_range
        self.sample = 0
        self.distance = 0.0
        self.hall = 0
        self.speed = 0.0
        self.steering = 0.0
        self.steps = 0
        self.time = 0.0
        self.min_clearance = math.inf
        self._by_name = {sensor.name: sensor for sensor in self.sensors}
        self._outline = self._outline_points()
        self._half_diagonal = math.hypot(p.length, p.width) / 2
        self._make_queries()
        # odometry: dead reckoning from the hall sensor and the steering model (its own seeded errors)
        odo = random.Random(f"odometry/{seed}")
        self._odo_scale = (1.0 + odo.gauss(0.0, p.odometry_noise)) / self._units if noise else 1.0 / self._units
        self._odo_offset = self._offset + (odo.gauss(0.0, p.odometry_steering_noise) if noise else 0.0)
        self._odo_hall = 0
        self._odo_delta: float | None = None  # the model's steering angle, its tangent, slip angle and cosine
        self._odo_tan = self._odo_beta = self._odo_cos = 0.0
        self._odo = [0.0, 0.0, 0.0]
        # camera
        self._view: CameraView | None = None
        self._frame: Any = None
        self._cam: Any = None
        self.camera_frames = self.rendered_frames = 0
        cam = p.camera
        self.gate_memory: GateMemory | None = None
        if cam.enabled:
            self._view = NO_VIEW
            self.gate_memory = GateMemory()
            self.camera_every = max(1, round(1.0 / (cam.rate * PHYSICS_DT)))
            self._markers = world_markers(world)
            self._cam_seed = seed
        self.sense()
        self._pose_step = -1  # the body may still be placed by hand before the first step

    # -- CarIO ----------------------------------------------------------------------------------------
    def pose(self) -> tuple[float, float, float]:
        """Odometry: x, y, heading dead-reckoned from the hall sensor and the steering model, in the frame of
        the start pose (origin at the start, x along the start heading). It drifts, as a real car's does."""
        o = self._odo
        return o[0], o[1], o[2]

    def true_pose(self) -> tuple[float, float, float]:
        """Ground truth (world frame): for metrics, rendering and tests only; no state or transition reads it.
        The pose :meth:`sense` read in this physics step when it ran in it (the trajectory, the trace's samples and
        the gate log read it at the ticks the sensors fire: one read of pymunk instead of several)."""
        if self._pose_step == self.steps:
            return self._pose
        return self._read_pose()

    def true_position(self) -> tuple[float, float]:
        """Ground truth: x, y of :meth:`true_pose` (one read of chipmunk fewer when :meth:`sense` did not run in this
        step)."""
        if self._pose_step == self.steps:
            pose = self._pose
            return pose[0], pose[1]
        mem = self._mem
        if mem is not None:
            p = mem[1]
            return p[0], p[1]
        c = self._c
        if c is not None:
            q = _get_position(c[0])
            return q.x, q.y
        x, y = self.body.position
        return x, y

    def _read_pose(self) -> tuple[float, float, float]:
        """The body's pose from chipmunk: x, y, angle (world frame)."""
        mem = self._mem
        if mem is not None:
            p = mem[1]
            return p[0], p[1], mem[0][0]
        c = self._c
        if c is not None:
            body = c[0]
            p = _get_position(body)
            return p.x, p.y, _get_angle(body)
        x, y = self.body.position
        return x, y, self.body.angle

    def odometry_error(self) -> float:
        """Distance between the odometry position and the true one (in the start frame), m."""
        s = self.world.start
        x, y, _ = self.true_pose()
        h = math.radians(s.heading)
        dx, dy = x - s.x, y - s.y
        tx, ty = math.cos(h) * dx + math.sin(h) * dy, -math.sin(h) * dx + math.cos(h) * dy
        return math.hypot(self._odo[0] - tx, self._odo[1] - ty)

    def set_steering(self, value: float) -> None:
        value = float(value)
        if not value == value:  # NaN: a controller bug must not steer the car somewhere random
            raise ValueError("steering command is NaN")
        value = -1.0 if value < -1.0 else 1.0 if value > 1.0 else value
        if value != self._cmd_steer and self._lag:
            self._pending.append((self.steps + self._lag, value))
        self.steering = self._cmd_steer = value

    @property
    def servo_position(self) -> float:
        """Where the steering servo stands, steering units (ground truth; the command is ``steering``)."""
        return self._servo

    @property
    def speed_command(self) -> float:
        """The last speed command, m/s (after clamping to the car's maximum)."""
        return self._cmd_speed

    def set_speed(self, value: float) -> None:
        value = float(value)
        if not value == value:
            raise ValueError("speed command is NaN")
        m = self._max_speed
        self._cmd_speed = -m if value < -m else m if value > m else value

    def emergency_stop(self) -> None:
        self._cmd_speed = 0.0
        self._v = 0.0
        self.speed = 0.0
        self.control.velocity = (0.0, 0.0)
        self.control.angular_velocity = self._w = 0.0
        self.body.velocity = (0.0, 0.0)
        self.body.angular_velocity = 0.0

    def camera(self) -> CameraView | None:
        """The latest camera detections (``None`` when the car has no camera)."""
        view = self._view
        if view is not None and view.frame != self.camera_frames:  # frames of a world without markers (see step)
            frames = self.camera_frames
            view = self._view = CameraView(frames * self.camera_every * PHYSICS_DT, frames)
        return view

    def camera_frame(self) -> Any:
        """The latest rendered camera frame as the detector saw it (grey, not annotated), or ``None`` (no camera, or
        no marker was in view: nothing rendered). For the trace's thumbnails and the camera of a ROS 2 robot."""
        return self._frame

    def camera_image(self) -> Any:
        """The latest rendered frame annotated with what was detected (BGR), or ``None`` (no camera, or no marker
        was in view: nothing rendered). For the video."""
        if self._frame is None or self._cam is None:
            return None
        from fsm.vision.draw import annotate

        view = self._view
        return annotate(self._frame, view.detections if view else (), self._cam[0].camera,
                        view.gates if view else ())

    # -- physics ------------------------------------------------------------------------------------
    def step(self) -> None:
        """One physics step of 0.01 s: servo, speed controller, bicycle model, pymunk, hall, sensors."""
        steps = self.steps
        if self._lag:
            pending = self._pending
            while pending and pending[0][0] <= steps:
                self._servo_cmd = pending.popleft()[1]
            target = self._servo_cmd
        else:
            target = self._servo_cmd = self._cmd_steer
        s = self._servo
        d = target - s
        half = self._half_band
        if d and (d > half or d < -half) or (s != target and self._moving):
            # outside the dead band the servo drives to the command at its rate limit, and on until it is there
            lim = self._rate_dt
            s = s + lim if d > lim else s - lim if d < -lim else target
            self._servo = s
            self._moving = s != target
        v = self._v
        command = self._cmd_speed
        d = command - v
        if d:  # at the commanded speed (most steps) the limits below would give the command itself
            lim = self._acc_dt if (v >= 0.0 and d > 0.0) or (v <= 0.0 and d < 0.0) else self._dec_dt
            v = v + lim if d > lim else v - lim if d < -lim else command
        else:
            v = command
        self._v = v
        delta = (s + self._offset) * self.max_steering_angle
        if delta != self._delta:
            self._delta = delta
            t = math.tan(delta)
            beta = math.atan(0.5 * t)
            self._k_beta = beta
            self._k_w = math.cos(beta) * t / self.wheelbase
        mem = self._mem
        c = self._c
        if mem is not None and steps:  # the first step through pymunk: it checks the bodies added
            angle, _position, velocity, spin, space = mem
            th = angle[0] + self._k_beta
            velocity[0] = v * math.cos(th)
            velocity[1] = v * math.sin(th)
            spin[0] = self._w = v * self._k_w  # a kinematic body's: chipmunk never changes it
            _space_step(space, PHYSICS_DT)
        elif c is not None and steps:
            body, control, space = c
            th = _get_angle(body) + self._k_beta
            _set_velocity(control, (v * math.cos(th), v * math.sin(th)))
            w = v * self._k_w
            if w != self._w or w == 0.0:  # a kinematic body keeps its velocity: set it when it changes (or is 0)
                _set_angular_velocity(control, w)
                self._w = w
            _space_step(space, PHYSICS_DT)
        else:
            th = self.body.angle + self._k_beta
            self.control.velocity = (v * math.cos(th), v * math.sin(th))
            self.control.angular_velocity = self._w = v * self._k_w
            self.space.step(PHYSICS_DT)
        if self._touching:
            self.contact_steps += 1
        self.steps = steps = steps + 1
        self.time = steps * PHYSICS_DT
        self._travel = travel = self._travel + abs(v) * PHYSICS_DT
        units = self._units
        self.hall = h = int(travel * units)
        self.distance = h / units
        self.speed = v
        if h != self._odo_hall:  # dead reckoning moves only with the hall count
            self._odometry(h)
        if steps % self.sensor_every == 0:
            self.sense()
        if self._view is not None and steps % self.camera_every == 0:
            if self._markers:
                self.capture()
            else:  # a world without markers: nothing is ever in view, and camera() makes the frame's view when asked
                self.camera_frames += 1

    def _odometry(self, hall: int) -> None:
        """Dead reckoning for one step: hall units travelled and the steering servo as the car's model of it (its
        datasheet figures, which the simulated servo follows exactly, and its calibrated straight-ahead offset, which
        is a little off)."""
        s = self._servo
        dh = hall - self._odo_hall
        if not dh:
            return
        self._odo_hall = hall
        ds = dh * self._odo_scale
        if self._cmd_speed < 0 or (self._cmd_speed == 0 and self._v < 0):
            ds = -ds
        delta = (s + self._odo_offset) * self.max_steering_angle
        if delta != self._odo_delta:  # as in step(): the trigonometry only when the steering moved
            self._odo_delta = delta
            self._odo_tan = t = math.tan(delta)
            self._odo_beta = beta = math.atan(0.5 * t)
            self._odo_cos = math.cos(beta)
        o = self._odo
        th = o[2] + self._odo_beta
        o[0] += ds * math.cos(th)
        o[1] += ds * math.sin(th)
        o[2] += ds * self._odo_cos * self._odo_tan / self.wheelbase

    # -- camera -------------------------------------------------------------------------------------
    def _camera_setup(self) -> tuple[Any, Any]:
        """The renderer and the detector (built on the first frame: OpenCV loads only for cars that see markers)."""

        from fsm.sim.camera import MarkerSpec, SimCamera
        from fsm.vision.camera import CameraModel, CameraMount
        from fsm.vision.detector import MarkerDetector

        c = self.params.camera
        model = CameraModel.from_intrinsics(c.width, c.height, c.fx, c.fy)
        mount = CameraMount(x=c.x, y=c.y, height=c.z, yaw=math.radians(c.yaw), pitch=math.radians(c.pitch))
        specs = self._specs = [MarkerSpec(i, x, y, z, f, size) for i, x, y, z, f, size, _post in self._markers]
        occluders = self.world.segments()
        renderer = SimCamera(specs, camera=model, mount=mount, occluders=occluders, dictionary=c.dictionary,
                             blur=c.blur, noise=c.noise, lighting=c.lighting, seed=self._cam_seed)
        sizes = {} if c.marker_size is not None else {m.id: m.size for m in specs}
        detector = MarkerDetector(model, dictionary=c.dictionary, marker_size=c.marker_size or 0.15, sizes=sizes,
                                  mount=mount, track=True, full_every=c.full_every)
        return renderer, detector

    def _maybe_in_view(self) -> list[int]:
        """A cheap frustum test: the indices of the markers that could be in the image (in front, within the field
        of view plus a margin, in range, their face towards the camera)."""
        c = self.params.camera
        x, y, th = self.true_pose()
        ct, st = math.cos(th), math.sin(th)
        cx, cy = x + ct * c.x - st * c.y, y + st * c.x + ct * c.y
        yaw = th + math.radians(c.yaw)
        cy_, sy_ = math.cos(yaw), math.sin(yaw)
        half = math.atan2(c.width / 2, c.fx) + 0.2
        out = []
        for k, (_id, mx, my, _z, facing, size, _post) in enumerate(self._markers):
            dx, dy = mx - cx, my - cy
            fwd = cy_ * dx + sy_ * dy
            if fwd <= 0.02 or fwd > CAMERA_RANGE:
                continue
            side = -sy_ * dx + cy_ * dy
            if abs(math.atan2(side, fwd)) > half + size / max(fwd, 0.1):
                continue
            if math.cos(facing) * dx + math.sin(facing) * dy >= 0:
                continue  # seen from behind
            out.append(k)
        return out

    def capture(self) -> None:
        """Take one camera frame: render the markers in view from the true pose (rendering only) and detect
        them in the pixels; what states see comes from the detector. No marker can be in view: no frame to
        look at, nothing detected."""
        self.camera_frames += 1
        t = self.time
        if not self._markers:  # a world without markers: nothing is ever in view (the hallway)
            self._view = CameraView(t, self.camera_frames)
            return
        candidates = self._maybe_in_view()
        if not candidates:
            self._frame = None
            if self._cam is not None:
                self._cam[1].reset()
            self._view = CameraView(t, self.camera_frames)
            return
        if self._cam is None:
            self._cam = self._camera_setup()
        renderer, detector = self._cam
        renderer.markers = [self._specs[k] for k in candidates]  # the exact projection only for these
        frame = renderer.render(*self.true_pose())
        self.rendered_frames += 1
        detections = detector.detect(frame)
        gates: tuple[Any, ...] = ()
        if len(detections) > 1:
            from fsm.vision.gates import find_gates

            gates = tuple(find_gates(detections))
        self._frame = frame
        self._view = CameraView(t, self.camera_frames, tuple(detections), gates)
        if gates and self.gate_memory is not None:  # it is: a car with a camera has one
            self.gate_memory.update(self.pose(), gates)

    def _begin(self, arbiter: Any, space: Any, data: Any) -> None:
        if self._touching == 0:
            self.collisions += 1
        self._touching += 1

    def _separate(self, arbiter: Any, space: Any, data: Any) -> None:
        self._touching = max(0, self._touching - 1)
        self._apart = self.steps

    # -- snapshots (fsm.session.snapshot) -------------------------------------------------------------------
    def snapshot_ready(self) -> bool:
        """Whether a snapshot taken now restores exactly: pymunk keeps no contact of the car (none now, and none
        cached from the last few steps: a contact's impulses carry over to the next steps, and they cannot be
        read), and its joints' memory can be read on this pymunk build."""
        return (not self._touching and self.steps - self._apart > self.space.collision_persistence
                and self._c is not None and _joint_layout(self._joints) is not None)

    def __snapshot__(self) -> tuple[Any, ...]:
        """The bodies' state (position, angle, velocities, forces) and the joints' accumulated impulses (which
        the next step starts from: pymunk has no way to set them, so their memory is copied)."""
        body, control, _space = self._c or (None, None, None)
        layout = _joint_layout(self._joints)
        if body is None or layout is None:
            return ()
        bodies = tuple((_lib.cpBodyGetPosition(b), _lib.cpBodyGetAngle(b), _lib.cpBodyGetVelocity(b),
                        _lib.cpBodyGetAngularVelocity(b), _lib.cpBodyGetForce(b), _lib.cpBodyGetTorque(b))
                       for b in (body, control))
        joints = tuple(bytes(_ffi.buffer(_ffi.cast("char *", joint._constraint) + start, size))
                       for joint, (start, size) in zip(self._joints, layout, strict=True))
        return tuple((p.x, p.y, a, v.x, v.y, w, f.x, f.y, t) for p, a, v, w, f, t in bodies), joints

    def __restore__(self, state: tuple[Any, ...]) -> None:
        """Put the bodies and joints back as :meth:`__snapshot__` found them, and drop the contacts pymunk caches
        for the car (the car's shape taken out of the space and put back): a snapshot has none."""
        if not state or self._c is None:
            return
        bodies, joints = state
        restored = self._touching, self._apart, self.collisions
        self.space.remove(self.shape)  # its cached contacts go with it (their callbacks' counts: put back below)
        self.space.add(self.shape)
        self._touching, self._apart, self.collisions = restored
        for b, (x, y, a, vx, vy, w, fx, fy, t) in zip(self._c[:2], bodies, strict=True):
            _lib.cpBodySetAngle(b, a)
            _lib.cpBodySetPosition(b, (x, y))
            _lib.cpBodySetVelocity(b, (vx, vy))
            _lib.cpBodySetAngularVelocity(b, w)
            _lib.cpBodySetForce(b, (fx, fy))
            _lib.cpBodySetTorque(b, t)
        layout = _joint_layout(self._joints)
        assert layout is not None
        for joint, (start, size), raw in zip(self._joints, layout, joints, strict=True):
            _ffi.memmove(_ffi.cast("char *", joint._constraint) + start, raw, size)

    # -- sensors ------------------------------------------------------------------------------------
    def sense(self) -> None:
        """Take one ultrasonic sample of all three sensors (and the clearance to the walls)."""
        self._pose = x, y, th = self._read_pose()
        self._pose_step = self.steps
        c, s = math.cos(th), math.sin(th)
        max_r = self._max_r
        rng = self.rng
        beam = self._beam is not None
        echo = self._beam_echo if self._beam is not None and self._beam[1] else self._wall_echo
        sd0, sd1, outliers, dropouts, min_r, res = (self._sd0, self._sd1, self._outliers, self._dropouts, self._min_r,
                                                    self._res)
        for sensor in self.sensors:
            ox = x + c * sensor.mx - s * sensor.my
            oy = y + s * sensor.mx + c * sensor.my
            if beam:
                lx, ly = sensor.rays[0]  # the centre ray: the beam's axis
                best = echo(ox, oy, c * lx - s * ly, s * lx + c * ly)
            else:
                best = self._ray_echo(ox, oy, c, s, sensor.rays)
            if best < max_r:
                if sd0 or sd1:
                    best += rng.gauss(0.0, sd0 + sd1 * best)
                if outliers and rng.random() < outliers:
                    best = rng.uniform(min_r, max_r)
                if dropouts and rng.random() < dropouts:
                    best = max_r  # the echo was missed
                if best < min_r:
                    best = min_r
                elif best > max_r:
                    best = max_r
                if res:
                    best = round(best / res) * res
            setattr(self, sensor.name, best)
        self.sample += 1
        clear = self.min_clearance
        reach = clear + self._half_diagonal
        # The body can only be nearer than the clearance so far if its centre is within that plus its half diagonal.
        centre = self._nearest(self.space, x, y, reach)
        if centre < reach:
            self._clearance_near(x, y, c, s, centre)

    def _ray_echo(self, ox: float, oy: float, c: float, s: float, rays: Iterable[tuple[float, float]]) -> float:
        """The ``rays`` model: the nearest echo along the sensor's rays (directions in the car's frame, the car
        turned by cos ``c``, sin ``s``) from a sensor at (ox, oy); ``max_range`` when none comes back."""
        ray = self._ray
        max_r = self._max_r
        back = RAY_BACK
        length = max_r + back
        cos_inc = self._cos_inc
        best = max_r
        for lx, ly in rays:
            dx = c * lx - s * ly
            dy = s * lx + c * ly
            # Start behind the mount, inside the body: a sensor pressed against a wall still sees it.
            hit = ray(ox - dx * back, oy - dy * back, ox + dx * max_r, oy + dy * max_r)
            if hit is None:
                continue
            alpha, nx, ny = hit
            if -(nx * dx + ny * dy) < cos_inc:
                continue  # too oblique: the echo is reflected away
            r = alpha * length - back
            if r < best:
                best = r
        return best

    def _clearance_near(self, x: float, y: float, c: float, s: float, centre: float = 0.0) -> None:
        """The body's clearance to the walls, where its centre (x, y, turned by cos ``c``, sin ``s``) is near
        enough for it to be below the smallest so far: the nearest wall to each point of the outline. ``centre`` is
        the centre's distance to the nearest wall: a point ``r`` from the centre is at least ``centre - r`` from any
        wall, so a point that cannot be nearer than the clearance so far (a nanometre of slack for rounding) is not
        asked (on a straight, the middles of the sides)."""
        nearest = self._nearest
        clear = self.min_clearance
        reach = clear if clear != math.inf else 1e3
        for px, py, r in self._outline:
            if centre - r - 1e-9 >= clear:
                continue
            d = nearest(self.space, x + c * px - s * py, y + s * px + c * py, reach)
            if d < clear:
                clear = d
        self.min_clearance = clear

    def _beam_echo(self, ox: float, oy: float, ux: float, uy: float) -> float:
        """The ``beam`` model: the distance from a sensor at (ox, oy) looking along the unit vector (ux, uy) to the
        nearest surface inside its cone (half-angle ``cone / 2``) within range; a flat surface (a wall segment) only
        where the beam meets it within ``max_incidence`` of its normal (its nearest point in the cone is the one most
        square to the beam), a round one (a post, a circular obstacle) anywhere in the beam. ``max_range`` when there
        is none. Occlusion is implied: the nearest echo is never behind another surface. The round surfaces here,
        the flat ones in :meth:`_wall_echo` (which a world without round ones calls directly)."""
        assert self._beam is not None
        best = self._max_r
        half = self._half
        for cx, cy, r in self._beam[1]:
            dx, dy = cx - ox, cy - oy
            d = math.hypot(dx, dy)
            if d - r >= best:
                continue
            if d <= r:
                return self._min_r
            cos_a = (dx * ux + dy * uy) / d
            if math.acos(max(-1.0, min(1.0, cos_a))) <= half + math.asin(r / d):
                best = d - r
        return self._wall_echo(ox, oy, ux, uy, best)

    def _wall_echo(self, ox: float, oy: float, ux: float, uy: float, best: float | None = None) -> float:
        """The ``beam`` model's echo from the wall segments (see :meth:`_beam_echo`): the nearest one nearer than
        ``best`` (``max_range`` without one), else ``best``."""
        index = self._beam_index
        assert index is not None
        # BeamIndex.near, its filled cells looked up here (three of these per sample)
        segments = index.cells.get((math.floor(ox / BEAM_CELL), math.floor(oy / BEAM_CELL),
                                    int(math.atan2(uy, ux) // index.width) % BEAM_SECTORS))
        if segments is None:
            segments = index.near(ox, oy, ux, uy)
        if best is None:
            best = self._max_r
        tan_h = self._tan_half
        cos_inc = self._cos_inc
        reach = best + WALL_RADIUS
        x_lo, x_hi, y_lo, y_hi = ox - reach, ox + reach, oy - reach, oy + reach
        for ax, ay, bx, by, lox, hix, loy, hiy in segments:
            if lox > x_hi or hix < x_lo or loy > y_hi or hiy < y_lo:
                continue  # its bounding box is farther than the nearest echo so far
            # in the sensor's frame: x along the beam, y to its left
            rx, ry = ax - ox, ay - oy
            x0 = rx * ux + ry * uy
            qx, qy = bx - ox, by - oy
            x1 = qx * ux + qy * uy
            if x0 <= 0.0 and x1 <= 0.0 or x0 >= best and x1 >= best:
                continue  # behind the sensor, or every point farther along the beam than the nearest echo
            y0 = -rx * uy + ry * ux
            # clip P(t) = P0 + t (P1 - P0), t in [0, 1], to the cone |y| <= x tan_h: f + t df <= 0 on either side
            # (a side that leaves nothing ends the segment: the other side can only narrow the range further)
            ex, ey = x1 - x0, (-qx * uy + qy * ux) - y0
            xt, et = x0 * tan_h, ex * tan_h
            t0, t1 = 0.0, 1.0
            f, df = y0 - xt, ey - et  # the left edge, y = x tan_h
            if df > 0.0:
                t = -f / df
                t1 = t if t < 1.0 else 1.0
            elif df < 0.0:
                t = -f / df
                t0 = t if t > 0.0 else 0.0
            elif f > 0.0:
                continue  # parallel to the edge, all of it outside
            f, df = -y0 - xt, -ey - et  # the right one, y = -x tan_h
            if df > 0.0:
                t = -f / df
                t1 = t if t < t1 else t1
            elif df < 0.0:
                t = -f / df
                t0 = t if t > t0 else t0
            elif f > 0.0:
                continue
            if t0 <= t1:
                d = _cone_echo(x0, y0, ex, ey, t0, t1, cos_inc)
                if d < best:
                    if d <= 0.0:
                        return self._min_r
                    best = d
                    reach = best + WALL_RADIUS
                    x_lo, x_hi, y_lo, y_hi = ox - reach, ox + reach, oy - reach, oy + reach
        return best

    def _make_queries(self) -> None:
        """Ray and nearest-point queries on this car's space (fast path through pymunk's cffi binding)."""
        space = self.space
        flt = self._query
        if _lib is not None:
            seg_info = _ffi.new("cpSegmentQueryInfo *")
            pt_info = _ffi.new("cpPointQueryInfo *")
            null = _ffi.NULL
            seg_first = _lib.cpSpaceSegmentQueryFirst
            pt_nearest = _lib.cpSpacePointQueryNearest
            cflt = _ffi.new("cpShapeFilter *", tuple(flt))[0]

            def ray_c(ax: float, ay: float, bx: float, by: float, _sp: Any = space._space) -> Hit | None:
                if seg_first(_sp, (ax, ay), (bx, by), 0.0, cflt, seg_info) == null:
                    return None
                n = seg_info.normal
                return seg_info.alpha, n.x, n.y

            def nearest_c(sp: pymunk.Space, px: float, py: float, max_d: float) -> float:
                if pt_nearest(sp._space, (px, py), max_d, cflt, pt_info) == null:
                    return math.inf
                distance: float = pt_info.distance
                return distance

            self._ray: RayQuery = ray_c
            self._nearest: NearestQuery = nearest_c
        else:
            def ray(ax: float, ay: float, bx: float, by: float) -> Hit | None:
                hit = space.segment_query_first((ax, ay), (bx, by), 0.0, flt)
                if hit is None:
                    return None
                return hit.alpha, hit.normal.x, hit.normal.y

            def nearest(sp: pymunk.Space, px: float, py: float, max_d: float) -> float:
                info = sp.point_query_nearest((px, py), max_d, flt)
                return math.inf if info is None else info.distance

            self._ray = ray
            self._nearest = nearest

    def _outline_points(self) -> list[tuple[float, float, float]]:
        """The points of the body's outline whose clearance is measured: x, y in the car's frame and the distance
        from its centre."""
        hl, hw = self.length / 2, self.width / 2
        return [(px, py, math.hypot(px, py)) for px, py in ((-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw), (0.0, hw),
                                                               (0.0, -hw))]

    # -- ground truth for metrics -----------------------------------------------------------------------
    def true_distance(self, side: str, pose: tuple[float, float, float] | None = None) -> float:
        """Ground truth: distance from sensor ``side`` to the nearest nominal wall (door recesses left out), from
        ``pose`` (the :meth:`true_pose` of this step, which the caller may have read already) or the body's."""
        if self._nominal is None:
            has_doors = any(w.doors for w in self.world.walls)
            self._nominal = build_space(self.world, doors=False) if has_doors else self.space
        sensor = self._by_name[side]
        x, y, th = pose if pose is not None else self.true_pose()
        c, s = math.cos(th), math.sin(th)
        return self._nearest(self._nominal, x + c * sensor.mx - s * sensor.my, y + s * sensor.mx + c * sensor.my, 5.0)


#: Where a pivot and a gear joint keep their numbers in chipmunk's memory (bytes from the start, how many): after
#: the common constraint header, the pivot's anchors, arms, mass matrix, accumulated impulse and bias; the gear's
#: phase, ratio, inverse ratio, mass, bias and accumulated impulse. Found and checked once (see _joint_layout).
_JOINT_FIELDS = (16, 6)
_layout: list[tuple[tuple[int, int], ...] | None] = []


def _joint_layout(joints: tuple[Any, ...]) -> tuple[tuple[int, int], ...] | None:
    """Where the pivot's and the gear's numbers are in chipmunk's memory, or None if they cannot be found on this
    pymunk build. Found by writing known anchors and a known phase and looking for them, then checked: the
    accumulated impulses at the places found must be what pymunk reports as the joints' impulses."""
    if _layout:
        return _layout[0]
    found: tuple[tuple[int, int], ...] | None = None
    if _lib is not None:
        a, b = pymunk.Body(body_type=pymunk.Body.KINEMATIC), pymunk.Body(1.0, 1.0)
        probe = (pymunk.PivotJoint(a, b, (0.123456789, 0.987654321), (0.5, 0.25)),
                 pymunk.GearJoint(a, b, 0.314159, 1.5))
        marks = (0.123456789, 0.314159)
        starts: list[int] = []
        for joint, mark in zip(probe, marks, strict=True):
            d = _ffi.cast("double *", joint._constraint)
            starts += [i for i in range(4, 40) if d[i] == mark][:1]
        if len(starts) == 2:
            found = tuple((8 * start, 8 * n) for start, n in zip(starts, _JOINT_FIELDS, strict=True))
    if found is not None and not _impulses_agree(joints, found):
        found = None
    _layout.append(found)
    return found


def _impulses_agree(joints: tuple[Any, ...], layout: tuple[tuple[int, int], ...]) -> bool:
    pivot, gear = joints
    p = _ffi.cast("double *", pivot._constraint)
    g = _ffi.cast("double *", gear._constraint)
    i, j = layout[0][0] // 8 + 12, layout[1][0] // 8 + 5
    return bool(math.isclose(math.sqrt(p[i] * p[i] + p[i + 1] * p[i + 1]), pivot.impulse, rel_tol=1e-9, abs_tol=1e-300)
                and math.isclose(abs(g[j]), gear.impulse, rel_tol=1e-9, abs_tol=1e-300))


#: Where chipmunk keeps a body's angle, the x of its position and of its velocity, and its angular velocity (indices
#: of doubles from the body's start), found once (see _body_layout); None when they cannot be found.
_body: list[tuple[int, int, int, int] | None] = []
#: The size of chipmunk 7's cpBody in 8-byte words (pymunk declares the struct opaque, so cffi cannot say).
BODY_WORDS = 34


def _body_layout() -> tuple[int, int, int, int] | None:
    """Where a body's angle, position (the x of its transform's translation, what ``cpBodyGetPosition`` returns),
    velocity and angular velocity are in chipmunk's memory. Found on a probe body whose centre of gravity is off
    its origin (so that its position and its centre's differ) by setting known values through chipmunk and looking
    for them; None if any is not found once."""
    if _body:
        return _body[0]
    found: tuple[int, int, int, int] | None = None
    if _lib is not None:
        probe = pymunk.Body(1.0, 1.0)
        probe.center_of_gravity = (0.375, -0.625)
        b = probe._body
        _lib.cpBodySetAngle(b, 0.123456789)
        _lib.cpBodySetPosition(b, (4.5678, -7.8912))
        _lib.cpBodySetVelocity(b, (0.314159, -0.271828))
        _lib.cpBodySetAngularVelocity(b, 0.577215)
        d = _ffi.cast("double *", b)
        pos = _lib.cpBodyGetPosition(b)
        # only inside the struct: chipmunk 7's cpBody is 34 words (two function pointers, then mass, moment, centre
        # of gravity, position, velocity, force, angle, angular velocity, torque, transform, ... sleeping); reading
        # further would read whatever the allocator put after it
        words = range(2, BODY_WORDS - 1)
        spots = [[i for i in words if d[i] == 0.123456789],
                 [i for i in words if d[i] == pos.x and d[i + 1] == pos.y],
                 [i for i in words if d[i] == 0.314159 and d[i + 1] == -0.271828],
                 [i for i in words if d[i] == 0.577215]]
        if all(len(spot) == 1 for spot in spots):
            found = (spots[0][0], spots[1][0], spots[2][0], spots[3][0])
    _body.append(found)
    return found


def _body_fields(body: Any, control: Any) -> tuple[Any, Any, Any, Any] | None:
    """Pointers into chipmunk's memory: ``body``'s angle and position (x, y), ``control``'s velocity (x, y) and
    angular velocity; ``None`` where the layout is not found or a read disagrees with chipmunk's own functions.

    Writing the velocities there is what ``cpBodySetVelocity`` and ``cpBodySetAngularVelocity`` do for a kinematic
    body (they only wake a *dynamic* body, and check the values in debug builds)."""
    layout = _body_layout()
    if layout is None:
        return None
    a, p, v, w = layout
    bd, cd = _ffi.cast("double *", body), _ffi.cast("double *", control)
    pos, vel = _lib.cpBodyGetPosition(body), _lib.cpBodyGetVelocity(control)
    if (bd[a], bd[p], bd[p + 1], cd[v], cd[v + 1], cd[w]) != (
            _lib.cpBodyGetAngle(body), pos.x, pos.y, vel.x, vel.y, _lib.cpBodyGetAngularVelocity(control)):
        return None
    return bd + a, bd + p, cd + v, cd + w


def _clip(f: float, df: float, t0: float, t1: float) -> tuple[float, float]:
    """[t0, t1] narrowed to where f + t df <= 0 (one edge of the cone, see SimCar._wall_echo); t0 > t1 when nothing
    is left."""
    if df > 0.0:
        t = -f / df
        return t0, t if t < t1 else t1
    if df < 0.0:
        t = -f / df
        return t if t > t0 else t0, t1
    return (2.0 if f > 0.0 else t0), t1  # parallel to the edge: all of it on one side


def _cone_echo(x0: float, y0: float, ex: float, ey: float, t0: float, t1: float, cos_inc: float) -> float:
    """The echo of the wall segment P(t) = (x0, y0) + t (ex, ey) (the sensor's frame, the sensor at the origin) over
    t0 <= t <= t1 (its part in the cone): the distance to its nearest point there, or ``inf`` when it has no length
    or meets the beam too obliquely; at most 0 when the sensor touches it."""
    ll = ex * ex + ey * ey
    if ll == 0.0:
        return math.inf
    t = -(x0 * ex + y0 * ey) / ll  # the foot of the perpendicular from the sensor
    t = t0 if t < t0 else t1 if t > t1 else t
    d = math.hypot(x0 + t * ex, y0 + t * ey) - WALL_RADIUS
    if d > 0.0 and abs(x0 * ey - y0 * ex) / math.sqrt(ll) < cos_inc * (d + WALL_RADIUS):
        return math.inf  # too oblique: the echo is reflected away
    return d


class BeamIndex:
    """The wall segments a beam may echo from, filed by where the sensor is and where it looks: the plane in square
    cells of :data:`BEAM_CELL`, the directions in :data:`BEAM_SECTORS` equal sectors. A (cell, sector) holds the
    segments whose bounding box meets the cell grown by the box around every cone of the sector (radius ``reach``):
    any segment with a point inside the beam within ``reach`` is among them, so the echoes are the ones a search of
    every wall gives, in the same order. Filled lazily: a run visits a few hundred of them."""

    def __init__(self, segments: list[tuple[float, ...]], reach: float, half: float) -> None:
        self.segments = segments
        self.width = 2.0 * math.pi / BEAM_SECTORS
        margin = 0.01  # rounding at the boxes' edges must never drop a segment
        self.wedges: list[tuple[float, float, float, float]] = []
        for k in range(BEAM_SECTORS):
            a0, a1 = k * self.width - half, (k + 1) * self.width + half
            angles = [a0, a1] + [m * math.pi / 2 for m in range(-4, 9) if a0 < m * math.pi / 2 < a1]
            xs = [0.0] + [reach * math.cos(a) for a in angles]
            ys = [0.0] + [reach * math.sin(a) for a in angles]
            self.wedges.append((min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin))
        self.cells: dict[tuple[int, int, int], tuple[tuple[float, ...], ...]] = {}
        #: each distinct list of segments once: neighbouring cells mostly hold the same walls, and a long run keeps
        #: filling cells where its track wanders (memory per cell: its key and a reference)
        self._shared: dict[tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...]] = {}

    def near(self, ox: float, oy: float, ux: float, uy: float) -> tuple[tuple[float, ...], ...]:
        """The segments a sensor at (ox, oy) looking along (ux, uy) may echo from."""
        key = (math.floor(ox / BEAM_CELL), math.floor(oy / BEAM_CELL),
               int(math.atan2(uy, ux) // self.width) % BEAM_SECTORS)
        found = self.cells.get(key)
        if found is None:
            i, j, k = key
            wx0, wx1, wy0, wy1 = self.wedges[k]
            x0, x1 = i * BEAM_CELL + wx0, (i + 1) * BEAM_CELL + wx1
            y0, y1 = j * BEAM_CELL + wy0, (j + 1) * BEAM_CELL + wy1
            found = tuple(seg for seg in self.segments
                          if seg[4] <= x1 and seg[5] >= x0 and seg[6] <= y1 and seg[7] >= y0)
            found = self.cells[key] = self._shared.setdefault(found, found)
        return found
