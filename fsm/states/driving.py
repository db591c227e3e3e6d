"""The TRAL driving states: wall following (PD(I), door-frame filter, ramp), ApproachPoint, Motor, Stop.

They see the car only through :class:`fsm.sim.io.CarIO` (``ctx.car``), so they run on the simulator
and on any bridge to a real car. Steering is normalised to [-1, 1], positive = left; speeds in m/s;
distances in metres (the hall sensor's 1500 units per 1.60 m are converted by the car).

Default gains (p=1, i=0.2, d=1; error in metres, derivative per second) are tuned for the simulated
TRAL car at 0.4-0.9 m from the wall and 0.5-1.2 m/s: with the car's lateral dynamics
(e'' = -(v^2 * max_angle / wheelbase) * (p*e + d*e')) they give a damping ratio of about 0.7. The
derivative is the least-squares slope of the last 16 errors (0.8 s at 20 Hz), not the difference of
the last two: the difference carried the ultrasonic noise into the command (a standard deviation of
0.18 and 12 sign changes a second on straights, which makes a real servo buzz); the slope and the
lower gains give 0.026 and 0.35 (docs/car.md), with a wall error of 1.1 cm RMS. The small i removes the
steady offset the steering servo's straight-ahead error would leave (offset / p, 3 cm). The report's
gains (p=12, d=30) were in the real car's units and are not comparable.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, TypeVar

from pydantic import Field, model_validator

from fsm.loading.registry import register_state
from fsm.model.params import StateParams
from fsm.runtime.state import State
from fsm.transitions.markers import snap_heading  # the corridor's direction, as the gate states take it

if TYPE_CHECKING:
    from fsm.runtime.context import Context


#: Slack for comparing travelled distances (sums of floats), metres.
EPS = 1e-9
#: Wall following with ``max_angle``: the limit holds from this much before it (the steering servo lags), rad,
#: and turns back with this gain (steering per radian beyond that point).
ANGLE_MARGIN = math.radians(3.0)
ANGLE_GAIN = 4.0
#: The wall followers' derivative: the least-squares slope over this many sensor samples (0.8 s at 20 Hz, lagging
#: by half of it).
D_SAMPLES = 16


def clamp(x: float, lo: float = -1.0, hi: float = 1.0) -> float:
    """``x`` limited to [``lo``, ``hi``] (by default the steering range, [-1, 1])."""
    return lo if x < lo else hi if x > hi else x


P = TypeVar("P", bound=StateParams)


class CarState(State[P]):
    """Base of the states that drive the car: they need ``ctx.car`` (``fsmctl run`` creates one)."""

    __slots__ = ()
    needs_car = True

    def on_pause(self, ctx: Context) -> None:
        """A paused (or suspended) driving state stops the car; its next tick after the pause drives again."""
        ctx.car.set_speed(0.0)


# -- wall following -------------------------------------------------------------------------------------
class WallParams(StateParams):
    side: Literal["left", "right"] = Field(default="right", description="Which wall to follow.")
    distance: Annotated[float, Field(gt=0, le=3.0)] | Literal["lane"] = Field(
        default=0.4, description="Wall distance to keep, m (the side ultrasonic sensor's reading); \"lane\": the "
                                 "reading on entry (keep the lane the car is in; see clear).")
    speed: float = Field(default=0.8, ge=-3.0, le=3.0, description="Speed, m/s.")
    clear: float | None = Field(default=None, gt=0, le=3.0,
                                description="With distance \"lane\": keep at least this reading from the opposite wall "
                                            "(its sensor), m (default: no limit).")
    snap: float | None = Field(
        default=None, gt=0, le=180,
        description="The walls run along a multiple of this many degrees from the start heading (90 in a rectangular "
                    "loop): the side reading is taken square to the wall (times the cosine of the car's angle to it, "
                    "odometry), so that a far wall read askew does not look farther than it is (default: the car is "
                    "taken to drive along the wall).")
    p: float = Field(default=1.0, ge=0, le=1000, description="Proportional gain, steering per metre of error.")
    i: float = Field(default=0.2, ge=0, le=1000, description="Integral gain, steering per metre-second.")
    d: float = Field(default=1.0, ge=0, le=1000, description="Derivative gain, steering per metre/second.")
    d_samples: int = Field(
        default=D_SAMPLES, ge=2, le=50,
        description="The derivative is the least-squares slope of the error over this many sensor samples (2: the "
                    "difference of the last two, the report's law): more samples, less of the sensor's noise in the "
                    "steering (a real servo buzzes on a noisy command) and a little more lag.")
    max_angle: float | None = Field(
        default=None, gt=0, le=80,
        description="Never turn more than this towards the wall from the heading on entry (odometry), degrees: a car "
                    "that starts far from the wall approaches it at this angle instead of turning into it (facing "
                    "the wall, the side sensor reads farther, not nearer). Default: no limit.")


WP = TypeVar("WP", bound=WallParams)


@register_state
class BasicFollowWall(CarState[WP]):
    """Keeps `distance` to the `side` wall with the report's PD(I) law y = p*e + esum*i*dt + d*(e - eold)/dt.

    ``e`` is the side sensor's reading minus the distance to keep. The law is evaluated whenever a
    new ultrasonic sample arrives (``dt`` = time since the previous one) and its output is held in
    between, so the derivative sees real changes, not the sensor's sample-and-hold steps.
    """

    __slots__ = ("target", "wall_target", "wall_side", "_sign", "_esum", "_eold", "_sample", "_t", "_y",
                 "_p", "_i", "_d", "_hist", "_n", "_speed", "_sensor", "_snap", "_max_angle", "_heading")
    Params: ClassVar[type[WallParams]] = WallParams
    #: Samples of this state count towards the wall-distance error on straights (the sim's metric).
    straight_metric: ClassVar[bool] = True

    def __init__(self, id: str, params: WP | None = None) -> None:
        super().__init__(id, params)
        p = self.params
        self.target: float = 0.4 if p.distance == "lane" else p.distance
        self.wall_target: float | None = None
        self.wall_side: str = p.side
        self._sign = -1.0 if p.side == "right" else 1.0
        self._sensor = p.side
        self._p, self._i, self._d = p.p, p.i, p.d
        self._n = p.d_samples
        self._hist: list[tuple[float, float]] = []
        self._speed = p.speed
        self._snap = p.snap
        limit = p.max_angle
        self._max_angle = math.radians(limit) if limit is not None else None
        self._heading = 0.0
        self._esum = 0.0
        self._eold = 0.0
        self._sample = -1
        self._t = 0.0
        self._y = 0.0

    def on_enter(self, ctx: Context) -> None:
        car = ctx.car
        p = self.params
        if p.distance == "lane":  # keep the lane the car is in ...
            reading = self.reading(car)
            other = car.left if self._sensor == "right" else car.right
            if p.clear is not None and other < 2.9:  # ... clear of the other wall
                reading = min(reading, reading + other - p.clear)
            self.target = max(0.1, min(reading, 2.0))
        self._esum = 0.0
        self._eold = self.measure(ctx, self.reading(car)) - self.target
        self._hist = [(ctx.now, self._eold)]
        self._sample = car.sample
        self._t = ctx.now
        self._y = 0.0
        self.wall_target = self.target
        if self._max_angle is not None:
            self._heading = car.pose()[2]
        car.set_speed(self._speed)

    def reading(self, car: Any) -> float:
        """The side sensor's reading, square to the wall with `snap` (a reading at the sensor's maximum is kept)."""
        value: float = getattr(car, self._sensor)
        if self._snap is None or value >= 2.9:
            return value
        th = car.pose()[2]
        return value * abs(math.cos(th - snap_heading(th, self._snap)))

    def measure(self, ctx: Context, reading: float) -> float:
        """The wall distance the controller uses for a new reading (``FollowWall`` filters door frames)."""
        return reading

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        if car.sample != self._sample:
            self._sample = car.sample
            dt = ctx.now - self._t
            self._t = ctx.now
            e = self.measure(ctx, self.reading(car)) - self.target
            limited = False
            if self._max_angle is not None:
                th = car.pose()[2] - self._heading
                toward = self._sign * math.atan2(math.sin(th), math.cos(th))  # > 0: turned towards the wall
                limited = toward > self._max_angle - ANGLE_MARGIN
            if dt > 0:
                if not limited:  # no wind-up while the angle limit holds the car back
                    self._esum += e
                self._y = self._p * e + self._esum * self._i * dt + self._d * self._slope(ctx.now, e)
            self._eold = e
            steering = clamp(self._sign * self._y)
            # at the limit: turn no further towards the wall (limited implies a max_angle)
            if limited and self._sign * steering > 0 and self._max_angle is not None:
                steering = -self._sign * clamp(ANGLE_GAIN * (toward - self._max_angle + ANGLE_MARGIN), 0.0, 1.0)
            car.set_steering(steering)
        car.set_speed(self._speed)

    def _slope(self, now: float, e: float) -> float:
        """The error's rate, m/s: the least-squares slope of the last `d_samples` errors over their times."""
        hist = self._hist
        hist.append((now, e))
        if len(hist) > self._n:
            del hist[0]
        n = len(hist)
        if n < 2:
            return 0.0
        st = se = 0.0  # the sums in the order sum() takes them: the same floats, without four generators a tick
        for t, v in hist:
            st += t
            se += v
        mt, me = st / n, se / n
        stt = ste = 0.0
        for t, v in hist:
            dt = t - mt
            stt += dt ** 2
            ste += dt * (v - me)
        return ste / stt if stt > 0 else 0.0

    def on_exit(self, ctx: Context) -> None:
        self.wall_target = None


