"""What the report shows, computed from a trace: state lanes, transitions, the seek tables (keyframes and events)
the page replays the configuration and variables from, the samples as columns, camera frames, the map.

Everything here is plain data (the page embeds it as JSON); nothing is drawn. A trace without a header (an
older version), without samples or with a machine document that no longer loads still gives what can be shown,
and a warning says what is missing.
"""

from __future__ import annotations

import math
from itertools import pairwise
from typing import Any, TypedDict

from pydantic import ValidationError

from fsm.trace.replay import Trace, event_active

#: Sample fields and how the page groups them into plots: (title, unit, [(field, label)]).
PLOTS = [
    ("Ultrasonic sensors", "m", [("car.left", "left"), ("car.front", "front"), ("car.right", "right")]),
    ("Speed", "m/s", [("car.speed", "speed"), ("car.speed_command", "command")]),
    ("Steering", "-1 to 1", [("car.steering", "steering")]),
]
#: Digits kept per sample value (millimetres, milliradians): the page's size, not the trace's precision.
DIGITS = 3


def build_model(trace: Trace) -> dict[str, Any]:
    """The report's data: see the module docstring. ``warnings`` collects what could not be shown."""
    header = trace.header
    warnings = list(trace.warnings)
    dt = trace.dt or _guess_dt(trace)
    t_end = _end_time(trace, dt)
    states, index = _states(trace)
    regions = _regions(trace, states, index)
    lanes = _lanes(trace, regions, states, index, t_end)
    types, transitions = _transitions(trace, index)
    model: dict[str, Any] = {
        "meta": _meta(trace, dt, t_end),
        "states": states,
        "regions": [{"path": r["path"], "label": r["label"]} for r in regions],
        "lanes": lanes,
        "types": types,
        "transitions": transitions,
        **_timeline(trace, index),
    }
    samples, plots = _samples(trace)
    if samples is None and trace.version >= 2:
        warnings.append("the trace has no samples (a machine without a car): no map or plots")
    model["samples"] = samples
    model["plots"] = plots
    model["frames"] = [_frame(f) for f in trace.frames]
    world = header.get("world")
    model["map"] = _map(world, warnings) if world is not None else None
    model["meta"]["warnings"] = warnings
    return model


def _timeline(trace: Trace, index: dict[str, int]) -> dict[str, list[list[Any]]]:
    """The trace's lines in the page's form: monitor firings, pauses and resumes, keyframes and events (the
    active states as indexes)."""
    events = trace.events
    return {
        "monitors": [[e["time"], m.get("owner"), m.get("behavior"), m.get("kind"), m.get("exception")]
                     for e in events for m in e.get("monitors", ())],
        "pauses": [[e["time"], p, kind == "paused"] for e in events for kind in ("paused", "resumed")
                   for p in e.get(kind, ())],
        "keyframes": [[k["tick"], [index[a] for a in k["active"] if a in index], k["vars"]]
                      for k in trace.keyframes],
        "events": [[e["tick"], [index[a] for a in event_active(e) if a in index], e.get("vars", {}),
                    e.get("unset", [])] for e in events],
    }


def _transitions(trace: Trace, index: dict[str, int]) -> tuple[list[str], list[list[Any]]]:
    """The transition types in the order they first fire, and each firing: [time, tick, from, to, type] (from is
    -1 for an initial entry)."""
    types: list[str] = []
    transitions = []
    for e in trace.events:
        for tr in e.get("transitions", ()):
            kind = str(tr.get("type"))
            if kind not in types:
                types.append(kind)
            src = tr.get("from")
            transitions.append([tr.get("time", e["time"]), e["tick"], index.get(src, -1) if src else -1,
                                index[str(tr.get("to"))], types.index(kind)])
    return types, transitions


