"""Clocks: where a machine's time comes from. Never the wall clock unless asked for (RealTimeClock)."""

from __future__ import annotations

import math
import numbers
import time
from typing import Protocol, runtime_checkable

#: The TRAL car's control period: 80 Hz (the seed's PD constants 0.0125 s and 80 1/s).
DEFAULT_DT = 0.0125
#: Machine time a run stops after when given neither a duration nor a tick limit (seconds): a machine that can
#: never finish still returns. The one default of ``fsmctl run``, sweeps, scenarios, sessions and ``fsm.run``.
DEFAULT_DURATION = 600.0


@runtime_checkable
class Clock(Protocol):
    """What a machine asks its clock: the tick period, the time of a tick, and waiting for a tick to be due.

    :class:`SimulatedClock` and :class:`RealTimeClock` are clocks; any object with these members is one too
    (a clock driven by a robot's own control loop, say)."""

    @property
    def dt(self) -> float:
        """The tick period, seconds."""

    @property
    def realtime(self) -> bool:
        """True when ``time_at`` reads a wall clock (the machine asks it each tick); false when tick ``n``
        happens at ``n * dt`` exactly."""

    def time_at(self, tick: int) -> float:
        """The machine time of tick ``tick``, seconds."""

    def wait_for(self, tick: int) -> None:
        """Return when tick ``tick`` is due (at once for simulated time)."""


def check_dt(dt: object) -> float:
    """A tick period: a finite number of seconds > 0 (``TypeError`` for a non-number, ``ValueError`` else)."""
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real):
        raise TypeError(f"dt must be a number of seconds, got {dt!r} ({type(dt).__name__})")
    value = float(dt)
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"dt must be a finite number of seconds > 0, got {dt!r}")
    return value


class SimulatedClock:
    """Simulated time: tick ``n`` happens at ``n * dt`` exactly, so runs are bit-identical.

    Multiplying instead of accumulating keeps ``now`` free of summed rounding errors.
    """

    __slots__ = ("dt",)
    realtime = False

    def __init__(self, dt: float = DEFAULT_DT) -> None:
        self.dt = check_dt(dt)

    def time_at(self, tick: int) -> float:
        """Tick ``tick`` happens at ``tick * dt``."""
        return tick * self.dt

    def wait_for(self, tick: int) -> None:
        """Simulated time does not wait."""


class RealTimeClock:
    """Wall-clock time from ``time.monotonic``, for hardware; ``run`` sleeps so ticks keep the period ``dt``."""

    __slots__ = ("dt", "_t0")
    realtime = True

    def __init__(self, dt: float = DEFAULT_DT) -> None:
        self.dt = check_dt(dt)
        self._t0: float | None = None

    def time_at(self, tick: int) -> float:
        """Seconds since the first reading (``tick`` is not needed: the wall clock says when it is)."""
        now = time.monotonic()
        if self._t0 is None:
            self._t0 = now
        return now - self._t0

    def wait_for(self, tick: int) -> None:
        """Sleep until tick ``tick`` is due (``tick * dt`` after the first reading)."""
        if self._t0 is None:
            self._t0 = time.monotonic()
        delay = self._t0 + tick * self.dt - time.monotonic()
        if delay > 0:
            time.sleep(delay)
