"""The video's frames on their way to the encoder: the writer thread keeps their order and content while buffers are
reused, an encoder error reaches the caller, and ffmpeg (imageio-ffmpeg's, not ours) decodes the colours drawn."""

from __future__ import annotations

import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

from fsm.model.errors import FsmError
from fsm.sim.render import FramePipe, H264Writer


class Slow:
    """A writer that is slower than the frames come, so the buffers are all in use and reused."""

    def __init__(self, fail_at: int | None = None) -> None:
        self.seen: list[int] = []
        self.threads: set[str] = set()
        self.fail_at = fail_at
        self.released = False

    def write(self, frame: np.ndarray) -> None:
        threading.Event().wait(0.002)
        self.threads.add(threading.current_thread().name)
        if self.fail_at is not None and len(self.seen) == self.fail_at:
            raise FsmError("disk full")
        self.seen.append(int(frame[0, 0, 0]))

    def release(self) -> None:
        self.released = True


def test_frames_arrive_in_order_from_reused_buffers_in_another_thread() -> None:
    writer = Slow()
    pipe = FramePipe(writer, (4, 6, 3), depth=3)
    buffers = set()
    for k in range(40):
        buf = pipe.buffer()
        buffers.add(id(buf))
        buf[:] = k
        pipe.submit(buf)
    pipe.close()
    assert writer.seen == list(range(40)) and writer.released
    assert len(buffers) == 3 and writer.threads == {"video-writer"}


def test_an_encoder_error_is_raised_by_close_and_the_writer_still_released() -> None:
    writer = Slow(fail_at=5)
    pipe = FramePipe(writer, (2, 2, 3), depth=2)
    for k in range(20):  # the run goes on: frames after the error are dropped, never block
        buf = pipe.buffer()
        buf[:] = k
        pipe.submit(buf)
    with pytest.raises(FsmError, match="disk full"):
        pipe.close()
    assert writer.seen == [0, 1, 2, 3, 4] and writer.released


def test_h264_from_yuv_decodes_to_the_colours_drawn(tmp_path: Path) -> None:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "v.mp4"
    w, h = 64, 48
    writer = H264Writer.open(out, 25.0, (w, h))
    assert writer is not None
    frame = np.zeros((h, w, 3), np.uint8)
    frame[:, : w // 2] = (200, 110, 30)  # BGR: the car's blue
    frame[:, w // 2:] = (245, 245, 245)  # the floor
    for _ in range(10):
        writer.write(frame)
    writer.release()
    raw = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-i", str(out), "-frames:v", "1",
                          "-f", "rawvideo", "-pix_fmt", "bgr24", "-"], capture_output=True, check=True).stdout
    back = np.frombuffer(raw, np.uint8).reshape(h, w, 3).astype(int)
    assert np.abs(back[h // 2, w // 4] - (200, 110, 30)).max() <= 8
    assert np.abs(back[h // 2, 3 * w // 4] - (245, 245, 245)).max() <= 8
