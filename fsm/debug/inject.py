"""Injection checked like a document: what a debugger may inject into a running machine, said before it is.

:func:`fsm.session.inputs.check_input` says whether an input can be applied at all (a path that names an active
state, a monitor the state has). Here the values are checked against the machine as it is: a variable must be one
the machine has, and the value of the kind it holds (a list stays a list, a whole number whole); a signal must be
one a condition of the machine reads. Each refusal names the field it is about (``name`` or ``value``), so a page
can point at it, and what would have been right. The run never gets a value its states were not written for.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from fsm.loading.checking import value_kind
from fsm.session.inputs import ForceSensor, InputError, check_input
from fsm.session.session import Input, SetSignal, SetVars

if TYPE_CHECKING:
    from fsm.runtime.machine import Machine


class Refused(InputError):
    """An injection refused: ``message`` says why, ``field`` which field (``name``, ``value`` or ``None``)."""


#: What each forceable reading can be on a car of ours, and in what unit: the sonars' range (a world allows at
#: most 10 m), the odometer's distance and the speed (a world allows at most 20 m/s). A force outside it is a
#: reading no car gives, so the machine would be tested against something that cannot happen.
FORCE_LIMITS: dict[str, tuple[float, float, str]] = {
    "left": (0.0, 10.0, "m"), "right": (0.0, 10.0, "m"), "front": (0.0, 10.0, "m"),
    "distance": (0.0, 1e6, "m"), "speed": (-20.0, 20.0, "m/s"),
}


def kind_of(value: Any) -> str:
    """The kind of ``value`` in the document's words (:func:`fsm.loading.checking.value_kind`), a whole number
    told from a number: a counter set to 2.5 would break what counts with it."""
    if isinstance(value, int) and not isinstance(value, bool):
        return "a whole number"
    kind = value_kind(value)
    return {"text": "a text", "null": "nothing (null)", "object": "an object"}.get(kind, f"a {kind}")


def fits(current: Any, value: Any) -> bool:
    """Whether ``value`` may replace ``current`` (a variable's value now) without changing what it is."""
    if current is None:
        return isinstance(value, (bool, int, float, str))  # unset yet: any plain value
    if isinstance(current, list):  # a list stays a list of what it holds (any plain values while it is empty)
        return isinstance(value, list) and all(fits(current[0] if current else None, item) for item in value)
    if isinstance(current, dict):  # an object keeps its keys, each value of its kind
        return (isinstance(value, dict) and value.keys() == current.keys()
                and all(fits(current[key], item) for key, item in value.items()))
    if isinstance(current, bool) or isinstance(value, bool):
        return isinstance(current, bool) and isinstance(value, bool)
    if isinstance(current, int):
        return isinstance(value, int) or (isinstance(value, float) and value.is_integer() and abs(value) < 2**53)
    if isinstance(current, float):
        return isinstance(value, (int, float))
    if isinstance(current, str):
        return isinstance(value, str)
    return False


def _nearest(name: str, known: Iterable[str]) -> str:
    close = difflib.get_close_matches(name, list(known), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _names(known: list[str]) -> str:
    shown = ", ".join(known[:12]) + (", ..." if len(known) > 12 else "")
    return shown or "none"


def check_injection(item: Input, machine: Machine, signals: Iterable[str]) -> Input:
    """``item`` as it will be applied (a whole number given as ``3.0`` made ``3``), or :class:`Refused` saying
    why it cannot be: see the module docstring. ``signals``: the signal names the machine's conditions read."""
    why = check_input(item, machine)
    if why is not None:
        raise Refused(why, "name")
    if isinstance(item, SetVars):
        variables = machine.ctx.vars
        known = sorted(str(k) for k in variables)
        values: dict[str, Any] = {}
        for name, value in item.values.items():
            if name not in variables:
                raise Refused(f"set {name}: the machine has no variable '{name}'{_nearest(name, known)}; its "
                              f"variables: {_names(known)}", "name")
            current = variables[name]
            if not fits(current, value):
                raise Refused(f"set {name}: '{name}' holds {kind_of(current)} ({_short(current)}); {_short(value)} is "
                              f"{kind_of(value)}. Inject {kind_of(current)}{_written(current)}, or change the "
                              "document", "value")
            values[name] = _as_current(current, value)
        return SetVars(values)
    if isinstance(item, ForceSensor):
        low, high, unit = FORCE_LIMITS[item.sensor]
        if not low <= item.value <= high:
            raise Refused(f"force {item.sensor}: {item.value:g} {unit} is not a reading a car gives; force "
                          f"{item.sensor} to a value from {low:g} to {high:g} {unit}", "value")
        return item
    if isinstance(item, SetSignal):
        read = sorted(set(signals))
        if item.name not in read:
            raise Refused(f"signal {item.name}: no condition of the machine reads it{_nearest(item.name, read)}; the "
                          f"signals it reads: {_names(read)}", "name")
    return item


def _written(current: Any) -> str:
    """How the page's value field takes a value like ``current`` when it is not a plain one."""
    if isinstance(current, list):
        return " written as JSON, such as " + (f"[{_short(current[0])}]" if current else "[]")
    if isinstance(current, dict):
        return " written as JSON with the keys " + ", ".join(sorted(map(str, current)))
    return ""


def _as_current(current: Any, value: Any) -> Any:
    """``value`` in ``current``'s form: a whole number given as ``3.0`` made ``3``, in a list or object too."""
    if isinstance(current, int) and not isinstance(current, bool):
        return int(value)
    if isinstance(current, list) and current:
        return [_as_current(current[0], item) for item in value]
    if isinstance(current, dict):
        return {key: _as_current(current[key], item) for key, item in value.items()}
    return value


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


__all__ = ["FORCE_LIMITS", "Refused", "check_injection", "fits", "kind_of"]
