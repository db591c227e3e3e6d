"""The simulated camera: geometry against OpenCV's projection, what is skipped, determinism, bad set-ups."""

from __future__ import annotations

import math
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from fsm.sim.camera import MarkerSpec, SimCamera, markers_from_gates
from fsm.vision import CameraModel, CameraMount, MarkerDetector
from fsm.vision.detector import object_points


def clean_camera(markers: list[MarkerSpec], **kw: object) -> SimCamera:
    return SimCamera(markers, blur=0.0, noise=0.0, lighting=0.0, exposure=0.0, posts=False, **kw)  # type: ignore[arg-type]


def marker_at(distance: float, yaw_deg: float, mid: int = 3, size: float = 0.15, lateral: float = 0.0) -> MarkerSpec:
    """A marker ``distance`` m ahead of the default camera (car at the origin, heading 0), turned by ``yaw``."""
    return MarkerSpec(mid, 0.15 + distance, lateral, 0.18, math.pi + math.radians(yaw_deg), size)


def opencv_projection(cam: SimCamera, m: MarkerSpec, pose: tuple[float, float, float]) -> np.ndarray:
    """The marker's corners through cv2.projectPoints, from its pose built independently of the renderer."""
    R, t = cam.pose_in_world(*pose)
    r = np.array([-math.sin(m.facing), math.cos(m.facing), 0.0])
    u = np.array([0.0, 0.0, 1.0])
    n = np.array([math.cos(m.facing), math.sin(m.facing), 0.0])
    R_marker_world = np.column_stack((r, u, n))
    R_marker_opt = R.T @ R_marker_world
    t_opt = R.T @ (np.array([m.x, m.y, m.z]) - t)
    rvec, _ = cv2.Rodrigues(R_marker_opt)
    pts, _ = cv2.projectPoints(object_points(m.size), rvec, t_opt, cam.camera.K, cam.camera.dist)
    return pts.reshape(4, 2)


@pytest.mark.parametrize("distance,yaw,pose",
                         [(1.0, 0, (0, 0, 0)), (2.0, 30, (0, 0, 0.1)), (1.5, -45, (0.2, 0.1, -0.05))])
def test_projected_corners_are_opencvs_projection(distance: float, yaw: float,
                                                  pose: tuple[float, float, float]) -> None:
    m = marker_at(distance, yaw)
    cam = clean_camera([m])
    (p,) = cam.project(*pose)
    assert np.abs(p.corners - opencv_projection(cam, m, pose)).max() < 1e-6


@pytest.mark.parametrize("distance,yaw", [(0.7, 0), (1.0, 0), (1.0, 30), (2.0, 0), (2.0, 45)])
def test_rendered_corners_match_the_projection_within_half_a_pixel(distance: float, yaw: float) -> None:
    """The pixels: sub-pixel corners found in a noise-free render lie on the analytic projection."""
    m = marker_at(distance, yaw)
    cam = clean_camera([m])
    frame = cam.render(0, 0, 0)
    corners, ids = MarkerDetector(cam.camera).find(frame)
    assert ids == [3]
    err = np.linalg.norm(corners[0] - opencv_projection(cam, m, (0, 0, 0)), axis=1)
    assert err.mean() < 0.5 and err.max() < 0.8, err


def test_rendered_paper_covers_its_projected_area() -> None:
    """Mip level and homography are right: the bright paper plus the dark marker cover the projected sheet."""
    m = marker_at(1.2, 20)
    cam = clean_camera([m])
    frame = cam.render(0, 0, 0).astype(np.float64)
    background = cam.render(0, 0, math.pi).astype(np.float64)  # the same view with the marker behind the car
    changed = np.abs(frame - background) > 20
    (p,) = cam.project(0, 0, 0)
    sheet = (p.corners - p.corners.mean(axis=0)) * (8 / 6) + p.corners.mean(axis=0)  # approximately
    area = cv2.contourArea(sheet.astype(np.float32))
    assert abs(changed.sum() - area) / area < 0.06


def test_markers_behind_facing_away_outside_or_behind_a_wall_are_skipped() -> None:
    ahead = marker_at(2.0, 0, mid=1)
    cam = clean_camera([ahead])
    assert [p.spec.id for p in cam.project(0, 0, 0)] == [1]
    assert cam.project(0, 0, math.pi) == []  # behind the camera
    assert cam.project(0, 0, math.radians(60)) == []  # outside the field of view
    away = MarkerSpec(2, 2.15, 0, 0.18, 0.0)  # its face looks away from the car
    assert clean_camera([away]).project(0, 0, 0) == []
    walled = clean_camera([ahead], occluders=[((1.0, -1.0), (1.0, 1.0))])
    assert walled.project(0, 0, 0) == []
    assert clean_camera([ahead], occluders=[((1.0, 0.5), (1.0, 1.0))]).project(0, 0, 0) != []
    frame = walled.render(0, 0, 0)
    assert MarkerDetector(walled.camera).detect(frame) == []


def test_far_markers_are_drawn_first() -> None:
    near, far = marker_at(1.0, 0, mid=1), marker_at(3.0, 0, mid=2)
    assert [p.spec.id for p in clean_camera([near, far]).project(0, 0, 0)] == [2, 1]


def test_frames_are_seeded() -> None:
    m = [marker_at(1.5, 10)]
    a, b, c = SimCamera(m, seed=4), SimCamera(m, seed=4), SimCamera(m, seed=5)
    fa, fb, fc = a.render(0, 0, 0), b.render(0, 0, 0), c.render(0, 0, 0)
    assert fa.shape == (480, 640) and fa.dtype == np.uint8
    assert np.array_equal(fa, fb) and not np.array_equal(fa, fc)
    assert not np.array_equal(fa, a.render(0, 0, 0))  # noise differs from frame to frame


def test_gates_of_a_world_become_left_and_right_markers_facing_the_car() -> None:
    gate = SimpleNamespace(markers=(8, 9), center=(5.0, 2.0), heading=90.0, width=0.8, marker_size=0.12, height=0.2)
    left, right = markers_from_gates([gate])
    assert (left.id, right.id) == (8, 9)
    assert (left.x, left.y) == pytest.approx((4.6, 2.0)) and (right.x, right.y) == pytest.approx((5.4, 2.0))
    assert math.cos(left.facing - math.radians(270)) == pytest.approx(1.0)
    assert left.size == 0.12 and left.z == 0.2


def test_bad_set_ups_are_refused() -> None:
    with pytest.raises(ValueError, match="into the floor"):
        SimCamera([], mount=CameraMount(pitch=math.radians(40)))
    with pytest.raises(ValueError, match="not in DICT_4X4_50"):
        SimCamera([MarkerSpec(50, 1, 0, 0.2, math.pi)])
    with pytest.raises(ValueError, match="size must be > 0"):
        SimCamera([MarkerSpec(1, 1, 0, 0.2, math.pi, 0.0)])
    with pytest.raises(ValueError, match="distortion"):
        SimCamera([], camera=CameraModel.from_intrinsics(640, 480, 600, dist=[0.1, 0, 0, 0, 0]))
    SimCamera([], mount=CameraMount(pitch=math.radians(15)))  # looking down a little is fine
