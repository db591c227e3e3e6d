"""World files: walls, obstacles, ArUco gates, the start pose and the car's parameters; validation with located errors.

A world is a JSON document (``diagrams/worlds/*.json``) checked like a machine document: first the
shape against pydantic models (the same models the committed ``world.schema.json`` is generated
from), then semantic checks (a door that does not fit its segment, a car that starts inside a wall).
Every problem carries file, JSON pointer and line:column, and all of a file's problems are reported.

Stdlib and pydantic only; the pymunk space is built from a checked world in :mod:`fsm.sim.physics`.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationError, model_validator

from fsm.model.errors import DiagramError, Problem, UsageError
from fsm.model.params import ParamsBase
from fsm.sim.io import SensorName


def _pair(value: Any) -> Any:
    """JSON has no tuples: a list of two becomes a pair (then checked strictly as two numbers)."""
    return tuple(value) if isinstance(value, list) and len(value) == 2 else value


Point = Annotated[tuple[float, float], BeforeValidator(_pair)]
Segment = tuple[tuple[float, float], tuple[float, float]]

#: Coordinates beyond this many metres are refused (a typo guard; a hallway is tens of metres).
MAX_COORD = 10_000.0
HALL_UNITS_PER_M = 1500 / 1.60


class WorldModel(ParamsBase):
    """Strict like machine documents: unknown keys, strings for numbers, NaN and infinity are errors."""

    model_config = {**ParamsBase.model_config, "frozen": False}


def _check_points(points: list[Point], what: str) -> None:
    for p in points:
        for c in p:
            if abs(c) > MAX_COORD:
                raise ValueError(f"{what} coordinate {c} is beyond {MAX_COORD:g} m")


# -- geometry -----------------------------------------------------------------------------------------
class Door(WorldModel):
    """A door frame: a recess of a few cm in one segment of a wall."""

    segment: int = Field(ge=0, description="Index of the wall segment (0 = from the first to the second point).")
    at: float = Field(ge=0, description="Distance of the door's centre from the segment's first point, m.")
    width: float = Field(default=0.9, gt=0, le=5, description="Width of the door frame along the wall, m.")
    depth: float = Field(default=0.05, gt=0, le=0.5, description="How far the recess goes into the wall, m.")
    side: Literal["left", "right"] = Field(
        default="right", description="Side of the segment (looking from its first point) the recess goes into.")


class Wall(WorldModel):
    """A wall: a polyline in metres (open or closed; it may cross itself: walls are just segments)."""

    points: list[Point] = Field(min_length=2, description="Corner points [x, y] in metres.")
    closed: bool = Field(default=False, description="Join the last point back to the first.")
    doors: list[Door] = Field(default_factory=list, description="Door frames (recesses) along the segments.")

    @model_validator(mode="after")
    def _coords(self) -> Wall:
        _check_points(self.points, "wall")
        if all(p == self.points[0] for p in self.points):
            raise ValueError("a wall needs two different points (this one has no length)")
        return self


class Obstacle(WorldModel):
    """A static obstacle: a box (centre, size, angle), a circle (centre, radius) or a polygon (points)."""

    type: Literal["box", "circle", "polygon"] = Field(description="Shape of the obstacle.")
    center: Point | None = Field(default=None, description="Centre [x, y] in metres (box, circle).")
    size: Annotated[tuple[float, float], BeforeValidator(_pair)] | None = Field(
        default=None, description="Box size [length, width] in metres.")
    angle: float = Field(default=0.0, description="Box rotation in degrees, counter-clockwise.")
    radius: float | None = Field(default=None, gt=0, description="Circle radius in metres.")
    points: list[Point] | None = Field(default=None, min_length=3, description="Polygon corners in metres.")

    @model_validator(mode="after")
    def _fields_for_shape(self) -> Obstacle:
        need = {"box": ("center", "size"), "circle": ("center", "radius"), "polygon": ("points",)}[self.type]
        missing = [n for n in need if getattr(self, n) is None]
        if missing:
            raise ValueError(f"a {self.type} obstacle needs {' and '.join(repr(n) for n in missing)}")
        if self.size is not None and not (self.size[0] > 0 and self.size[1] > 0):
            raise ValueError(f"box size must be > 0, got {list(self.size)}")
        _check_points([p for p in (self.center,) if p is not None] + list(self.points or []), "obstacle")
        return self

    def polygon(self) -> list[Point] | None:
        """Corners of a box or polygon (``None`` for a circle)."""
        if self.type == "polygon":
            return list(self.points or [])
        if self.type == "box":
            assert self.center is not None and self.size is not None
            cx, cy = self.center
            hl, hw = self.size[0] / 2, self.size[1] / 2
            a = math.radians(self.angle)
            c, s = math.cos(a), math.sin(a)
            return [(cx + x * c - y * s, cy + x * s + y * c) for x, y in ((-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw))]
        return None


class Gate(WorldModel):
    """An ArUco gate: two markers beside each other in the hallway (used by the camera states)."""

    name: str | None = Field(default=None, description="Name of the gate, for traces.")
    markers: Annotated[tuple[int, int], BeforeValidator(_pair)] = Field(
        description="ArUco ids of the left and right marker (DICT_4X4_50).")
    center: Point = Field(description="Midpoint between the two markers [x, y] in metres.")
    heading: float = Field(default=0.0, description="Direction to drive through the gate, degrees.")
    width: float = Field(default=0.6, gt=0, le=5, description="Distance between the marker centres, m.")
    marker_size: float = Field(default=0.15, gt=0, le=1, description="Side of the black marker square, m.")
    height: float = Field(default=0.15, ge=0, le=2, description="Height of the marker centres above the floor, m.")


class Marker(WorldModel):
    """A standalone ArUco marker (a sign on a wall or on a post): id, position, the direction its face looks to."""

    name: str | None = Field(default=None, description="Name of the marker, for traces.")
    id: int = Field(ge=0, description="ArUco id (in the car camera's dictionary, DICT_4X4_50 by default: 0-49).")
    position: Point = Field(description="Centre of the marker [x, y] in metres (on the floor plan).")
    facing: float = Field(description="Direction the printed face looks to, degrees counter-clockwise from +x.")
    size: float = Field(default=0.15, gt=0, le=1, description="Side of the black marker square, m.")
    height: float = Field(default=0.15, ge=0, le=2, description="Height of the marker centre above the floor, m.")
    post: bool = Field(default=False, description="The marker stands on a post (a physical obstacle) rather "
                                                  "than hanging on a wall.")


class Start(WorldModel):
    """Where the car starts: position of its centre and heading."""

    x: float = Field(description="x of the car's centre, m.")
    y: float = Field(description="y of the car's centre, m.")
    heading: float = Field(default=0.0, description="Heading in degrees, counter-clockwise from +x.")


# -- the car ------------------------------------------------------------------------------------------
class Mount(WorldModel):
    """Where an ultrasonic sensor sits on the car (car frame: x forward, y left, from the car's centre)."""

    x: float = Field(description="Forward offset from the car's centre, m.")
    y: float = Field(description="Left offset from the car's centre, m.")
    angle: float = Field(description="Direction the sensor looks, degrees from straight ahead (left positive).")


def _default_mounts() -> dict[SensorName, Mount]:
    return {
        "left": Mount(x=0.08, y=0.095, angle=90.0),
        "right": Mount(x=0.08, y=-0.095, angle=-90.0),
        "front": Mount(x=0.20, y=0.0, angle=0.0),
    }


class Ultrasonic(WorldModel):
    """The three ultrasonic sensors: a cone of rays each, nearest echo, range limits, seeded noise."""

    rate: float = Field(default=20.0, gt=0, le=100, description="Samples per second (all three sensors together).")
    min_range: float = Field(default=0.05, ge=0, description="Nearer echoes read as this, m.")
    max_range: float = Field(default=3.0, gt=0, le=10, description="No echo (or farther) reads as this, m.")
    model: Literal["rays", "beam"] = Field(
        default="beam",
        description="How an echo is found: \"beam\" (as the hardware sees), the nearest surface anywhere inside the "
                    "cone, posts and round obstacles included, flat surfaces only within max_incidence of their "
                    "normal; \"rays\" (the model before), the nearest hit of `rays` rays spread over the cone (a "
                    "thin post can fall between them). docs/car.md.")
    rays: int = Field(default=5, ge=1, le=31, description="Rays per cone.")
    cone: float = Field(default=15.0, ge=0, lt=180,
                        description="Full opening angle of the cone, degrees (HC-SR04: 15).")
    max_incidence: float = Field(
        default=70.0, gt=0, le=90,
        description="Echoes hitting a surface more obliquely than this (degrees from its normal) are lost.")
    noise: float = Field(default=0.002, ge=0, le=0.5, description="Noise standard deviation, m (constant part).")
    noise_rel: float = Field(default=0.004, ge=0, le=0.5, description="Noise standard deviation, fraction of range.")
    outliers: float = Field(default=0.0, ge=0, le=1, description="Probability that a sample is a random outlier.")
    dropouts: float = Field(default=0.0, ge=0, le=1,
                            description="Probability that an echo is missed (the sample reads max_range).")
    resolution: float = Field(default=0.001, ge=0, le=0.1, description="Readings are rounded to this, m (0: off).")
    mounts: dict[SensorName, Mount] = Field(
        default_factory=_default_mounts, description="Position and direction of each sensor on the car.")

    @model_validator(mode="after")
    def _range(self) -> Ultrasonic:
        missing = {k: v for k, v in _default_mounts().items() if k not in self.mounts}
        if missing:  # a file that moves one sensor keeps the other two where they are by default
            object.__setattr__(self, "mounts", {**missing, **self.mounts})
        if self.min_range >= self.max_range:
            raise ValueError(f"min_range ({self.min_range}) must be below max_range ({self.max_range})")
        return self


#: Ids per predefined ArUco dictionary (world checks run without OpenCV).
DICTIONARY_SIZES: dict[str, int] = {
    **{f"DICT_{b}X{b}_{n}": n for b in (4, 5, 6, 7) for n in (50, 100, 250, 1000)},
    "DICT_ARUCO_ORIGINAL": 1024, "DICT_APRILTAG_16h5": 30, "DICT_APRILTAG_25h9": 35,
    "DICT_APRILTAG_36h10": 2320, "DICT_APRILTAG_36h11": 587, "DICT_ARUCO_MIP_36h12": 250,
}


class Camera(WorldModel):
    """The car's camera: a pinhole (no distortion) on a mount, rendering the world's markers at ``rate``; the
    same ArUco detector a real car runs finds them in those frames."""

    enabled: bool = Field(default=True, description="False: the car has no camera (car.camera() is None).")
    rate: float = Field(default=20.0, gt=0, le=100, description="Frames per second.")
    width: int = Field(default=640, ge=32, le=4096, description="Image width, px.")
    height: int = Field(default=480, ge=32, le=4096, description="Image height, px.")
    fx: float = Field(default=600.0, gt=0, le=100000, description="Focal length in pixels (x).")
    fy: float | None = Field(default=None, gt=0, le=100000, description="Focal length in pixels (y; default fx).")
    x: float = Field(default=0.15, ge=-5, le=5, description="Forward offset of the camera from the car's centre, m.")
    y: float = Field(default=0.0, ge=-5, le=5, description="Left offset of the camera from the car's centre, m.")
    z: float = Field(default=0.18, ge=0, le=5, description="Height of the camera above the floor, m.")
    yaw: float = Field(default=0.0, ge=-180, le=180, description="Camera yaw, degrees (left positive).")
    pitch: float = Field(default=0.0, ge=-90, le=90, description="Camera pitch, degrees (down positive).")
    dictionary: str = Field(default="DICT_4X4_50", description="ArUco dictionary of the markers.")
    marker_size: float | None = Field(
        default=None, gt=0, le=1,
        description="Side of the printed markers the detector assumes, m (default: the sizes of the world's "
                    "markers, as an operator configures the sizes they printed).")
    blur: float = Field(default=0.7, ge=0, le=10, description="Gaussian blur of the rendered frames, px.")
    noise: float = Field(default=3.0, ge=0, le=50, description="Image noise standard deviation, grey levels.")
    lighting: float = Field(default=0.2, ge=0, le=1, description="Vignetting strength (0: off).")
    full_every: int = Field(default=5, ge=1, le=100,
                            description="Full-frame search every this many frames; in between only around "
                                        "tracked markers.")

    @model_validator(mode="after")
    def _dictionary(self) -> Camera:
        if self.dictionary not in DICTIONARY_SIZES:
            raise ValueError(f"unknown ArUco dictionary {self.dictionary!r}; choose one of "
                             + ", ".join(sorted(DICTIONARY_SIZES)))
        return self

    @property
    def ids(self) -> int:
        """Number of ids of the dictionary (valid ids: 0 .. ids - 1)."""
        return DICTIONARY_SIZES[self.dictionary]


class Servo(WorldModel):
    """The steering servo as a 1:10 RC car's: a speed from its datasheet, the horn travel that gives full steering,
    a dead band, and the latency between a command and the servo acting on it (docs/car.md)."""

    seconds_per_60: float = Field(
        default=0.15, ge=0.02, le=2.0,
        description="Servo speed, seconds per 60 degrees of horn rotation (datasheet; 1:10 RC servos: 0.08-0.22).")
    travel: float = Field(
        default=45.0, ge=5.0, le=90.0,
        description="Horn rotation from centre to full steering (command 1), degrees (typically 35-50).")
    dead_band: float = Field(
        default=0.008, ge=0.0, le=0.2,
        description="Dead band, steering units (full range 2): the servo does not move while its command is within "
                    "half of it of where it stands (typically 2-8 us of the 1000 us pulse range: 0.004-0.016).")
    latency: float = Field(
        default=0.02, ge=0.0, le=0.5,
        description="Delay from a steering command to the servo acting on it, s (one 50 Hz PWM frame: 0.02).")

    @property
    def rate(self) -> float:
        """The rate limit this speed and travel give, steering units per second."""
        return 60.0 / (self.seconds_per_60 * self.travel)


class Car(WorldModel):
    """The TRAL car: body, bicycle-model steering with a servo, speed controller, hall sensor, ultrasonic sensors."""

    length: float = Field(default=0.40, gt=0, le=5, description="Body length, m.")
    width: float = Field(default=0.19, gt=0, le=5, description="Body width, m.")
    mass: float = Field(default=1.5, gt=0, description="Mass, kg.")
    wheelbase: float = Field(default=0.26, gt=0, le=5, description="Distance between the axles, m.")
    max_steering_angle: float = Field(
        default=24.0, gt=0, lt=60, description="Wheel angle at steering 1, degrees.")
    servo: Servo = Field(default_factory=Servo, description="The steering servo: speed, travel, dead band, latency.")
    steering_rate: float | None = Field(
        default=None, gt=0, le=1e6,
        description="Servo rate limit in steering units per second (2 / rate = lock to lock); default: from the "
                    "servo's seconds_per_60 and travel.")
    steering_offset: float = Field(
        default=0.03, ge=-0.5, le=0.5,
        description="Actual steering at command 0: the real car does not drive straight at steering 0.")
    max_speed: float = Field(default=2.5, gt=0, le=20, description="Speed commands are clamped to this, m/s.")
    acceleration: float = Field(default=1.5, gt=0, description="Acceleration limit, m/s^2.")
    deceleration: float = Field(default=3.0, gt=0, description="Braking limit, m/s^2.")
    hall_units_per_m: float = Field(default=HALL_UNITS_PER_M, gt=0,
                                    description="Hall units per metre (1500 per 1.60 m).")
    ultrasonic: Ultrasonic = Field(default_factory=Ultrasonic, description="The ultrasonic sensors.")
    camera: Camera = Field(default_factory=Camera, description="The camera (ArUco markers).")
    odometry_noise: float = Field(
        default=0.005, ge=0, le=0.5,
        description="Odometry: relative error of the hall sensor's distance (seeded, per run), fraction.")
    odometry_steering_noise: float = Field(
        default=0.001, ge=0, le=0.2,
        description="Odometry: error of the steering model's straight-ahead (seeded, per run), in steering units.")

    @property
    def servo_rate(self) -> float:
        """The servo's rate limit, steering units per second: ``steering_rate`` when given, else the servo's."""
        return self.steering_rate if self.steering_rate is not None else self.servo.rate

    @model_validator(mode="after")
    def _geometry(self) -> Car:
        if self.wheelbase >= self.length:
            raise ValueError(f"wheelbase ({self.wheelbase}) must be shorter than the body ({self.length})")
        return self


class World(WorldModel):
    """A world file: walls, obstacles, gates, the start pose and the car."""

    schema_: str | None = Field(default=None, alias="$schema", description="JSON Schema for editors.")
    name: str | None = Field(default=None, description="Name of the world.")
    description: str | None = Field(default=None, description="Free text for people.")
    walls: list[Wall] = Field(default_factory=list, description="Wall polylines in metres.")
    obstacles: list[Obstacle] = Field(default_factory=list, description="Static obstacles.")
    gates: list[Gate] = Field(default_factory=list, description="ArUco gates (two markers each).")
    markers: list[Marker] = Field(default_factory=list, description="Standalone ArUco markers (signs).")
    start: Start = Field(description="The car's start pose.")
    car: Car = Field(default_factory=Car, description="Car and sensor parameters (defaults: the TRAL car).")

    # -- derived geometry ---------------------------------------------------------------------------
    def segments(self, doors: bool = True) -> list[Segment]:
        """All wall segments; with ``doors=False`` the nominal walls without their recesses."""
        out: list[Segment] = []
        for wall in self.walls:
            out.extend(wall_segments(wall, doors))
        for ob in self.obstacles:
            poly = ob.polygon()
            if poly is not None:
                out.extend((poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly)))
        return out

    def bounds(self) -> tuple[float, float, float, float]:
        """x0, y0, x1, y1 of everything in the world (walls, obstacles, gates, start)."""
        xs = [self.start.x]
        ys = [self.start.y]
        for a, b in self.segments():
            xs += [a[0], b[0]]
            ys += [a[1], b[1]]
        for ob in self.obstacles:
            if ob.type == "circle" and ob.center and ob.radius:
                xs += [ob.center[0] - ob.radius, ob.center[0] + ob.radius]
                ys += [ob.center[1] - ob.radius, ob.center[1] + ob.radius]
        for g in self.gates:
            xs.append(g.center[0])
            ys.append(g.center[1])
        return min(xs), min(ys), max(xs), max(ys)


