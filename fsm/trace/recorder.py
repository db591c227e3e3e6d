"""Trace and summary: listeners that record what a machine did (JSONL trace, visited states, counts).

The trace (``fsmctl run --trace``) is the one record of a run that reports, exports and replays read; its
lines are described by ``fsm/schema/trace.schema.json`` and read back by :mod:`fsm.trace.replay`. Each line is a JSON
object with a ``"type"``:

- ``header`` (first line): format and version, the machine's regions and their states, ``dt``, the sample
  and keyframe periods, and what the caller adds (the machine document with its layout, world, car, seed).
- ``event``: a tick in which something happened: transitions (with the initial entries, type
  ``"initial"``), variable changes (``vars``; removed ones in ``unset``), monitor firings, pauses; ``active``
  lists the active leaf paths after the tick.
- ``keyframe``: every ``keyframe_period`` seconds (and at tick 0), the whole active configuration and every
  variable, so a reader seeks to any tick by reading one keyframe and the events after it.
- ``sample``: every ``sample_period`` seconds, continuous values (the car's pose, sensors and commands).
- ``frame``: every ``frame_period`` seconds, what ``frames`` returns (camera thumbnails and detections).
- ``input``: an input applied between two ticks (a variable set, a signal, a fault a debugger injected), with
  the tick before which it applied, so a steered run replays from its trace (:mod:`fsm.session.inputs`).
- ``end`` (last line, when the run ended normally or was stopped): outcome, ticks, time. A trace without it was
  cut off (the process was killed); its whole lines still read.

Lines of one tick come in that order: event, keyframe, sample, frame.
"""

from __future__ import annotations

import base64
import functools
import itertools
import json
import platform
import struct
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from fsm.model.version import VERSION
from fsm.runtime.machine import Listener

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

    from fsm.runtime.context import Context
    from fsm.runtime.machine import Fired, Machine
    from fsm.runtime.state import State
    from fsm.runtime.supervisor import Monitor

#: What the first line's ``format`` says, and the version of the line layout described here.
TRACE_FORMAT = "tral-fsm-trace"
TRACE_VERSION = 3
#: How a version-3 ``samples`` line packs rows of numbers: ``data`` is their little-endian float32 values, row after
#: row, in base64 (``count`` rows; the columns listed in ``integers`` hold integers).
PACKED_SAMPLES = "float32-base64"
#: Default periods (seconds of machine time): samples at 20 Hz, a keyframe every second, camera frames at 1 Hz.
SAMPLE_PERIOD = 0.05
KEYFRAME_PERIOD = 1.0
FRAME_PERIOD = 1.0