def _meta(trace: Trace, dt: float, t_end: float) -> dict[str, Any]:
    """What the report's heading says of the run: the machine, the trace, its length and how it ended."""
    header = trace.header
    end = trace.end or {}
    error = end.get("error")
    return {
        "name": header.get("name") or (header.get("machine") or {}).get("name") or trace.name,
        "source": header.get("source") or trace.name,
        "trace": trace.name,
        "version": trace.version,
        "tral_fsm": header.get("tral_fsm"),
        "dt": dt,
        "t_end": t_end,
        "ticks": trace.last_tick,
        "outcome": end.get("outcome"),
        "finished": end.get("finished"),
        "interrupted": bool(end.get("interrupted")),
        "error": (error or {}).get("message") if isinstance(error, dict) else None,
        "cut_off": trace.version >= 2 and trace.end is None,
        "seed": header.get("seed"),
        "world_file": header.get("world_file"),
        "overrides": header.get("overrides") or [],
    }


def _guess_dt(trace: Trace) -> float:
    for lines in (trace.events, trace.samples):
        for line in lines:
            if line["tick"] > 0 and isinstance(line.get("time"), (int, float)) and line["time"] > 0:
                return float(line["time"]) / float(line["tick"])
    return 0.0125


def _end_time(trace: Trace, dt: float) -> float:
    times = [float(line["time"]) for lines in (trace.events, trace.samples, trace.keyframes) if lines
             for line in (lines[-1],) if isinstance(line.get("time"), (int, float))]
    if trace.end is not None and isinstance(trace.end.get("time"), (int, float)):
        times.append(float(trace.end["time"]))
    return max(times + [trace.last_tick * dt])


def _states(trace: Trace) -> tuple[list[str], dict[str, int]]:
    """Every state path the trace names (the header's regions first, in their order), and their index."""
    states: list[str] = []
    index: dict[str, int] = {}

    def add(path: Any) -> None:
        if isinstance(path, str) and path not in index:
            index[path] = len(states)
            states.append(path)

    for region in trace.header.get("regions", ()):
        for path in region.get("states", ()):
            add(path)
    for e in trace.events:
        for tr in e.get("transitions", ()):
            add(tr.get("from"))
            add(tr.get("to"))
        for a in event_active(e):
            add(a)
    for k in trace.keyframes:
        for a in k["active"]:
            add(a)
    return states, index


class Region(TypedDict):
    """A region of the machine: its path, the indexes of its states and the label its lane shows."""

    path: str
    states: list[int]
    label: str


def _regions(trace: Trace, states: list[str], index: dict[str, int]) -> list[Region]:
    """The machine's regions (from the header; for an older trace, one per parent path), outermost first, each
    with the indexes of its states."""
    name = trace.header.get("name") or "machine"
    members = _members(trace.header.get("regions"), states, index)
    members.sort(key=lambda m: [part for part in m[0].split("/") if part])
    paths = [path for path, _ in members]
    regions: list[Region] = []
    for path, indexes in members:
        label = path or f"{name} (top level)"
        if paths.count(path) > 1:  # a sequence's exception regions sit at their sequence's path
            steps = [states[i].rpartition("/")[2] for i in indexes]
            label += ": " + ", ".join(steps[:3]) + (", …" if len(steps) > 3 else "")
        regions.append(Region(path=path, states=indexes, label=label))
    return regions


def _members(found: Any, states: list[str], index: dict[str, int]) -> list[tuple[str, list[int]]]:
    """Each region's path and the indexes of its states: the header's regions (``found``), or for an older trace
    one per parent path."""
    if isinstance(found, list) and found:
        return [(str(r.get("path", "")), [index[s] for s in r.get("states", ()) if s in index])
                for r in found if isinstance(r, dict)]
    by_parent: dict[str, list[int]] = {}
    for i, path in enumerate(states):
        by_parent.setdefault(path.rpartition("/")[0], []).append(i)
    return list(by_parent.items())