def wall_points(wall: Wall) -> list[Point]:
    return list(wall.points) + ([wall.points[0]] if wall.closed else [])


def wall_segments(wall: Wall, doors: bool = True) -> list[Segment]:
    """The segments of a wall, door recesses cut in (each door: jamb, recess back, jamb)."""
    pts = wall_points(wall)
    by_segment: dict[int, list[Door]] = {}
    if doors:
        for d in wall.doors:
            by_segment.setdefault(d.segment, []).append(d)
    out: list[Segment] = []
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        ds = sorted(by_segment.get(i, ()), key=lambda d: d.at)
        if not ds:
            out.append((a, b))
            continue
        length = math.dist(a, b)
        ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
        chain: list[Point] = [a]
        for d in ds:
            nx, ny = (uy, -ux) if d.side == "right" else (-uy, ux)
            s0, s1 = d.at - d.width / 2, d.at + d.width / 2
            p0 = (a[0] + ux * s0, a[1] + uy * s0)
            p1 = (a[0] + ux * s1, a[1] + uy * s1)
            chain += [p0, (p0[0] + nx * d.depth, p0[1] + ny * d.depth),
                      (p1[0] + nx * d.depth, p1[1] + ny * d.depth), p1]
        chain.append(b)
        out.extend((chain[k], chain[k + 1]) for k in range(len(chain) - 1))
    return out


