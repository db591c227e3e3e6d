"""ArUco markers in an image, each with its pose: ``cv2.aruco.ArucoDetector`` + ``solvePnP(IPPE_SQUARE)``.

Works with OpenCV 4.8+ and 5.x (5.x removed ``estimatePoseSingleMarkers``). Settings chosen by measurement
on rendered frames (``benchmarks/bench_vision.py``): sub-pixel corner refinement (best accuracy at ~3 ms per
640x480 frame) and ``minMarkerDistanceRate`` 0.05 (recovers near markers whose paper almost touches the image
border).

Optional region-of-interest tracking (``track=True``): between full-frame searches (every
``full_every`` frames) only boxes around the markers found in the previous frame are searched, so a
frame costs a fraction of a full search. A marker that newly enters the view is found at the next
full search; when every tracked marker is lost the detector searches the whole frame at once, when
some are lost, in the next frame. A region search keeps the full frame's marker size limits in pixels.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from fsm.vision.camera import CameraModel, CameraMount

DEFAULT_DICTIONARY = "DICT_4X4_50"
#: Side of the black square of a marker when nothing else is said, metres.
DEFAULT_MARKER_SIZE = 0.15


def dictionary_names() -> list[str]:
    """The predefined ArUco dictionaries of the installed OpenCV (``DICT_4X4_50``, ...)."""
    return sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_") and isinstance(getattr(cv2.aruco, n), int))


def get_dictionary(name: str) -> Any:
    """The predefined dictionary ``name``; raises ValueError naming the choices."""
    if name not in dictionary_names():
        raise ValueError(f"unknown ArUco dictionary {name!r}; choose one of {', '.join(dictionary_names())}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def dictionary_size(name: str) -> int:
    """How many ids the dictionary has (ids are 0 .. size-1)."""
    return int(get_dictionary(name).bytesList.shape[0])


def object_points(size: float) -> np.ndarray:
    """A marker's corners in its own frame (x right, y up, z out of the face), in the detector's order
    TL, TR, BR, BL (what ``solvePnP(IPPE_SQUARE)`` requires)."""
    h = size / 2
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]], dtype=np.float64)


@dataclass(frozen=True, eq=False, slots=True)
class Detection:
    """One marker seen in one image.

    ``corners``: 4x2 pixels, TL, TR, BR, BL of the black square as printed. ``rvec``/``tvec``: the
    marker's pose in the optical frame (x right, y down, z forward; ``tvec`` is the marker centre, m).
    ``position``: the marker centre in the car frame (x forward, y left, z up, m). ``distance``: the
    horizontal distance from the car frame's origin, m. ``bearing``: ``atan2(y, x)`` of the centre,
    rad, left positive. ``facing``: direction of the marker's face normal in the car frame, rad (a
    marker square to the camera faces pi); from one marker's rotation, which flips beyond about 2 m,
    so prefer a :class:`~fsm.vision.gates.Gate`'s heading. ``error``: RMS reprojection error, px.
    """

    id: int
    corners: np.ndarray
    size: float
    rvec: np.ndarray
    tvec: np.ndarray
    position: tuple[float, float, float]
    distance: float
    bearing: float
    facing: float
    error: float

    @property
    def center_px(self) -> tuple[float, float]:
        c = self.corners.mean(axis=0)
        return float(c[0]), float(c[1])

    @property
    def range(self) -> float:
        """Straight-line distance from the camera to the marker centre, m."""
        return float(np.linalg.norm(self.tvec))

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id, "size": self.size,
            "corners": [[round(float(x), 3), round(float(y), 3)] for x, y in self.corners],
            "position": [round(v, 4) for v in self.position],
            "distance": round(self.distance, 4), "bearing_deg": round(math.degrees(self.bearing), 3),
            "facing_deg": round(math.degrees(self.facing), 3), "range": round(self.range, 4),
            "rvec": [round(float(v), 6) for v in self.rvec], "tvec": [round(float(v), 5) for v in self.tvec],
            "reprojection_px": round(self.error, 4),
        }


class MarkerDetector:
    """Finds markers of one dictionary in grey or BGR images and estimates each marker's pose.

    ``marker_size`` is the side of the black square in metres; ``sizes`` overrides it per id. ``mount``
    places the camera on the car (default: the car frame is the camera's, x forward). With ``track``
    the detector searches around the markers of the previous frame and the full frame every
    ``full_every`` frames (``margin``: how far around a marker to search, in marker sides).
    """

    def __init__(self, camera: CameraModel, *, dictionary: str = DEFAULT_DICTIONARY,
                 marker_size: float = DEFAULT_MARKER_SIZE, sizes: Mapping[int, float] | None = None,
                 mount: CameraMount | None = None, track: bool = False, full_every: int = 10,
                 margin: float = 1.0) -> None:
        if not marker_size > 0 or not math.isfinite(marker_size):
            raise ValueError(f"marker size must be > 0, got {marker_size}")
        for i, s in (sizes or {}).items():
            if not s > 0 or not math.isfinite(s):
                raise ValueError(f"marker {i}: size must be > 0, got {s}")
        if full_every < 1:
            raise ValueError(f"full_every must be >= 1, got {full_every}")
        self.camera = camera
        self.dictionary_name = dictionary
        self.marker_size = float(marker_size)
        self.sizes = dict(sizes or {})
        self.mount = mount or CameraMount()
        self.track = track
        self.full_every = full_every
        self.margin = margin
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        params.minMarkerDistanceRate = 0.05
        self._params = params
        self._detector = cv2.aruco.ArucoDetector(get_dictionary(dictionary), params, cv2.aruco.RefineParameters())
        # The perimeter limits are rates of the searched image's larger side; a region search keeps the
        # full frame's limits in pixels (a small crop would otherwise accept every noise speck as a candidate).
        self._min_perimeter_px = params.minMarkerPerimeterRate * max(camera.width, camera.height)
        self._max_perimeter_px = params.maxMarkerPerimeterRate * max(camera.width, camera.height)
        self._roi_detector = cv2.aruco.ArucoDetector(get_dictionary(dictionary), params, cv2.aruco.RefineParameters())
        self._roi_side = 0
        self._R = self.mount.rotation()
        self._t = self.mount.translation()
        self._objects: dict[float, np.ndarray] = {}
        self._tracks: dict[int, np.ndarray] = {}  # id -> corners of the previous frame
        self._velocity: dict[int, np.ndarray] = {}
        self._since_full = full_every  # the first frame is a full search
        #: How many full-frame and region searches ran (for benchmarks).
        self.full_searches = 0
        self.roi_searches = 0

    # -- detection --------------------------------------------------------------------------------------
    def detect(self, image: np.ndarray) -> list[Detection]:
        """Markers in ``image`` (grey or BGR uint8), sorted by id; each with its pose."""
        gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        if gray.shape[1] != self.camera.width or gray.shape[0] != self.camera.height:
            raise ValueError(f"image is {gray.shape[1]}x{gray.shape[0]}, the camera model "
                             f"{self.camera.width}x{self.camera.height}")
        corners, ids = self.find(gray)
        out = [d for d in (self._pose(i, c) for c, i in zip(corners, ids, strict=True)) if d is not None]
        out.sort(key=lambda d: d.id)
        return out

    def find(self, gray: np.ndarray) -> tuple[list[np.ndarray], list[int]]:
        """Corners (4x2 float32 each) and ids, without poses: full frame or tracked regions."""
        self._since_full += 1
        if not self.track:
            return self._full(gray)
        if self._since_full >= self.full_every:
            corners, ids = self._full(gray)
        elif not self._tracks:  # nothing in view: new markers are looked for at the next full search
            corners, ids = [], []
        else:
            corners, ids = self._regions(gray)
            if not ids:  # everything lost (left the view, or moved too fast): look everywhere now
                corners, ids = self._full(gray)
            elif any(i not in ids for i in self._tracks):  # one lost: look everywhere in the next frame
                self._since_full = self.full_every
        self._update_tracks(corners, ids)
        return corners, ids

    def reset(self) -> None:
        """Forget tracked markers (the next frame is a full search)."""
        self._tracks.clear()
        self._velocity.clear()
        self._since_full = self.full_every

    def _full(self, gray: np.ndarray) -> tuple[list[np.ndarray], list[int]]:
        self.full_searches += 1
        self._since_full = 0
        corners, ids, _ = self._detector.detectMarkers(gray)
        if ids is None:
            return [], []
        return [c.reshape(4, 2) for c in corners], [int(i) for i in ids.reshape(-1)]

    def _regions(self, gray: np.ndarray) -> tuple[list[np.ndarray], list[int]]:
        h, w = gray.shape
        boxes = []
        for i, c in self._tracks.items():
            c = c + self._velocity.get(i, 0.0)
            side = float(np.max(np.ptp(c, axis=0)))
            pad = self.margin * side + 12.0
            x0, y0 = np.min(c, axis=0) - pad
            x1, y1 = np.max(c, axis=0) + pad
            boxes.append([max(0, int(x0)), max(0, int(y0)), min(w, int(math.ceil(x1)) + 1),
                          min(h, int(math.ceil(y1)) + 1)])
        corners: list[np.ndarray] = []
        ids: list[int] = []
        for x0, y0, x1, y1 in _merge(boxes):
            if x1 - x0 < 8 or y1 - y0 < 8:
                continue
            self.roi_searches += 1
            cs, found, _ = self._roi_detect(gray[y0:y1, x0:x1])
            if found is None:
                continue
            offset = np.array([x0, y0], dtype=np.float32)
            corners += [c.reshape(4, 2) + offset for c in cs]
            ids += [int(i) for i in found.reshape(-1)]
        return corners, ids

    def _roi_detect(self, crop: np.ndarray) -> Any:
        side = max(crop.shape)
        if side != self._roi_side:
            self._params.minMarkerPerimeterRate = self._min_perimeter_px / side
            self._params.maxMarkerPerimeterRate = self._max_perimeter_px / side
            self._roi_detector.setDetectorParameters(self._params)
            self._roi_side = side
        return self._roi_detector.detectMarkers(crop)

    def _update_tracks(self, corners: list[np.ndarray], ids: list[int]) -> None:
        tracks: dict[int, np.ndarray] = {}
        for c, i in zip(corners, ids, strict=True):
            if i in self._tracks:
                self._velocity[i] = (c.mean(axis=0) - self._tracks[i].mean(axis=0))
            else:
                self._velocity.pop(i, None)
            tracks[i] = c
        self._velocity = {i: v for i, v in self._velocity.items() if i in tracks}
        self._tracks = tracks

    # -- pose -------------------------------------------------------------------------------------------
    def size_of(self, marker_id: int) -> float:
        return self.sizes.get(marker_id, self.marker_size)

    def _pose(self, marker_id: int, corners: np.ndarray) -> Detection | None:
        """The marker's pose, or ``None`` when there is none to give (``solvePnP`` failed or its numbers are not
        finite: a degenerate camera matrix or distortion, an absurd marker size)."""
        size = self.size_of(marker_id)
        obj = self._objects.get(size)
        if obj is None:
            obj = self._objects[size] = object_points(size)
        img = corners.astype(np.float64)
        ok, rvec, tvec = cv2.solvePnP(obj, img, self.camera.K, self.camera.dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
        if not ok or rvec is None or tvec is None:
            return None
        rvec, tvec = rvec.reshape(3), tvec.reshape(3)
        proj, _ = cv2.projectPoints(obj, rvec, tvec, self.camera.K, self.camera.dist)
        error = float(np.sqrt(np.mean(np.sum((proj.reshape(4, 2) - img) ** 2, axis=1))))
        p = self._R @ tvec + self._t
        normal = self._R @ cv2.Rodrigues(rvec)[0][:, 2]
        x, y, z = float(p[0]), float(p[1]), float(p[2])
        if not (math.isfinite(x + y + z + error) and np.isfinite(rvec).all() and np.isfinite(normal).all()):
            return None
        return Detection(marker_id, corners.astype(np.float32), size, rvec, tvec, (x, y, z), math.hypot(x, y),
                         math.atan2(y, x), math.atan2(float(normal[1]), float(normal[0])), error)


def _merge(boxes: list[list[int]]) -> list[list[int]]:
    """Union overlapping boxes until none overlap (a handful of boxes: quadratic is fine)."""
    boxes = [b[:] for b in boxes]
    merged = True
    while merged:
        merged = False
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                a, b = boxes[i], boxes[j]
                if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                    boxes[i] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
                    del boxes[j]
                    merged = True
                    break
            if merged:
                break
    return boxes