class Recorder(Listener):
    """Records a run: visited states and counts for the summary, and, with ``out``, the JSONL trace.

    ``extra`` (a callable returning a dict) adds fields to every event line (e.g. the car at a transition);
    ``sample`` (likewise) makes the sample lines; or, when ``sample_fields`` names its values (``"car.x"``,
    ``"car.odometry[0]"``, ...), it returns a tuple of numbers and the samples are written in blocks of one keyframe
    period (a ``samples`` line with a row per sample: cheaper to write, and :mod:`fsm.trace.replay` reads them back as
    sample lines); ``frames`` (a callable returning a dict or ``None``) the frame
    lines; ``header`` is merged into the header line.

    A snapshot of the run (:mod:`fsm.session.snapshot`) copies what the recorder has not written yet and its
    counts; its stream, header and callables are shared (``__snapshot_skip__``): the callables read the car, which
    the snapshot restores, and the stream is cut where the snapshot was taken by whoever restores it.
    """

    __snapshot_skip__ = ("out", "extra", "header", "sample", "_sampler", "sample_fields", "_tails", "periods")
    #: what a snapshot reads, by name (reading ``__dict__`` would slow every attribute of the recorder down)
    __snapshot_fields__ = ("sample_digits", "_rows", "_active_json", "frames", "_every", "_sample_every", "visited",
                           "_seen", "transitions", "_pending", "_vars", "_events", "monitor_counts", "_last_tick",
                           "_due", "_special", "_sample_only", "ended", "_input_lines")

    def __init__(self, out: SupportsWrite[str] | None = None, extra: Callable[[], dict[str, Any]] | None = None, *,
                 header: dict[str, Any] | None = None, sample: Callable[[], Any] | None = None,
                 sample_period: float = SAMPLE_PERIOD, keyframe_period: float = KEYFRAME_PERIOD,
                 frames: Callable[[], dict[str, Any] | None] | None = None, frame_period: float = FRAME_PERIOD,
                 sample_fields: list[str] | None = None, sample_digits: int = 4) -> None:
        self.out = out
        self.extra = extra
        self.header = header or {}
        self.sample = sample
        #: ``sample`` for the tick loop, which calls it only when a sample is due (so never ``tuple``)
        self._sampler: Callable[[], Any] = sample if sample is not None else tuple
        self.sample_fields = list(sample_fields) if sample_fields is not None else None
        self.sample_digits = sample_digits
        self._rows: list[tuple[int, Any]] = []  # the samples not written yet (block mode), each (tick, values)
        self._tails: dict[tuple[int, ...], str] = {}
        self._active_json: str | None = None  # the active leaves as JSON, until the next transition
        self.frames = frames
        self.periods = (sample_period, keyframe_period, frame_period)
        #: the sample, keyframe and frame periods in ticks, known at the first flush (which writes the header)
        self._every = (0, 0, 0)
        self._sample_every = 0  # the first of them, read each tick a sample is due
        self.visited: list[str] = []
        self._seen: set[str] = set()
        self.transitions = 0
        self._pending: list[dict[str, Any]] = []
        self._vars: dict[str, Any] | None = None
        #: monitor firings, pauses and resumes of the current tick, by kind
        self._events: dict[str, list[Any]] = {}
        #: monitor (and timeout) firings so far, by owner path
        self.monitor_counts: dict[str, int] = {}
        self._last_tick = -1
        self._due = 0  # the next tick with a keyframe, sample or frame line
        self._special = 0  # the next tick with a keyframe or frame line
        self._sample_only = False
        self.ended = False
        self._input_lines: list[str] = []  # input lines applied before the header was written

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        if target.path not in self._seen:
            self._seen.add(target.path)
            self.visited.append(target.path)
        if transition is not None:
            self.transitions += 1
        self._active_json = None
        self._pending.append({
            "tick": ctx.tick,
            "time": round(ctx.now, 9),
            "from": source.path if source is not None else None,
            "to": target.path,
            "type": transition.type_name if transition is not None else "initial",
        })

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
        event = {"owner": owner.path, "monitor": monitor.label, "kind": monitor.kind, "behavior": monitor.behavior}
        if monitor.exception_id is not None:
            event["exception"] = monitor.exception_id
        self._events.setdefault("monitors", []).append(event)
        self.monitor_counts[owner.path] = self.monitor_counts.get(owner.path, 0) + 1

    def on_pause(self, ctx: Context, state: State[Any], paused: bool) -> None:
        self._events.setdefault("paused" if paused else "resumed", []).append(state.path)

    def on_skipped(self, ctx: Context, state: State[Any]) -> None:
        """A state entered and skipped by its precondition: its entry is a transition of the line, ``skipped``
        says that nothing of it ran (coverage counts it apart)."""
        self._events.setdefault("skipped", []).append(state.path)

    def on_input(self, tick: int, time: float, item: Any) -> None:
        """An input applied before ``tick`` (:mod:`fsm.session.session`): an ``input`` line, what it was and its
        text."""
        if self.out is None:
            return
        line = _dumps({"type": "input", "tick": tick, "time": time, "input": input_json(item),
                       "text": item.describe()})
        if self._sample_every:
            self.out.write(line)
        else:
            self._input_lines.append(line)

    def on_reload(self, tick: int, time: float, info: dict[str, Any]) -> None:
        """A hot reload applied before ``tick`` (:mod:`fsm.debug.reload`): a ``reload`` line with ``info`` (the file,
        the
        states kept and missing, the new regions)."""
        self._active_json = None
        if self.out is None:
            return
        self.out.write(_dumps({"type": "reload", "tick": tick, "time": time, **info}))

    def on_tick(self, machine: Machine) -> None:
        # Called every tick: the common case (nothing happened, no line due) returns after a few comparisons.
        if self._pending or self._events:
            if self.out is None:  # summary only: visited states and counts come from the other hooks
                self._pending = []
                self._events = {}
            else:
                self.flush(machine)
            return
        if self.out is None:
            return
        ctx = machine.ctx
        current, last = ctx.vars, self._vars
        if current != last or (current and not all(type(v) is type(last[k]) for k, v in current.items())):
            self.flush(machine)
            return
        tick = ctx._tick
        if tick < self._due:
            return
        if tick == self._due and self._sample_only:  # most due ticks: one sample, kept for its block
            self._rows.append((tick, self._sampler()))
            self._last_tick = tick
            due = self._due = tick + self._sample_every
            if due >= self._special:
                self._schedule(tick)
            return
        self.flush(machine)

    def flush(self, machine: Machine) -> None:
        """Write the lines of the tick that just ended (also used after ``start`` for the initial entries; a
        second call for the same tick writes only what happened since)."""
        out = self.out
        changed = self._changed_vars(machine.ctx.vars)
        if out is None:
            self._pending = []
            self._events = {}
            return
        if not self._sample_every:
            self._begin(machine, out)
        if self._pending or changed is not None or self._events:
            self._write_event(machine, out, changed)
        tick = machine.ctx.tick
        if tick == self._last_tick:
            return
        self._last_tick = tick
        self._write_due(machine, out, tick)
        self._schedule(tick)

    def _begin(self, machine: Machine, out: SupportsWrite[str]) -> None:
        """The first flush: the periods in ticks, the header, and the inputs applied before it."""
        s_every, k_every, f_every = (max(1, round(p / machine.dt)) for p in self.periods)
        self._every = (s_every, k_every, f_every)
        self._sample_every = s_every
        out.write(_dumps(self._header_line(machine)))
        for input_line in self._input_lines:
            out.write(input_line)
        self._input_lines = []

    def _write_event(self, machine: Machine, out: SupportsWrite[str],
                     changed: tuple[dict[str, Any], list[str]] | None) -> None:
        """The tick's ``event`` line: its transitions, variables changed and removed, monitors and pauses."""
        ctx = machine.ctx
        line: dict[str, Any] = {"type": "event", "tick": ctx.tick, "time": round(ctx.now, 9),
                                "active": machine.active_paths, "transitions": self._pending}
        if changed is not None:
            values, unset = changed
            if values:
                line["vars"] = {k: jsonable(v) for k, v in values.items()}
            if unset:
                line["unset"] = unset
        if self._events:
            line.update(self._events)
        if self.extra is not None:
            line.update(self.extra())
        out.write(_dumps(line))
        self._pending = []
        self._events = {}
        self._active_json = None  # whatever changed (a transition, an abort, a pause), print it again

    def _write_due(self, machine: Machine, out: SupportsWrite[str], tick: int) -> None:
        """The keyframe, sample and frame lines due at ``tick``."""
        s_every, k_every, f_every = self._every
        time = round(machine.ctx.now, 9)
        if tick % k_every == 0:
            active = self._active_json
            if active is None:  # printed again only after a transition
                active = self._active_json = _dumps(machine.active_paths)[:-1]
            variables = machine.ctx.vars
            shown = _dumps({k: jsonable(v) for k, v in variables.items()})[:-1] if variables else "{}"
            out.write(f'{{"type":"keyframe","tick":{tick},"time":{time!r},"active":{active},"vars":{shown}}}\n')
        if self.sample is not None and tick % s_every == 0:
            if self.sample_fields is not None:
                if tick % k_every == 0:
                    self._write_samples(machine)
                self._rows.append((tick, self.sample()))
            else:
                out.write(_dumps({"type": "sample", "tick": tick, "time": time, **self.sample()}))
        if self.frames is not None and tick % f_every == 0:
            frame = self.frames()
            if frame:
                out.write(_dumps({"type": "frame", "tick": tick, "time": time, **frame}))

    def flush_samples(self, machine: Machine) -> None:
        """Write the samples kept for the current block now (a debugger that pauses shows the car where it is; the
        next block starts at the next sample)."""
        self._write_samples(machine)

    def _write_samples(self, machine: Machine) -> None:
        """The samples kept since the last block, as one ``samples`` line (first tick, tick step, and the rows).
        Rows of numbers are packed (:data:`PACKED_SAMPLES`: float32, base64; a reader rounds them to ``digits``
        decimals), which costs the loop a fifth of rounding and printing each number; other rows are written as
        they are."""
        rows = self._rows
        if not rows or self.out is None:
            return
        self._rows = []
        values = [v for _, v in rows]
        tick = rows[0][0]
        time = round(tick * machine.dt, 9)
        every = self._sample_every or 1
        digits = self.sample_digits
        packed = _packed_rows(values)
        if packed is None:
            self.out.write(_dumps({
                "type": "samples", "tick": tick, "time": time, "every": every, "fields": self.sample_fields,
                "rows": [[round(v, digits) if v.__class__ is float else jsonable(v) for v in row] for row in values]}))
            return
        integers, data = packed
        key = tuple(integers)
        tail = self._tails.get(key)
        if tail is None:  # what all blocks of these fields share, printed once
            tail = self._tails[key] = _dumps({"fields": self.sample_fields, "encoding": PACKED_SAMPLES,
                                              "digits": digits, **({"integers": integers} if integers else {})})[1:-2]
        # printed by hand, not by json.dumps: this line is written every second and base64 needs no escaping
        self.out.write(f'{{"type":"samples","tick":{tick},"time":{time!r},"every":{every},{tail},'
                       f'"count":{len(values)},"data":"{data}"}}\n')

    def _schedule(self, tick: int) -> None:
        """The next tick after ``tick`` with a keyframe, sample or frame, whether it has only a sample, and the next
        tick with a keyframe or frame."""
        s_every, k_every, f_every = self._every
        special = tick - tick % k_every + k_every
        if self.frames is not None:
            special = min(special, tick - tick % f_every + f_every)
        self._special = special
        due = special
        if self.sample is not None:
            due = min(due, tick - tick % s_every + s_every)
        self._due = due
        self._sample_only = due < special

    def finish(self, machine: Machine, **info: Any) -> None:
        """Write the last line (``end``): outcome, ticks, time and ``info`` (``interrupted``, ``error``)."""
        if self.out is None or self.ended:
            return
        self.flush(machine)
        self._write_samples(machine)
        self.ended = True
        self.out.write(_dumps({"type": "end", "tick": machine.ctx.tick, "time": round(machine.ctx.now, 9),
                               "outcome": machine.outcome, "finished": machine.finished,
                               "transitions": machine.transition_count, **info}))

    def _header_line(self, machine: Machine) -> dict[str, Any]:
        s_every, k_every, f_every = self._every
        dt = machine.dt
        line: dict[str, Any] = {
            "type": "header", "format": TRACE_FORMAT, "version": TRACE_VERSION,
            "tral_fsm": VERSION, "python": platform.python_version(),
            "name": machine.name, "dt": dt,
            "regions": [{"path": r.path, "name": r.name, "states": [s.path for s in r.states.values()]}
                        for r in machine.regions],
            "keyframe_period": round(k_every * dt, 9),
        }
        if self.sample is not None:
            line["sample_period"] = round(s_every * dt, 9)
            if self.sample_fields is not None:
                line["sample_fields"] = self.sample_fields
        if self.frames is not None:
            line["frame_period"] = round(f_every * dt, 9)
        line.update(self.header)
        return line

    def _changed_vars(self, current: dict[str, Any]) -> tuple[dict[str, Any], list[str]] | None:
        """The variables set or changed since the last call and those removed; None if nothing changed."""
        last = self._vars
        if last is not None and current == last and all(type(v) is type(last[k]) for k, v in current.items()):
            return None
        self._vars = dict(current)
        if last is None:
            return (dict(current), []) if current else None
        values = {k: v for k, v in current.items() if k not in last or last[k] != v or type(last[k]) is not type(v)}
        unset = [k for k in last if k not in current]
        return (values, unset) if values or unset else None