#: A jump larger than this is no door frame: FollowWall takes it at once, m.
MAX_OFFSET = 0.3


class FollowWallParams(WallParams):
    jump: float = Field(default=0.02, gt=0, le=1.0,
                        description="Ignore readings that jump more than this from the last one used, m "
                                    "(door frames).")
    hold: float = Field(default=1.5, gt=0, le=20.0,
                        description="Accept a jump after ignoring it for this travelled distance, m "
                                    "(so a real change of the wall is followed).")


@register_state
class FollowWall(BasicFollowWall[FollowWallParams]):
    """BasicFollowWall that ignores ultrasonic jumps larger than `jump` (2 cm), so door frames do not make it swing.

    A jump between two samples is taken out of the signal (remembered as an offset) instead of
    freezing it, so the controller keeps following the wall's small changes while it passes a door
    frame; the jump back at the frame's end cancels the offset. After `hold` metres with an offset
    the new level is accepted (the wall really moved).
    """

    __slots__ = ("_last", "_offset", "_ignored_at", "_jump", "_hold")
    Params = FollowWallParams

    def __init__(self, id: str, params: FollowWallParams | None = None) -> None:
        super().__init__(id, params)
        self._jump = self.params.jump
        self._hold = self.params.hold
        self._last = 0.0
        self._offset = 0.0
        self._ignored_at = 0.0

    def on_enter(self, ctx: Context) -> None:
        self._last = self.reading(ctx.car)
        self._offset = 0.0
        super().on_enter(ctx)

    def measure(self, ctx: Context, reading: float) -> float:
        value = reading - self._offset
        step = value - self._last
        if step > self._jump or step < -self._jump:
            if self._offset == 0.0:
                self._ignored_at = ctx.car.distance
            self._offset += step
            if -self._jump < self._offset < self._jump or not -MAX_OFFSET < self._offset < MAX_OFFSET:
                # The jump back: the door frame (or an outlier) is over; or too big for a door: take it.
                self._offset = 0.0
            value = reading - self._offset
        elif self._offset != 0.0 and ctx.car.distance - self._ignored_at >= self._hold - EPS:
            self._offset = 0.0  # held long enough: the wall really moved
            value = reading
        self._last = value
        return value


