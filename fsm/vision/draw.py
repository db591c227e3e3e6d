"""Annotated images: detected markers (outline, id, axes, distance) and gates (their line and heading)."""

from __future__ import annotations

import math
from collections.abc import Iterable

import cv2
import numpy as np

from fsm.vision.camera import CameraModel
from fsm.vision.detector import Detection
from fsm.vision.gates import Gate

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_GATE = (0, 200, 255)
_TEXT = (40, 220, 40)


def annotate(image: np.ndarray, detections: Iterable[Detection], camera: CameraModel,
             gates: Iterable[Gate] = ()) -> np.ndarray:
    """A BGR copy of ``image`` with the markers' outlines, ids and axes, and each gate's line and pose."""
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    detections = list(detections)
    scale = max(0.4, out.shape[1] / 1000)
    if detections:
        corners = [d.corners.reshape(1, 4, 2) for d in detections]
        ids = np.array([[d.id] for d in detections], dtype=np.int32)
        cv2.aruco.drawDetectedMarkers(out, corners, ids)
    for d in detections:
        cv2.drawFrameAxes(out, camera.K, camera.dist, d.rvec, d.tvec, d.size * 0.5, 2)
        x, y = d.corners[:, 0].min(), d.corners[:, 1].max()
        cv2.putText(out, f"{d.distance:.2f} m", (int(x), int(y) + int(18 * scale)), _FONT, 0.5 * scale, _TEXT, 1,
                    cv2.LINE_AA)
    for g in gates:
        a = tuple(int(round(v)) for v in g.left.center_px)
        b = tuple(int(round(v)) for v in g.right.center_px)
        cv2.line(out, a, b, _GATE, 2, cv2.LINE_AA)
        mid = ((a[0] + b[0]) // 2, (a[1] + b[1]) // 2)
        cv2.circle(out, mid, 4, _GATE, -1, cv2.LINE_AA)
        label = f"gate {g.ids[0]}/{g.ids[1]}: {g.distance:.2f} m, heading {math.degrees(g.heading):+.1f} deg"
        cv2.putText(out, label, (max(0, mid[0] - 120), max(12, mid[1] - int(30 * scale))), _FONT, 0.5 * scale,
                    _GATE, 1, cv2.LINE_AA)
    return out
