"""A scenario's inputs as exact changes on the simulated clock: signal levels (pulses, levels, bouncing presses)
and blackboard variable sets, each with the tick that first sees it.

Times are computed as ``at + k * interval`` (never by adding up intervals), so a bounce lands on the same
tick on every platform. How a tick sees them is the core's rule (:class:`fsm.runtime.context.Context`): every change
due by a tick's time is applied before that tick, and an edge is seen only when the level at the start of a
tick differs from the level at the start of the previous one. So a contact that bounces faster than ``dt``
shows the tick only its net level: a press whose bounce settles within one tick makes exactly one rising
edge; a slower bounce makes one edge per tick whose level differs from the previous tick's, which is what a
debounced condition has to cope with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from fsm.session.session import tick_at

from .model import Bounce, PauseInput, PressInput, ResumeInput, Scenario, SetInput, SignalInput


def press_changes(at: float, duration: float, bounce: Bounce | None = None) -> list[tuple[float, bool]]:
    """The level changes of one button press: ``(time, level)`` in time order.

    Without bounce: high at ``at``, low at ``at + duration``. With ``bounce`` (``count`` c, ``interval`` i) the
    contact closes at ``at``, then opens and closes again c times, a change every i seconds, and is settled
    high from ``at + 2*c*i``; the release at ``at + duration`` bounces the same way and settles low.
    """
    changes: list[tuple[float, bool]] = []
    for start, level in ((at, True), (at + duration, False)):
        changes.append((start, level))
        if bounce is not None:
            for k in range(1, 2 * bounce.count + 1):
                changes.append((start + k * bounce.interval, level if k % 2 == 0 else not level))
    return changes


@dataclass(frozen=True)
class SignalChange:
    time: float
    tick: int
    name: str
    level: bool
    index: int  # of the input in the scenario


@dataclass(frozen=True)
class VarSet:
    time: float
    tick: int
    values: dict[str, Any]
    index: int


def expand(scenario: Scenario, dt: float) -> tuple[list[SignalChange], list[VarSet]]:
    """Every signal change and variable set of the scenario's inputs, in time order (ties: scenario order)."""
    signals: list[SignalChange] = []
    sets: list[VarSet] = []
    for i, item in enumerate(scenario.inputs):
        if isinstance(item, (SignalInput, PressInput)):
            signals += [SignalChange(t, tick_at(t, dt), name, level, i) for name, t, level in _levels(item, dt)]
        elif isinstance(item, SetInput):
            sets.append(VarSet(item.at, tick_at(item.at, dt), dict(item.set), i))
    signals = [c for c in signals if math.isfinite(c.time)]  # a release at 1e308 s + 1e308 s never comes
    signals.sort(key=lambda c: (c.time, c.index))
    sets.sort(key=lambda s: (s.time, s.index))
    return signals, sets


def _levels(item: SignalInput | PressInput, dt: float) -> list[tuple[str, float, bool]]:
    """The level changes of a signal input (a level, or a pulse ``width`` long, one tick by default) or of a press:
    ``(signal, time, level)`` in time order."""
    if isinstance(item, PressInput):
        return [(item.press, t, level) for t, level in press_changes(item.at, item.duration, item.bounce)]
    if item.value is not None:
        return [(item.signal, item.at, item.value)]
    width = item.width if item.width is not None else dt
    return [(item.signal, item.at, True), (item.signal, item.at + width, False)]


def seen_levels(changes: list[tuple[float, bool]], dt: float, ticks: int, initial: bool = False) -> list[bool]:
    """The level each tick ``0..ticks-1`` sees for these changes: the last change due by its time (the core's
    rule, for tests and for reasoning about bounce)."""
    out = []
    level = initial
    todo = sorted(changes, key=lambda c: c[0])
    k = 0
    for n in range(ticks):
        while k < len(todo) and todo[k][0] <= n * dt + 1e-9:
            level = todo[k][1]
            k += 1
        out.append(level)
    return out


@dataclass(frozen=True)
class PauseChange:
    """A state paused (``paused`` True) or resumed by the scenario, before ``tick``."""

    time: float
    tick: int
    path: str
    paused: bool
    index: int


def pause_changes(scenario: Scenario, dt: float) -> list[PauseChange]:
    """The scenario's ``pause`` and ``resume`` inputs, in time order (ties: scenario order)."""
    out = [PauseChange(item.at, tick_at(item.at, dt), *item.held(), i) for i, item in enumerate(scenario.inputs)
           if isinstance(item, (PauseInput, ResumeInput))]
    out.sort(key=lambda c: (c.time, c.index))
    return out
