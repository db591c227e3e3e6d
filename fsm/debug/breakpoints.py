"""Breakpoints of a run: what makes a debugged run (:mod:`fsm.debug.control`) pause after the tick in which it happened.

A breakpoint is given as JSON (what the live page sends) and checked against the machine before it is kept:

- ``{"kind": "enter", "state": GLOB}`` / ``{"kind": "leave", "state": GLOB}``: a state whose path matches is
  entered / left (a path, or a glob: ``lap1/*``, ``*/turn``; ``*`` also matches ``/``);
- ``{"kind": "transition", "from": GLOB, "to": GLOB}``: a transition fires (a monitor's restart too);
- ``{"kind": "monitor", "owner": GLOB, "monitor": GLOB}``: a monitor (or a timeout) fires;
- ``{"kind": "exception", "owner": GLOB}``: an exception sequence starts;
- ``{"kind": "timeout", "owner": GLOB}``: a timeout expires;
- ``{"kind": "expr", "expr": TEXT}``: an expression of the document's language (:mod:`fsm.model.expr`) becomes true,
  over the variables, the signals (``signal_NAME``: true/false) and the car's readings (``car_left``,
  ``car_right``, ``car_front``, ``car_distance``, ``car_speed``, ``car_steering``, ``car_speed_command``).

A breakpoint that cannot be used raises :class:`BreakpointError` (an expression's with its column), and the run
goes on without it.
"""

from __future__ import annotations

import difflib
import fnmatch
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.model.expr import BOOL, NUMBER, ExprError, ExprRuntimeError, compile_expr, kind_of
from fsm.runtime.machine import Listener
from fsm.runtime.supervisor import supervisor_of

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Fired, Machine
    from fsm.runtime.state import State
    from fsm.runtime.supervisor import Monitor

KINDS = ("enter", "leave", "transition", "monitor", "exception", "timeout", "expr")
#: The car's readings an expression may use, as ``car_NAME``.
CAR_READINGS = ("left", "right", "front", "distance", "speed", "steering", "speed_command")


class BreakpointError(ValueError):
    """A breakpoint that cannot be used; ``column`` is the expression's column (1-based) when it is one."""

    def __init__(self, message: str, column: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.column = column


@dataclass
class Breakpoint:
    """One breakpoint: its id, its JSON ``spec``, how a person reads it, how often it was hit."""

    id: int
    spec: dict[str, Any]
    text: str
    hits: int = 0
    enabled: bool = True
    #: why it was switched off (an expression that failed while the run went on), or None
    error: str | None = None
    #: for an expression: the compiled test and its value after the last tick
    test: Callable[[dict[str, Any]], Any] | None = None
    last: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "spec": self.spec, "text": self.text, "hits": self.hits, "enabled": self.enabled,
                "error": self.error}


@dataclass
class Happened:
    """What a tick did that breakpoints look at: transitions (from, to, type), monitor firings (owner, label, kind,
    whether it starts an exception sequence), states entered and left."""

    transitions: list[tuple[str | None, str, str]] = field(default_factory=list)
    monitors: list[tuple[str, str, str, bool]] = field(default_factory=list)
    entered: list[str] = field(default_factory=list)
    left: list[str] = field(default_factory=list)


class Watch(Listener):
    """A listener noting the transitions and monitor firings of each tick (read and cleared by the controller)."""

    def __init__(self) -> None:
        self.moved = False
        self.transitions: list[tuple[str | None, str, str]] = []
        self.monitors: list[tuple[str, str, str, bool]] = []

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        self.moved = True
        self.transitions.append((source.path if source is not None else None, target.path,
                                 transition.type_name if transition is not None else "initial"))

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
        self.moved = True
        self.monitors.append((owner.path, monitor.label, monitor.kind, monitor.exception_id is not None))

    def clear(self) -> None:
        self.moved = False
        self.transitions = []
        self.monitors = []


def active_set(machine: Machine) -> set[str]:
    """Every active state's path, the ancestors of the active leaves included."""
    out: set[str] = set()
    for leaf in machine.active_paths:
        parts = leaf.split("/")
        out.update("/".join(parts[:n]) for n in range(1, len(parts) + 1))
    return out


