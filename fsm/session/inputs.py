"""Inputs that steer a run from outside, as JSON: what a trace's ``input`` lines hold and a debugger submits.

:mod:`fsm.session.session` applies inputs between two ticks (never inside one) and the trace records each one it applied
(an ``input`` line: the tick before which it applied, what it was), so a steered run replays identically from its
trace. Besides the session's own inputs (:class:`~fsm.session.session.SetVars`, :class:`~fsm.session.session.SetSignal`,
:class:`~fsm.session.session.PauseState`) this module adds the faults a debugger injects:

- :class:`ForceSensor`: a car reading (``left``, ``right``, ``front``, ``distance``, ``speed``) forced to a value
  for N ticks; the machine sees it through a :class:`ForcedCar` that stands in for the car meanwhile.
- :class:`FireMonitor`: a monitor (or a timeout) of an active state fires in the coming tick, as if its condition
  held, at its place in the tick (outermost first).
- :class:`FinishState`: an active state finishes with an outcome, so its ``Finished`` transitions can fire in the
  coming tick.

Each input has ``to_json()``; :func:`input_from_json` makes one back, checking every field (:class:`InputError`
says what is wrong, for the page or the trace reader).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fsm.runtime.supervisor import supervisor_of
from fsm.session.session import Input, PauseState, SetSignal, SetVars
from fsm.trace.recorder import input_json

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Machine
    from fsm.runtime.supervisor import Monitor

#: The car readings a :class:`ForceSensor` may force.
FORCEABLE = ("left", "right", "front", "distance", "speed")
#: The longest force, in ticks (about 35 hours at 80 Hz): a typo of a few digits more is refused.
MAX_FORCE_TICKS = 10_000_000


class InputError(ValueError):
    """An input that cannot be applied or read back; the message says which field and why, ``field`` names it
    (the input's key, for a form to point at) when one field is wrong."""

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field


# -- faults ----------------------------------------------------------------------------------------------------
class ForcedCar:
    """The car as the machine sees it while readings are forced: each forced reading holds its value until its
    last tick, every other attribute is the car's own. It takes itself out (``ctx.car`` is the car again) at the
    first read after the last force ended, so a run pays for it only while forcing."""

    __slots__ = ("_car", "_ctx", "_forces")

    def __init__(self, car: Any, ctx: Context) -> None:
        object.__setattr__(self, "_car", car)
        object.__setattr__(self, "_ctx", ctx)
        #: reading -> (value, last tick it holds)
        object.__setattr__(self, "_forces", {})

    @property
    def car(self) -> Any:
        """The car behind the forces."""
        return self._car

    def force(self, name: str, value: float, last_tick: int) -> None:
        self._forces[name] = (value, last_tick)

    def __getattr__(self, name: str) -> Any:
        forced = self._forces.get(name)
        if forced is not None:
            if self._ctx.tick <= forced[1]:
                return forced[0]
            del self._forces[name]
            if not self._forces and self._ctx.car is self:
                self._ctx.car = self._car
        return getattr(self._car, name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._car, name, value)


@dataclass(frozen=True)
class ForceSensor:
    """Force car reading ``sensor`` to ``value`` for the next ``ticks`` ticks (the readings the machine sees; the
    simulated physics and the trace's samples keep the true ones)."""

    sensor: str
    value: float
    ticks: int

    def apply(self, machine: Machine) -> None:
        ctx = machine.ctx
        car = ctx.car
        if car is None:
            return  # a machine without a car reads no sensor
        if not isinstance(car, ForcedCar):
            car = ForcedCar(car, ctx)
            ctx.car = car
        # applied before tick n (ctx.tick is n - 1 then, or 0 before the start): holds in ticks n .. n + ticks - 1
        first = ctx.tick + 1 if machine.started else 0
        car.force(self.sensor, self.value, first + self.ticks - 1)

    def describe(self) -> str:
        return f"force {self.sensor} = {self.value:g} for {self.ticks} tick{'s' * (self.ticks != 1)}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": "force", "sensor": self.sensor, "value": self.value, "ticks": self.ticks}


