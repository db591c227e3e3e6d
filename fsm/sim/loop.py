"""The closed loop: physics at 100 Hz, ultrasonic at 20 Hz (inside the car), the machine at its tick (80 Hz).

Before machine tick ``k`` (at ``k * dt``) the physics is stepped up to that time, so the machine
always sees sensors as they were at its tick and its commands act from then on. Everything runs on
simulated time: the same world, machine and seed give a bit-identical run.

The loop also measures what the summary reports: travelled distance, collisions, the clearance
between body and walls, and the wall-distance error on straights (ground truth against the
nominal walls, door recesses left out, sampled at the sensor rate while a wall-following state
with a fixed distance (BasicFollowWall, FollowWall; not FollowWallRamp) has been active for
``settle`` metres, 2 m by default, so the transients after corners and lane changes are not "straights").
"""

from __future__ import annotations

import math
import os
import time
from array import array
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any, Protocol, cast

from fsm.runtime.machine import Listener
from fsm.session.run import stop_rules
from fsm.session.session import RunResult, Session, StopRules
from fsm.sim.car import PHYSICS_DT, SimCar
from fsm.sim.world import Gate, World
from fsm.trace.recorder import Recorder, summary

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Fired, Machine
    from fsm.runtime.state import State


class WallFollowing(Protocol):
    """What a wall-following state (fsm/states/driving.py) shows the loop, which measures the wall-distance error while
    ``wall_target`` is set and the state counts as a straight."""

    wall_target: float | None
    wall_side: str
    straight_metric: bool


class GateLog:
    """Ground truth for the summary: when the car's centre crossed each gate (the segment between its two markers) in
    the gate's direction."""

    __snapshot_fields__ = ("gates", "first_passed", "times_passed", "_last")

    def __init__(self, world: World) -> None:
        self.gates: list[tuple[Gate, tuple[float, float], tuple[float, float], float, float]] = []
        for g in world.gates:
            h = math.radians(g.heading)
            nx, ny = -math.sin(h), math.cos(h)
            a = (g.center[0] + nx * g.width / 2, g.center[1] + ny * g.width / 2)
            b = (g.center[0] - nx * g.width / 2, g.center[1] - ny * g.width / 2)
            self.gates.append((g, a, b, math.cos(h), math.sin(h)))
        #: per gate: when the car first drove through it (``None``: never) and how many times it did
        self.first_passed: list[float | None] = [None for _ in self.gates]
        self.times_passed: list[int] = [0 for _ in self.gates]
        self._last: tuple[float, float] | None = None

    def update(self, now: float, x: float, y: float) -> None:
        last, self._last = self._last, (x, y)
        if last is None or last == (x, y):
            return
        px, py = last
        for k, (_g, a, b, ux, uy) in enumerate(self.gates):
            if (x - px) * ux + (y - py) * uy <= 0:
                continue  # not driving through in the gate's direction
            if _crosses(px, py, x, y, a, b):
                if not self.times_passed[k]:
                    self.first_passed[k] = round(now, 4)
                self.times_passed[k] += 1

    def metrics(self) -> dict[str, Any]:
        return {
            "gates_passed": sum(1 for n in self.times_passed if n),
            "gates_total": len(self.gates),
            "gates": [{"name": g.name, "markers": list(g.markers), "passed_at": first, "times_passed": n}
                      for (g, *_rest), first, n in zip(self.gates, self.first_passed, self.times_passed, strict=True)],
        }


class WallError:
    """The wall-distance error on straights as a running figure (nothing kept per sample): how many samples, the RMS
    (the sum of squares in sample order, as a list's would be) and the largest magnitude."""

    __slots__ = ("samples", "sum_squares", "max_abs")

    def __init__(self) -> None:
        self.samples = 0
        self.sum_squares = 0.0
        self.max_abs = 0.0

    def add(self, error: float) -> None:
        self.samples += 1
        self.sum_squares += error * error
        size = -error if error < 0 else error
        if size > self.max_abs:
            self.max_abs = size

    def metrics(self) -> dict[str, Any]:
        n = self.samples
        return {"wall_error_rms_m": round(math.sqrt(self.sum_squares / n), 5) if n else None,
                "wall_error_max_m": round(self.max_abs, 5) if n else None,
                "wall_error_samples": n}