def _lanes(trace: Trace, regions: list[Region], states: list[str], index: dict[str, int],
           t_end: float) -> list[dict[str, Any]]:
    """The state lanes: one per machine level (nesting depth), and one per parallel region at each level below a
    ``Parallel`` state; regions of one level that are never active at once share its lane (the three turns of a lap
    are one lane), others get their own. Each lane: its label, depth and segments ``[t0, t1, state]`` (flat
    triples)."""
    segments = _segments(trace, regions, index, t_end)
    lanes = _shared_lanes(regions, segments, set(states))
    lanes.sort(key=lambda lane: (lane["depth"], lane["key"][1], lane["seg"][0][0]))
    return [{"label": lane_label(lane["regions"]), "depth": lane["depth"], "regions": lane["regions"],
             "seg": [v for seg in lane["seg"] for v in seg]} for lane in lanes]


def _segments(trace: Trace, regions: list[Region], index: dict[str, int],
              t_end: float) -> dict[int, list[list[float]]]:
    """Region index -> its segments ``[t0, t1, state]``: which of its states was active from when to when."""
    region_of: dict[int, int] = {}
    for r_i, r in enumerate(regions):
        for s in r["states"]:
            region_of.setdefault(s, r_i)
    current: dict[int, tuple[int, float]] = {}  # region -> (state, since)
    segments: dict[int, list[list[float]]] = {}

    def close(r_i: int, t: float) -> None:
        s, since = current.pop(r_i)
        segments.setdefault(r_i, []).append([since, t, s])

    for e in trace.events:
        t = float(e["time"])
        active = _active_indexes(event_active(e), index)
        now = {region_of[i]: i for i in active if i in region_of}
        for r_i in list(current):
            if now.get(r_i) != current[r_i][0]:
                close(r_i, t)
        for r_i, s in now.items():
            if r_i not in current:
                current[r_i] = (s, t)
    for r_i in list(current):
        close(r_i, t_end)
    return segments


def _active_indexes(leaves: list[str], index: dict[str, int]) -> set[int]:
    """The indexes of the active leaves and of all their ancestors."""
    active: set[int] = set()
    for leaf in leaves:
        parts = leaf.split("/")
        for n in range(1, len(parts) + 1):
            i = index.get("/".join(parts[:n]))
            if i is not None:
                active.add(i)
    return active


def _shared_lanes(regions: list[Region], segments: dict[int, list[list[float]]],
                  state_set: set[str]) -> list[dict[str, Any]]:
    """The regions that were ever active, put into lanes: a region joins the first lane of its depth and parallel
    branch whose segments it does not overlap."""
    lanes: list[dict[str, Any]] = []
    for r_i, r in enumerate(regions):
        if r_i not in segments:
            continue
        steps = [p for p in r["path"].split("/") if p]
        prefixes = ["/".join(steps[:n]) for n in range(1, len(steps) + 1)]
        branch = tuple(p for p in prefixes if p not in state_set)  # the parallel regions it lies in
        depth = len(steps) - len(branch)
        key = (depth, branch)
        for lane in lanes:
            if lane["key"] == key and not _overlap(lane["seg"], segments[r_i]):
                lane["seg"] = sorted(lane["seg"] + segments[r_i])
                lane["regions"].append(r["label"])
                break
        else:
            lanes.append({"key": key, "depth": depth, "seg": segments[r_i], "regions": [r["label"]]})
    return lanes


def lane_label(regions: list[str]) -> str:
    """What a lane shows, named by its regions: the one region's label, or the composites whose sub-states share
    the lane (``lap1/{bottom_turn, right_turn, top_turn +1}``; without a common parent, the composites' names)."""
    if len(regions) == 1:
        return regions[0]
    parents = {r.rpartition("/")[0] for r in regions}
    names = list(dict.fromkeys(r.rpartition("/")[2] for r in regions))
    shown = ", ".join(names[:3]) + (f" +{len(names) - 3}" if len(names) > 3 else "")
    parent = parents.pop() if len(parents) == 1 else ""
    return f"{parent}/{{{shown}}}" if parent else f"in {shown}"


def _overlap(a: list[list[float]], b: list[list[float]]) -> bool:
    """Whether two lists of ``[t0, t1, state]`` share any time (touching ends do not count)."""
    both = sorted([(s[0], s[1]) for s in a] + [(s[0], s[1]) for s in b])
    return any(later[0] < earlier[1] for earlier, later in pairwise(both))


