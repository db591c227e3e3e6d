"""The simulated camera: a pinhole on the car that renders the world's ArUco markers into grey frames.

The frames go to the same :class:`fsm.vision.MarkerDetector` a real car would use, so what states see
comes from pixels. The camera pose is the simulator's ground truth (rendering only; no state reads it).

Rendering: a plain background (floor grey below the horizon, lighter wall
above), each marker in view as ``generateImageMarker`` with a one-cell white margin, taken from a
pre-generated mip pyramid and drawn with one perspective warp into its region (``BORDER_TRANSPARENT``),
far markers first, each on a post down to the floor; then a Gaussian blur, an optional vignetting
gradient, a per-frame exposure jitter and seeded noise cropped at random from a pre-generated bank.
Markers facing away, behind the camera, outside the image, or hidden behind a wall (line of sight
from the camera to the marker centre crosses a wall segment) are skipped; partial occlusion is not
modelled. The simulated lens has no distortion.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from fsm.vision.camera import CameraModel, CameraMount
from fsm.vision.detector import DEFAULT_DICTIONARY, dictionary_size, get_dictionary

#: Default camera of the TRAL car: 640x480, fx = fy = 600 px (56 degrees horizontal field of view).
DEFAULT_WIDTH, DEFAULT_HEIGHT, DEFAULT_FOCAL = 640, 480, 600.0
#: Default mount: at the front of the car, 0.18 m above the floor, looking straight ahead.
DEFAULT_MOUNT = CameraMount(x=0.15, y=0.0, height=0.18, yaw=0.0, pitch=0.0)
#: The printed sheet is the marker (6 cells: 4 data + border) plus one white cell on each side.
PAPER_CELLS, MARKER_CELLS = 8, 6
MIP_SIZES = tuple(16 << k for k in range(7))  # 16 .. 1024 px, multiples of 8 cells
NEAR = 0.02
FLOOR, WALL, POST = 120, 175, 70
POST_WIDTH = 0.03

Segment = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class MarkerSpec:
    """A marker in the world: id, centre (x, y on the floor plan; z above the floor, m), the direction
    its printed face looks to (``facing``, rad, counter-clockwise from +x) and the black square's side."""

    id: int
    x: float
    y: float
    z: float
    facing: float
    size: float = 0.15

    @property
    def paper(self) -> float:
        """Side of the white sheet the marker is printed on, m."""
        return self.size * PAPER_CELLS / MARKER_CELLS


def markers_from_gates(gates: Iterable[Any]) -> list[MarkerSpec]:
    """The markers of gates as :mod:`fsm.sim.world` describes them (``markers`` = (left id, right id),
    ``center``, ``heading`` in degrees = direction to drive through, ``width`` between the marker centres,
    ``marker_size``, ``height`` of the centres): left and right as seen when driving through, both
    facing the approaching car."""
    out = []
    for g in gates:
        h = math.radians(g.heading)
        nx, ny = -math.sin(h), math.cos(h)  # left of the driving direction
        for marker_id, side in zip(g.markers, (1.0, -1.0), strict=True):
            out.append(MarkerSpec(int(marker_id), g.center[0] + side * nx * g.width / 2,
                                  g.center[1] + side * ny * g.width / 2, float(g.height), h + math.pi,
                                  float(g.marker_size)))
    return out


@dataclass(frozen=True)
class Projected:
    """A marker in view: its spec, the black square's corners in the image (TL, TR, BR, BL as the
    detector reports them, px), its centre in the optical frame and its distance from the camera."""

    spec: MarkerSpec
    corners: np.ndarray
    center: np.ndarray
    depth: float