class RampParams(WallParams):
    distance: float = Field(gt=0, le=3.0, description="Wall distance at the end of the ramp, m.")
    length: float = Field(gt=0, le=100.0, description="Travelled distance over which the wall distance changes, m.")
    start: float | None = Field(default=None, gt=0, le=3.0,
                                description="Wall distance at the start, m (default: the reading on entry).")


@register_state
class FollowWallRamp(BasicFollowWall[RampParams]):
    """Follows the wall at a distance changing linearly from the current one to `distance` over `length` metres travelled; finishes at the end of the ramp (and keeps following at `distance`)."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_from", "_d0", "_length", "_end")
    Params = RampParams
    can_finish = True
    straight_metric = False

    def __init__(self, id: str, params: RampParams | None = None) -> None:
        super().__init__(id, params)
        self._end = self.params.distance
        self._length = self.params.length
        self._from = self._end
        self._d0 = 0.0

    def on_enter(self, ctx: Context) -> None:
        car = ctx.car
        start = self.params.start
        self._from = start if start is not None else min(self.reading(car), 3.0)
        self._d0 = car.distance
        self.target = self._from
        super().on_enter(ctx)

    def tick(self, ctx: Context) -> None:
        progress = (ctx.car.distance - self._d0) / self._length
        if progress >= 1.0 - EPS:
            progress = 1.0
            if not self.finished:
                self.finish()
        self.target = self._from + (self._end - self._from) * progress
        self.wall_target = self.target
        super().tick(ctx)


# -- driving to a point, fixed commands, stopping ------------------------------------------------------------
class ApproachParams(StateParams):
    x: float | None = Field(default=None, ge=-20, le=20,
                            description="Target ahead of the car (at entry), m; leave it out when a transition "
                                        "hands the target (ArucoGateFound: a point before the gate).")
    y: float = Field(default=0.0, ge=-20, le=20, description="Target to the left of the car (at entry), m.")
    speed: float = Field(default=0.5, gt=0, le=3.0, description="Speed, m/s.")
    tolerance: float = Field(default=0.1, gt=0, le=5.0, description="Arrived when this close, m.")

    @model_validator(mode="after")
    def _not_here(self) -> ApproachParams:
        if self.x is not None and math.hypot(self.x, self.y) <= self.tolerance:
            raise ValueError(f"the point ({self.x}, {self.y}) is within the tolerance {self.tolerance} m of the "
                             "car: the state would finish at once")
        return self


AP = TypeVar("AP", bound=ApproachParams)


@register_state
class ApproachPoint(CarState[AP]):
    """Drives to a point given relative to the car when the state is entered (pure pursuit on odometry); finishes on arrival, or with outcome `missed` when the point falls behind within reach of a turn."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_tx", "_ty", "_handed")
    Params: ClassVar[type[ApproachParams]] = ApproachParams
    can_finish = True
    outcomes = ("succeeded", "missed")
    #: Transitions may hand this state its target (``set_target``), as the report's ArucoGateFound does.
    accepts_target = True

    def __init__(self, id: str, params: AP | None = None) -> None:
        super().__init__(id, params)
        self._tx = self._ty = 0.0
        self._handed: tuple[float, float] | None = None

    def set_target(self, ctx: Context, x: float, y: float, heading: float | None = None) -> None:
        """The point to drive to, relative to the car now (x ahead, y left, m); used on the next entry."""
        self._handed = (x, y)

    def on_enter(self, ctx: Context) -> None:
        p = self.params
        if self._handed is not None:
            px, py = self._handed
            self._handed = None
        elif p.x is not None:
            px, py = p.x, p.y
        else:  # nothing handed and no point given: nowhere to go
            self._tx = math.nan
            return
        self.aim(ctx, px, py)

    def aim(self, ctx: Context, px: float, py: float) -> None:
        """Drive to the point ``px`` ahead and ``py`` to the left of the car now (kept in the odometry frame)."""
        x, y, th = ctx.car.pose()
        c, s = math.cos(th), math.sin(th)
        self._tx = x + c * px - s * py
        self._ty = y + s * px + c * py

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        p = self.params
        if self._tx != self._tx:  # no target (NaN): nothing was handed
            car.set_speed(0.0)
            if not self.finished:
                self.finish("missed")
            return
        x, y, th = car.pose()
        dx, dy = self._tx - x, self._ty - y
        dist = math.hypot(dx, dy)
        if dist <= p.tolerance:
            car.set_speed(0.0)
            self.finish()
            return
        c, s = math.cos(th), math.sin(th)
        fx, fy = c * dx + s * dy, -s * dx + c * dy  # the point in the car frame
        turn_radius = car.wheelbase / math.tan(car.max_steering_angle)
        if fx < 0 and dist < 2 * turn_radius:
            car.set_speed(0.0)
            self.finish("missed")
            return
        alpha = math.atan2(fy, fx)
        delta = math.atan2(2.0 * car.wheelbase * math.sin(alpha), dist)  # pure pursuit, look-ahead = dist
        car.set_steering(clamp(delta / car.max_steering_angle))
        car.set_speed(p.speed)