@dataclass(frozen=True)
class FireMonitor:
    """Fire monitor ``monitor`` (its label, or its index among the owner's monitors) of the state at ``owner`` in
    the coming tick, as if its condition held there (a timeout expires). Nothing happens when the owner is not
    checked in that tick (not active, or an outer monitor used the tick up)."""

    owner: str
    monitor: str

    def apply(self, machine: Machine) -> None:
        found = find_monitor(machine, self.owner, self.monitor)
        if isinstance(found, str):
            return  # checked when it was submitted; a machine that changed since has nothing to fire
        tick = machine.ctx.tick + 1 if machine.started else 1
        found.holds = _once(found, found.holds, tick)

    def describe(self) -> str:
        return f"fire monitor {self.monitor} of {self.owner}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": "monitor", "owner": self.owner, "monitor": self.monitor}


def _once(monitor: Monitor, holds: Callable[[Context], bool], tick: int) -> Callable[[Context], bool]:
    """``holds`` that is true when checked in ``tick``; the first check puts the monitor's own condition back."""

    def fire(ctx: Context) -> bool:
        monitor.holds = holds
        return True if ctx.tick == tick else holds(ctx)

    return fire


def find_monitor(machine: Machine, owner: str, monitor: str) -> Monitor | str:
    """The monitor ``monitor`` (label or index) of the state at ``owner``, or why there is none."""
    try:
        state = machine.state(owner)
    except (KeyError, TypeError) as exc:
        return str(exc).strip("'\"")
    supervisor = supervisor_of(state)
    monitors = supervisor.monitors if supervisor is not None else ()
    if not monitors:
        return f"state '{owner}' has no monitor and no timeout"
    for k, m in enumerate(monitors):
        if m.label == monitor or str(k) == monitor:
            return m
    names = ", ".join(m.label for m in monitors)
    return f"state '{owner}' has no monitor '{monitor}' (it has: {names})"


@dataclass(frozen=True)
class FinishState:
    """Finish the active state at ``path`` with ``outcome``: its ``Finished`` transitions may fire in the coming
    tick (what the state's own tick does then is up to it)."""

    path: str
    outcome: str = "succeeded"

    def apply(self, machine: Machine) -> None:
        try:
            state = machine.state(self.path)
        except KeyError:
            return
        if state.active:
            state.finish(self.outcome)

    def describe(self) -> str:
        return f"finish {self.path} with {self.outcome}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": "finish", "path": self.path, "outcome": self.outcome}


# -- JSON --------------------------------------------------------------------------------------------------------
#: ``item`` as JSON, as the trace's ``input`` lines write it (:func:`fsm.trace.recorder.input_json`).
input_to_json = input_json


def input_from_json(data: Any) -> Input:
    """The input ``data`` describes (as :func:`input_to_json` writes it); :class:`InputError` if it is none."""
    if not isinstance(data, Mapping):
        raise InputError("an input is a JSON object with a 'kind'")
    kind = data.get("kind")
    reader = _READERS.get(kind) if isinstance(kind, str) else None
    if reader is None:
        raise InputError(f"unknown input kind {kind!r} (one of {', '.join(_READERS)})")
    return reader(data)


def _text(data: Mapping[str, Any], key: str, *, empty: bool = False) -> str:
    value = data.get(key)
    if not isinstance(value, str) or (not value and not empty) or len(value) > 1000:
        raise InputError(f"'{key}' must be a text of 1 to 1000 characters" if not empty else f"'{key}' must be a text")
    return value


def _bool(data: Mapping[str, Any], key: str, default: bool) -> bool:
    value = data.get(key, default)
    if not isinstance(value, bool):
        raise InputError(f"'{key}' must be true or false")
    return value


def _set(data: Mapping[str, Any]) -> Input:
    values = data.get("values")
    if not isinstance(values, Mapping) or not values:
        raise InputError("'values' must be an object of variable names and values")
    for name, value in values.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise InputError(f"variable name {name!r} is not a name (letters, digits, _)")
        why = _not_plain(value, 2)
        if why:
            raise InputError(f"variable {name}: {why}", "value")
    return SetVars(dict(values))


