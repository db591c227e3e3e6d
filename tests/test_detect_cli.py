"""``fsmctl detect`` on PNGs rendered here: text and JSON output, the annotated image, and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import cv2
import pytest

from fsm.sim.camera import CameraMount, SimCamera, markers_from_gates
from fsm.tools.cli import main

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


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture()
def gate_png(tmp_path: Path) -> Path:
    """A gate (ids 6 left, 9 right) 1.5 m ahead of a camera at the origin, turned 15 degrees."""
    gate = SimpleNamespace(markers=(6, 9), center=(1.5, 0.1), heading=15.0, width=0.7, marker_size=0.15, height=0.0)
    cam = SimCamera(markers_from_gates([gate]), mount=CameraMount(), posts=False, seed=7)
    path = tmp_path / "gate.png"
    assert cv2.imwrite(str(path), cam.render(0, 0, 0))
    (tmp_path / "cal.yaml").write_text(CALIBRATION)
    return path


def test_text_output_names_markers_gate_and_the_camera(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "detect", str(gate_png), "--calibration", str(gate_png.parent / "cal.yaml"))
    assert code == 0, err
    assert "marker 6: distance" in out and "marker 9: distance" in out
    assert "gate 6/9:" in out and "x forward, y left" in out
    code, out, _ = run(capsys, "detect", str(gate_png))
    assert code == 0 and "assumed pinhole, 60 deg" in out


def test_json_output_parses_with_poses(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "detect", str(gate_png), "--calibration", str(gate_png.parent / "cal.yaml"),
                         "--format", "json")
    assert code == 0, err
    (result,) = json.loads(out)
    assert [m["id"] for m in result["markers"]] == [6, 9] and result["camera"]["note"] is None
    (gate,) = result["gates"]
    assert gate["ids"] == [6, 9]
    assert gate["center"] == pytest.approx([1.5, 0.1], abs=0.03)
    assert gate["heading_deg"] == pytest.approx(15.0, abs=1.0)
    assert gate["width"] == pytest.approx(0.7, abs=0.02)
    left = result["markers"][0]
    assert left["position"][1] > 0.3 and math.isfinite(left["bearing_deg"])


def test_annotated_png_is_written(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_png = gate_png.parent / "annotated.png"
    code, _, err = run(capsys, "detect", str(gate_png), "-o", str(out_png))
    assert code == 0, err
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = cv2.imread(str(out_png))
    assert image is not None and image.shape == (480, 640, 3)
    original = cv2.cvtColor(cv2.imread(str(gate_png), cv2.IMREAD_GRAYSCALE), cv2.COLOR_GRAY2BGR)
    assert (image != original).any(axis=2).sum() > 500  # outlines, axes and labels were drawn


def test_explicit_gate_ids(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "detect", str(gate_png), "--gate", "9,6", "--format", "json")
    assert code == 0 and json.loads(out)[0]["gates"][0]["ids"] == [9, 6]


def test_a_file_that_is_no_image(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "notes.png"
    bad.write_text("this is text, not a PNG\n")
    out_png = tmp_path / "annotated.png"
    code, out, err = run(capsys, "detect", str(bad), "-o", str(out_png))
    assert code == 1 and err.startswith(f"{bad}: error: ") and "Traceback" not in err
    assert not out_png.exists() and out == ""
    assert run(capsys, "detect", str(tmp_path / "missing.png"))[0] == 1


def test_a_missing_or_bad_calibration(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_png = gate_png.parent / "annotated.png"
    code, _, err = run(capsys, "detect", str(gate_png), "--calibration", str(gate_png.parent / "no.yaml"),
                       "-o", str(out_png))
    assert code == 1 and "calibration file not found" in err and not out_png.exists()
    bad = gate_png.parent / "bad.yaml"
    bad.write_text(CALIBRATION.replace("rows: 3\n  cols: 3", "rows: 3\n  cols: 2"))
    code, _, err = run(capsys, "detect", str(gate_png), "--calibration", str(bad))
    assert code == 1 and f"{bad}:3" in err


def test_calibration_at_another_resolution_is_scaled_or_refused(gate_png: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    big = gate_png.parent / "big.yaml"
    big.write_text(CALIBRATION.replace("640", "1280").replace("480", "960").replace("600, 0, 319.5, 0, 600, 239.5",
                                                                                     "1200, 0, 639.5, 0, 1200, 479.5"))
    code, out, _ = run(capsys, "detect", str(gate_png), "--calibration", str(big))
    assert code == 0 and "scaled to 640x480" in out
    wide = gate_png.parent / "wide.yaml"
    wide.write_text(CALIBRATION.replace("480", "360"))
    code, _, err = run(capsys, "detect", str(gate_png), "--calibration", str(wide))
    assert code == 1 and "another aspect ratio" in err


@pytest.mark.parametrize("argv,message", [
    (["--dictionary", "DICT_9X9_9"], "unknown 'DICT_9X9_9'"),
    (["--marker-size", "0"], "must be more than 0.001 m and at most 10 m"),
    (["--gate", "3,3"], "two different ids"),
    (["--fov", "50", "--calibration", "x.yaml"], "--fov is for images without"),
])
def test_usage_errors(gate_png: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    with pytest.raises(SystemExit) as info:
        code = main(["detect", str(gate_png), *argv])
        raise SystemExit(code)
    _, err = capsys.readouterr()
    assert info.value.code == 2 and message in err


def test_output_takes_one_image(gate_png: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "detect", str(gate_png), str(gate_png), "-o", str(gate_png.parent / "a.png"))
    assert code == 2 and "takes one IMAGE" in err


def test_the_annotated_output_never_replaces_the_image_it_reads(gate_png: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    before = gate_png.read_bytes()
    link = gate_png.parent / "link.png"
    link.symlink_to(gate_png)
    for out in (gate_png, link):
        code, _, err = run(capsys, "detect", str(gate_png), "-o", str(out))
        assert code == 2 and "same file as the input" in err, err
    assert gate_png.read_bytes() == before and link.is_symlink()


def test_the_annotated_output_in_a_missing_folder_is_refused_first(gate_png: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "detect", str(gate_png), "-o", str(gate_png.parent / "no" / "a.png"))
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
