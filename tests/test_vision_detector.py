"""Detection on rendered frames: ids, distances and car-frame positions; a blind camera; ROI tracking."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsm.sim.camera import MarkerSpec, SimCamera
from fsm.vision import CameraModel, MarkerDetector


def scene(distance: float, yaw_deg: float = 0.0, lateral: float = 0.0, seed: int = 0, size: float = 0.15,
          camera: CameraModel | None = None, mid: int = 7) -> tuple[SimCamera, MarkerSpec]:
    m = MarkerSpec(mid, 0.15 + distance, lateral, 0.18, math.pi + math.radians(yaw_deg), size)
    return SimCamera([m], seed=seed, camera=camera), m


@pytest.mark.parametrize("distance,tolerance", [(1.0, 0.01), (2.0, 0.04)])
def test_markers_are_found_with_small_distance_error(distance: float, tolerance: float) -> None:
    errors = []
    for seed in range(5):
        cam, m = scene(distance, yaw_deg=20, lateral=0.2, seed=seed)
        det = MarkerDetector(cam.camera, mount=cam.mount)
        (d,) = det.detect(cam.render(0, 0, 0))
        assert d.id == 7
        truth, _facing = cam.truth(m, 0, 0, 0)
        errors.append(np.linalg.norm(np.array(d.position) - truth))
        assert d.distance == pytest.approx(math.hypot(truth[0], truth[1]), abs=tolerance)
        assert d.bearing == pytest.approx(math.atan2(truth[1], truth[0]), abs=math.radians(0.5))
    assert float(np.median(errors)) < tolerance


def test_several_ids_and_a_bgr_image() -> None:
    ms = [MarkerSpec(i, 2.15, -0.6 + 0.4 * k, 0.18, math.pi) for k, i in enumerate((0, 13, 42, 49))]
    cam = SimCamera(ms, seed=2)
    frame = cam.render(0, 0, 0)
    import cv2

    assert [d.id for d in MarkerDetector(cam.camera).detect(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))] == [0, 13, 42, 49]


def test_a_blind_camera_sees_nothing_so_decisions_come_from_pixels() -> None:
    """Tiny markers at 4 m on a 160x120 camera cover about 2 px: nothing is detected. The same scene with
    a sharp camera and big markers is detected, so the test can fail."""
    small = CameraModel.from_intrinsics(160, 120, 150.0)
    ms = [MarkerSpec(1, 4.15, 0.3, 0.18, math.pi, 0.05), MarkerSpec(2, 4.15, -0.3, 0.18, math.pi, 0.05)]
    blind = SimCamera(ms, camera=small, seed=1)
    assert len(blind.project(0, 0, 0)) == 2  # in view, but too small to resolve
    det = MarkerDetector(small, mount=blind.mount)
    assert all(det.detect(blind.render(0, 0, 0)) == [] for _ in range(10))
    big = [MarkerSpec(1, 1.15, 0.3, 0.18, math.pi, 0.15), MarkerSpec(2, 1.15, -0.3, 0.18, math.pi, 0.15)]
    sharp = SimCamera(big, seed=1)
    assert [d.id for d in MarkerDetector(sharp.camera).detect(sharp.render(0, 0, 0))] == [1, 2]


def test_region_tracking_finds_what_full_frames_find() -> None:
    ms = [MarkerSpec(3, 3.0, 0.35, 0.18, math.pi), MarkerSpec(4, 3.0, -0.35, 0.18, math.pi)]
    cam = SimCamera(ms, seed=3)
    full = MarkerDetector(cam.camera, mount=cam.mount)
    tracked = MarkerDetector(cam.camera, mount=cam.mount, track=True, full_every=10)
    for k in range(30):  # the car drives towards the gate and weaves a little
        frame = cam.render(0.05 * k, 0.02 * math.sin(k / 3), 0.05 * math.sin(k / 4))
        a, b = full.detect(frame), tracked.detect(frame)
        assert [d.id for d in a] == [d.id for d in b] == [3, 4]
        for da, db in zip(a, b, strict=True):
            assert np.allclose(da.corners, db.corners, atol=0.3)
    assert tracked.full_searches == 3 and tracked.roi_searches >= 27


def test_tracking_searches_everything_when_markers_leave() -> None:
    cam = SimCamera([MarkerSpec(3, 2.0, 0.0, 0.18, math.pi)], seed=3)
    det = MarkerDetector(cam.camera, track=True, full_every=50)
    assert [d.id for d in det.detect(cam.render(0, 0, 0))] == [3]
    assert det.detect(cam.render(0, 0, math.pi)) == []  # lost: a full search ran at once
    assert det.full_searches == 2
    det.detect(cam.render(0, 0, math.pi))
    assert det.full_searches == 2  # nothing tracked: wait for the next scheduled full search


def test_bad_detector_settings() -> None:
    cam = CameraModel.from_intrinsics(640, 480, 600)
    with pytest.raises(ValueError, match="marker size must be > 0"):
        MarkerDetector(cam, marker_size=0)
    with pytest.raises(ValueError, match="marker 3: size"):
        MarkerDetector(cam, sizes={3: -1.0})
    with pytest.raises(ValueError, match="unknown ArUco dictionary"):
        MarkerDetector(cam, dictionary="DICT_9X9_1")
    with pytest.raises(ValueError, match="image is 320x240"):
        MarkerDetector(cam).detect(np.zeros((240, 320), np.uint8))


def test_sizes_per_id_scale_the_distance() -> None:
    cam, m = scene(1.5, mid=5, size=0.10)
    frame = cam.render(0, 0, 0)
    (wrong,) = MarkerDetector(cam.camera, mount=cam.mount).detect(frame)
    (right,) = MarkerDetector(cam.camera, mount=cam.mount, sizes={5: 0.10}).detect(frame)
    assert right.position[0] == pytest.approx(1.65, abs=0.02)
    assert wrong.position[0] == pytest.approx(0.15 + 1.5 * 1.5, abs=0.05)


def test_camera_model_conventions() -> None:
    cam = CameraModel.from_fov(640, 480, 60)
    assert cam.hfov == pytest.approx(60) and (cam.cx, cam.cy) == (319.5, 239.5)
    half = cam.scaled(320, 240)
    assert half.fx == pytest.approx(cam.fx / 2) and half.cx == pytest.approx(159.5)
