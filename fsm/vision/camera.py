"""The pinhole camera: intrinsics (:class:`CameraModel`) and where it sits on the car (:class:`CameraMount`).

The mount turns points from OpenCV's optical frame (x right, y down, z forward) into the car frame
(x forward, y left, z up): a camera at ``(x, y, height)`` on the car, turned by ``yaw`` (left positive)
and tilted down by ``pitch`` (down positive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Horizontal field of view assumed for an image without a calibration, degrees (a typical webcam).
DEFAULT_FOV = 60.0
#: The horizontal and vertical field of view a calibration may give, degrees: 180 is a focal length of 0 (the
#: pinhole model breaks down), and under 1 degree a marker across the room is a speck.
FOV_RANGE = (1.0, 179.0)
#: The field of view an image without a calibration may be assumed to have, degrees (a rectilinear lens; a wider
#: one is a fisheye and needs its calibration).
ASSUMED_FOV_RANGE = (1.0, 170.0)

#: Optical axes in the camera's body frame (x forward, y left, z up): columns are optical x, y, z.
_BODY_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


@dataclass(frozen=True, eq=False)
class CameraModel:
    """Image size, camera matrix ``K`` (3x3) and distortion coefficients (OpenCV's order, may be empty)."""

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64).reshape(3, 3)
        dist = np.asarray(self.dist, dtype=np.float64).reshape(-1)
        if not (self.width > 0 and self.height > 0):
            raise ValueError(f"image size must be positive, got {self.width}x{self.height}")
        if not (np.isfinite(K).all() and np.isfinite(dist).all()):
            raise ValueError("camera matrix and distortion must be finite numbers")
        if not (K[0, 0] > 0 and K[1, 1] > 0):
            raise ValueError(f"focal lengths must be > 0, got fx={K[0, 0]:g}, fy={K[1, 1]:g}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)

    @classmethod
    def from_intrinsics(cls, width: int, height: int, fx: float, fy: float | None = None, cx: float | None = None,
                        cy: float | None = None, dist: np.ndarray | list[float] | None = None) -> CameraModel:
        """From focal lengths in pixels; the principal point defaults to the image centre ((w-1)/2, (h-1)/2)."""
        fy = fx if fy is None else fy
        cx = (width - 1) / 2 if cx is None else cx
        cy = (height - 1) / 2 if cy is None else cy
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        return cls(int(width), int(height), K, np.zeros(5) if dist is None else np.asarray(dist, np.float64))

    @classmethod
    def from_fov(cls, width: int, height: int, hfov: float = DEFAULT_FOV) -> CameraModel:
        """A distortion-free pinhole with horizontal field of view ``hfov`` degrees and square pixels."""
        if not 0 < hfov < 180:
            raise ValueError(f"field of view must be between 0 and 180 degrees, got {hfov:g}")
        fx = (width / 2) / math.tan(math.radians(hfov) / 2)
        return cls.from_intrinsics(width, height, fx)

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def hfov(self) -> float:
        """Horizontal field of view, degrees."""
        return field_of_view(self.width, self.fx)

    @property
    def vfov(self) -> float:
        """Vertical field of view, degrees."""
        return field_of_view(self.height, self.fy)

    def scaled(self, width: int, height: int) -> CameraModel:
        """The same camera at another resolution (a calibration made at 1280x960 used at 640x480)."""
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        K[0, 0] *= sx
        K[1, 1] *= sy
        K[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
        K[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
        return CameraModel(int(width), int(height), K, self.dist.copy())

    def describe(self) -> str:
        return (f"{self.width}x{self.height}, fx={self.fx:.1f} fy={self.fy:.1f} cx={self.cx:.1f} cy={self.cy:.1f}, "
                f"hfov {self.hfov:.1f} deg" + (", distortion " + " ".join(f"{d:g}" for d in self.dist)
                                              if self.dist.size and np.any(self.dist) else ""))


def field_of_view(size_px: float, focal_px: float) -> float:
    """The field of view, degrees, of a pinhole whose image is ``size_px`` wide with focal length ``focal_px``."""
    return math.degrees(2 * math.atan2(size_px / 2, focal_px))


def pinhole_problems(width: int, height: int, fx: float, fy: float, cx: float, cy: float) -> list[str]:
    """Why these intrinsics are no usable camera (each a sentence), or nothing: focal lengths > 0 and a field of
    view in :data:`FOV_RANGE` both ways, the principal point inside the image."""
    values = (width, height, fx, fy, cx, cy)
    if not all(math.isfinite(v) for v in values):
        return ["the camera matrix and image size must be finite numbers"]
    if not (fx > 0 and fy > 0):
        return [f"focal lengths must be > 0, got fx={fx:g}, fy={fy:g}"]
    low, high = FOV_RANGE
    problems = []
    for axis, size, focal, name in (("horizontal", width, fx, "fx"), ("vertical", height, fy, "fy")):
        fov = field_of_view(size, focal)
        if not low <= fov <= high:
            problems.append(f"{name}={focal:g} px gives a {axis} field of view of {fov:.4g} deg at {width}x{height}; "
                            f"a pinhole camera has {low:g}-{high:g} deg")
    if not (-0.5 <= cx <= width - 0.5 and -0.5 <= cy <= height - 0.5):
        problems.append(f"the principal point (cx, cy) = ({cx:g}, {cy:g}) is outside the {width}x{height} image")
    return problems


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the car: position (m, car frame), ``yaw`` (rad, left positive) and ``pitch``
    (rad, down positive). The default puts the camera at the car frame's origin, looking straight ahead."""

    x: float = 0.0
    y: float = 0.0
    height: float = 0.0
    yaw: float = 0.0
    pitch: float = 0.0

    def rotation(self) -> np.ndarray:
        """Rotation taking optical-frame vectors to car-frame vectors (3x3)."""
        cy_, sy_ = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        yaw = np.array([[cy_, -sy_, 0.0], [sy_, cy_, 0.0], [0.0, 0.0, 1.0]])
        pitch = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])  # about +y: forward tilts down
        rotation: np.ndarray = yaw @ pitch @ _BODY_FROM_OPTICAL  # numpy types the product of arrays as Any
        return rotation

    def translation(self) -> np.ndarray:
        return np.array([self.x, self.y, self.height])

    def to_car(self, p_optical: np.ndarray) -> np.ndarray:
        """A point (or N x 3 points) from the optical frame into the car frame."""
        p = np.asarray(p_optical, dtype=np.float64)
        point: np.ndarray = p @ self.rotation().T + self.translation()  # numpy types the product as Any
        return point
