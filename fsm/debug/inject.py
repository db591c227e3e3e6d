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
from fsm.session.inputs import InputError, check_input
from fsm.session.session import Input, SetSignal, SetVars

if TYPE_CHECKING:
    from fsm.runtime.machine import Machine


class Refused(InputError):
    """An injection refused: ``message`` says why, ``field`` which field (``name``, ``value`` or ``None``)."""

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field


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
    if isinstance(current, bool) or isinstance(value, bool):
        return isinstance(current, bool) and isinstance(value, bool)
    if isinstance(current, int):
        return isinstance(value, int) or (isinstance(value, float) and value.is_integer() and abs(value) < 2**53)
    if isinstance(current, float):
        return isinstance(value, (int, float))
    if isinstance(current, str):
        return isinstance(value, str)
    return False  # a list, an object, anything else: not from a form's field


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
                              f"{kind_of(value)}. Inject {kind_of(current)}, or change the document", "value")
            values[name] = int(value) if isinstance(current, int) and not isinstance(current, bool) else value
        return SetVars(values)
    if isinstance(item, SetSignal):
        read = sorted(set(signals))
        if item.name not in read:
            raise Refused(f"signal {item.name}: no condition of the machine reads it{_nearest(item.name, read)}; the "
                          f"signals it reads: {_names(read)}", "name")
    return item


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


__all__ = ["Refused", "check_injection", "fits", "kind_of"]
