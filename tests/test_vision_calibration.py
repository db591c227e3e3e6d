"""Calibration files: OpenCV FileStorage and ROS camera_info YAML load; bad files give located errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fsm.errors import DiagramError
from fsm.vision import load_calibration

OPENCV = """%YAML:1.0
---
image_width: 1280
image_height: 720
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 9.1e+02, 0., 6.4e+02, 0., 9.2e+02, 3.6e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ 0.1, -0.25, 0.001, -0.002, 0.05 ]
"""

ROS = """image_width: 640
image_height: 480
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [600.5, 0, 320.5, 0, 601.25, 240.125, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.1, 0.01, 0, 0, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [600, 0, 320, 0, 0, 600, 240, 0, 0, 0, 1, 0]
"""


def write(tmp_path: Path, text: str, name: str = "cal.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_opencv_filestorage_yaml(tmp_path: Path) -> None:
    cam = load_calibration(write(tmp_path, OPENCV))
    assert (cam.width, cam.height) == (1280, 720)
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (910.0, 920.0, 640.0, 360.0)
    assert np.allclose(cam.dist, [0.1, -0.25, 0.001, -0.002, 0.05])


def test_ros_camera_info_yaml(tmp_path: Path) -> None:
    cam = load_calibration(write(tmp_path, ROS))
    assert (cam.width, cam.height) == (640, 480)
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (600.5, 601.25, 320.5, 240.125)
    assert np.allclose(cam.dist, [-0.1, 0.01, 0, 0, 0])


def test_plain_lists_and_image_size_from_the_caller(tmp_path: Path) -> None:
    cam = load_calibration(write(tmp_path, "camera_matrix: [[500, 0, 320], [0, 500, 240], [0, 0, 1]]\n"),
                           image_size=(640, 480))
    assert cam.fx == 500 and cam.dist.tolist() == [0, 0, 0, 0, 0]


@pytest.mark.parametrize("text,message,line", [
    ("camera_matrix: [1, 2\n  bad: : :\n", "malformed calibration file", 2),
    ("foo: 1\n", "no 'camera_matrix'", None),
    (ROS.replace("rows: 3\n  cols: 3\n  data: [600.5", "rows: 2\n  cols: 3\n  data: [600.5").replace(
        ", 0, 0, 1]\ndistortion_model", "]\ndistortion_model"), "camera_matrix must be 3x3, got 2x3", 4),
    (ROS.replace("data: [600.5, 0, 320.5, 0, 601.25, 240.125, 0, 0, 1]", "data: [600.5, 0, 320.5, 0, 601.25]"),
     "says 3x3 but has 5 values", 4),
    (ROS.replace("600.5, 0, 320.5", ".nan, 0, 320.5"), "values must be finite", 4),
    (ROS.replace("600.5, 0, 320.5", ".inf, 0, 320.5"), "values must be finite", 4),
    (ROS.replace("600.5, 0, 320.5", '"x", 0, 320.5'), "element 0 is not a number", 4),
    (ROS.replace("600.5, 0, 320.5", "-600.5, 0, 320.5"), "focal lengths must be > 0", 4),
    (ROS.replace("data: [-0.1, 0.01, 0, 0, 0]", "data: [-0.1, 0.01, 0]").replace("cols: 5", "cols: 3"),
     "distortion_coefficients has 3 values", 9),
    (ROS.replace("plumb_bob", "equidistant"), "not supported", 8),
    (ROS.replace("image_height: 480\n", ""), "image_width and image_height come together", 1),
    (ROS.replace("image_width: 640\nimage_height: 480\n", ""), "names no image size", None),
    ("", "file is empty", 1),
    ("- 1\n- 2\n", "not a calibration", 1),
])
def test_bad_calibrations_give_located_errors(tmp_path: Path, text: str, message: str, line: int | None) -> None:
    path = write(tmp_path, text)
    with pytest.raises(DiagramError) as info:
        load_calibration(path)
    (problem,) = info.value.problems
    assert problem.file == str(path) and message in problem.message, str(problem)
    assert problem.line == line, str(problem)


def test_missing_and_binary_files(tmp_path: Path) -> None:
    with pytest.raises(DiagramError, match="calibration file not found"):
        load_calibration(tmp_path / "nope.yaml")
    (tmp_path / "bin.yaml").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe")
    with pytest.raises(DiagramError, match="not a text file"):
        load_calibration(tmp_path / "bin.yaml")
    with pytest.raises(DiagramError, match="is a directory"):
        load_calibration(tmp_path)