class SimCamera:
    """Renders grey frames of ``markers`` from a camera ``mount``-ed on a car at a given pose.

    ``occluders``: wall segments that hide markers behind them. ``blur``: Gaussian sigma, px.
    ``noise``: noise sigma, grey levels. ``lighting``: vignetting strength (0 = off; 0.25 = corners
    25 % darker). ``exposure``: per-frame gain jitter (fraction; the offset jitters by 60x that in
    grey levels). All randomness comes from ``seed``.
    """

    def __init__(self, markers: Sequence[MarkerSpec] = (), *, camera: CameraModel | None = None,
                 mount: CameraMount = DEFAULT_MOUNT, occluders: Sequence[Segment] = (),
                 dictionary: str = DEFAULT_DICTIONARY, blur: float = 0.7, noise: float = 3.0, lighting: float = 0.2,
                 exposure: float = 0.1, posts: bool = True, seed: int = 0) -> None:
        self.camera = camera or CameraModel.from_intrinsics(DEFAULT_WIDTH, DEFAULT_HEIGHT, DEFAULT_FOCAL)
        self.mount = mount
        self.dictionary_name = dictionary
        self._dictionary = get_dictionary(dictionary)
        n_ids = dictionary_size(dictionary)
        for m in markers:
            if not 0 <= m.id < n_ids:
                raise ValueError(f"marker id {m.id} is not in {dictionary} (ids 0-{n_ids - 1})")
            if not m.size > 0:
                raise ValueError(f"marker {m.id}: size must be > 0, got {m.size}")
        if np.any(self.camera.dist):
            raise ValueError("the simulated camera has no lens distortion; give a camera without distortion")
        vfov_half = math.atan2(self.camera.height / 2, self.camera.fy)
        if abs(mount.pitch) >= vfov_half:
            where = "floor" if mount.pitch > 0 else "ceiling"
            raise ValueError(f"the camera points into the {where}: pitch {math.degrees(mount.pitch):.1f} deg puts the "
                             f"horizon outside the image (half the vertical field of view is "
                             f"{math.degrees(vfov_half):.1f} deg)")
        self.markers = list(markers)
        self.blur, self.noise, self.lighting, self.exposure, self.posts = blur, noise, lighting, exposure, posts
        self._rng = np.random.default_rng(seed)
        self._R_mount = mount.rotation()
        self._t_mount = mount.translation()
        self._textures: dict[tuple[int, int], np.ndarray] = {}
        self._occ = np.array(occluders, dtype=np.float64).reshape(-1, 4)
        w, h = self.camera.width, self.camera.height
        self._background = self._make_background()
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        self._gain = np.clip(np.round(255 * (1 - lighting * r2)), 0, 255).astype(np.uint8) if lighting > 0 else None
        pad = 64
        bank = self._rng.normal(0.0, noise, (h + pad, w + pad)) if noise > 0 else None
        self._noise_pos = None if bank is None else np.clip(np.round(bank), 0, 255).astype(np.uint8)
        self._noise_neg = None if bank is None else np.clip(np.round(-bank), 0, 255).astype(np.uint8)
        self._pad = pad

    # -- geometry ---------------------------------------------------------------------------------------
    def pose_in_world(self, x: float, y: float, heading: float) -> tuple[np.ndarray, np.ndarray]:
        """Rotation and position of the optical frame in the world, for a car at ``(x, y, heading)``."""
        c, s = math.cos(heading), math.sin(heading)
        Rw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return Rw @ self._R_mount, Rw @ self._t_mount + np.array([x, y, 0.0])

    def project(self, x: float, y: float, heading: float) -> list[Projected]:
        """The markers in view from the car at ``(x, y, heading)``, far ones first."""
        R, t = self.pose_in_world(x, y, heading)
        Rt = R.T
        K = self.camera.K
        w, h = self.camera.width, self.camera.height
        out = []
        for m in self.markers:
            n = np.array([math.cos(m.facing), math.sin(m.facing), 0.0])
            cw = np.array([m.x, m.y, m.z])
            if float(np.dot(t - cw, n)) <= 0:  # seen from behind
                continue
            r_w = np.array([-math.sin(m.facing), math.cos(m.facing), 0.0])
            co, ro, uo = Rt @ (cw - t), Rt @ r_w, Rt[:, 2]
            half = m.paper / 2
            paper = np.array([co + sx * half * ro + sy * half * uo for sx, sy in ((-1, 1), (1, 1), (1, -1), (-1, -1))])
            if np.any(paper[:, 2] <= NEAR):
                continue
            pp = paper @ K.T
            pp = pp[:, :2] / pp[:, 2:]
            if pp[:, 0].max() < 0 or pp[:, 0].min() > w - 1 or pp[:, 1].max() < 0 or pp[:, 1].min() > h - 1:
                continue
            if self._occluded(t[0], t[1], m.x, m.y):
                continue
            s2 = m.size / 2
            sq = np.array([co + sx * s2 * ro + sy * s2 * uo for sx, sy in ((-1, 1), (1, 1), (1, -1), (-1, -1))]) @ K.T
            out.append(Projected(m, (sq[:, :2] / sq[:, 2:]).astype(np.float64), co, float(np.linalg.norm(co))))
        out.sort(key=lambda p: -p.depth)
        return out

    def truth(self, marker: MarkerSpec, x: float, y: float, heading: float) -> tuple[np.ndarray, float]:
        """Ground truth for metrics: the marker centre in the car frame (x forward, y left, z up) and the
        direction its face looks to in the car frame, rad."""
        c, s = math.cos(heading), math.sin(heading)
        dx, dy = marker.x - x, marker.y - y
        p = np.array([c * dx + s * dy, -s * dx + c * dy, marker.z])
        return p, math.atan2(math.sin(marker.facing - heading), math.cos(marker.facing - heading))

    def _occluded(self, ax: float, ay: float, bx: float, by: float) -> bool:
        if not len(self._occ):
            return False
        o = self._occ
        px, py, qx, qy = o[:, 0], o[:, 1], o[:, 2], o[:, 3]
        d1 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
        d2 = (qx - px) * (by - py) - (qy - py) * (bx - px)
        d3 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        d4 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
        return bool(np.any((d1 * d2 < 0) & (d3 * d4 < 0)))

    # -- rendering --------------------------------------------------------------------------------------
    def render(self, x: float, y: float, heading: float) -> np.ndarray:
        """A grey uint8 frame (height x width) seen from the car at ``(x, y, heading)``."""
        frame = self._background.copy()
        K = self.camera.K
        w, h = self.camera.width, self.camera.height
        R, t = self.pose_in_world(x, y, heading)
        Rt = R.T
        for p in self.project(x, y, heading):
            m = p.spec
            r_w = np.array([-math.sin(m.facing), math.cos(m.facing), 0.0])
            ro, uo, co = Rt @ r_w, Rt[:, 2], p.center
            half = m.paper / 2
            if self.posts:
                self._draw_post(frame, co, ro, uo, m, K)
            corners = np.array([co + sx * half * ro + sy * half * uo
                                for sx, sy in ((-1, 1), (1, 1), (1, -1), (-1, -1))])
            pp = corners @ K.T
            pp = pp[:, :2] / pp[:, 2:]
            x0, y0 = max(0, int(math.floor(pp[:, 0].min()))), max(0, int(math.floor(pp[:, 1].min())))
            x1, y1 = min(w, int(math.ceil(pp[:, 0].max())) + 2), min(h, int(math.ceil(pp[:, 1].max())) + 2)
            if x1 <= x0 or y1 <= y0:
                continue
            extent = max(pp[:, 0].max() - pp[:, 0].min(), pp[:, 1].max() - pp[:, 1].min())
            n = next((s for s in MIP_SIZES if s >= extent), MIP_SIZES[-1])
            tex = self._texture(m.id, n)
            P = m.paper
            A = np.array([[P / n, 0.0, P / (2 * n) - P / 2], [0.0, -P / n, P / 2 - P / (2 * n)], [0.0, 0.0, 1.0]])
            H = K @ np.column_stack((ro, uo, co)) @ A
            T = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
            roi = frame[y0:y1, x0:x1]
            cv2.warpPerspective(tex, T @ H, (x1 - x0, y1 - y0), dst=roi, flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_TRANSPARENT)
        if self.blur > 0:
            cv2.GaussianBlur(frame, (0, 0), self.blur, dst=frame)
        if self._gain is not None:
            cv2.multiply(frame, self._gain, dst=frame, scale=1 / 255)
        if self.exposure > 0:
            gain = 1.0 + self._rng.uniform(-self.exposure, self.exposure)
            offset = 60.0 * self.exposure * self._rng.uniform(-1, 1)
            lut = np.clip(np.arange(256) * gain + offset, 0, 255).astype(np.uint8)
            cv2.LUT(frame, lut, dst=frame)
        if self._noise_pos is not None and self._noise_neg is not None:
            oy, ox = (int(v) for v in self._rng.integers(0, self._pad, 2))
            cv2.add(frame, self._noise_pos[oy:oy + h, ox:ox + w], dst=frame)
            cv2.subtract(frame, self._noise_neg[oy:oy + h, ox:ox + w], dst=frame)
        return frame

    def _draw_post(self, frame: np.ndarray, co: np.ndarray, ro: np.ndarray, uo: np.ndarray, m: MarkerSpec,
                   K: np.ndarray) -> None:
        """A post from the bottom of the sheet to the floor, just behind the marker's plane."""
        top = m.paper / 2
        bottom = m.z
        if bottom <= top:
            return
        back = np.cross(ro, uo) * -0.01
        pts = np.array([co + back + sx * POST_WIDTH / 2 * ro + sy * uo
                        for sx, sy in ((-1, -top), (1, -top), (1, -bottom), (-1, -bottom))])
        if np.any(pts[:, 2] <= NEAR):
            return
        pp = pts @ K.T
        pp = pp[:, :2] / pp[:, 2:]
        if np.abs(pp).max() > 1e5:
            return
        cv2.fillConvexPoly(frame, np.round(pp * 16).astype(np.int32), POST, cv2.LINE_AA, 4)

    def _texture(self, marker_id: int, n: int) -> np.ndarray:
        key = (marker_id, n)
        tex = self._textures.get(key)
        if tex is None:
            cell = n // PAPER_CELLS
            marker = cv2.aruco.generateImageMarker(self._dictionary, marker_id, cell * MARKER_CELLS, borderBits=1)
            tex = self._textures[key] = cv2.copyMakeBorder(marker, cell, cell, cell, cell, cv2.BORDER_CONSTANT,
                                                           value=255)
        return tex

    def _make_background(self) -> np.ndarray:
        """Floor below the horizon, wall above; the horizon row follows the pitch (the camera does not roll)."""
        w, h = self.camera.width, self.camera.height
        horizon = self.camera.cy - self.camera.fy * math.tan(self.mount.pitch)
        rows = np.arange(h, dtype=np.float64)
        column = np.where(rows < horizon, WALL, FLOOR).astype(np.uint8)
        bg = np.repeat(column[:, None], w, axis=1)
        return np.ascontiguousarray(bg)
