"""``fsmctl detect`` on what a hostile trial gave it: out-of-range flags are usage errors, huge and damaged images
and absurd calibrations are one located message each (no traceback, no decoder chatter, no NaN), and ``-`` reads
one image or the calibration from standard input."""

from __future__ import annotations

import io
import json
import math
import os
import struct
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from fsm.sim.camera import CameraMount, SimCamera, markers_from_gates
from fsm.tools.cli import main
from fsm.vision import CameraModel, MarkerDetector

CALIBRATION = """image_width: 640
image_height: 480
camera_matrix:
  rows: 3
  cols: 3
  data: [600, 0, 319.5, 0, 600, 239.5, 0, 0, 1]
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0, 0, 0, 0, 0]
"""


def run(capfd: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """``fsmctl argv`` in-process; stdout and stderr at the file-descriptor level, where libpng writes."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    out, err = capfd.readouterr()
    assert "Traceback" not in err
    return code, out, err


@pytest.fixture(scope="module")
def gate(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A gate (ids 6 and 9) 1.5 m ahead, and the calibration of the camera that took it."""
    folder = tmp_path_factory.mktemp("detect")
    spec = SimpleNamespace(markers=(6, 9), center=(1.5, 0.1), heading=15.0, width=0.7, marker_size=0.15, height=0.0)
    cam = SimCamera(markers_from_gates([spec]), mount=CameraMount(), posts=False, seed=7)
    assert cv2.imwrite(str(folder / "gate.png"), cam.render(0, 0, 0))
    (folder / "cal.yaml").write_text(CALIBRATION)
    return folder / "gate.png"


def stdin(monkeypatch: pytest.MonkeyPatch, data: bytes) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))


@pytest.mark.parametrize("argv,message", [
    (["--fov", "180"], "argument --fov: must be between 1 and 170 degrees, got 180"),
    (["--fov", "1e-300"], "must be between 1 and 170 degrees, got 1e-300"),
    (["--fov", "nan"], "must be between 1 and 170 degrees, got nan"),
    (["--fov", "wide"], "expected a number, got 'wide'"),
    (["--marker-size", "1e-320"], "argument --marker-size: must be more than 0.001 m and at most 10 m, got 1e-320"),
    (["--marker-size", "1e308"], "must be more than 0.001 m and at most 10 m, got 1e308"),
    (["--marker-size", "0.001"], "must be more than 0.001 m"),
    (["--marker-size", "inf"], "must be more than 0.001 m"),
])
def test_flags_out_of_their_physical_range_are_usage_errors(gate: Path, capfd: pytest.CaptureFixture[str],
                                                            argv: list[str], message: str) -> None:
    code, out, err = run(capfd, "detect", str(gate), *argv)
    assert code == 2 and out == "" and message in err, err


@pytest.mark.parametrize("argv", [["--fov", "1"], ["--fov", "170"], ["--marker-size", "0.0011"],
                                  ["--marker-size", "10"]])
def test_the_ends_of_the_ranges_give_finite_numbers(gate: Path, capfd: pytest.CaptureFixture[str],
                                                    argv: list[str]) -> None:
    code, out, err = run(capfd, "detect", str(gate), "--format", "json", *argv)
    assert code == 0, err
    assert "NaN" not in out and "Infinity" not in out
    json.loads(out, parse_constant=lambda name: pytest.fail(f"{name} in the output"))


def test_a_pose_solvepnp_cannot_give_is_dropped_not_raised(gate: Path) -> None:
    image = cv2.imread(str(gate), cv2.IMREAD_GRAYSCALE)
    for camera, size in ((CameraModel.from_fov(640, 480, 1e-6), 0.15), (CameraModel.from_fov(640, 480, 60), 1e308),
                         (CameraModel(640, 480, np.array([[600, 0, 319.5], [0, 600, 239.5], [0, 0, 1]]),
                                      np.array([1e300, 0, 0, 0, 0])), 0.15)):
        detector = MarkerDetector(camera, marker_size=size)
        assert len(detector.find(image)[1]) == 2  # both markers are found, but no pose can be given
        assert detector.detect(image) == []
    for d in MarkerDetector(CameraModel.from_fov(640, 480, 60), marker_size=10).detect(image):
        assert all(math.isfinite(v) for v in (*d.position, d.distance, d.bearing, d.facing, d.error))