class SteeringStats:
    """The steering command on straights as a running figure: its standard deviation (Welford's method; steering
    units, the full range is 2) and how often it changes sign per second. Samples are added as (sensor sample number,
    command); consecutive sample numbers are one stretch of straight, ``period`` seconds apart; a command of exactly 0
    has no sign and changes none."""

    __slots__ = ("period", "count", "mean", "m2", "changes", "intervals", "_last_n", "_last_sign")

    def __init__(self, period: float) -> None:
        self.period = period
        self.count = 0
        self.mean = 0.0
        self.m2 = 0.0  # the sum of squared deviations from the mean
        self.changes = 0
        self.intervals = 0
        self._last_n: int | None = None
        self._last_sign = 0.0

    def add(self, n: int, value: float) -> None:
        count = self.count = self.count + 1
        mean = self.mean
        delta = value - mean
        mean = self.mean = mean + delta / count
        self.m2 += delta * (value - mean)
        last = self._last_n
        self._last_n = n
        if last is None or n != last + 1:
            last_sign = 0.0  # a new stretch of straight
        else:
            self.intervals += 1
            last_sign = self._last_sign
        sign = 1.0 if value > 0 else -1.0 if value < 0 else 0.0
        if sign:
            if last_sign and sign != last_sign:
                self.changes += 1
            self._last_sign = sign
        elif not last_sign:
            self._last_sign = 0.0

    def metrics(self) -> dict[str, Any]:
        if self.count < 2:
            return {"steering_std": None, "steering_sign_changes_per_s": None, "straight_time_s": 0.0}
        std = math.sqrt(max(0.0, self.m2) / self.count)
        seconds = self.intervals * self.period
        return {"steering_std": round(std, 5),
                "steering_sign_changes_per_s": round(self.changes / seconds, 3) if seconds > 0 else None,
                "straight_time_s": round(seconds, 3)}


def steering_metrics(samples: Iterable[tuple[int, float]], period: float) -> dict[str, Any]:
    """:class:`SteeringStats`' figures of ``samples`` (sensor sample number, command), ``period`` seconds apart."""
    stats = SteeringStats(period)
    for n, value in samples:
        stats.add(n, value)
    return stats.metrics()


#: The trajectory keeps at most this many points: past it, every other point is dropped and points are taken half as
#: often (a plot of a long run stays a plot of all of it, in bounded memory).
TRACK_LIMIT = 4096


