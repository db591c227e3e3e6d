"""A trace as an MCAP file (the ``mcap`` package), for Foxglove, Lichtblick, PlotJuggler and Rerun.

Every message is JSON with a JSON Schema, stamped with the simulated time (nanoseconds). Channels:

- ``/fsm/active`` (each tick the configuration changed: the active leaf paths), ``/fsm/transitions`` (one
  message per transition, initial entries included), ``/fsm/vars`` (changed and removed variables),
  ``/fsm/monitors`` (monitor and timeout firings), ``/fsm/pause`` (pauses and resumes);
- ``/car/pose`` and ``/car/odometry`` as ``foxglove.PoseInFrame`` (frame ``world``; the 3D panel draws them),
  ``/car/cmd`` (speed command, steering), ``/car/state`` (speed, distance, collisions),
  ``/sensors/<name>`` (one per ultrasonic sensor: ``range`` in metres);
- ``/camera/detections`` (markers and gates of each recorded frame) and ``/camera/image`` as
  ``foxglove.CompressedImage`` (the JPEG thumbnails the trace holds).

The trace's header goes into a metadata record ``tral-fsm`` and the machine document into an attachment
``machine.json``. Written to a scratch file by the caller (:mod:`fsm.tools.files`), so a failed export leaves
nothing behind.
"""

from __future__ import annotations

import json
import math
from typing import IO, Any

from fsm.trace.replay import Trace, event_active

_OBJECT = {"type": "object"}
_STRINGS = {"type": "array", "items": {"type": "string"}}
SCHEMAS: dict[str, dict[str, Any]] = {
    "tral_fsm.Active": {"type": "object", "properties": {"tick": {"type": "integer"}, "active": _STRINGS}},
    "tral_fsm.Transition": {"type": "object", "properties": {
        "tick": {"type": "integer"}, "from": {"type": ["string", "null"]}, "to": {"type": "string"},
        "type": {"type": "string"}}},
    "tral_fsm.Vars": {"type": "object", "properties": {"tick": {"type": "integer"}, "vars": _OBJECT,
                                                       "unset": _STRINGS}},
    "tral_fsm.Monitor": {"type": "object", "properties": {
        "tick": {"type": "integer"}, "owner": {"type": "string"}, "monitor": {"type": "string"},
        "kind": {"type": "string"}, "behavior": {"type": "string"}, "exception": {"type": "string"}}},
    "tral_fsm.Pause": {"type": "object", "properties": {"tick": {"type": "integer"}, "state": {"type": "string"},
                                                        "paused": {"type": "boolean"}}},
    "foxglove.PoseInFrame": {"type": "object", "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "frame_id": {"type": "string"},
        "pose": {"type": "object", "properties": {
            "position": {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}},
            "orientation": {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}}}}},
    "tral_fsm.CarCommand": {"type": "object", "properties": {"speed": {"type": "number"},
                                                             "steering": {"type": "number"}}},
    "tral_fsm.CarState": {"type": "object", "properties": {"speed": {"type": "number"},
                                                           "distance": {"type": "number"},
                                                           "collisions": {"type": "integer"}}},
    "tral_fsm.Range": {"type": "object", "properties": {"range": {"type": ["number", "null"]}}},
    "tral_fsm.Detections": {"type": "object", "properties": {"frame": {"type": "integer"},
                                                             "markers": {"type": "array"}, "gates": {"type": "array"}}},
    "foxglove.CompressedImage": {"type": "object", "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "frame_id": {"type": "string"}, "data": {"type": "string", "contentEncoding": "base64"},
        "format": {"type": "string"}}},
}
#: The ultrasonic sensors of the car in a sample, each on ``/sensors/<name>``.
SENSORS = ("left", "front", "right")


def _ns(seconds: float) -> int:
    return max(0, round(seconds * 1e9))


def _stamp(seconds: float) -> dict[str, int]:
    ns = _ns(seconds)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _pose(seconds: float, x: float, y: float, heading: float) -> dict[str, Any]:
    return {"timestamp": _stamp(seconds), "frame_id": "world",
            "pose": {"position": {"x": x, "y": y, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2), "w": math.cos(heading / 2)}}}


class _Out:
    def __init__(self, stream: IO[bytes]) -> None:
        from mcap.writer import CompressionType, Writer

        self.writer = Writer(stream, compression=CompressionType.ZSTD)
        self.writer.start(profile="", library="tral-fsm")
        self.schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        self.sequence = 0
        self.counts: dict[str, int] = {}

    def channel(self, topic: str, schema: str) -> int:
        if topic not in self.channels:
            if schema not in self.schemas:
                self.schemas[schema] = self.writer.register_schema(
                    name=schema, encoding="jsonschema", data=json.dumps(SCHEMAS[schema]).encode())
            self.channels[topic] = self.writer.register_channel(topic=topic, message_encoding="json",
                                                                schema_id=self.schemas[schema])
        return self.channels[topic]

    def add(self, topic: str, schema: str, seconds: float, message: dict[str, Any]) -> None:
        self.sequence += 1
        self.writer.add_message(channel_id=self.channel(topic, schema), log_time=_ns(seconds),
                                publish_time=_ns(seconds), sequence=self.sequence,
                                data=json.dumps(message, separators=(",", ":")).encode())
        self.counts[topic] = self.counts.get(topic, 0) + 1