def test_standard_input_gives_one_image_or_the_calibration(gate: Path, capfd: pytest.CaptureFixture[str],
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    cal = gate.parent / "cal.yaml"
    code, by_name, err = run(capfd, "detect", str(gate), "--calibration", str(cal))
    assert code == 0, err
    stdin(monkeypatch, gate.read_bytes())
    code, out, err = run(capfd, "detect", "-", "--calibration", str(cal))
    assert code == 0 and out == by_name.replace(str(gate), "<stdin>"), err
    stdin(monkeypatch, cal.read_bytes())
    code, out, err = run(capfd, "detect", str(gate), "--calibration", "-")
    assert code == 0 and out == by_name, err
    stdin(monkeypatch, b"GIF89a")
    code, out, err = run(capfd, "detect", "-")
    assert code == 1 and err.startswith("<stdin>: error: not an image format detect reads"), err
    code, _, err = run(capfd, "detect", "-", "--calibration", "-")
    assert code == 2 and "'-' (standard input) can be given once" in err


def test_a_fifo_is_refused_with_a_hint_that_works(gate: Path, capfd: pytest.CaptureFixture[str]) -> None:
    fifo = gate.parent / "fifo.png"
    os.mkfifo(fifo)
    code, _, err = run(capfd, "detect", str(fifo))
    assert code == 1 and "an image file must be a regular file (pass '-' to read standard input)" in err, err


def png_header_only(width: int, height: int) -> bytes:
    z = zlib.compressobj(9)
    data = z.compress(b"\0" * (width + 1)) + z.flush()

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", data) + chunk(b"IEND", b""))


def test_a_30000_by_30000_png_is_refused_at_once(gate: Path, capfd: pytest.CaptureFixture[str]) -> None:
    huge = gate.parent / "huge.png"
    huge.write_bytes(png_header_only(30000, 30000))
    t0 = time.perf_counter()
    code, out, err = run(capfd, "detect", str(huge))
    assert time.perf_counter() - t0 < 1.0
    assert code == 1 and out == ""
    assert err == (f"{huge}: error: PNG image of 30000x30000 = 900,000,000 pixels; the limit is 50,000,000 (scale it "
                   "down, or set FSM_MAX_IMAGE_PIXELS to a larger number of pixels)\n")


def test_a_damaged_png_gets_our_message_only(gate: Path, capfd: pytest.CaptureFixture[str]) -> None:
    short = gate.parent / "short.png"
    short.write_bytes(png_header_only(100, 100))  # one row of data for a 100-row image
    code, out, err = run(capfd, "detect", str(short))
    assert code == 1 and out == ""
    assert err == (f"{short}: error: damaged PNG file: its header says 100x100 but the image data cannot be decoded "
                   "(the file is truncated or corrupt; export it again)\n")


@pytest.mark.parametrize("change,message,where", [
    (("image_width: 640\nimage_height: 480", "image_width: 40000000000000\nimage_height: 30000000000000"),
     "= 1.2e+27 pixels; the limit is 50,000,000", ":1 at /image_width"),
    (("data: [600, 0, 319.5, 0, 600", "data: [1e-9, 0, 319.5, 0, 600"), "horizontal field of view of 180 deg",
     ":3 at /camera_matrix"),
    (("camera_matrix:", "camera_matrix: &m"), "YAML anchor '&m'", ":3: error"),
])
def test_absurd_calibrations_are_located_errors(gate: Path, capfd: pytest.CaptureFixture[str],
                                                change: tuple[str, str], message: str, where: str) -> None:
    cal = gate.parent / "absurd.yaml"
    cal.write_text(CALIBRATION.replace(*change))
    code, out, err = run(capfd, "detect", str(gate), "--calibration", str(cal))
    assert code == 1 and out == "" and message in err and f"{cal}{where}" in err, err


def test_a_calibration_nested_40000_deep_is_refused_not_parsed(gate: Path, capfd: pytest.CaptureFixture[str]) -> None:
    deep = gate.parent / "deep.yaml"
    deep.write_text("camera_matrix: " + "[" * 40_000 + "1" + "]" * 40_000 + "\n")
    code, _, err = run(capfd, "detect", str(gate), "--calibration", str(deep))
    assert code == 1 and err.startswith(f"{deep}: error: file is 80,017 bytes; a calibration is a few hundred"), err


def test_a_json_calibration_repeating_a_key_is_refused(gate: Path, capfd: pytest.CaptureFixture[str]) -> None:
    cal = gate.parent / "dup.json"
    cal.write_text('{"image_width": 640, "image_width": 640, "image_height": 480,\n'
                   ' "camera_matrix": [600, 0, 319.5, 0, 600, 239.5, 0, 0, 1]}\n')
    code, _, err = run(capfd, "detect", str(gate), "--calibration", str(cal))
    assert code == 1 and f"{cal}:1:22 at /image_width: error: top-level object: duplicate key 'image_width'" in err