class Track:
    """The car's trajectory for the plot and a sweep's map: points (time, x, y, index into ``states_seen``) evenly
    spaced in time, the first at time 0, ``period`` seconds apart; at most :data:`TRACK_LIMIT` of them, in one
    compact array (x, y and index in single precision, 12 bytes a point; 2 um at 30 m is plenty for a plot). When it
    is full, every other point is dropped and ``every`` and ``period`` double: the caller adds a point only every
    ``every``-th time it could (the loop: every ``track_every * every`` ticks), so the track covers the whole run.

    The points only grow at their end until the array is replaced by a thinner one, so a snapshot of the run
    (:mod:`fsm.session.snapshot`) keeps the array and its length, not a copy of it: snapshots share it."""

    __snapshot_skip__ = ("_points",)
    __snapshot_fields__ = ("limit", "period", "every")

    def __init__(self, period: float, limit: int = TRACK_LIMIT) -> None:
        if limit < 2 or limit % 2:
            raise ValueError(f"limit must be even and at least 2, got {limit}")
        self.limit = limit
        self.period = period
        #: keep one of every this many possible points
        self.every = 1
        self._points = array("f")  # x, y, k of each point in turn

    def add(self, x: float, y: float, k: int) -> None:
        """Append the next point (thinning the track first when it is full)."""
        points = self._points
        if len(points) >= 3 * self.limit:
            self._points = points = array("f", (v for i in range(0, len(points), 6) for v in points[i:i + 3]))
            self.every *= 2
            self.period *= 2
        append = points.append  # three appends: half the time of extending by a tuple
        append(x)
        append(y)
        append(k)

    def __len__(self) -> int:
        return len(self._points) // 3

    def __snapshot__(self) -> tuple[array[float], int]:
        return self._points, len(self._points)

    def __restore__(self, state: tuple[array[float], int]) -> None:
        """The points as they were: the same array cut to its length then (what was added since is dropped), or,
        when it was replaced by a thinner one since, a copy of the first ones of the array it was."""
        points, n = state
        if points is self._points:
            del points[n:]
        else:
            self._points = array("f", points[:n])

    def __iter__(self) -> Iterator[tuple[float, float, float, int]]:
        p, period = self._points, self.period
        return ((i // 3 * period, p[i], p[i + 1], int(p[i + 2])) for i in range(0, len(p), 3))

    def __getitem__(self, index: slice) -> list[tuple[float, float, float, int]]:
        return list(self)[index]


def _crosses(px: float, py: float, qx: float, qy: float, a: tuple[float, float], b: tuple[float, float]) -> bool:
    def orient(ux: float, uy: float, vx: float, vy: float, wx: float, wy: float) -> float:
        return (vx - ux) * (wy - uy) - (vy - uy) * (wx - ux)

    d1, d2 = orient(a[0], a[1], b[0], b[1], px, py), orient(a[0], a[1], b[0], b[1], qx, qy)
    d3, d4 = orient(px, py, qx, qy, a[0], a[1]), orient(px, py, qx, qy, b[0], b[1])
    return d1 * d2 <= 0 and d1 != d2 and d3 * d4 <= 0


#: A lap ends where the car's centre crosses the start line (through the start pose, square to its heading) forwards
#: within this distance of the start point, m.
LAP_HALF_WIDTH = 3.0


#: The summary lists at most this many laps, the last ones; ``lap_totals`` covers all of them.
LAP_LIMIT = 1000


class LapLog:
    """Ground truth for the summary: the laps (a lap ends when the car's centre crosses the start line forwards) and
    the time spent in each active state (leaf path) in each lap. A state active when the car crosses the line is split
    between the two laps. The last :data:`LAP_LIMIT` complete laps are kept, with totals over all of them."""

    __snapshot_fields__ = ("x0", "y0", "c", "s", "_ahead", "limit", "laps", "completed", "_total", "_fastest",
                           "_slowest", "_state_totals", "_t0", "_states", "_path", "_since")

    def __init__(self, world: World, limit: int = LAP_LIMIT) -> None:
        s = world.start
        self.x0, self.y0 = s.x, s.y
        h = math.radians(s.heading)
        self.c, self.s = math.cos(h), math.sin(h)
        self._ahead: float | None = None
        self.limit = limit
        self.laps: deque[dict[str, Any]] = deque(maxlen=limit)
        #: complete laps so far (``laps`` keeps the last ``limit`` of them)
        self.completed = 0
        self._total = 0.0
        self._fastest: tuple[float, int] | None = None
        self._slowest: tuple[float, int] | None = None
        self._state_totals: dict[str, float] = {}
        self._t0 = 0.0
        self._states: dict[str, float] = {}
        self._path = ""
        self._since = 0.0

    def state(self, now: float, path: str) -> None:
        """The active path changed to ``path`` at ``now``."""
        if self._path:
            self._states[self._path] = self._states.get(self._path, 0.0) + now - self._since
        self._path, self._since = path, now

    def update(self, now: float, x: float, y: float) -> None:
        dx, dy = x - self.x0, y - self.y0
        ahead = dx * self.c + dy * self.s
        before, self._ahead = self._ahead, ahead
        if before is not None and before < 0.0 <= ahead and abs(-dx * self.s + dy * self.c) <= LAP_HALF_WIDTH:
            self._close(now)

    def _close(self, now: float) -> None:
        self.state(now, self._path)
        self.completed += 1
        time_s = now - self._t0
        self.laps.append({"lap": self.completed, "start_s": round(self._t0, 4), "time_s": round(time_s, 4),
                          "complete": True,
                          "states": {k: round(v, 4) for k, v in sorted(self._states.items()) if v > 0}})
        self._total += time_s
        if self._fastest is None or time_s < self._fastest[0]:
            self._fastest = (time_s, self.completed)
        if self._slowest is None or time_s > self._slowest[0]:
            self._slowest = (time_s, self.completed)
        for path, seconds in self._states.items():
            self._state_totals[path] = self._state_totals.get(path, 0.0) + seconds
        self._t0 = now
        self._states = {}

    def metrics(self, now: float) -> dict[str, Any]:
        """The summary's ``laps`` (the last :data:`LAP_LIMIT` complete laps), ``lap_unfinished`` (what the car drove
        since the last crossing: ``None`` if nothing) and ``lap_totals`` (over every complete lap, with how many
        ``laps`` leaves out), and ``laps_note`` when it leaves some out."""
        unfinished = None
        if now > self._t0:
            states = dict(self._states)
            if self._path:
                states[self._path] = states.get(self._path, 0.0) + now - self._since
            unfinished = {"lap": self.completed + 1, "start_s": round(self._t0, 4), "time_s": round(now - self._t0, 4),
                          "complete": False, "states": {k: round(v, 4) for k, v in sorted(states.items()) if v > 0}}
        n = self.completed
        dropped = n - len(self.laps)
        totals: dict[str, Any] = {
            "laps": n, "listed": len(self.laps), "dropped": dropped, "time_s": round(self._total, 4),
            "mean_s": round(self._total / n, 4) if n else None,
            "fastest": _lap_ref(self._fastest), "slowest": _lap_ref(self._slowest),
            "states": {k: round(v, 4) for k, v in sorted(self._state_totals.items()) if v > 0}}
        out: dict[str, Any] = {"laps": list(self.laps), "lap_unfinished": unfinished, "lap_totals": totals}
        if dropped:
            out["laps_note"] = (f"only the last {len(self.laps)} of {n} laps are listed (the limit is {self.limit}); "
                                "lap_totals covers all of them")
        return out


def _lap_ref(lap: tuple[float, int] | None) -> dict[str, Any] | None:
    return None if lap is None else {"lap": lap[1], "time_s": round(lap[0], 4)}


class _TransitionFlag(Listener):
    """Notices transitions, so the loop recomputes the active leaf and path only when they change."""

    def __init__(self) -> None:
        self.changed = True

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        self.changed = True


class Simulation:
    """The simulated car as the world around a machine (a session's :class:`~fsm.session.session.Driver`): physics up to
    each tick's time before it; metrics, gates passed and the trajectory after it.

    ``Simulation(machine, car)`` makes the session it drives (``sim.session``); ``sim.run(...)`` runs it.
    Observers are called as ``observer(sim)`` every ``period`` seconds of simulated time (the video recorder);
    every ``track_every`` machine ticks a trajectory point is recorded (the plot). With ``max_collisions`` the run
    stops as soon as the car has collided more often than that.
    """

    #: what a snapshot of the run reads, by name (see :attr:`fsm.sim.car.SimCar.__snapshot_fields__`)
    __snapshot_fields__ = ("machine", "car", "settle", "track_every", "max_collisions", "world_file", "seed", "noise",
                           "_flag", "active_path", "leaf", "_straight", "states_seen", "track", "_track_stride",
                           "path_index", "wall_error", "steering", "_err_sample", "_leaf_d0", "gate_log", "lap_log",
                           "output_time", "session")

    def __init__(self, machine: Machine, car: SimCar, *, settle: float = 2.0, track_every: int = 4,
                 max_collisions: int | None = None, world_file: str | os.PathLike[str] | None = None, seed: int = 0,
                 noise: bool = True) -> None:
        self.machine = machine
        self.car = car
        self.settle = settle
        self.track_every = track_every
        self.max_collisions = max_collisions
        self.world_file = world_file
        self.seed = seed
        self.noise = noise
        self._flag = _TransitionFlag()
        self.active_path = ""
        self.leaf: State[Any] | None = None
        self.states_seen: list[str] = []
        #: Trajectory: (time, x, y, index into states_seen), every ``track_every`` ticks, thinned past
        #: :data:`TRACK_LIMIT` points.
        self.track = Track(track_every * machine.dt)
        self._track_stride = track_every  # ticks between two points of the track
        #: Index into states_seen of the active configuration (the colour of the track, in the plot and video).
        self.path_index = 0
        #: The wall-distance error and the steering command on straights, sampled at the sensor rate (running figures).
        self.wall_error = WallError()
        self.steering = SteeringStats(1.0 / car.params.ultrasonic.rate)
        self._err_sample = -1
        self._leaf_d0 = 0.0
        #: the active leaf when it counts as a straight (a wall follower: :class:`WallFollowing`), else None
        self._straight: WallFollowing | None = None
        self.gate_log = GateLog(car.world) if car.world.gates else None
        self.lap_log = LapLog(car.world)
        #: Wall time spent in observers (outputs such as the video), seconds.
        self.output_time = 0.0
        self.session = Session(machine, driver=self)

    # -- the driver -------------------------------------------------------------------------------------
    def attach(self, session: Session) -> None:
        self.session = session
        self.machine = session.machine
        session.machine.add_listener(self._flag)

    def before_tick(self, time_s: float) -> None:
        """Physics up to the tick's time, never past it: the machine sees the past, as on a car."""
        target = time_s + 1e-9
        step = self.car.step
        n = self.car.steps + 1  # the car's step count after its next step (a step counts one)
        while n * PHYSICS_DT <= target:
            step()
            n += 1

    def after_tick(self) -> None:
        if self._flag.changed:
            self._update_active()
        car = self.car
        ctx = self.machine.ctx
        now = ctx._now  # the machine's time slot: the property costs a call each tick
        leaf = None
        if car.sample != self._err_sample:  # a new sensor sample: measure it on a straight
            self._err_sample = car.sample
            leaf = self._straight
        if leaf is None:
            x, y = car.true_position()  # the heading is not needed
        else:
            pose = car.true_pose()
            x, y = pose[0], pose[1]
            self._measure(leaf, pose)
        if self.gate_log is not None:
            self.gate_log.update(now, x, y)
        self.lap_log.update(now, x, y)
        if ctx._tick % self._track_stride == 0:
            track = self.track
            track.add(x, y, self.path_index)
            self._track_stride = self.track_every * track.every

    def snapshot_ready(self) -> bool:
        """Whether a snapshot of the run (:mod:`fsm.session.snapshot`) taken now restores exactly (the car's
        :meth:`~fsm.sim.car.SimCar.snapshot_ready`)."""
        return self.car.snapshot_ready()

    def should_stop(self) -> str | None:
        limit = self.max_collisions
        return "collisions" if limit is not None and self.car.collisions > limit else None

    def add_observer(self, period: float, observer: Callable[[Simulation], None]) -> None:
        """Call ``observer(sim)`` every ``period`` seconds of simulated time (first at the start). Observers write
        outputs (the video, saved camera frames): the wall time they take is counted in ``output_time``, which the
        summary's ``realtime_factor`` leaves out."""

        def timed(_session: Session) -> None:
            t0 = time.perf_counter()
            try:
                observer(self)
            finally:
                self.output_time += time.perf_counter() - t0

        self.session.every(period, timed)

    @property
    def now(self) -> float:
        return self.machine.ctx.now

    @property
    def wall_time(self) -> float:
        return self.session.wall_time

    def _update_active(self) -> None:
        m = self.machine
        self.active_path = m.active_path
        self.lap_log.state(m.ctx.now, self.active_path)
        record = m.root.current
        while record.regions:
            record = record.regions[0].current
        state = record.state
        if state is not self.leaf:
            self.leaf = state
            self._leaf_d0 = self.car.distance
            self._straight = cast(WallFollowing, state) if getattr(state, "straight_metric", False) else None
        try:
            self.path_index = self.states_seen.index(self.active_path)
        except ValueError:
            self.path_index = len(self.states_seen)
            self.states_seen.append(self.active_path)
        self._flag.changed = False

    def run(self, duration: float | None = None, max_ticks: int | None = None,
            progress: Callable[[Simulation], None] | None = None, progress_every: float = 0.5,
            stop: Callable[[], bool] | None = None, *, until: Callable[[Session], bool] | None = None) -> RunResult:
        """Run the session as :func:`fsm.run` runs one (:meth:`Session.run <fsm.session.session.Session.run>`, its
        arguments checked by the same rule) and say how it ended (a :class:`~fsm.session.session.RunResult`): until
        the machine finishes, ``duration`` seconds of machine time or ``max_ticks`` ticks (600 s without either),
        ``until(session)`` or ``stop()`` is true (checked after every tick: how ``fsmctl`` ends a run on Ctrl-C
        between two ticks). ``progress(self)`` is called every ``progress_every`` seconds of machine time. A state
        that fails raises after the car was stopped."""
        rules = stop_rules(None, duration, max_ticks, self.machine.dt)
        if progress is not None:
            self.session.every(progress_every, lambda _session: progress(self))
        return self.session.run(until=until, stop=stop, stop_rules=rules or StopRules())

    def _measure(self, leaf: WallFollowing, pose: tuple[float, float, float]) -> None:
        """One sample of the wall-distance error and the steering on a straight (``leaf`` measures straights)."""
        target = getattr(leaf, "wall_target", None)  # a plugin's straight may lack it: then nothing to measure
        if target is None or self.car.distance - self._leaf_d0 < self.settle:
            return
        true = self.car.true_distance(leaf.wall_side, pose)
        if true > target + 0.5:
            return  # no wall there (an opening): nothing to follow
        self.wall_error.add(true - target)
        self.steering.add(self.car.sample, self.car.steering)

    # -- results ----------------------------------------------------------------------------------------
    def summary(self, recorder: Recorder | None = None, world: object = None, seed: int | None = None,
                noise: bool | None = None) -> dict[str, Any]:
        """The run summary of ``fsmctl run --summary`` (and of each run of a sweep): the machine's, then the car's."""
        result = self.session.summary() if recorder is None else summary(self.machine, recorder) | self.metrics()
        if world is not None:
            result["world"] = str(world)
        if seed is not None:
            result["seed"] = seed
        if noise is not None:
            result["noise"] = noise
        return result

    def metrics(self) -> dict[str, Any]:
        """What the summary adds for a car run."""
        car = self.car
        sim_time = self.machine.ctx.now
        clearance = car.min_clearance if car.min_clearance != math.inf else None
        wall_time = self.wall_time
        run_time = wall_time - self.output_time
        out = {
            "distance_m": round(car.distance, 4),
            "hall_units": car.hall,
            "collisions": car.collisions,
            "contact_time_s": round(car.contact_steps * PHYSICS_DT, 3),
            "min_wall_distance_m": None if clearance is None else round(clearance, 4),
            **self.wall_error.metrics(),
            **self.steering.metrics(),
            "sim_time": round(sim_time, 6),
            "wall_time": round(wall_time, 4),
            "realtime_factor": round(sim_time / run_time, 1) if run_time > 0 else None,
            "realtime_factor_with_outputs": round(sim_time / wall_time, 1) if wall_time > 0 else None,
            **self._camera_metrics(),
            **self.lap_log.metrics(sim_time),
        }
        if self.world_file is not None:
            out.update({"world": str(self.world_file), "seed": self.seed, "noise": self.noise})
        return out

    def _camera_metrics(self) -> dict[str, Any]:
        """Gates passed (ground truth), the odometry's error at the end, and what the camera did."""
        car = self.car
        out: dict[str, Any] = {}
        if self.gate_log is not None:
            out.update(self.gate_log.metrics())
        else:
            out.update({"gates_passed": 0, "gates_total": 0, "gates": []})
        if hasattr(car, "odometry_error"):
            out["odometry_error_m"] = round(car.odometry_error(), 4)
        if getattr(car, "camera_frames", 0):
            out["camera_frames"] = car.camera_frames
            out["camera_rendered"] = car.rendered_frames
        return out


#: The car's values in a trace's samples (``car_trace_sample``), the same as :func:`car_trace_fields`'s.
CAR_SAMPLE_FIELDS = ["car.x", "car.y", "car.heading", "car.odometry[0]", "car.odometry[1]", "car.odometry[2]",
                     "car.left", "car.right", "car.front", "car.distance", "car.speed", "car.speed_command",
                     "car.steering", "car.collisions"]


def car_trace_sample(car: SimCar) -> Callable[[], tuple[Any, ...]]:
    """The trace's samples of ``car``: a tuple of the values named by :data:`CAR_SAMPLE_FIELDS` (a sample is taken
    every few ticks, so it must cost little; the recorder writes them in blocks)."""
    true_pose = car.true_pose
    pose = car.pose

    def sample() -> tuple[Any, ...]:
        return (*true_pose(), *pose(), car.left, car.right, car.front, car.distance, car.speed,
                car.speed_command, car.steering, car.collisions)

    return sample


def car_trace_fields(car: SimCar) -> Callable[[], dict[str, Any]]:
    """The trace's extra fields (``fsmctl run --trace``, a sweep's traces): sensors, commands and pose of the car at
    the line's tick."""

    def fields() -> dict[str, Any]:
        x, y, th = car.true_pose()  # ground truth, for reports; "odometry" is what the car believed
        ox, oy, oth = car.pose()
        return {"car": {
            "x": round(x, 4), "y": round(y, 4), "heading": round(th, 4),
            "odometry": [round(ox, 4), round(oy, 4), round(oth, 4)],
            "left": round(car.left, 4), "right": round(car.right, 4), "front": round(car.front, 4),
            "distance": round(car.distance, 4), "speed": round(car.speed, 4),
            "speed_command": round(car.speed_command, 4), "steering": round(car.steering, 4),
            "collisions": car.collisions,
        }}

    return fields


#: Camera thumbnails in a trace: this wide (px), JPEG at this quality.
THUMB_WIDTH = 160
THUMB_QUALITY = 70


def car_trace_frames(car: SimCar, width: int = THUMB_WIDTH) -> Callable[[], dict[str, Any] | None] | None:
    """The trace's frame lines (``None`` for a car without a camera): the latest camera frame as a small JPEG
    (base64) with what the detector found in it (marker ids, corners scaled to the thumbnail, distance and
    bearing; gates by their marker ids). ``None`` from the callable when no new frame was taken since the last
    call (a frame appears once in a trace) or no marker was in view (nothing was rendered)."""
    if car.params.camera is None or not car.params.camera.enabled:
        return None
    return CarFrames(car, width)


class CarFrames:
    """:func:`car_trace_frames`' callable: the frame it gave last is an attribute (a snapshot of the run keeps it)."""

    __snapshot_fields__ = ("car", "width", "last")

    def __init__(self, car: SimCar, width: int) -> None:
        self.car = car
        self.width = width
        self.last = -1

    def __call__(self) -> dict[str, Any] | None:
        car = self.car
        view = car.camera()
        if view is None or view.frame == self.last:
            return None
        self.last = view.frame
        image = car.camera_frame()
        if image is None and not view.detections:
            return None  # nothing in view: no frame was rendered
        line: dict[str, Any] = {"camera_time": round(view.time, 6), "frame": view.frame}
        scale = 1.0
        if image is not None:
            import base64

            import cv2

            h, w = image.shape[:2]
            scale = self.width / w
            small = cv2.resize(image, (self.width, max(1, round(h * scale))), interpolation=cv2.INTER_AREA)
            ok, jpeg = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, THUMB_QUALITY])
            if ok:
                line.update(jpeg=base64.b64encode(jpeg.tobytes()).decode("ascii"), width=small.shape[1],
                            height=small.shape[0])
        line["detections"] = [{"id": int(d.id), "corners": [[round(float(x) * scale, 1), round(float(y) * scale, 1)]
                                                            for x, y in d.corners],
                               "distance": round(float(d.distance), 3), "bearing": round(float(d.bearing), 4)}
                              for d in view.detections]
        if view.gates:
            line["gates"] = [[int(g.left.id), int(g.right.id)] for g in view.gates]
        return line


def car_trace_header(car: SimCar, world_file: object, seed: int, noise: bool) -> dict[str, Any]:
    """What a trace's header says of the car and its world: the world (walls, obstacles, gates, markers, start) and
    car parameters as loaded, the world's file name, seed and noise; enough to draw the map of a run."""
    world = car.world
    return {"world": world.model_dump(mode="json", exclude_none=True), "world_file": str(world_file),
            "seed": seed, "noise": noise}