# -- checks -------------------------------------------------------------------------------------------
def car_footprint(car: Car, x: float, y: float, heading: float) -> list[Point]:
    """Corners of the car's body at pose (x, y, heading in radians), counter-clockwise."""
    c, s = math.cos(heading), math.sin(heading)
    hl, hw = car.length / 2, car.width / 2
    return [(x + px * c - py * s, y + px * s + py * c) for px, py in ((-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw))]


def _seg_dist(p: Point, a: Point, b: Point) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    L2 = ax * ax + ay * ay
    t = 0.0 if L2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / L2))
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def _segments_cross(p: Point, q: Point, a: Point, b: Point) -> bool:
    def orient(u: Point, v: Point, w: Point) -> float:
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])

    d1, d2 = orient(a, b, p), orient(a, b, q)
    d3, d4 = orient(p, q, a), orient(p, q, b)
    return (d1 * d2 <= 0) and (d3 * d4 <= 0)


def _inside(p: Point, poly: list[Point]) -> bool:
    inside = False
    n = len(poly)
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        if (y1 > p[1]) != (y2 > p[1]) and p[0] < x1 + (p[1] - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def footprint_hits(world: World, x: float, y: float, heading: float, margin: float = 0.005) -> str | None:
    """What the car's body at this pose touches (a description), or ``None`` when it is free."""
    body = car_footprint(world.car, x, y, heading)
    edges = [(body[i], body[(i + 1) % 4]) for i in range(4)]
    for wi, wall in enumerate(world.walls):
        for a, b in wall_segments(wall):
            if any(_segments_cross(p, q, a, b) for p, q in edges) or _inside(a, body) or \
                    min(_seg_dist(c, a, b) for c in body) < margin:
                return f"wall {wi} (segment {_fmt(a)}-{_fmt(b)})"
    for oi, ob in enumerate(world.obstacles):
        poly = ob.polygon()
        if poly is None:
            assert ob.center is not None and ob.radius is not None
            if _inside(ob.center, body) or min(_seg_dist(ob.center, p, q) for p, q in edges) < ob.radius + margin:
                return f"obstacle {oi} (circle at {_fmt(ob.center)})"
            continue
        if any(_inside(c, poly) for c in body) or any(_inside(c, body) for c in poly) or any(
                _segments_cross(p, q, poly[i], poly[(i + 1) % len(poly)]) for p, q in edges for i in range(len(poly))):
            return f"obstacle {oi} ({ob.type})"
    return None


def _fmt(p: Point) -> str:
    return f"({p[0]:g}, {p[1]:g})"


def polygon_problem(points: list[Point]) -> str | None:
    """Why a polygon is no usable shape (fewer than 3 distinct corners, no area, edges that cross), or None."""
    pts = [p for i, p in enumerate(points) if p != points[i - 1]] if len(points) > 1 else list(points)
    distinct = set(pts)
    if len(distinct) < 3:
        return f"a polygon needs 3 different corners, this one has {len(distinct)}"
    a0, a1 = pts[0], next(p for p in pts if p != pts[0])
    if all(abs((a1[0] - a0[0]) * (p[1] - a0[1]) - (a1[1] - a0[1]) * (p[0] - a0[0])) < 1e-12 for p in pts):
        return "the polygon's corners lie on one line: it has no area"
    n = len(pts)
    if len(distinct) < n:
        return "the polygon visits a corner twice"
    if n <= 200:  # edges that cross (not neighbours): O(n^2), cheap for hand-written polygons
        edges = [(pts[i], pts[(i + 1) % n]) for i in range(n)]
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue  # neighbours through the closing edge
                if _edges_meet(*edges[i], *edges[j]):
                    return f"the polygon's edges {i} and {j} cross: it intersects itself"
    area = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1], strict=True)) / 2
    if abs(area) < 1e-12:
        return "the polygon has no area"
    return None