def _not_plain(value: Any, depth: int) -> str:
    """Why ``value`` is not a value a variable may be set to ('' when it is): a number (finite), true/false, a
    text, or a list or object of those (one level deep, at most 1,000 items)."""
    if isinstance(value, float) and not math.isfinite(value):
        return f"{value!r} is not a finite number"
    if isinstance(value, (bool, int, float)) or (isinstance(value, str) and len(value) <= 1000):
        return ""
    if depth > 1 and isinstance(value, (list, Mapping)) and len(value) <= 1000:
        items = value.values() if isinstance(value, Mapping) else value
        if isinstance(value, Mapping) and not all(isinstance(key, str) for key in value):
            return "an object's keys are texts"
        return next((why for why in (_not_plain(item, depth - 1) for item in items) if why), "")
    return "a value is a number, true/false, a text of at most 1,000 characters, or a list or object of those"


def _signal(data: Mapping[str, Any]) -> Input:
    return SetSignal(_text(data, "name"), _bool(data, "value", True))


def _pause(data: Mapping[str, Any]) -> Input:
    return PauseState(_text(data, "path", empty=True), _bool(data, "paused", True))


def _force(data: Mapping[str, Any]) -> Input:
    sensor = data.get("sensor")
    if sensor not in FORCEABLE:
        raise InputError(f"force {sensor}: 'sensor' must be one of {', '.join(FORCEABLE)}", "sensor")
    value, ticks = data.get("value"), data.get("ticks")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"force {sensor}: 'value' must be a finite number, got {value!r}", "value")
    if isinstance(ticks, bool) or not isinstance(ticks, int) or not 1 <= ticks <= MAX_FORCE_TICKS:
        raise InputError(f"force {sensor}: 'ticks' must be a whole number from 1 to {MAX_FORCE_TICKS:,}, got "
                         f"{ticks!r}", "ticks")
    return ForceSensor(str(sensor), float(value), ticks)


def _monitor(data: Mapping[str, Any]) -> Input:
    return FireMonitor(_text(data, "owner"), _text(data, "monitor"))


def _finish(data: Mapping[str, Any]) -> Input:
    return FinishState(_text(data, "path"), _text(data, "outcome") if "outcome" in data else "succeeded")


_READERS: dict[str, Callable[[Mapping[str, Any]], Input]] = {
    "set": _set, "signal": _signal, "pause": _pause, "force": _force, "monitor": _monitor, "finish": _finish}


def check_input(item: Input, machine: Machine) -> str | None:
    """Why ``item`` cannot be applied to ``machine`` now (a path that names no active state, a monitor it does
    not have, an outcome the state cannot finish with), or None: said to whoever submits it, before it is."""
    if isinstance(item, (FinishState, PauseState)) and item.path:
        try:
            state = machine.state(item.path)
        except (KeyError, TypeError) as exc:
            return str(exc).strip("'\"")
        if not state.active:
            return f"state '{item.path}' is not active"
        if isinstance(item, FinishState):
            outcomes = type(state).possible_outcomes(state.params)
            if outcomes is not None and item.outcome not in outcomes:
                can = ", ".join(sorted(outcomes)) if outcomes else "none: it never finishes"
                return f"state '{item.path}' cannot finish with '{item.outcome}' (its outcomes: {can})"
    if isinstance(item, FireMonitor):
        found = find_monitor(machine, item.owner, item.monitor)
        if isinstance(found, str):
            return found
        if not machine.state(item.owner).active:
            return f"state '{item.owner}' is not active: its monitors are not checked"
    if isinstance(item, ForceSensor) and machine.ctx.car is None:
        return "this machine runs without a car: there is no sensor to force"
    return None


def recorded_inputs(lines: list[dict[str, Any]]) -> tuple[list[tuple[int, Input]], list[str]]:
    """The inputs of a trace's ``input`` lines, each with the tick before which it applied, and a warning for each
    line that cannot be replayed."""
    out: list[tuple[int, Input]] = []
    warnings: list[str] = []
    for line in lines:
        try:
            out.append((int(line["tick"]), input_from_json(line.get("input"))))
        except InputError as exc:
            warnings.append(f"the input at tick {line.get('tick')} cannot be replayed: {exc}")
    return out, warnings


__all__ = ["FORCEABLE", "FinishState", "FireMonitor", "ForceSensor", "ForcedCar", "InputError", "check_input",
           "find_monitor", "input_from_json", "input_to_json", "recorded_inputs"]
