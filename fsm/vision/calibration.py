"""Camera calibration files: OpenCV FileStorage YAML/JSON (``!!opencv-matrix``) and ROS ``camera_info`` YAML.

Both forms store ``camera_matrix`` and ``distortion_coefficients`` as ``{rows, cols, data}`` (OpenCV adds
``dt``), and the image size as ``image_width`` / ``image_height``. We parse them with ``cv2.FileStorage``
(it reads YAML 1.0 with or without the ``%YAML:1.0`` header, and JSON), so no YAML library is needed;
a matrix may also be a plain list (flat or nested). Every problem is a located
:class:`fsm.errors.DiagramError`: the file, the line of the key, and what to fix.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from fsm.errors import DiagramError, Problem

from .camera import CameraModel

#: A calibration is a few hundred bytes; anything far larger is not one.
MAX_BYTES = 1_000_000
#: Distortion vector lengths OpenCV understands (plumb_bob is 5, rational_polynomial 8).
DIST_LENGTHS = (0, 4, 5, 8, 12, 14)
_HINT = ("expected an OpenCV or ROS calibration: camera_matrix {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, "
         "0, 0, 1]}, distortion_coefficients {rows: 1, cols: 5, data: [...]}, image_width, image_height")


class _Bad(Exception):
    def __init__(self, message: str, key: str = "", hint: str | None = None) -> None:
        super().__init__(message)
        self.key, self.hint = key, hint


def load_calibration(path: str | Path, *, image_size: tuple[int, int] | None = None) -> CameraModel:
    """The camera described by a calibration file; ``image_size`` (width, height) is used when the file
    names none, and otherwise must agree with it (raises :class:`DiagramError`)."""
    from fsm.reading import read_file_bytes

    name = str(path)
    raw = read_file_bytes(Path(path), "calibration")
    if len(raw) > MAX_BYTES:
        raise DiagramError([Problem(f"file is {len(raw)} bytes; a calibration is a few hundred", name)])
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise DiagramError([Problem(f"not a text file: byte 0x{raw[exc.start]:02x} cannot be decoded as UTF-8",
                                    name, line=line, hint=_HINT)]) from None
    if not text.strip():
        raise DiagramError([Problem("file is empty", name, line=1, hint=_HINT)])
    fs = _open(text, name)
    try:
        return _camera(fs, text, name, image_size)
    except _Bad as bad:
        raise DiagramError([Problem(str(bad), name, pointer=f"/{bad.key}" if bad.key else "",
                                    line=_line_of(text, bad.key), hint=bad.hint)]) from None
    finally:
        fs.release()


def _open(text: str, name: str) -> Any:
    import cv2

    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError) as exc:  # the binding wraps cv2.error in SystemError
        cause = exc.__cause__ if isinstance(exc, SystemError) and exc.__cause__ is not None else exc
        message = str(cause).strip()
        m = re.search(r"'[^']*\((\d+)\): ([^']*)'", message)
        line, what = (int(m.group(1)), m.group(2)) if m else (None, message.splitlines()[-1] if message else "")
        raise DiagramError([Problem(f"malformed calibration file: {what.strip() or 'cannot parse'}", name,
                                    line=line, hint=_HINT)]) from None
    if not fs.isOpened() or not fs.root().isMap():
        raise DiagramError([Problem("not a calibration: the file is not a YAML/JSON mapping", name, line=1,
                                    hint=_HINT)])
    return fs


def _camera(fs: Any, text: str, name: str, image_size: tuple[int, int] | None) -> CameraModel:
    K = _matrix(fs, "camera_matrix", required=True)
    assert K is not None
    if K.shape != (3, 3):
        raise _Bad(f"camera_matrix must be 3x3, got {K.shape[0]}x{K.shape[1]}", "camera_matrix")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise _Bad(f"camera_matrix focal lengths must be > 0, got fx={K[0, 0]:g}, fy={K[1, 1]:g}", "camera_matrix")
    if abs(K[2, 0]) > 1e-9 or abs(K[2, 1]) > 1e-9 or abs(K[2, 2] - 1) > 1e-6 or abs(K[1, 0]) > 1e-9:
        raise _Bad("camera_matrix must have the form [fx, s, cx; 0, fy, cy; 0, 0, 1]", "camera_matrix")
    model = _text(fs, "distortion_model")
    if model is not None and model not in ("plumb_bob", "rational_polynomial"):
        raise _Bad(f"distortion_model {model!r} is not supported (only plumb_bob and rational_polynomial)",
                   "distortion_model", hint="fisheye (equidistant) calibrations need cv2.fisheye; undistort first")
    dist = _matrix(fs, "distortion_coefficients", required=False)
    if dist is None:
        dist = np.zeros(5)
    else:
        if 1 not in dist.shape and dist.size:
            raise _Bad(f"distortion_coefficients must be one row or column, got {dist.shape[0]}x{dist.shape[1]}",
                       "distortion_coefficients")
        dist = dist.reshape(-1)
        if dist.size not in DIST_LENGTHS:
            raise _Bad(f"distortion_coefficients has {dist.size} values; OpenCV takes "
                       f"{', '.join(str(n) for n in DIST_LENGTHS[1:])}", "distortion_coefficients")
    width, height = _int(fs, "image_width"), _int(fs, "image_height")
    if (width is None) != (height is None):
        raise _Bad("image_width and image_height come together", "image_height" if width is None else "image_width")
    if width is None or height is None:
        if image_size is None:
            raise _Bad("the file names no image size", "image_width",
                       hint="add image_width and image_height (the resolution the camera was calibrated at)")
        width, height = image_size
    return CameraModel(int(width), int(height), K, dist)


def _node(fs: Any, key: str) -> Any | None:
    node = fs.getNode(key)
    return None if node.empty() or node.isNone() else node


def _numbers(node: Any, key: str) -> list[float]:
    import cv2

    values = []
    for i in range(node.size()):
        item = node.at(i)
        if item.type() not in (cv2.FILE_NODE_INT, cv2.FILE_NODE_REAL):
            raise _Bad(f"{key}: element {i} is not a number", key)
        v = item.real()
        if not math.isfinite(v):
            raise _Bad(f"{key}: element {i} is {v} (values must be finite)", key)
        values.append(v)
    return values


def _matrix(fs: Any, key: str, required: bool) -> np.ndarray | None:
    node = _node(fs, key)
    if node is None:
        if required:
            raise _Bad(f"no '{key}' in the file", "", hint=_HINT)
        return None
    if node.isMap():
        rows, cols, data = _int(node, "rows", key), _int(node, "cols", key), _node(node, "data")
        if rows is None or cols is None or data is None or not data.isSeq():
            raise _Bad(f"{key} needs rows, cols and a data list", key)
        values = _numbers(data, key)
        if rows <= 0 or cols <= 0 or len(values) != rows * cols:
            raise _Bad(f"{key} says {rows}x{cols} but has {len(values)} values", key)
        return np.array(values, dtype=np.float64).reshape(rows, cols)
    if node.isSeq():
        if node.size() and node.at(0).isSeq():  # nested rows
            rows_ = [_numbers(node.at(i), key) for i in range(node.size())]
            if len({len(r) for r in rows_}) != 1:
                raise _Bad(f"{key}: rows of different lengths", key)
            return np.array(rows_, dtype=np.float64)
        values = _numbers(node, key)
        if key == "camera_matrix" and len(values) == 9:
            return np.array(values, dtype=np.float64).reshape(3, 3)
        if key == "camera_matrix":
            raise _Bad(f"camera_matrix must be 3x3, got a list of {len(values)} values", key)
        return np.array(values, dtype=np.float64).reshape(1, -1)
    raise _Bad(f"{key} must be a matrix ({{rows, cols, data}} or a list)", key)


def _int(fs_or_node: Any, key: str, where: str | None = None) -> int | None:
    import cv2

    node = _node(fs_or_node, key)
    if node is None:
        return None
    if node.type() != cv2.FILE_NODE_INT:
        raise _Bad(f"{key} must be a whole number", where or key)
    value = int(node.real())
    if where is None and value <= 0:
        raise _Bad(f"{key} must be > 0, got {value}", key)
    return value


def _text(fs: Any, key: str) -> str | None:
    import cv2

    node = _node(fs, key)
    return node.string() if node is not None and node.type() == cv2.FILE_NODE_STRING else None


def _line_of(text: str, key: str) -> int | None:
    """The 1-based line where ``key`` is defined (FileStorage keeps no positions), for the message."""
    if not key:
        return None
    m = re.search(rf'^\s*"?{re.escape(key)}"?\s*:', text, re.M)
    return text.count("\n", 0, m.start()) + 1 if m else None
