"""Calibration files: OpenCV FileStorage YAML/XML/JSON and ROS camera_info YAML load; bad and hostile files give
located errors, quickly, and FileStorage never sees a text that is not small and simple; fuzzed files give a sane
camera or our own error."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any
from unittest import mock

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.model.errors import DiagramError
from fsm.vision import load_calibration
from fsm.vision.calibration import parse_calibration

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


# -- every form OpenCV writes ------------------------------------------------------------------------------
def opencv_written(fmt: int, suffix: str, extra: bool = True) -> str:
    """A calibration as OpenCV's own FileStorage writes it, with what its calibration sample adds (every view's
    image points, extrinsics and errors, the time)."""
    fs = cv2.FileStorage(f"cal.{suffix}", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY | fmt)
    fs.write("calibration_time", "Mon Nov 25 12:00:00 2024")
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", np.array([[600.0, 0, 319.5], [0, 600, 239.5], [0, 0, 1]]))
    fs.write("distortion_coefficients", np.array([[0.1, -0.2, 0.001, 0.002, 0.05]]))
    if extra:
        fs.write("per_view_reprojection_errors", np.full((25, 1), 0.2, np.float32))
        fs.write("extrinsic_parameters", np.zeros((25, 6)))
        fs.write("image_points", np.zeros((25, 54, 2), np.float32))
    return str(fs.releaseAndGetString())


@pytest.mark.parametrize("fmt,suffix", [(cv2.FILE_STORAGE_FORMAT_YAML, "yaml"), (cv2.FILE_STORAGE_FORMAT_XML, "xml"),
                                        (cv2.FILE_STORAGE_FORMAT_JSON, "json")])
def test_what_opencv_writes_loads(tmp_path: Path, fmt: int, suffix: str) -> None:
    for extra in (False, True):
        cam = load_calibration(write(tmp_path, opencv_written(fmt, suffix, extra), f"cal.{suffix}"))
        assert (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy) == (640, 480, 600, 600, 319.5, 239.5)
        assert np.allclose(cam.dist, [0.1, -0.2, 0.001, 0.002, 0.05])


def test_opencv_yaml_without_the_header_and_a_json_calibration(tmp_path: Path) -> None:
    headless = OPENCV.replace("%YAML:1.0\n---\n", "")
    assert load_calibration(write(tmp_path, headless)).fx == 910.0
    doc = {"image_width": 640, "image_height": 480, "camera_matrix": [[600, 0, 320], [0, 600, 240], [0, 0, 1]],
           "distortion_coefficients": {"rows": 1, "cols": 5, "data": [0, 0, 0, 0, 0]}}
    assert load_calibration(write(tmp_path, json.dumps(doc), "cal.json")).cx == 320


# -- hostile calibrations ------------------------------------------------------------------------------------
def nested(depth: int) -> str:
    return "camera_matrix: " + "[" * depth + "1" + "]" * depth + "\n"


HOSTILE = [
    pytest.param(nested(40_000), "file is 80,017 bytes; a calibration is a few hundred", None, id="40000-deep"),
    pytest.param("camera_matrix: [" + ", ".join(["1"] * 190_000) + "]\n", "the limit is 65,536", None, id="190000"),
    pytest.param(nested(20_000), "nested more than 8 levels deep", 1, id="20000-deep"),
    pytest.param('{"camera_matrix": ' + "[" * 9 + "1" + "]" * 9 + "}", "nested more than 8 levels", 1, id="json-deep"),
    pytest.param("".join(" " * i + f"k{i}:\n" for i in range(40)), "nested more than 8 levels", 9, id="indented"),
    pytest.param("camera_matrix:\n" + "- " * 20 + "1\n", "nested more than 8 levels deep", 2, id="dashes"),
    pytest.param('<?xml version="1.0"?>\n<opencv_storage>\n' + "<_>" * 9 + "1" + "</_>" * 9 + "</opencv_storage>\n",
                 "nested more than 8 levels deep", 3, id="xml-deep"),
    pytest.param("camera_matrix: [" + ",".join(["1"] * 20_000) + "]\n", "more than 10,000 values", 1, id="values"),
    pytest.param('{"image_width": ' + "9" * 5000 + "}", "a value of 5,000 characters", 1, id="json-digits"),
    pytest.param("image_width: " + "9" * 300 + "\n", "a value of 300 characters (at most 256)", 1, id="digits"),
    pytest.param(ROS.replace("data: [600.5", "data: &k [600.5") + "copy: *k\n", "YAML anchor '&k'", 7, id="anchor"),
    pytest.param(ROS + "copy: *k\n", "YAML alias '*k'", 21, id="alias"),
    pytest.param(ROS.replace("image_width: 640", "image_width: !!int 640"), "YAML tag '!!int'", 1, id="tag"),
    pytest.param(ROS + "blob: !!binary AAAA\n", "YAML tag '!!binary'", 21, id="binary"),
    pytest.param("%TAG ! tag:example.com,2000:\n---\n" + ROS, "YAML directive '%TAG'", 1, id="directive"),
    pytest.param(ROS.replace("narrow_stereo", "narrow\0stereo"), "control character U+0000", 3, id="nul"),
    pytest.param('<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY a "aaaaaaaa">]>\n<opencv_storage>\n'
                 "<image_width>&a;</image_width></opencv_storage>\n", "XML declaration '<!DOCTYPE", 2, id="doctype"),
    pytest.param('<?xml version="1.0"?>\n<opencv_storage>\n<camera_matrix type_id="opencv-sparse-matrix">'
                 "</camera_matrix></opencv_storage>\n", "type_id 'opencv-sparse-matrix'", 3, id="type_id"),
    pytest.param(ROS + "image_width: 320\n", "duplicate key 'image_width' (first at line 1)", 21, id="dup-yaml"),
    pytest.param(ROS.replace("  rows: 3\n  cols: 3\n", "  rows: 3\n  rows: 3\n  cols: 3\n", 1),
                 "camera_matrix: duplicate key 'rows'", 4, id="dup-nested"),
    pytest.param(ROS.replace("image_width: 640", "image_width: 40000000000000").replace(
        "image_height: 480", "image_height: 30000000000000"), "= 1.2e+27 pixels; the limit is 50,000,000", 1,
        id="4e13x3e13"),
    pytest.param(ROS.replace("data: [600.5, 0, 320.5, 0, 601.25", "data: [0.001, 0, 320.5, 0, 601.25"),
                 "fx=0.001 px gives a horizontal field of view of 180 deg at 640x480; a pinhole camera has 1-179 deg",
                 4, id="hfov-180"),
    pytest.param(ROS.replace("data: [600.5, 0, 320.5, 0, 601.25", "data: [600.5, 0, 320.5, 0, 1e9"),
                 "fy=1e+09 px gives a vertical field of view of 2.75e-05 deg", 4, id="vfov-0"),
    pytest.param(ROS.replace("data: [600.5, 0, 320.5, 0, 601.25, 240.125", "data: [600.5, 0, 320.5, 0, 601.25, -3"),
                 "the principal point (cx, cy) = (320.5, -3) is outside the 640x480 image", 4, id="principal-point"),
    pytest.param(ROS.replace("data: [-0.1, 0.01, 0, 0, 0]", "data: [1e300, 0.01, 0, 0, 0]"),
                 "distortion_coefficients: element 0 is 1e+300", 9, id="distortion"),
    pytest.param(ROS.replace("data: [600.5, 0, 320.5, 0, 601.25, 240.125, 0, 0, 1]", "data: [" + "1, " * 400 + "1]"),
                 "camera_matrix has 401 values; a calibration matrix has at most 16", 4, id="long-matrix"),
]


@pytest.mark.parametrize("text,message,line", HOSTILE)
def test_hostile_calibrations_are_refused_quickly_and_located(tmp_path: Path, text: str, message: str,
                                                              line: int | None) -> None:
    path = write(tmp_path, text)
    t0 = time.perf_counter()
    with pytest.raises(DiagramError) as info:
        load_calibration(path)
    assert time.perf_counter() - t0 < 0.5
    (problem,) = info.value.problems
    assert problem.file == str(path) and message in problem.message, str(problem)
    assert problem.line == line, str(problem)


@pytest.mark.parametrize("text", [nested(20_000), "camera_matrix: [" + ",".join(["1"] * 20_000) + "]\n",
                                  ROS + "copy: *k\n", OPENCV.replace("dt: d", "dt: !!str d")])
def test_filestorage_never_sees_a_text_that_is_refused(tmp_path: Path, text: str) -> None:
    with mock.patch.object(cv2, "FileStorage", side_effect=AssertionError("parsed")), pytest.raises(DiagramError):
        load_calibration(write(tmp_path, text))


def test_a_camera_seeing_180_degrees_gets_one_message_per_axis(tmp_path: Path) -> None:
    path = write(tmp_path, ROS.replace("data: [600.5, 0, 320.5, 0, 601.25", "data: [0.001, 0, 320.5, 0, 0.001"))
    with pytest.raises(DiagramError) as info:
        load_calibration(path)
    assert [p.line for p in info.value.problems] == [4, 4]
    assert ["horizontal" in p.message for p in info.value.problems] == [True, False]


def test_json_calibrations_go_through_the_strict_reader(tmp_path: Path) -> None:
    good = {"image_width": 640, "image_height": 480, "camera_matrix": [600, 0, 319.5, 0, 600, 239.5, 0, 0, 1]}
    text = json.dumps(good, indent=1).replace('"image_height": 480', '"image_height": 480,\n "image_width": 320')
    with pytest.raises(DiagramError) as info:
        load_calibration(write(tmp_path, text, "cal.json"))
    (problem,) = info.value.problems
    assert "duplicate key 'image_width' (first at line 2, column 2)" in problem.message
    assert (problem.line, problem.column) == (4, 2)
    cases = [({**good, "image_width": 640.0}, "image_width must be a whole number", (2, 2)),
             ({**good, "image_width": True}, "image_width must be a whole number", (2, 2)),
             ({**good, "camera_matrix": [True] + good["camera_matrix"][1:]}, "element 0 is not a number", (4, 2)),
             ({**good, "camera_matrix": list(range(5000))}, "has 5000 values", (4, 2))]
    for doc, message, (line, column) in cases:
        with pytest.raises(DiagramError) as info:
            load_calibration(write(tmp_path, json.dumps(doc, indent=1), "cal.json"))
        (problem,) = info.value.problems
        assert message in problem.message and (problem.line, problem.column) == (line, column), str(problem)


def test_the_pixel_limit_of_the_calibrated_size_follows_the_environment(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    path = write(tmp_path, ROS)
    monkeypatch.setenv("FSM_MAX_IMAGE_PIXELS", str(640 * 480 - 1))
    with pytest.raises(DiagramError, match="640x480 = 307,200 pixels; the limit is 307,199"):
        load_calibration(path)
    monkeypatch.setenv("FSM_MAX_IMAGE_PIXELS", str(640 * 480))
    assert load_calibration(path).width == 640


# -- fuzz ---------------------------------------------------------------------------------------------------
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
REAL = [OPENCV, ROS, OPENCV.replace("%YAML:1.0\n---\n", "")] + [
    opencv_written(fmt, suffix, extra=False) for fmt, suffix in ((cv2.FILE_STORAGE_FORMAT_XML, "xml"),
                                                                  (cv2.FILE_STORAGE_FORMAT_JSON, "json"),
                                                                  (cv2.FILE_STORAGE_FORMAT_YAML, "yaml"))]


def camera_or_our_error(raw: bytes) -> None:
    """A calibration gives a sane camera or a DiagramError naming the file; never anything else."""
    try:
        cam = parse_calibration(raw, "fuzz.yaml")
    except DiagramError as exc:
        assert exc.problems and all(p.file == "fuzz.yaml" for p in exc.problems)
        return
    assert 0 < cam.width * cam.height <= 50_000_000
    assert np.isfinite(cam.K).all() and np.isfinite(cam.dist).all()
    assert 1 <= cam.hfov <= 179 and 1 <= cam.vfov <= 179
    assert -0.5 <= cam.cx <= cam.width - 0.5 and -0.5 <= cam.cy <= cam.height - 0.5


numbers = st.one_of(st.integers(-(2**70), 2**70), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([0, 1, -1, 1e-300, 1e300, 319.5, 600.0]))
scalars = st.one_of(numbers, st.booleans(), st.none(), st.text(alphabet="ab: -#&*![]{}'\"", max_size=6))
matrices = st.one_of(
    st.lists(numbers, max_size=20), st.lists(st.lists(numbers, max_size=4), max_size=4),
    st.fixed_dictionaries({"rows": st.one_of(st.integers(-2, 4), scalars), "cols": st.one_of(st.integers(-2, 6),
                                                                                             scalars),
                           "data": st.one_of(st.lists(numbers, max_size=20), scalars)}),
    scalars)
documents = st.fixed_dictionaries({}, optional={
    "image_width": st.one_of(st.integers(-5, 10**15), scalars), "image_height": st.one_of(st.integers(-5, 10**15),
                                                                                         scalars),
    "camera_matrix": matrices, "distortion_coefficients": matrices,
    "distortion_model": st.one_of(st.sampled_from(["plumb_bob", "equidistant"]), scalars)})


def to_yaml(value: Any, indent: int = 0) -> str:
    """A small YAML writer (flow lists, block mappings, as ROS and OpenCV write them)."""
    if isinstance(value, dict):
        pad = " " * indent
        return "".join(f"{pad}{k}:" + (f"\n{to_yaml(v, indent + 2)}" if isinstance(v, dict) else f" {to_yaml(v)}\n")
                       for k, v in value.items())
    if isinstance(value, list):
        return "[" + ", ".join(to_yaml(v) for v in value) + "]"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and not math.isfinite(value):
        return ".nan" if math.isnan(value) else ".inf" if value > 0 else "-.inf"
    return "~" if value is None else json.dumps(value) if isinstance(value, str) else repr(value)


@FUZZ
@given(st.binary(max_size=300))
def test_fuzz_random_bytes(raw: bytes) -> None:
    camera_or_our_error(raw)


@FUZZ
@given(st.text(alphabet="[]{}:,-&*!%#'\"<>/?|\n \t0123456789.eE+_abcdimgtrwhx", max_size=300))
def test_fuzz_yaml_punctuation(text: str) -> None:
    camera_or_our_error(text.encode())


@FUZZ
@given(documents, st.sampled_from(["json", "yaml", "yaml-header"]))
def test_fuzz_documents_of_the_right_shape_with_wrong_values(doc: dict[str, Any], form: str) -> None:
    if form == "json":
        text = json.dumps(doc)
    else:
        text = ("%YAML:1.0\n---\n" if form == "yaml-header" else "") + (to_yaml(doc) or "foo: 1\n")
    camera_or_our_error(text.encode())


@FUZZ
@given(st.sampled_from(REAL), st.floats(0, 1))
def test_fuzz_truncated_real_calibrations(text: str, cut: float) -> None:
    camera_or_our_error(text.encode()[:int(len(text) * cut)])


@FUZZ
@given(st.sampled_from(REAL), st.lists(st.tuples(st.floats(0, 1), st.sampled_from(list("[]{}:,-&*!%#'\"<> \n\t9.e"))),
                                       min_size=1, max_size=5))
def test_fuzz_real_calibrations_with_punctuation_inserted(text: str, edits: list[tuple[float, str]]) -> None:
    for at, char in edits:
        k = int(len(text) * at)
        text = text[:k] + char + text[k:]
    camera_or_our_error(text.encode())