def _edges_meet(p: Point, q: Point, a: Point, b: Point) -> bool:
    """Whether two segments share a point (collinear ones only when they overlap)."""
    def orient(u: Point, v: Point, w: Point) -> float:
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])

    d1, d2, d3, d4 = orient(a, b, p), orient(a, b, q), orient(p, q, a), orient(p, q, b)
    if d1 == d2 == d3 == d4 == 0:
        return (min(p[0], q[0]) <= max(a[0], b[0]) and min(a[0], b[0]) <= max(p[0], q[0])
                and min(p[1], q[1]) <= max(a[1], b[1]) and min(a[1], b[1]) <= max(p[1], q[1]))
    return d1 * d2 <= 0 and d3 * d4 <= 0


def _closed_walls_around(world: World, x: float, y: float) -> list[int] | None:
    """Indexes of the closed walls whose outline holds (x, y); None when the world has no closed wall."""
    closed = [(wi, wall) for wi, wall in enumerate(world.walls) if wall.closed and len(set(wall.points)) >= 3]
    if not closed:
        return None
    return [wi for wi, wall in closed if _inside((x, y), list(wall.points))]


def semantic_problems(world: World, name: str | None) -> list[Problem]:
    """Checks beyond shape: doors that do not fit their segment, degenerate obstacle polygons, markers the
    camera could not tell apart (:func:`marker_problems`), and a car that starts outside every closed wall or
    inside or touching a wall or obstacle."""
    problems: list[Problem] = []
    for oi, ob in enumerate(world.obstacles):
        if ob.type == "polygon" and ob.points is not None:
            why = polygon_problem(list(ob.points))
            if why is not None:
                problems.append(Problem(why, name, f"/obstacles/{oi}/points", element=f"obstacle {oi} (polygon)",
                                        hint="list the corners in order around the outline, at least 3 of them"))
    for wi, wall in enumerate(world.walls):
        pts = wall_points(wall)
        for di, d in enumerate(wall.doors):
            ptr = f"/walls/{wi}/doors/{di}"
            if d.segment >= len(pts) - 1:
                problems.append(Problem(f"door on segment {d.segment}, but this wall has {len(pts) - 1} segments",
                                        name, ptr + "/segment", element=f"wall {wi}",
                                        hint="segments count from 0; set 'closed': true for the closing segment"))
                continue
            length = math.dist(pts[d.segment], pts[d.segment + 1])
            if d.at - d.width / 2 < 0 or d.at + d.width / 2 > length:
                problems.append(Problem(
                    f"door from {d.at - d.width / 2:g} m to {d.at + d.width / 2:g} m does not fit its segment "
                    f"(0 to {length:g} m)", name, ptr + "/at", element=f"wall {wi}",
                    hint="'at' is the door centre's distance from the segment's first point"))
    around = _closed_walls_around(world, world.start.x, world.start.y) if not problems else None
    if around is not None and len(around) % 2 == 0:  # even-odd, as for a loop: inside the outer, not the inner wall
        where = "outside every closed wall" if not around else (
            f"inside the area walled off by wall {around[-1]} (within {len(around)} closed walls)")
        problems.append(Problem(f"the car starts at ({world.start.x:g}, {world.start.y:g}), {where}", name,
                                "/start", element="start",
                                hint="move the start pose into the hallway, between its walls"))
    problems += marker_problems(world, name)
    if not problems:
        hit = footprint_hits(world, world.start.x, world.start.y, math.radians(world.start.heading))
        if hit is not None:
            problems.append(Problem(f"the car starts inside or touching {hit}", name, "/start", element="start",
                                    hint="move the start pose into free space (the car is "
                                         f"{world.car.length:g} x {world.car.width:g} m around x, y)"))
    return problems


