"""Reading a trace back (:mod:`fsm.trace.recorder` writes it): its lines by type, and the machine's configuration and
variables at any tick, rebuilt from the nearest keyframe and the events after it.

A trace is an input like any other: read by the reading rule (:mod:`fsm.loading.reading`: a regular file or standard
input, capped in size), each line strict JSON checked against ``fsm/schema/trace.schema.json`` before it is used
(compiled once, :mod:`fsm.trace.jsoncheck`), so what the report and the MCAP export get holds no surprise (no NaN, no
time beyond :data:`MAX_TIME`, no string where a list belongs).

A trace cut off mid-line (the process was killed) reads up to its last whole line, with a warning naming the
line that is not; so does one with a damaged line (the rest is not trusted), the warning saying where in the line,
what was expected and what was found. A trace written before the header, keyframes and samples existed (version
1: event lines only) reads too, with a warning saying what it lacks. Anything else that is not a trace raises
:class:`TraceError` with the reason and the line.
"""

from __future__ import annotations

import array
import base64
import bisect
import functools
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsm.loading.reading import max_input_bytes, parse_json_line, read_file_bytes
from fsm.model.errors import FsmError
from fsm.trace.jsoncheck import Check, compile_definition, describe
from fsm.trace.recorder import TRACE_FORMAT, TRACE_VERSION


class TraceError(FsmError, ValueError):
    """The file is not a trace (or not one this version reads); the message says why and where."""