def _flatten(prefix: str, value: Any, out: dict[str, float | None]) -> None:
    if isinstance(value, bool):
        out[prefix] = float(value)
    elif isinstance(value, (int, float)):
        out[prefix] = float(value) if math.isfinite(value) else None
    elif isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}", v, out)
    elif isinstance(value, list) and len(value) <= 8:
        for i, v in enumerate(value):
            _flatten(f"{prefix}[{i}]", v, out)


def _samples(trace: Trace) -> tuple[dict[str, list[Any]] | None, list[dict[str, Any]]]:
    """The samples as columns (``t`` and one per numeric field, e.g. ``car.x``), and which plots to draw."""
    if not trace.samples:
        return None, []
    rows = [(float(s["time"]), _flat_sample(s)) for s in trace.samples]
    names = list(dict.fromkeys(k for _, flat in rows for k in flat))
    columns: dict[str, list[Any]] = {"t": [round(t, 4) for t, _ in rows]}
    for name in names:
        columns[name] = [None if (v := flat.get(name)) is None else round(v, DIGITS) for _, flat in rows]
    plots = [{"title": title, "unit": unit, "series": got} for title, unit, series in PLOTS
             if (got := [{"field": f, "label": label} for f, label in series if f in columns])]
    return columns, plots


def _flat_sample(sample: dict[str, Any]) -> dict[str, float | None]:
    """A sample line's numbers by field (``car.x``, ``car.odometry[0]``; ``None`` for one that is not finite)."""
    flat: dict[str, float | None] = {}
    for k, v in sample.items():
        if k not in ("type", "tick", "time"):
            _flatten(k, v, flat)
    return flat


def _frame(f: dict[str, Any]) -> dict[str, Any]:
    return {"t": f.get("time"), "jpeg": f.get("jpeg"), "w": f.get("width"), "h": f.get("height"),
            "det": [{"id": d.get("id"), "c": d.get("corners"), "d": d.get("distance")}
                    for d in f.get("detections", ())],
            "gates": f.get("gates", [])}


def _map(world_doc: Any, warnings: list[str]) -> dict[str, Any] | None:
    """Walls, obstacles, gates and markers of the run's world, in metres (None, with a warning, if the world in
    the header does not load)."""
    from fsm.sim.world import World

    try:
        world = World.model_validate(world_doc)
    except (ValidationError, TypeError, ValueError) as exc:
        warnings.append(f"the world in the trace does not load ({str(exc).splitlines()[0]}): no walls on the map")
        return None
    walls = [[a[0], a[1], b[0], b[1]] for wall in world.walls for a, b in _wall_segments(wall)]
    obstacles: list[dict[str, list[Any]]] = []
    for ob in world.obstacles:
        poly = ob.polygon()
        if poly is not None:
            obstacles.append({"poly": [list(p) for p in poly]})
        elif ob.center is not None and ob.radius is not None:
            obstacles.append({"circle": [ob.center[0], ob.center[1], ob.radius]})
    gates = []
    for g in world.gates:
        h = math.radians(g.heading)
        nx, ny = -math.sin(h), math.cos(h)
        gates.append({"name": g.name or f"gate {g.markers[0]}/{g.markers[1]}",
                      "a": [g.center[0] + nx * g.width / 2, g.center[1] + ny * g.width / 2],
                      "b": [g.center[0] - nx * g.width / 2, g.center[1] - ny * g.width / 2],
                      "heading": g.heading})
    markers = [{"id": m.id, "p": list(m.position), "facing": m.facing} for m in world.markers]
    x0, y0, x1, y1 = world.bounds()
    car = world.car
    return {"walls": walls, "obstacles": obstacles, "gates": gates, "markers": markers,
            "bounds": [x0, y0, x1, y1], "car": {"length": car.length, "width": car.width},
            "start": [world.start.x, world.start.y]}


def _wall_segments(wall: Any) -> list[tuple[Any, Any]]:
    from fsm.sim.world import wall_segments

    return wall_segments(wall, True)
