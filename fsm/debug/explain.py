"""Why: for one tick, every transition leaving each state that was active, in the order the tick checks them, with
what it read and whether it fired, and if not, why not.

Nothing of it runs while a run goes: :func:`explain_next` is handed a session standing between two ticks (a
debugged run rebuilt to just before the tick, as a rewind does, or ``fsmctl explain`` re-simulating a trace) and
runs that one tick with each transition's check wrapped, so the tick does exactly what it did (the checks are
the same calls, in the same order) and each check's answer is kept. Afterwards every transition is as it was.

For each transition: its type and parameters, the document's guard, the values it read at this tick (the
variables and signals its guard names, the car's reading a sensor condition names, the time in its source state),
and one verdict: ``fired``; ``guard false``; ``condition false`` (the guard held, the type's own condition did
not); or, not checked at all, ``a higher-priority transition fired``, ``paused subtree``, ``a monitor took over``,
``left by an outer transition``, ``not checked``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.debug.breakpoints import expression_kinds, expression_values
from fsm.model.expr import BOOL, ExprError, ExprRuntimeError, compile_expr
from fsm.model.plan import GuardKind
from fsm.runtime.region import TransitionWiring, wiring

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Machine
    from fsm.runtime.state import State
    from fsm.runtime.supervisor import Monitor
    from fsm.runtime.transition import Transition
    from fsm.session.session import Session

_NAME = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
#: Parameters every transition has (not the type's own).
_COMMON = ("type", "from_", "to", "priority", "preempt", "guard", "set", "description", "layout")


@dataclass
class Check:
    """One transition at one tick (see the module docstring)."""

    source: str
    target: str
    type: str
    params: dict[str, Any]
    guard: str | None
    preempt: bool
    checked: bool = False
    result: bool | None = None
    guard_value: bool | None = None
    values: dict[str, Any] = field(default_factory=dict)
    verdict: str = "not checked"

    def to_json(self) -> dict[str, Any]:
        return {"from": self.source, "to": self.target, "type": self.type, "params": self.params,
                "guard": self.guard, "preempt": self.preempt, "checked": self.checked, "result": self.result,
                "guard_value": self.guard_value, "values": self.values, "verdict": self.verdict}

    def line(self) -> str:
        """One line for a person: ``from -> to (Type params) [guard]: verdict; read: name = value, ...``."""
        own = " ".join(f"{k}={v}" for k, v in self.params.items())
        head = f"{self.source} -> {self.target} ({self.type}{' ' + own if own else ''})"
        if self.guard:
            head += f" [{self.guard}]"
        read = ", ".join(f"{k} = {_shown(v)}" for k, v in self.values.items())
        return f"{head}: {self.verdict}" + (f"; read {read}" if read else "")


def _shown(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


@dataclass
class Explanation:
    """What tick ``tick`` did and why: the states active before it, each with its transitions' checks in the order
    checked, and what fired (transitions, monitors)."""

    tick: int
    time: float
    active: list[str]
    states: list[tuple[str, list[Check]]]
    fired: list[str]
    monitors: list[str]
    paused: list[str]

    def to_json(self) -> dict[str, Any]:
        return {"tick": self.tick, "time": self.time, "active": self.active,
                "states": [{"state": s, "transitions": [c.to_json() for c in cs]} for s, cs in self.states],
                "fired": self.fired, "monitors": self.monitors, "paused": self.paused}

    def text(self) -> str:
        lines = [f"tick {self.tick} ({self.time:.4f} s), from {', '.join(self.active) or 'nothing active'}:"]
        for path, checks in self.states:
            lines.append(f"  {path}:" + ("" if checks else " no transition leaves it"))
            lines.extend(f"    {k + 1}. {c.line()}" for k, c in enumerate(checks))
        lines.append("  fired: " + ("; ".join(self.fired + self.monitors) or "nothing"))
        return "\n".join(lines)


class _Watch:
    """A listener that keeps what the tick fired."""

    def __init__(self) -> None:
        self.transitions: list[tuple[str | None, str, Any]] = []
        self.monitors: list[tuple[str, str]] = []

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any], transition: Any) -> None:
        self.transitions.append((source.path if source is not None else None, target.path, transition))

    def on_tick(self, machine: Machine) -> None:
        return None

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
        self.monitors.append((owner.path, monitor.label))


def _states_on(machine: Machine) -> list[State[Any]]:
    """The states active now, outermost first (each active leaf's ancestors, once)."""
    out: dict[str, State[Any]] = {}
    for leaf in machine.active_paths:
        parts = leaf.split("/")
        for n in range(1, len(parts) + 1):
            path = "/".join(parts[:n])
            if path not in out:
                try:
                    out[path] = machine.state(path)
                except (KeyError, TypeError):
                    continue
    return list(out.values())


def _guard_test(text: str, machine: Machine, signals: Iterable[str]) -> Callable[[dict[str, Any]], Any] | None:
    try:
        return compile_expr(text, expression_kinds(machine, signals), want=BOOL).fn
    except ExprError:
        return None


def _read(tr: Transition[Any], guard: str | None, values: dict[str, Any], ctx: Context) -> dict[str, Any]:
    """The values ``tr`` reads at this tick: its guard's names, the reading a sensor condition names, the time in
    its source state."""
    read: dict[str, Any] = {}
    if guard:
        for name in _NAME.findall(guard):
            if name in values:
                read[name] = values[name]
            elif f"signal_{name}" in values:
                read[f"signal_{name}"] = values[f"signal_{name}"]
    params = tr.params
    sensor = getattr(params, "sensor", None)
    if isinstance(sensor, str) and f"car_{sensor}" in values:
        read[f"car_{sensor}"] = values[f"car_{sensor}"]
    signal = getattr(params, "signal", None)
    if isinstance(signal, str):
        read[f"signal_{signal}"] = bool(ctx.signals.get(signal, False))
    variable = getattr(params, "variable", None)
    if isinstance(variable, str) and variable in values:
        read[variable] = values[variable]
    entered = wiring(tr.source).entered_at
    if entered is not None:
        read["time_in_state"] = round(ctx.now - entered, 9)
    return read


def explain_next(session: Session, signals: Iterable[str] = ()) -> Explanation:
    """Run ``session``'s next tick (it stands between two ticks, started) with every check of the active states'
    transitions kept, and say what it did and why (see the module docstring)."""
    from fsm.session.session import StopRules

    machine = session.machine
    signals = tuple(signals)
    states = _states_on(machine)
    tick = session.ticks + 1
    saved: list[tuple[TransitionWiring, Any, Any]] = []
    table: list[tuple[str, list[Check]]] = []
    pairs: list[tuple[Transition[Any], Check]] = []
    for state in states:
        mine: list[Check] = []
        record = wiring(state)
        for link in (*record.preempt, *record.regular):
            tr = link.transition
            params = {k: v for k, v in tr.params.model_dump(exclude_none=True).items() if k not in _COMMON}
            guard_field = tr.params.guard
            guard = guard_field if isinstance(guard_field, str) else None
            check = Check(tr.source.path, tr.target.path, tr.params.type, params,
                          guard if guard is not None else (None if guard_field is None else "a condition object"),
                          bool(tr.params.preempt))
            mine.append(check)
            pairs.append((tr, check))
            saved.append((link, link.kind, link.test))
            link.kind, link.test = GuardKind.CALL, _recording(link, check, guard, machine, signals)
        table.append((state.path, mine))
    watch = _Watch()
    machine.add_listener(watch)
    before = [s.path for s in states]
    paused = [s.path for s in states if s.paused]
    try:
        session.run(stop_rules=StopRules(max_ticks=1))
    finally:
        machine.remove_listener(watch)
        for link, kind, test in saved:
            link.kind, link.test = kind, test
    fired = {id(tr) for _src, _dst, tr in watch.transitions if tr is not None}
    fired_checks = {id(check) for tr, check in pairs if id(tr) in fired}
    left = {src for src, _dst, _tr in watch.transitions if src is not None}
    took_over = {owner for owner, _label in watch.monitors}
    for path, mine in table:
        fired_here = False
        for check in mine:
            if id(check) in fired_checks:
                check.verdict = "fired"
                fired_here = True
            elif check.checked:
                if check.result:
                    check.verdict = "held, but the state was left otherwise"
                elif check.guard_value is False:
                    check.verdict = "guard false"
                else:
                    check.verdict = "condition false"
            elif fired_here:
                check.verdict = "a higher-priority transition fired"
            elif any(path == p or path.startswith(p + "/") for p in paused):
                check.verdict = "paused subtree"
            elif any(path == o or path.startswith(o + "/") for o in took_over):
                check.verdict = "a monitor took over"
            elif any(path.startswith(s + "/") for s in left):
                check.verdict = "left by an outer transition"
    return Explanation(tick, round(tick * session.dt, 9), [p for p in before if not any(
        q.startswith(p + "/") for q in before)], table,
        [f"{src} -> {dst}" for src, dst, _tr in watch.transitions if src is not None],
        [f"monitor {label} of {owner}" for owner, label in watch.monitors], paused)


def _recording(link: TransitionWiring, check: Check, guard: str | None, machine: Machine,
               signals: tuple[str, ...]) -> Callable[[Context], bool]:
    """The check of ``link``'s transition as it was (by its kind), keeping its answer and what it read in ``check``."""
    kind, test, compare, tr = link.kind, link.test, link.compare, link.transition
    guard_fn = _guard_test(guard, machine, signals) if guard else None

    def recorded(ctx: Context) -> bool:
        values = expression_values(machine, signals)
        check.values = _read(tr, guard, values, ctx)
        if guard_fn is not None:
            try:
                check.guard_value = guard_fn(values) is True
            except (ExprRuntimeError, TypeError, ValueError, ArithmeticError):
                check.guard_value = None
        if kind is GuardKind.ALWAYS:
            result = True
        elif kind is GuardKind.COMPARE:
            assert compare is not None
            name, op, const, _swapped, read = compare
            v = ctx.vars
            x = v[name] if name in v else read(v)
            result = bool(op(x if type(x) in (int, float) else read(v), const))
        else:
            assert test is not None
            result = bool(test(ctx))
        check.checked = True
        check.result = result
        return result

    return recorded


__all__ = ["Check", "Explanation", "explain_next"]
