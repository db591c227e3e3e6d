"""Trace lines for tests: one of every type as ``fsmctl run`` writes them, and wild JSON values to put in them."""

from __future__ import annotations

import base64
import struct
from typing import Any

from hypothesis import strategies as st

from fsm.trace.replay import MAX_TICK, MAX_TIME

FIELDS = ["car.x", "car.y", "car.heading", "car.odometry[0]", "car.odometry[1]", "car.odometry[2]", "car.front",
          "car.steering", "car.collisions"]
CAR = {"x": 1.0, "y": 1.5, "heading": 0.1, "odometry": [0.0, 0.0, 0.0], "left": 1.2, "right": "inf", "front": 2.5,
       "distance": 0.0, "speed": 0.5, "speed_command": 0.5, "steering": -0.2, "collisions": 0}
WORLD = {"walls": [{"points": [[0, 0], [4, 0], [4, 3], [0, 3]], "closed": True}], "start": {"x": 1, "y": 1},
         "gates": [{"markers": [1, 2], "center": [2, 1.5]}], "markers": [{"id": 1, "position": [2, 1.2], "facing": 0}]}


def packed(rows: list[list[float]]) -> str:
    """Rows of numbers as a version-3 samples block packs them (little-endian float32, base64)."""
    flat = [v for row in rows for v in row]
    return base64.b64encode(struct.pack(f"<{len(flat)}f", *flat)).decode("ascii")


#: One line of every type, as fsmctl run writes them (a car, a camera, packed and JSON sample blocks).
LINES: dict[str, dict[str, Any]] = {
    "header": {"type": "header", "format": "tral-fsm-trace", "version": 3, "tral_fsm": "0.1.0", "name": "m",
               "dt": 0.0125, "regions": [{"path": "", "name": "m", "states": ["a", "b"]}], "keyframe_period": 1.0,
               "sample_period": 0.05, "frame_period": 1.0, "sample_fields": FIELDS, "machine": None,
               "world": WORLD, "world_file": "w.json", "seed": 3, "noise": True, "overrides": ["a.x=1"]},
    "event": {"type": "event", "tick": 0, "time": 0.0, "active": ["a"],
              "transitions": [{"tick": 0, "time": 0.0, "from": None, "to": "a", "type": "initial"}],
              "vars": {"n": 1, "s": "x"}, "unset": ["old"], "paused": ["a"], "resumed": ["a"], "car": CAR,
              "monitors": [{"owner": "a", "monitor": "t", "kind": "timeout", "behavior": "abort", "exception": "e"}]},
    "keyframe": {"type": "keyframe", "tick": 0, "time": 0.0, "active": ["a"], "vars": {"n": 1}},
    "samples": {"type": "samples", "tick": 0, "time": 0.0, "every": 4, "fields": FIELDS, "encoding": "float32-base64",
                "digits": 4, "integers": [8], "count": 2,
                "data": packed([[1.0, 1.5, 0.1, 0.0, 0.0, 0.0, 2.5, -0.2, 0],
                                [1.1, 1.5, 0.1, 0.1, 0.0, 0.0, 2.4, 0.0, 1]])},
    "rows": {"type": "samples", "tick": 8, "time": 0.1, "every": 4, "fields": ["car.x", "car.front", "v"],
             "rows": [[1.2, "inf", None], [1.3, 2.0, "on"]]},
    "sample": {"type": "sample", "tick": 16, "time": 0.2, "car": CAR},
    "frame": {"type": "frame", "tick": 80, "time": 1.0, "camera_time": 0.98, "frame": 3, "jpeg": "/9j/AA==",
              "width": 160, "height": 120, "gates": [[1, 2]],
              "detections": [{"id": 1, "corners": [[1, 2], [3, 2], [3, 4], [1, 4]], "distance": 1.2, "bearing": 0.1}]},
    "input": {"type": "input", "tick": 40, "time": 0.5, "input": {"kind": "set", "values": {"n": 2}},
              "text": "set n = 2"},
    "reload": {"type": "reload", "tick": 60, "time": 0.75, "file": "m.json", "kept": ["a"],
               "missing": [{"path": "b", "entered": "c"}], "started": [{"path": "a/r", "entered": "x"}]},
    "event2": {"type": "event", "tick": 88, "time": 1.1, "active": ["b"],
               "transitions": [{"tick": 88, "time": 1.1, "from": "a", "to": "b", "type": "Timeout"}]},
    "end": {"type": "end", "tick": 90, "time": 1.125, "outcome": "done", "finished": True, "transitions": 1,
            "interrupted": False, "error": {"message": "m"}},
}
V1 = {"tick": 0, "time": 0.0, "active": "a, b", "vars": {"n": 1},
      "transitions": [{"tick": 0, "time": 0.0, "from": None, "to": "a", "type": "initial"}]}


#: Any JSON value, with numbers at and beyond the trace's limits.
WILD = st.recursive(
    st.none() | st.booleans() | st.integers(-(2 ** 70), 2 ** 70) | st.floats(allow_nan=False, allow_infinity=False)
    | st.sampled_from([1e308, -1e308, MAX_TIME + 1, MAX_TICK + 1, 3.5e38, -1, 0, 1.0, "inf", "", "a/b", "car.x[0]"])
    | st.text(max_size=6),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=6)