def marker_problems(world: World, name: str | None) -> list[Problem]:
    """Markers the camera could not tell apart or not decode, and a camera that cannot see them: two markers
    sharing an id, an id outside the dictionary, a camera pitched so far that the horizon leaves the image."""
    problems: list[Problem] = []
    cam = world.car.camera
    seen: dict[int, tuple[str, str]] = {}

    def check(marker_id: int, ptr: str, element: str) -> None:
        if marker_id >= cam.ids:
            problems.append(Problem(f"marker id {marker_id} is not in {cam.dictionary} (ids 0-{cam.ids - 1})", name,
                                    ptr, element=element, hint="use an id of the camera's dictionary, or set "
                                                               "car.camera.dictionary"))
        elif marker_id in seen:
            first, first_ptr = seen[marker_id]
            where = "this gate's other marker" if first == element else first
            problems.append(Problem(f"marker id {marker_id} is used twice (also by {where}, {first_ptr})", name, ptr,
                                    element=element, hint="every marker needs its own id, or the car cannot tell "
                                                          "them (or a gate's sides) apart"))
        else:
            seen[marker_id] = (element, ptr)

    for gi, g in enumerate(world.gates):
        element = f"gate {g.name or gi}"
        for k, marker_id in enumerate(g.markers):
            check(marker_id, f"/gates/{gi}/markers/{k}", element)
    for mi, m in enumerate(world.markers):
        check(m.id, f"/markers/{mi}/id", f"marker {m.name or mi}")
    fy = cam.fy or cam.fx
    problems += camera_fov_problems(cam, name)
    half = math.degrees(math.atan2(cam.height / 2, fy))
    if abs(cam.pitch) >= half:
        where = "floor" if cam.pitch > 0 else "ceiling"
        problems.append(Problem(
            f"the camera points into the {where}: pitch {cam.pitch:g} deg puts the horizon outside the image "
            f"(half the vertical field of view is {half:.1f} deg)", name, "/car/camera/pitch", element="car",
            hint=f"use a pitch between {-half:.1f} and {half:.1f} degrees (down positive)"))
    return problems