def write_mcap(trace: Trace, stream: IO[bytes]) -> dict[str, int]:
    """Write ``trace`` to ``stream`` as MCAP; returns the number of messages per topic."""
    out = _Out(stream)
    _write_header(out, trace)
    _write_events(out, trace.events)
    for s in trace.samples:
        car = s.get("car")
        if isinstance(car, dict):
            _write_sample(out, float(s["time"]), car)
    _write_frames(out, trace.frames)
    out.writer.finish()
    return out.counts


def _write_header(out: _Out, trace: Trace) -> None:
    """The header's fields as metadata; the machine document and the world as attachments."""
    header = dict(trace.header)
    document = header.pop("machine", None)
    world = header.pop("world", None)
    meta = {k: v if isinstance(v, str) else json.dumps(v) for k, v in header.items()}
    meta["trace"] = trace.name
    out.writer.add_metadata("tral-fsm", meta)
    if document is not None:
        out.writer.add_attachment(0, 0, "machine.json", "application/json", json.dumps(document, indent=1).encode())
    if world is not None:
        out.writer.add_attachment(0, 0, "world.json", "application/json", json.dumps(world, indent=1).encode())


def _write_events(out: _Out, events: list[dict[str, Any]]) -> None:
    """The machine's topics: active states (when they change), transitions, variables, monitors, pauses."""
    last_active: list[str] | None = None
    for e in events:
        t, tick = float(e["time"]), e["tick"]
        active = event_active(e)
        if active != last_active:
            out.add("/fsm/active", "tral_fsm.Active", t, {"tick": tick, "active": active})
            last_active = active
        for tr in e.get("transitions", ()):
            out.add("/fsm/transitions", "tral_fsm.Transition", float(tr.get("time", t)),
                    {"tick": tr.get("tick", tick), "from": tr.get("from"), "to": tr.get("to"), "type": tr.get("type")})
        if e.get("vars") or e.get("unset"):
            out.add("/fsm/vars", "tral_fsm.Vars", t, {"tick": tick, "vars": e.get("vars", {}),
                                                      "unset": e.get("unset", [])})
        for m in e.get("monitors", ()):
            out.add("/fsm/monitors", "tral_fsm.Monitor", t, {"tick": tick, **m})
        for kind in ("paused", "resumed"):
            for path in e.get(kind, ()):
                out.add("/fsm/pause", "tral_fsm.Pause", t, {"tick": tick, "state": path, "paused": kind == "paused"})


def _write_sample(out: _Out, t: float, car: dict[str, Any]) -> None:
    """One sample of the car: pose, odometry, command, state and each sensor, as far as the sample has them."""
    if _numbers(car, "x", "y", "heading"):
        out.add("/car/pose", "foxglove.PoseInFrame", t, _pose(t, car["x"], car["y"], car["heading"]))
    odo = car.get("odometry")
    if isinstance(odo, list) and len(odo) == 3 and all(isinstance(v, (int, float)) for v in odo):
        out.add("/car/odometry", "foxglove.PoseInFrame", t, _pose(t, *odo))
    if _numbers(car, "speed_command", "steering"):
        out.add("/car/cmd", "tral_fsm.CarCommand", t, {"speed": car["speed_command"], "steering": car["steering"]})
    if _numbers(car, "speed", "distance"):
        out.add("/car/state", "tral_fsm.CarState", t, {"speed": car["speed"], "distance": car["distance"],
                                                       "collisions": car.get("collisions", 0)})
    for name in SENSORS:
        if name in car:
            value = car[name]
            out.add(f"/sensors/{name}", "tral_fsm.Range", t,
                    {"range": value if isinstance(value, (int, float)) else None})


def _write_frames(out: _Out, frames: list[dict[str, Any]]) -> None:
    """The camera's detections and images."""
    for f in frames:
        t = float(f["time"])
        out.add("/camera/detections", "tral_fsm.Detections", t,
                {"frame": f.get("frame", 0), "markers": f.get("detections", []), "gates": f.get("gates", [])})
        if isinstance(f.get("jpeg"), str):
            out.add("/camera/image", "foxglove.CompressedImage", t,
                    {"timestamp": _stamp(t), "frame_id": "camera", "data": f["jpeg"], "format": "jpeg"})


def _numbers(d: dict[str, Any], *keys: str) -> bool:
    return all(isinstance(d.get(k), (int, float)) and not isinstance(d.get(k), bool) for k in keys)
