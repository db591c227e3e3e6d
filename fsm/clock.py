"""Clocks: where a machine's time comes from. Never the wall clock unless asked for (RealTimeClock)."""

from __future__ import annotations

import math
import numbers
import time

#: The TRAL car's control period: 80 Hz (the seed's PD constants 0.0125 s and 80 1/s).
DEFAULT_DT = 0.0125
#: Machine time a run stops after when given neither a duration nor a tick limit (seconds): a machine that can
#: never finish still returns. The one default of ``fsmctl run``, sweeps, scenarios, sessions and ``Machine.run``.
DEFAULT_DURATION = 600.0


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