#: The field of view a camera may have, degrees: fsm.vision.camera.FOV_RANGE, the range calibrations are held
#: to (written out here because world checks run without OpenCV).
CAMERA_FOV_RANGE = (1.0, 179.0)


def camera_fov_problems(cam: Camera, name: str | None) -> list[Problem]:
    """A focal length that makes the camera see (nearly) 180 degrees or under 1 degree: the pinhole model breaks
    down (no marker pose comes out) or every marker is out of view."""
    low, high = CAMERA_FOV_RANGE
    problems = []
    fy = cam.fy if cam.fy is not None else cam.fx
    for axis, size, focal, key in (("horizontal", cam.width, cam.fx, "fx"), ("vertical", cam.height, fy, "fy")):
        fov = math.degrees(2 * math.atan2(size / 2, focal))
        if not low <= fov <= high:
            shared = key == "fy" and cam.fy is None
            label = "fx (fy is not set, so also the vertical focal length)" if shared else key
            at = "fx" if shared else key
            lo, hi = (size / 2) / math.tan(math.radians(high / 2)), (size / 2) / math.tan(math.radians(low / 2))
            problems.append(Problem(
                f"{label} = {focal:g} px gives a {axis} field of view of {fov:.4g} deg at {cam.width}x{cam.height}; "
                f"a pinhole camera has {low:g}-{high:g} deg", name, f"/car/camera/{at}", element="car",
                hint=f"use a focal length between {lo:.4g} and {hi:.4g} px for this {axis} size of {size} px"))
    return problems