def _glob(spec: Mapping[str, Any], key: str, names: Iterable[str], what: str) -> str:
    """``spec[key]``: a path or glob (``*`` when absent) that matches at least one of ``names``."""
    value = spec.get(key, "*")
    if not isinstance(value, str) or not value.strip() or len(value) > 500:
        raise BreakpointError(f"'{key}' must be a {what} path or glob such as lap1/* (1 to 500 characters)")
    value = value.strip().strip("/") or "*"
    known = list(names)
    if not any(fnmatch.fnmatchcase(n, value) for n in known):
        close = difflib.get_close_matches(value, known, n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise BreakpointError(f"'{value}' matches no {what} of the machine{hint}")
    return value


def make_breakpoint(number: int, spec: Any, machine: Machine, signals: Iterable[str] = ()) -> Breakpoint:
    """The breakpoint ``spec`` describes, checked against ``machine``; :class:`BreakpointError` if it is none."""
    if not isinstance(spec, Mapping):
        raise BreakpointError("a breakpoint is a JSON object with a 'kind'")
    kind = spec.get("kind")
    if kind not in KINDS:
        raise BreakpointError(f"unknown breakpoint kind {kind!r} (one of {', '.join(KINDS)})")
    states = list(machine.states_by_path)
    supervisors = {p: w for p, s in machine.states_by_path.items() if (w := supervisor_of(s)) is not None}
    owners = [p for p, w in supervisors.items() if w.monitors]
    if kind in ("enter", "leave"):
        state = _glob(spec, "state", states, "state")
        return Breakpoint(number, {"kind": kind, "state": state}, f"{'entering' if kind == 'enter' else 'leaving'} "
                                                                   f"{state}")
    if kind == "transition":
        src, dst = _glob(spec, "from", states, "state"), _glob(spec, "to", states, "state")
        return Breakpoint(number, {"kind": kind, "from": src, "to": dst}, f"transition {src} -> {dst}")
    if kind in ("monitor", "exception", "timeout"):
        if not owners:
            raise BreakpointError("the machine has no monitor and no timeout")
        owner = _glob(spec, "owner", owners, "state with monitors")
        if kind != "monitor":
            what = "exception sequence starting" if kind == "exception" else "timeout expiring"
            return Breakpoint(number, {"kind": kind, "owner": owner}, f"{what} in {owner}")
        labels = [m.label for p in owners for m in supervisors[p].monitors]
        label = _glob(spec, "monitor", labels, "monitor")
        return Breakpoint(number, {"kind": kind, "owner": owner, "monitor": label},
                          f"monitor {label} of {owner} firing")
    text = spec.get("expr")
    if not isinstance(text, str):
        raise BreakpointError("'expr' must be an expression such as n > 3 or car_front < 0.5", 1)
    try:
        compiled = compile_expr(text, expression_kinds(machine, signals), want=BOOL)
    except ExprError as exc:
        raise BreakpointError(with_names(exc.message, machine, signals), exc.column) from None
    bp = Breakpoint(number, {"kind": kind, "expr": text}, f"{text} becomes true", test=compiled.fn)
    bp.last = _value(bp, expression_values(machine, signals)) is True
    return bp


def expression_kinds(machine: Machine, signals: Iterable[str] = ()) -> dict[str, str]:
    """The names a breakpoint expression may use and their kinds: variables, ``signal_NAME``, ``car_NAME``."""
    kinds = {f"signal_{name}": BOOL for name in (*signals, *machine.ctx.signals)}
    if machine.ctx.car is not None:
        kinds.update({f"car_{name}": NUMBER for name in CAR_READINGS})
    kinds.update({name: kind_of(value) for name, value in machine.ctx.vars.items()})
    return kinds


def with_names(message: str, machine: Machine, signals: Iterable[str]) -> str:
    """An unknown name's message with the names that are known."""
    if not message.startswith("unknown variable"):
        return message
    name = message.split("'")[1] if "'" in message else ""
    known = sorted(expression_kinds(machine, signals))
    close = difflib.get_close_matches(name, known, n=3)
    hint = f"did you mean {', '.join(close)}?" if close else f"known: {', '.join(known[:12]) or 'none'}"
    return f"{message} ({hint})"


def expression_values(machine: Machine, signals: Iterable[str] = ()) -> dict[str, Any]:
    """What a breakpoint expression sees now (see :func:`expression_kinds`; a signal never set is low)."""
    ctx = machine.ctx
    values: dict[str, Any] = {f"signal_{name}": False for name in signals}
    values.update({f"signal_{name}": level for name, level in ctx.signals.items()})
    car = ctx.car
    if car is not None:
        for name in CAR_READINGS:
            reading = getattr(car, name, None)
            if isinstance(reading, (int, float)):
                values[f"car_{name}"] = reading
    values.update(ctx.vars)
    return values


def _value(bp: Breakpoint, values: dict[str, Any]) -> Any:
    """The expression's value, or its run-time error kept on the breakpoint (which then stays off)."""
    assert bp.test is not None
    try:
        return bp.test(values)
    except (ExprRuntimeError, TypeError, ValueError, ArithmeticError) as exc:
        bp.enabled = False
        bp.error = f"switched off: {exc}"
        return False


def hits(breakpoints: list[Breakpoint], happened: Happened | None, machine: Machine,
         signals: Iterable[str] = ()) -> list[tuple[Breakpoint, str]]:
    """The breakpoints hit by the tick that just ended, each with why (what happened, in words)."""
    out: list[tuple[Breakpoint, str]] = []
    values: dict[str, Any] | None = None
    for bp in breakpoints:
        if not bp.enabled:
            continue
        if bp.test is not None:
            if values is None:
                values = expression_values(machine, signals)
            now = _value(bp, values) is True
            rose, bp.last = now and not bp.last, now
            if rose:
                out.append((bp, f"{bp.spec['expr']} became true"))
            continue
        if happened is not None:
            why = _why(bp.spec, happened)
            if why is not None:
                out.append((bp, why))
    return out


def _why(spec: dict[str, Any], h: Happened) -> str | None:
    """Why the tick described by ``h`` hits the breakpoint ``spec``, or None."""
    kind = spec["kind"]
    match = fnmatch.fnmatchcase
    if kind in ("enter", "leave"):
        for path in h.entered if kind == "enter" else h.left:
            if match(path, spec["state"]):
                return f"{'entered' if kind == 'enter' else 'left'} {path}"
        return None
    if kind == "transition":
        for src, dst, type_name in h.transitions:
            if src is not None and match(src, spec["from"]) and match(dst, spec["to"]):
                return f"transition {src} -> {dst} ({type_name}) fired"
        return None
    for owner, label, monitor_kind, exception in h.monitors:
        if not match(owner, spec["owner"]):
            continue
        if kind == "monitor" and match(label, spec["monitor"]):
            return f"monitor {label} of {owner} fired"
        if kind == "exception" and exception:
            return f"monitor {label} of {owner} started its exception sequence"
        if kind == "timeout" and monitor_kind == "timeout":
            return f"the timeout of {owner} expired"
    return None


__all__ = ["CAR_READINGS", "KINDS", "Breakpoint", "BreakpointError", "Happened", "Watch", "active_set",
           "expression_kinds", "expression_values", "hits", "make_breakpoint", "with_names"]
