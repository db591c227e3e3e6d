"""Ctrl-C in a terminal (SIGINT to the whole process group) and SIGTERM during ``fsmctl run``: the run stops
between two ticks, exit 130, and the video up to that moment, the summary (``"interrupted": true``), the trace
and the plot are all written; the ffmpeg encoder runs in its own session so the group's signal misses it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FSMCTL = str(Path(sys.executable).parent / "fsmctl")


def _wait_for(path: Path, proc: subprocess.Popen[bytes], timeout: float = 60) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None:
        if path.exists() and path.stat().st_size > 0:
            return
        time.sleep(0.05)
    raise AssertionError(f"{path} never appeared (exit {proc.poll()})")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_to_the_group_keeps_video_summary_trace_and_plot(signum: int, tmp_path: Path) -> None:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    argv = [FSMCTL, "run", str(REPO / "diagrams" / "hallway_lap.json"), "--video", "v.mp4", "--plot", "p.png",
            "--summary", "s.json", "--trace", "-", "--no-progress"]
    trace = tmp_path / "trace.jsonl"
    with open(trace, "wb") as out:  # the trace streams to standard output: its first line says the run is on
        proc = subprocess.Popen(argv, cwd=tmp_path, stdout=out, stderr=subprocess.PIPE, start_new_session=True)
        try:
            _wait_for(trace, proc)
            time.sleep(1.5)  # some video frames
            os.killpg(proc.pid, signum)  # what a terminal does: the whole group, ffmpeg included
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130, err.decode()
    assert b"Traceback" not in err
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["interrupted"] is True and summary["finished"] is False
    assert summary["video"]["frames"] > 0
    frames, _secs = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "v.mp4"))
    assert frames == summary["video"]["frames"]
    assert (tmp_path / "p.png").read_bytes().startswith(b"\x89PNG")
    lines = [json.loads(line) for line in trace.read_text().splitlines()]
    assert lines and lines[1]["type"] == "event" and lines[1]["transitions"][0]["type"] == "initial"
    assert lines[-1]["type"] == "end" and lines[-1]["interrupted"] is True
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png", "s.json", "trace.jsonl", "v.mp4"]


def test_interrupted_run_without_a_car(tmp_path: Path) -> None:
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}]}
    (tmp_path / "idle.json").write_text(json.dumps(doc))
    argv = [FSMCTL, "run", "idle.json", "--summary", "s.json", "--trace", "t.jsonl", "--max-ticks", "2000000000"]
    proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        parts = [p for p in tmp_path.iterdir() if p.name.startswith(".t.jsonl.")]
        end = time.monotonic() + 30
        while not parts and time.monotonic() < end:  # the trace's temporary file: the run has started
            time.sleep(0.05)
            parts = [p for p in tmp_path.iterdir() if p.name.startswith(".t.jsonl.")]
        time.sleep(0.3)
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert b"Traceback" not in err and b"(interrupted)" in out
    assert json.loads((tmp_path / "s.json").read_text())["interrupted"] is True
    lines = (tmp_path / "t.jsonl").read_text().splitlines()
    assert lines[0].startswith('{"type":"header"') and lines[1].startswith('{"type":"event","tick":0')
    assert json.loads(lines[-1])["interrupted"] is True


def test_encoder_runs_in_its_own_session(tmp_path: Path) -> None:
    pytest.importorskip("imageio_ffmpeg")
    from fsm.sim.render import H264Writer

    writer = H264Writer.open(tmp_path / "x.mp4", 25, (64, 48))
    if writer is None:
        pytest.skip("no ffmpeg")
    try:
        assert os.getpgid(writer.proc.pid) != os.getpgid(0)
        assert os.getsid(writer.proc.pid) != os.getsid(0)
    finally:
        import numpy as np

        writer.write(np.zeros((48, 64, 3), np.uint8))
        writer.release()


def test_keyboard_interrupt_while_loading_exits_130(monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from fsm.tools.cli import main, validate

    def boom(*_a: object, **_k: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(validate, "check_one", boom)
    assert main(["validate", str(REPO / "diagrams" / "examples" / "blinker.json")]) == 130
    assert capsys.readouterr().err == "fsmctl: interrupted\n"