def world_markers(world: World) -> list[tuple[int, float, float, float, float, float, bool]]:
    """Every marker of the world as (id, x, y, height, facing in rad, size, on a post): the gates' two each
    (facing the approaching car, on posts) and the standalone ones."""
    out = []
    for g in world.gates:
        h = math.radians(g.heading)
        nx, ny = -math.sin(h), math.cos(h)
        for marker_id, side in zip(g.markers, (1.0, -1.0), strict=True):
            out.append((int(marker_id), g.center[0] + side * nx * g.width / 2, g.center[1] + side * ny * g.width / 2,
                        float(g.height), h + math.pi, float(g.marker_size), True))
    for m in world.markers:
        out.append((m.id, m.position[0], m.position[1], m.height, math.radians(m.facing), m.size, m.post))
    return out


# -- loading ------------------------------------------------------------------------------------------
def parse_world(data: Any, name: str | None = None, locator: Any = None) -> World:
    """A checked world from a parsed JSON document; raises :class:`DiagramError` with every problem, located."""
    from fsm.model.document import Source, problems_from_validation

    source = Source(name=name, locator=locator)
    problems: list[Problem] = []
    world: World | None = None
    if not isinstance(data, dict):
        kind = "array" if isinstance(data, list) else type(data).__name__
        problems.append(Problem(f"a world must be a JSON object with 'walls' and 'start', got {kind}", name,
                                hint='{"walls": [{"points": [[0, 0], [5, 0]]}], "start": {"x": 1, "y": 1}}'))
    else:
        try:
            world = World.model_validate(data)
        except ValidationError as err:
            problems += problems_from_validation(err, source=source, base="", element=None, model=World, kind="key")
            for p in problems:
                p.message = p.message.replace("Value error, ", "")
        if world is not None:
            problems += semantic_problems(world, name)
    if problems:
        _locate(problems, locator)
        raise DiagramError(problems)
    assert world is not None
    return world


def _locate(problems: list[Problem], locator: Any) -> None:
    from fsm.loading.reading import place

    place(problems, locator)

