"""Trace and summary: listeners that record what a machine did (JSONL trace, visited states, counts)."""

from __future__ import annotations

import json
from typing import IO, TYPE_CHECKING, Any

from .machine import Listener

if TYPE_CHECKING:
    from .context import Context
    from .machine import Machine
    from .state import State
    from .transition import Transition


class Recorder(Listener):
    """Collects the transitions of the current tick; writes one JSONL line per tick that had any.

    A line: ``{"tick", "time", "active", "transitions": [{"tick", "time", "from", "to", "type"}]}``, and when
    they happened in the tick, ``"monitors": [{"owner", "monitor", "kind", "behavior", "exception"}]`` (monitor
    and timeout firings), ``"paused"`` / ``"resumed"``: [state paths];
    the initial entry is a transition from ``null`` of type ``"initial"``. A line also has ``"vars"``,
    the blackboard variables whose value changed during the tick (all of them on the first line), and a
    line is written for a tick in which only variables changed. ``extra`` (a callable returning a dict) adds
    fields to every line, e.g. sensors and commands of a car.
    """

    def __init__(self, out: IO[str] | None = None, extra: Any = None) -> None:
        self.out = out
        self.extra = extra
        self.visited: list[str] = []
        self._seen: set[str] = set()
        self.transitions = 0
        self._pending: list[dict[str, Any]] = []
        self._vars: dict[str, Any] | None = None
        #: monitor firings, pauses and resumes of the current tick, by kind
        self._events: dict[str, list[Any]] = {}
        #: monitor (and timeout) firings so far, by owner path
        self.monitor_counts: dict[str, int] = {}

    def on_transition(self, ctx: Context, source: State | None, target: State, transition: Transition | None) -> None:
        if target.path not in self._seen:
            self._seen.add(target.path)
            self.visited.append(target.path)
        if transition is not None:
            self.transitions += 1
        self._pending.append({
            "tick": ctx.tick,
            "time": round(ctx.now, 9),
            "from": source.path if source is not None else None,
            "to": target.path,
            "type": transition.type_name if transition is not None else "initial",
        })

    def on_monitor(self, ctx: Context, owner: State, monitor: Any) -> None:
        event = {"owner": owner.path, "monitor": monitor.label, "kind": monitor.kind, "behavior": monitor.behavior}
        if monitor.exception_id is not None:
            event["exception"] = monitor.exception_id
        self._events.setdefault("monitors", []).append(event)
        self.monitor_counts[owner.path] = self.monitor_counts.get(owner.path, 0) + 1

    def on_pause(self, ctx: Context, state: State, paused: bool) -> None:
        self._events.setdefault("paused" if paused else "resumed", []).append(state.path)

    def on_tick(self, machine: Machine) -> None:
        self.flush(machine)

    def flush(self, machine: Machine) -> None:
        """Write the pending line (also used after ``start`` for the initial entries)."""
        changed = self._changed_vars(machine.ctx.vars)
        if not self._pending and not changed and not self._events:
            return
        if self.out is not None:
            line: dict[str, Any] = {
                "tick": machine.ctx.tick,
                "time": round(machine.ctx.now, 9),
                "active": machine.active_path,
                "transitions": self._pending,
            }
            if changed:
                line["vars"] = {k: jsonable(v) for k, v in changed.items()}
            if self._events:
                line.update(self._events)
            if self.extra is not None:
                line.update(self.extra())
            self.out.write(json.dumps(line, separators=(",", ":")) + "\n")
        self._pending = []
        self._events = {}


    def _changed_vars(self, current: dict[str, Any]) -> dict[str, Any] | None:
        """The variables set or changed since the last call (a removed one as None); None if nothing changed."""
        last = self._vars
        if last is not None and current == last and all(type(v) is type(last[k]) for k, v in current.items()):
            return None
        self._vars = dict(current)
        if last is None:
            return dict(current) or None
        out = {k: v for k, v in current.items() if k not in last or last[k] != v or type(last[k]) is not type(v)}
        out.update({k: None for k in last if k not in current})
        return out or None


def jsonable(value: Any) -> Any:
    """A value as JSON can hold it (a state may store anything on the blackboard)."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if value == value and value not in (float("inf"), float("-inf")) else str(value)
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    return repr(value)


def summary(machine: Machine, recorder: Recorder) -> dict[str, Any]:
    """The run summary: outcome, finished, ticks, sim_time, transitions, visited, vars (final values)."""
    return {
        "outcome": machine.outcome,
        "finished": machine.finished,
        "ticks": machine.ticks,
        "sim_time": round(machine.now, 9),
        "transitions": machine.transition_count,
        "visited": list(recorder.visited),
        "vars": {k: jsonable(v) for k, v in machine.ctx.vars.items()},
        **({"monitors": dict(recorder.monitor_counts)} if recorder.monitor_counts else {}),
    }
