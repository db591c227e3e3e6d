"""What a car run reports beyond its end (issue 26): the steering on straights, laps and the time per state in each,
the sweep's flags for runs whose lap or state times stand out, and the raw camera frames of --frames."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from fsm.sim.loop import LapLog, steering_metrics
from fsm.sim.world import parse_world
from fsm.tools.sweep.folder import jsonl_text
from fsm.tools.sweep.results import csv_text, html_page, outliers, with_flags
from helpers import cli

REPO = Path(__file__).resolve().parents[1]


def test_steering_metrics_count_sign_changes_within_stretches_only() -> None:
    samples = [(1, 0.1), (2, -0.1), (3, 0.1), (4, 0.0), (5, -0.1), (10, 0.1), (11, 0.1)]
    m = steering_metrics(samples, 0.05)
    # 1->2, 2->3, 3->5 (the zero has no sign) change; 5 -> 10 is a new stretch: 3 changes in 5 intervals
    assert m["steering_sign_changes_per_s"] == pytest.approx(3 / 0.25)
    assert m["straight_time_s"] == pytest.approx(0.25)
    values = [v for _n, v in samples]
    mean = sum(values) / len(values)
    assert m["steering_std"] == pytest.approx(math.sqrt(sum((v - mean) ** 2 for v in values) / len(values)),
                                              abs=1e-5)
    assert steering_metrics([], 0.05)["steering_std"] is None


def test_a_lap_ends_where_the_car_crosses_the_start_line_forwards() -> None:
    world = parse_world({"walls": [{"points": [[0, 0], [10, 0], [10, 10], [0, 10]], "closed": True}],
                         "start": {"x": 5.0, "y": 1.0, "heading": 0}})
    log = LapLog(world)
    log.state(0.0, "bottom")
    log.update(0.0, 5.0, 1.0)
    log.update(1.0, 6.0, 1.0)  # leaves the start line: no lap
    log.state(2.0, "turn")
    log.update(3.0, 4.0, 1.0)  # driving backwards over the line: no lap
    log.update(4.0, 4.0, 9.0)
    log.update(5.0, 6.0, 9.0)  # crossing its extension far across (another straight): no lap
    log.update(6.0, 4.9, 1.2)
    log.state(7.0, "bottom")
    log.update(8.0, 5.1, 1.2)  # forwards over the line, 0.2 m beside the start: lap 1 ends
    m = log.metrics(9.0)
    laps, rest = m["laps"], m["lap_unfinished"]
    assert [lap["complete"] for lap in laps] == [True] and rest["complete"] is False
    assert laps[0]["time_s"] == 8.0 and laps[0]["states"] == {"bottom": 3.0, "turn": 5.0}
    assert rest["start_s"] == 8.0 and rest["states"] == {"bottom": 1.0}


def record(i: int, right_slow: float = 2.3, lap2: float = 67.0) -> dict[str, Any]:
    return {"id": f"{i:04d}", "key": f"k{i}", "ok": True, "world": "w.json", "seed": i, "run_seed": i, "params": {},
            "command": f"fsmctl run lap.uxf --seed {i}",
            "summary": {"outcome": "succeeded", "collisions": 0,
                        "laps": [{"lap": 1, "time_s": 67.4 + 0.01 * (i % 3), "complete": True},
                                 {"lap": 2, "time_s": lap2 + 0.02 * (i % 2), "complete": True},
                                 {"lap": 3, "time_s": 1.0, "complete": False}]},
            "dwell": {"lap1/right_slow": right_slow + 0.05 * (i % 2), "lap1/arc": 1.9}}


def test_runs_whose_lap_or_state_time_stands_out_are_flagged() -> None:
    records = [record(i) for i in range(10)]
    records[3] = record(3, right_slow=8.35, lap2=70.2)  # the slow-after-corner glitch
    records[5] = record(5, right_slow=2.45)  # one more 20 Hz sample than the others: no glitch
    flags = outliers(records)
    assert set(flags) == {"0003"}
    assert [f["figure"] for f in flags["0003"]] == ["time in lap1/right_slow", "lap 2 time"]
    assert flags["0003"][0]["median"] == pytest.approx(2.325) and flags["0003"][0]["mads"] > 3
    assert not outliers(records[:4])  # too few runs to tell


def test_flags_reach_the_csv_the_jsonl_and_the_top_of_the_page(tmp_path: Path) -> None:
    records = [record(i) for i in range(8)]
    records[3] = record(3, right_slow=8.35)
    flagged = with_flags(records)
    assert [bool(r["flags"]) for r in flagged] == [i == 3 for i in range(8)]
    csv = csv_text(flagged, []).splitlines()
    assert csv[0].endswith(",flags") and "time in lap1/right_slow 8.4 s (median 2.325 s" in csv[4]
    page = html_page("t", flagged, [], {})
    top = page.index("Runs that stand out")
    assert top < page.index("<h2>Runs</h2>") and "fsmctl run lap.uxf --seed 3" in page[top:top + 2000]
    jsonl = tmp_path / "sweep.jsonl"
    other = json.dumps({"id": "0000", "key": "another-grid", "ok": True})
    jsonl.write_text("".join(json.dumps(r) + "\n" for r in records) + other + "\n")
    text = jsonl_text(jsonl, flagged)
    assert text is not None
    lines = [json.loads(line) for line in text.splitlines()]
    assert [r["key"] for r in lines] == [f"k{i}" for i in range(8)] + ["another-grid"]
    assert lines[3]["flags"][0]["figure"] == "time in lap1/right_slow" and "flags" not in lines[8]
    assert text.splitlines()[0] == json.dumps(records[0]).encode()  # the others stay byte for byte
    jsonl.write_bytes(text)
    assert jsonl_text(jsonl, flagged) is None  # nothing new: sweep.jsonl is left alone


# -- fsmctl run --frames ------------------------------------------------------------------------------------
GATES = REPO / "diagrams" / "worlds" / "gates.json"


def test_frames_are_saved_with_their_calibration_and_detect_finds_the_gate_where_it_is(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "frames"
    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "gate_run.uxf"), "--world", str(GATES), "--duration",
                       "1", "--frames", str(out), "--frames-every", "5", "-q")
    assert code == 0, err
    lines = [json.loads(line) for line in (out / "frames.jsonl").read_text().splitlines()]
    assert lines and sorted(p.name for p in out.iterdir()) == sorted(
        ["camera.yaml", "frames.jsonl"] + [line["file"] for line in lines])
    first = lines[0]
    assert first["markers"] == [10, 11]
    code, text, err = cli(capsys, "detect", str(out / first["file"]), "--calibration", str(out / "camera.yaml"),
                          "--format", "json")
    assert code == 0, err
    gate = json.loads(text)[0]["gates"][0]
    # the truth: gate "east" (markers 10 and 11) at (14, 1), seen from the camera's pose in the world
    cx, cy, yaw = first["camera"]
    dx, dy = 14.0 - cx, 1.0 - cy
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    ahead, left = c * dx + s * dy, -s * dx + c * dy
    assert sorted(gate["ids"]) == [10, 11]
    assert gate["center"][0] == pytest.approx(ahead, rel=0.04) and gate["center"][1] == pytest.approx(left, abs=0.05)


@pytest.mark.parametrize("how", ["file", "folder", "missing parent", "every 0", "no car"])
def test_bad_frames_options_are_one_message_and_write_nothing(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                              how: str) -> None:
    target = tmp_path / "frames"
    extra = ["--frames", str(target)]
    machine = str(REPO / "diagrams" / "gate_run.uxf")
    if how == "file":
        target.write_text("keep")
    elif how == "folder":
        target.mkdir()
    elif how == "missing parent":
        target = tmp_path / "no" / "frames"
        extra = ["--frames", str(target)]
    elif how == "every 0":
        extra += ["--frames-every", "0"]
    elif how == "no car":
        machine = str(REPO / "diagrams" / "examples" / "mission.json")
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = cli(capsys, "run", machine, "--world" if how != "no car" else "--duration",
                         str(GATES) if how != "no car" else "1", *extra)
    assert code == 2, err
    assert "--frames" in err.strip().splitlines()[-1]  # argparse's usage lines, then the one message
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    if how == "file":
        assert target.read_text() == "keep"


def test_the_first_twenty_state_colours_are_told_apart_and_leaves_share_theirs() -> None:
    import cv2
    import numpy as np

    from fsm.sim.render import leaf_name, palette

    colours = palette(20)
    lab = cv2.cvtColor(np.array([colours], np.float32) / 255, cv2.COLOR_BGR2LAB)[0]
    nearest = min(float(np.linalg.norm(lab[i] - lab[j])) for i in range(20) for j in range(i))
    assert nearest > 25  # CIELAB delta E: no two look alike at a glance (the golden-ratio hues: 13 at 20 colours)
    assert len(set(palette(40))) == 40
    assert leaf_name("lap2/right_turn/arc") == leaf_name("lap1/left_turn/arc") == "arc"