def read_json_file(path: str | os.PathLike[str], what: str,
                   duplicates: list[Problem] | None = None) -> tuple[Any, Any]:
    """Parse a JSON file strictly (UTF-8, line:column on errors); returns the data and a pointer locator.

    Repeated keys raise, or are added to ``duplicates`` when it is given (see ``parse_json_bytes``)."""
    from fsm.loading.reading import parse_json_bytes, read_file_bytes

    p = Path(path)
    raw = read_file_bytes(p, what)
    if not raw.strip():
        raise DiagramError([Problem(f"file is empty; a {what} is a JSON object", str(path), line=1, column=1)])
    data, source = parse_json_bytes(raw, str(path), p.parent, duplicates=duplicates)
    return data, source.locator


def load_world(path: str | os.PathLike[str], car: str | os.PathLike[str] | None = None) -> World:
    """Read and check a world file; ``car`` names an optional car file that replaces the world's ``car``.

    Every problem of the file is reported at once, repeated keys together with the others."""
    repeated: list[Problem] = []
    data, locator = read_json_file(path, "world", repeated)
    try:
        world = parse_world(data, str(path), locator)
    except DiagramError as exc:
        raise DiagramError(sorted(repeated + exc.problems, key=lambda p: (p.line or 0, p.column or 0))) from None
    if repeated:
        raise DiagramError(repeated)
    if car is not None:
        world.car = load_car(car)
        problems = semantic_problems(world, str(path))
        if problems:  # the world's start pose must also fit the car of the car file
            for p in problems:
                p.hint = f"{p.hint}; the car comes from {car}" if p.hint else f"the car comes from {car}"
            _locate(problems, locator)
            raise DiagramError(problems)
    return world


def load_car(path: str | os.PathLike[str]) -> Car:
    """Read and check a car file (the ``car`` object of a world, on its own)."""
    from fsm.model.document import Source, problems_from_validation

    data, locator = read_json_file(path, "car")
    problems: list[Problem] = []
    name = str(path)
    if not isinstance(data, dict):
        problems.append(Problem("a car file must be a JSON object", name))
    else:
        data = {k: v for k, v in data.items() if k != "$schema"}
        try:
            return Car.model_validate(data)
        except ValidationError as err:
            problems += problems_from_validation(err, source=Source(name=name), base="", element=None, model=Car,
                                                 kind="key")
            for p in problems:
                p.message = p.message.replace("Value error, ", "")
    _locate(problems, locator)
    raise DiagramError(problems)


def world_schema() -> dict[str, Any]:
    """The JSON Schema of world files (committed as ``fsm/schema/world.schema.json``)."""
    from fsm.model.document import file_schema

    return file_schema(World, "world.schema.json", "tral-fsm world",
                       "A world for the simulated TRAL car; generated from fsm.sim.world by "
                       "`python -m fsm.sim.world --schema`.")


WORLD_SCHEMA_PATH = Path(__file__).resolve().parent.parent / "schema" / "world.schema.json"


def world_schema_text() -> str:
    import json

    return json.dumps(world_schema(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":  # pragma: no cover - regenerate the committed schema
    import sys

    if sys.argv[1:2] == ["--schema"]:
        out = sys.argv[2] if len(sys.argv) > 2 else None
        if out:
            Path(out).write_text(world_schema_text(), encoding="utf-8")
        else:
            sys.stdout.write(world_schema_text())
    else:
        for arg in sys.argv[1:]:
            try:
                load_world(arg)
                print(f"{arg}: ok")
            except DiagramError as exc:
                print(exc, file=sys.stderr)
                sys.exit(1)


from fsm.sim import DEFAULT_WORLD  # noqa: E402 - the name lives in the cheap package init for the CLI's help


def default_world(machine_file: str) -> Path:
    """``hallway.json`` from ``worlds/`` next to the machine, else ``diagrams/worlds/`` here, else the worlds
    installed with the package (``fsm.worlds``, which is ``diagrams/worlds`` of the repository)."""
    candidates = [Path(machine_file).resolve().parent / "worlds" / DEFAULT_WORLD,
                  Path.cwd() / "diagrams" / "worlds" / DEFAULT_WORLD]
    from importlib.resources import files

    try:  # installed from a wheel
        candidates.append(Path(str(files("fsm.worlds") / DEFAULT_WORLD)))
    except (ModuleNotFoundError, TypeError):
        import fsm  # an editable install: the checkout's diagrams/worlds

        candidates.append(Path(fsm.__file__).resolve().parent.parent / "diagrams" / "worlds" / DEFAULT_WORLD)
    for c in candidates:
        if c.is_file():
            return c
    raise UsageError(f"no world given and no {DEFAULT_WORLD} found (looked in "
                     + ", ".join(str(c.parent) for c in candidates) + "); pass --world WORLD.json")