def _packed_rows(rows: list[Any]) -> tuple[list[int], str] | None:
    """``rows`` (tuples of numbers, all as long) as little-endian float32, row after row, in base64, and the columns
    that hold integers (by the first row); ``None`` when a row holds anything else (a string, a bool) or is longer or
    shorter than the first, an integer is beyond what a float32 holds exactly, or a number beyond its range."""
    first = rows[0]
    if not all(v.__class__ is float or v.__class__ is int for v in first) or len(set(map(len, rows))) != 1:
        return None
    integers = [i for i, v in enumerate(first) if v.__class__ is int]
    for i in integers:
        column = [row[i] for row in rows]
        if not all(v.__class__ is int for v in column) or max(column) > 1 << 24 or min(column) < -(1 << 24):
            return None
    try:
        data = _packer(len(rows) * len(first)).pack(*itertools.chain.from_iterable(rows))
    except (TypeError, struct.error, OverflowError):  # a value that is no number, or too big for a float32
        return None
    return integers, base64.b64encode(data).decode("ascii")


@functools.lru_cache(maxsize=16)
def _packer(count: int) -> struct.Struct:
    return struct.Struct(f"<{count}f")


def _dumps(line: dict[str, Any] | list[Any]) -> str:
    """One line; a value JSON cannot hold (an infinite reading, an object on the blackboard) as :func:`jsonable`
    makes it, so every line parses in any JSON reader (a browser's too)."""
    try:
        return json.dumps(line, separators=(",", ":"), allow_nan=False) + "\n"
    except (ValueError, TypeError):
        return json.dumps(jsonable(line), separators=(",", ":")) + "\n"


def input_json(item: Any) -> dict[str, Any]:
    """An input (:class:`fsm.session.session.Input`) as an ``input`` line writes it: what its ``to_json`` says, or
    ``{"kind": "other", "text": ...}`` (which cannot be replayed)."""
    to_json = getattr(item, "to_json", None)
    if callable(to_json):
        data = to_json()
        if isinstance(data, dict):
            return data
    return {"kind": "other", "text": item.describe()}


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