@dataclass
class Trace:
    """A trace's lines by type. ``header`` is ``{}`` for a version-1 trace; ``end`` is ``None`` when the run was
    cut off; ``warnings`` says what was skipped or is missing."""

    name: str
    version: int
    header: dict[str, Any]
    events: list[dict[str, Any]] = field(default_factory=list)
    keyframes: list[dict[str, Any]] = field(default_factory=list)
    samples: list[dict[str, Any]] = field(default_factory=list)
    frames: list[dict[str, Any]] = field(default_factory=list)
    end: dict[str, Any] | None = None
    warnings: list[str] = field(default_factory=list)
    #: the inputs applied between ticks (a variable set, a signal, an injected fault), in order
    #: (:mod:`fsm.session.inputs`)
    inputs: list[dict[str, Any]] = field(default_factory=list)
    #: the hot reloads of a live run (:mod:`fsm.debug.reload`): before which tick, the file, what was kept and missing
    reloads: list[dict[str, Any]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._event_ticks: list[int] = []
        self._key_ticks: list[int] = []

    def index(self) -> None:
        """Build the lookup tables (done by :func:`read_trace`; call again after changing the lists)."""
        self._event_ticks = [e["tick"] for e in self.events]
        self._key_ticks = [k["tick"] for k in self.keyframes]

    @property
    def last_tick(self) -> int:
        ticks = [self.end["tick"]] if self.end else []
        for lines in (self.events, self.keyframes, self.samples, self.frames, self.inputs, self.reloads):
            if lines:
                ticks.append(lines[-1]["tick"])
        return max(ticks, default=0)

    @property
    def dt(self) -> float | None:
        dt = self.header.get("dt")
        return float(dt) if isinstance(dt, (int, float)) else None

    def at(self, tick: int) -> tuple[list[str], dict[str, Any]]:
        """The active leaf paths and the variables after ``tick`` (before the first event: nothing active)."""
        k = bisect.bisect_right(self._key_ticks, tick) - 1
        if k >= 0:
            key = self.keyframes[k]
            active, variables, since = list(key["active"]), dict(key["vars"]), key["tick"]
        else:
            active, variables, since = [], {}, -1
        first = bisect.bisect_right(self._event_ticks, since)
        last = bisect.bisect_right(self._event_ticks, tick)
        for event in self.events[first:last]:
            active = event_active(event)
            variables.update(event.get("vars", {}))
            for name in event.get("unset", ()):
                variables.pop(name, None)
        return active, variables


def event_active(event: dict[str, Any]) -> list[str]:
    """The active leaf paths of an event line (a version-1 line joined them with ``", "``)."""
    active = event.get("active")
    if isinstance(active, list):
        return [str(a) for a in active]
    return str(active).split(", ") if active else []


def expand_samples(block: dict[str, Any], dt: float | None) -> list[dict[str, Any]]:
    """A ``samples`` block as sample lines: ``{"type": "sample", "tick", "time", "car": {"x": ..., "odometry":
    [...]}}`` from the fields ``car.x``, ``car.odometry[0]``, ... (checked by :func:`_samples_problem`)."""
    paths = _field_paths(tuple(block["fields"]))
    out = []
    step = block["every"]
    first, t0 = block["tick"], float(block.get("time", 0.0))
    for i, row in enumerate(block["rows"]):
        tick = first + i * step
        line: dict[str, Any] = {"type": "sample", "tick": tick,
                                "time": round(tick * dt, 9) if dt else t0}
        for (head, key, index), value in zip(paths, row, strict=True):
            group = line.setdefault(head, {}) if key else line
            if not key:
                line[head] = value
            elif index is None:
                group[key] = value
            else:
                group.setdefault(key, []).append(value)
        out.append(line)
    return out


@functools.lru_cache(maxsize=64)
def _field_paths(fields: tuple[str, ...]) -> list[tuple[str, str, int | None]]:
    """Each field's place in a sample (every block of a trace has the same fields: worked out once)."""
    return [_field_path(name) for name in fields]


def _field_path(name: str) -> tuple[str, str, int | None]:
    """``car.odometry[0]`` -> ``("car", "odometry", 0)``; ``car.x`` -> ``("car", "x", None)``; ``n`` -> ``("n", "",
    None)`` (names follow the schema's field pattern)."""
    head, _, rest = name.partition(".")
    key, _, index = rest.partition("[")
    return head, key, int(index.rstrip("]")) if index else None


#: Limits of what a trace holds, as the schema states them: machine time (s; in nanoseconds it stays within an
#: MCAP stamp's 64 bits) and ticks (exact in a double). A samples block's rows must end within them too.
MAX_TIME = 1e9
MAX_TICK = 2**53


def read_trace(path: str | os.PathLike[str]) -> Trace:
    """Read a trace file by the reading rule (a regular file, at most ``FSM_MAX_INPUT_BYTES``): :class:`TraceError`
    if it is no trace, :class:`~fsm.model.errors.DiagramError` if it cannot be read."""
    return parse_trace(read_file_bytes(Path(path), "trace"), str(path))


def parse_trace(data: bytes, name: str = "<trace>") -> Trace:
    """A trace from its bytes (see :func:`read_trace`). Each line is strict JSON
    (:func:`fsm.loading.reading.parse_json_line`)
    checked against ``fsm/schema/trace.schema.json`` before use; the first line that is not (or is cut off) ends
    the reading, with a warning saying where and why; a first line that is no header is a :class:`TraceError`."""
    if not data.strip():
        raise TraceError(f"{name}: the file is empty; a trace is written by `fsmctl run --trace FILE.jsonl`")
    if b"\0" in data[:4096]:
        raise TraceError(f"{name}: this is a binary file, not a trace (JSON lines written by `fsmctl run --trace`)")
    lines = data.split(b"\n")
    cut = bool(lines[-1].strip())  # the last line has no newline: the writer was stopped in it
    trace: Trace | None = None
    stopped = False  # at a whole line: the run may well have ended, its end line unread
    limit = max_samples()
    for number, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        if trace is None:
            trace = _first(raw, number, name)
            continue
        try:
            line = _checked_line(raw, trace, limit - len(trace.samples))
        except _TooMany:
            stopped = True
            trace.warnings.append(f"{name}:{number}: line {number} would make the trace hold more than {limit} "
                                  f"samples (one per {BYTES_PER_SAMPLE} bytes of the input size cap; set "
                                  f"FSM_MAX_INPUT_BYTES higher to read more); read up to line {number - 1}")
            break
        except _Damaged as exc:
            stopped = not (number == len(lines) and cut)
            if stopped:
                why = f"is damaged ({exc}); the lines after it are not read either"
            else:
                why = "is cut off (the run was stopped while it was written)"
            trace.warnings.append(f"{name}:{number}: line {number} {why}; read up to line {number - 1}")
            break
        _add(trace, line)
    assert trace is not None
    if trace.version >= 2 and trace.end is None and not stopped:
        trace.warnings.append(f"{name}: no end line: the run was cut off after tick {trace.last_tick}")
    trace.index()
    return trace


#: A trace may hold one sample per this many bytes of the input size cap (1 Mi samples by default: 14 hours at
#: 20 Hz; the 200 s lap takes 108 bytes a sample). A samples block row can be 4 bytes of text but becomes a
#: sample of some hundred bytes, and the report a few more: without a bound, 64 MiB of rows would fill 10 GB.
BYTES_PER_SAMPLE = 64


def max_samples() -> int:
    """How many samples a trace may hold (see :data:`BYTES_PER_SAMPLE`; ``FSM_MAX_INPUT_BYTES`` raises it)."""
    return max(1, max_input_bytes() // BYTES_PER_SAMPLE)


def _sample_count(line: dict[str, Any]) -> int:
    """How many samples a line says it holds (before it is checked: a block's rows, or the count of packed ones)."""
    kind = line.get("type")
    if kind == "samples":
        rows, count = line.get("rows"), line.get("count")
        return len(rows) if isinstance(rows, list) else count if isinstance(count, int) else 0
    return 1 if kind == "sample" else 0


class _Damaged(Exception):
    """A line after the first that cannot be used; the message says why and what was expected."""


class _TooMany(Exception):
    """A line whose samples the trace has no room for (:func:`max_samples`)."""


def _first(raw: bytes, number: int, name: str) -> Trace:
    """The trace that the first line begins: a header (version 2 or later) or a version-1 event line."""
    where = f"{name}:{number}"
    try:
        line, reason = parse_json_line(raw), None
    except ValueError as exc:
        line, reason = None, str(exc)
    if not isinstance(line, dict):
        text = raw[:40].decode("utf-8", "replace")
        why = f"{reason}; it begins {text!r}" if reason else describe(line)
        raise TraceError(f"{where}: not a trace: the first line is not a JSON object ({why}); "
                         "a trace is written by `fsmctl run --trace FILE.jsonl`")
    if line.get("type") == "header":
        version = _header_version(line, where)
        mismatch = _line_checks()["header"](line)
        if mismatch is not None:
            raise TraceError(f"{where}: the trace's header is damaged ({mismatch})")
        return Trace(name, version, line)
    if "type" not in line and isinstance(line.get("tick"), int) and isinstance(line.get("transitions"), list):
        mismatch = _line_checks()["event_v1"](line)
        if mismatch is not None:
            raise TraceError(f"{where}: the first line of this version-1 trace is damaged ({mismatch})")
        trace = Trace(name, 1, {})
        trace.warnings.append(f"{name}: a trace of an older tral-fsm (no header, keyframes or samples): only the "
                              "states, transitions and variables can be shown")
        _add(trace, line)
        return trace
    keys = ", ".join(sorted(k[:40] for k in line)[:6])
    raise TraceError(f"{where}: not a trace: the first line is a JSON object without a trace header "
                     f"(keys: {keys or 'none'}); a trace is written by `fsmctl run --trace FILE.jsonl`")


def _header_version(header: dict[str, Any], where: str) -> int:
    """The header's format and version checked, saying what was found; the version."""
    readable = f"this tral-fsm reads trace versions {', '.join(map(str, range(2, TRACE_VERSION)))} and {TRACE_VERSION}"
    if header.get("format") != TRACE_FORMAT:
        found = f"is {describe(header['format'])}" if "format" in header else "is missing"
        raise TraceError(f"{where}: not a trace: the header's format {found}, not {TRACE_FORMAT!r}")
    if "version" not in header:
        raise TraceError(f"{where}: the trace's header has no version ({readable})")
    version = header["version"]
    if not isinstance(version, int) or isinstance(version, bool):
        raise TraceError(f"{where}: trace version {describe(version)} is not a version: a version is a whole "
                         f"number ({readable})")
    if version < 1:
        raise TraceError(f"{where}: trace version {version} is not a version: versions count from 1 ({readable})")
    if version == 1:
        raise TraceError(f"{where}: a header saying trace version 1 is not a trace: version-1 traces have no header "
                         f"({readable})")
    if version > TRACE_VERSION:
        raise TraceError(f"{where}: trace version {version} is newer than this tral-fsm reads (up to "
                         f"{TRACE_VERSION}); update tral-fsm")
    return version


#: Where each line type goes in a :class:`Trace`.
_KINDS = {"event": "events", "keyframe": "keyframes", "sample": "samples", "frame": "frames", "input": "inputs",
          "reload": "reloads"}
#: The line types after the header (``event_v1``: a version-1 line, which has no type).
_LINE_TYPES = ("event", "keyframe", "sample", "samples", "frame", "input", "reload", "end")


@functools.cache
def _line_checks() -> dict[str, Check]:
    """The trace schema's check of each line type, compiled once (:mod:`fsm.trace.jsoncheck`: a few microseconds a
    line, where a general validator takes a millisecond)."""
    schema = json.loads((Path(__file__).parent.parent / "schema" / "trace.schema.json").read_text(encoding="utf-8"))
    return {kind: compile_definition(schema, kind) for kind in ("header", "event_v1", *_LINE_TYPES)}


def _checked_line(raw: bytes, trace: Trace, room: int) -> dict[str, Any]:
    """A line after the first, parsed strictly and checked against the schema (a samples block also unpacked and
    checked against its fields); :class:`_Damaged` saying the first thing wrong with it, :class:`_TooMany` if it
    holds more than ``room`` samples (said before they are checked or unpacked)."""
    try:
        line = parse_json_line(raw)
    except ValueError as exc:
        raise _Damaged(str(exc)) from None
    if not isinstance(line, dict):
        raise _Damaged(f"not a JSON object but {describe(line)}")
    if "type" in line:
        kind = line["type"]
        if kind not in _LINE_TYPES:
            raise _Damaged(f"unknown line type {describe(kind)} (expected one of {', '.join(_LINE_TYPES)})")
    else:
        kind = "event_v1" if trace.version == 1 else None
        if kind is None:
            raise _Damaged("a line without a type")
    if _sample_count(line) > room:
        raise _TooMany()
    mismatch = _line_checks()[kind](line)
    if mismatch is not None:
        raise _Damaged(f"{kind} line {mismatch}" if mismatch.path else f"{kind} line: {mismatch}")
    if kind == "samples":
        problem = _samples_problem(line, trace.dt)
        if problem is not None:
            raise _Damaged(problem)
    return line


def _samples_problem(line: dict[str, Any], dt: float | None) -> str | None:
    """What is wrong with a samples block the schema allows (its rows unpacked first when packed): rows as long
    as its fields, fields that can be put together, rows that end within the tick and time limits; or None."""
    fields = line["fields"]
    if "data" in line and "rows" not in line:
        problem = _unpack_samples(line)
        if problem is not None:
            return problem
    if any(len(row) != len(fields) for row in line["rows"]):
        return f"a samples block's rows must be as long as its {len(fields)} fields"
    problem = _fields_problem(tuple(fields))
    if problem is not None:
        return problem
    last = line["tick"] + max(len(line["rows"]) - 1, 0) * line["every"]
    if last > MAX_TICK or (dt is not None and last * dt > MAX_TIME):
        return f"a samples block's rows run past tick {MAX_TICK} or time {MAX_TIME:g} s"
    return None


@functools.lru_cache(maxsize=64)
def _fields_problem(fields: tuple[str, ...]) -> str | None:
    """Fields whose values cannot be put together into one sample (``car`` and ``car.x``; ``car.x`` and
    ``car.x[0]``), or None."""
    kinds: dict[tuple[str, ...], str] = {}
    for name, (head, key, index) in zip(fields, _field_paths(fields), strict=True):
        parts: list[tuple[tuple[str, ...], str]] = [((head,), "group" if key else "value")]
        if key:
            parts.append(((head, key), "list" if index is not None else "value"))
        for where, kind in parts:
            if kinds.setdefault(where, kind) != kind:
                return f"a samples block's field {name!r} clashes with another field of {'.'.join(where)!r}"
    return None


def _unpack_samples(line: dict[str, Any]) -> str | None:
    """Unpack a version-3 block's ``data`` into ``rows`` (numbers rounded to its ``digits``, integer columns as
    integers, an infinite reading as the string JSON gives it elsewhere); what is wrong with it, or None."""
    fields, count, digits = line["fields"], line["count"], line.get("digits", 6)
    integers = line.get("integers", [])
    wrong = next((i for i in integers if i >= len(fields)), None)
    if wrong is not None:
        return f"a samples block's integers name column {wrong}, but it has {len(fields)} fields"
    try:
        raw = base64.b64decode(line["data"], validate=True)
    except (ValueError, TypeError):
        return "a samples block's data is not base64"
    if len(raw) != 4 * count * len(fields):
        return f"a samples block's data holds {len(raw) // 4} values, not {count} rows of {len(fields)}"
    values = array.array("f")
    values.frombytes(raw)
    if sys.byteorder == "big":
        values.byteswap()
    flat = [v if v - v == 0 else str(v) for v in (round(v, digits) for v in values.tolist())]  # v - v: nan for inf
    width = len(fields)
    rows = [flat[i:i + width] for i in range(0, len(flat), width)]
    for i in integers:
        for row in rows:
            if isinstance(row[i], float):
                row[i] = int(row[i])
    line["rows"] = rows
    return None


def _add(trace: Trace, line: dict[str, Any]) -> None:
    kind = line.get("type", "event")
    if kind == "end":
        trace.end = line
    elif kind == "samples":
        trace.samples.extend(expand_samples(line, trace.dt))
    else:
        getattr(trace, _KINDS[kind]).append(line)
