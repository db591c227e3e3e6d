"""Reading a trace back (:mod:`fsm.trace` writes it): its lines by type, and the machine's configuration and
variables at any tick, rebuilt from the nearest keyframe and the events after it.

A trace cut off mid-line (the process was killed) reads up to its last whole line, with a warning naming the
line that is not; so does one with a damaged line (the rest is not trusted). A trace written before the header,
keyframes and samples existed (version 1: event lines only) reads too, with a warning saying what it lacks.
Anything else that is not a trace raises :class:`TraceError` with the reason and the line.
"""

from __future__ import annotations

import array
import base64
import bisect
import json
import os
import sys
from dataclasses import dataclass, field
from typing import Any

from .errors import FsmError
from .trace import PACKED_SAMPLES, TRACE_FORMAT, TRACE_VERSION


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
        for lines in (self.events, self.keyframes, self.samples, self.frames):
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
    [...]}}`` from the fields ``car.x``, ``car.odometry[0]``, ..."""
    paths = []
    for name in block["fields"]:
        head, _, rest = str(name).partition(".")
        key, _, bracket = rest.partition("[")
        paths.append((head, key, int(bracket.rstrip("]")) if bracket else None))
    out = []
    step = block["every"]
    first, t0 = block["tick"], float(block.get("time", 0.0))
    for i, row in enumerate(block["rows"]):
        tick = first + i * step
        line: dict[str, Any] = {"type": "sample", "tick": tick,
                                "time": round(tick * dt, 9) if dt else t0}
        for (head, key, index), value in zip(paths, row):
            group = line.setdefault(head, {}) if key else line
            if not key:
                line[head] = value
            elif index is None:
                group[key] = value
            else:
                group.setdefault(key, []).append(value)
        out.append(line)
    return out


def read_trace(path: str | os.PathLike[str]) -> Trace:
    """Read a trace file; :class:`TraceError` if it is none, ``OSError`` if it cannot be read."""
    with open(path, "rb") as fh:
        data = fh.read()
    return parse_trace(data, str(path))


def parse_trace(data: bytes, name: str = "<trace>") -> Trace:
    """A trace from its bytes (see :func:`read_trace`)."""
    if not data.strip():
        raise TraceError(f"{name}: the file is empty; a trace is written by `fsmctl run --trace FILE.jsonl`")
    if b"\0" in data[:4096]:
        raise TraceError(f"{name}: this is a binary file, not a trace (JSON lines written by `fsmctl run --trace`)")
    lines = data.split(b"\n")
    cut = bool(lines[-1].strip())  # the last line has no newline: the writer was stopped in it
    trace: Trace | None = None
    for number, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        try:
            line = json.loads(raw)
        except (UnicodeDecodeError, ValueError):
            line = None
        if trace is None:
            trace = _first(line, raw, number, name)
            if trace.version == 1:
                _add(trace, line)  # a version-1 trace starts with an event
            continue
        problem = _problem(line, trace.version)
        if problem is not None:
            if number == len(lines) and cut:
                why = "is cut off (the run was stopped while it was written)"
            else:
                why = f"is damaged ({problem}); the lines after it are not read either"
            trace.warnings.append(f"{name}:{number}: line {number} {why}; read up to line {number - 1}")
            break
        _add(trace, line)
    assert trace is not None
    if trace.version >= 2 and trace.end is None:
        trace.warnings.append(f"{name}: no end line: the run was cut off after tick {trace.last_tick}")
    trace.index()
    return trace


def _first(line: Any, raw: bytes, number: int, name: str) -> Trace:
    where = f"{name}:{number}"
    if not isinstance(line, dict):
        text = raw[:40].decode("utf-8", "replace")
        raise TraceError(f"{where}: not a trace: the first line is not a JSON object ({text!r}); "
                         "a trace is written by `fsmctl run --trace FILE.jsonl`")
    if line.get("type") == "header":
        if line.get("format") != TRACE_FORMAT:
            raise TraceError(f"{where}: not a trace: the header's format is {line.get('format')!r}, "
                             f"not {TRACE_FORMAT!r}")
        version = line.get("version")
        if not isinstance(version, int) or version > TRACE_VERSION:
            raise TraceError(f"{where}: trace version {version!r} is newer than this tral-fsm reads "
                             f"(up to {TRACE_VERSION}); update tral-fsm")
        return Trace(name, version, line)
    if "type" not in line and isinstance(line.get("tick"), int) and isinstance(line.get("transitions"), list):
        trace = Trace(name, 1, {})
        trace.warnings.append(f"{name}: a trace of an older tral-fsm (no header, keyframes or samples): only the "
                              "states, transitions and variables can be shown")
        return trace
    keys = ", ".join(sorted(map(str, line))[:6])
    raise TraceError(f"{where}: not a trace: the first line is a JSON object without a trace header "
                     f"(keys: {keys or 'none'}); a trace is written by `fsmctl run --trace FILE.jsonl`")


_KINDS = {"event": "events", "keyframe": "keyframes", "sample": "samples", "frame": "frames"}


def _problem(line: Any, version: int) -> str | None:
    """What is wrong with a line after the first, or None."""
    if not isinstance(line, dict):
        return "not a JSON object"
    kind = line.get("type", "event" if version == 1 else None)
    if kind not in _KINDS and kind not in ("end", "samples"):
        return f"unknown line type {kind!r}"
    if kind == "samples":
        if "data" in line and "rows" not in line:
            problem = _unpack_samples(line)
            if problem is not None:
                return problem
        if not (isinstance(line.get("fields"), list) and isinstance(line.get("rows"), list)
                and isinstance(line.get("every"), int) and line["every"] > 0
                and all(isinstance(r, list) and len(r) == len(line["fields"]) for r in line["rows"])):
            return "a samples block needs fields, every and rows as long as fields"
    if not isinstance(line.get("tick"), int) or isinstance(line.get("tick"), bool):
        return "no tick"
    if kind == "event" and not isinstance(line.get("transitions", []), list):
        return "transitions is not a list"
    if kind == "keyframe" and not (isinstance(line.get("active"), list) and isinstance(line.get("vars"), dict)):
        return "a keyframe needs active and vars"
    if kind == "event" and not isinstance(line.get("vars", {}), dict):
        return "vars is not an object"
    return None


def _unpack_samples(line: dict[str, Any]) -> str | None:
    """Unpack a version-3 block's ``data`` into ``rows`` (numbers rounded to its ``digits``, integer columns as
    integers, an infinite reading as the string JSON gives it elsewhere); what is wrong with it, or None."""
    fields, count, digits = line.get("fields"), line.get("count"), line.get("digits", 6)
    integers = line.get("integers", [])
    if line.get("encoding") != PACKED_SAMPLES:
        return f"a samples block's encoding is {line.get('encoding')!r}, not {PACKED_SAMPLES!r}"
    if not (isinstance(fields, list) and isinstance(count, int) and count >= 0 and isinstance(digits, int)
            and isinstance(line["data"], str) and isinstance(integers, list)
            and all(isinstance(i, int) and 0 <= i < len(fields) for i in integers)):
        return "a packed samples block needs fields, count, digits and data"
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