class MotorParams(StateParams):
    speed: float = Field(ge=-3.0, le=3.0, description="Speed, m/s (negative: backwards); not 0.")
    steering: float = Field(default=0.0, ge=-1.0, le=1.0, description="Steering, -1 (right) to 1 (left).")
    distance: float = Field(gt=0, le=1000.0, description="Travelled distance after which the state finishes, m.")

    @model_validator(mode="after")
    def _moves(self) -> MotorParams:
        if self.speed == 0:
            raise ValueError("speed 0 would never cover the distance; use Stop to stand still")
        return self


@register_state
class Motor(CarState[MotorParams]):
    """Drives with a fixed speed and steering; finishes after `distance` metres (hall sensor)."""

    __slots__ = ("_d0",)
    Params = MotorParams
    can_finish = True

    def __init__(self, id: str, params: MotorParams | None = None) -> None:
        super().__init__(id, params)
        self._d0 = 0.0

    def on_enter(self, ctx: Context) -> None:
        car = ctx.car
        self._d0 = car.distance
        car.set_steering(self.params.steering)
        car.set_speed(self.params.speed)

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        if not self.finished and car.distance - self._d0 >= self.params.distance - EPS:
            self.finish()
        car.set_steering(self.params.steering)
        car.set_speed(self.params.speed)


class StopParams(StateParams):
    steering: float | None = Field(default=None, ge=-1.0, le=1.0,
                                   description="Steering while stopping (default: keep the last command).")
    still: float = Field(default=0.01, gt=0, le=1.0, description="Below this speed the car stands still, m/s.")


@register_state
class Stop(CarState[StopParams]):
    """Commands speed 0; finishes when the car stands still."""

    __slots__ = ()
    Params = StopParams
    can_finish = True

    def on_enter(self, ctx: Context) -> None:
        ctx.car.set_speed(0.0)
        if self.params.steering is not None:
            ctx.car.set_steering(self.params.steering)

    def tick(self, ctx: Context) -> None:
        car = ctx.car
        car.set_speed(0.0)
        if not self.finished and abs(car.speed) < self.params.still:
            self.finish()
