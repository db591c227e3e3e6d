"""Top-down pictures of a run with OpenCV: the video (walls, car, ultrasonic cones, path, active state) and the plot.

The frame has a slot for the camera view (top right): when ``car.camera()`` returns an image
(the camera/ArUco issue), it is drawn there; today it returns ``None`` and the slot stays empty.
Videos are H.264 through imageio-ffmpeg's ffmpeg (OpenCV's ``mp4v`` without it; ``MJPG`` for .avi), written to a
uniquely named temporary file that replaces the target only when the video is complete (or to a file the caller
names and puts in place itself: ``fsmctl`` does, through its output writer). The encoder runs in its own session,
so Ctrl-C in a terminal (SIGINT to the whole process group) reaches ``fsmctl``, not ffmpeg, and the video up to
that moment is kept. Frames are encoded while the run goes on: the simulation draws a frame into one of a few
reusable buffers and goes on; a writer thread converts it and feeds the encoder (:class:`FramePipe`).
"""

from __future__ import annotations

import colorsys
import math
import os
import queue
import subprocess
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from fsm.model.errors import FsmError
from fsm.sim.world import World, car_footprint, wall_segments

if TYPE_CHECKING:
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation

FLOOR = (245, 245, 245)
WALL = (60, 60, 60)
OBSTACLE = (70, 90, 160)
CAR = (200, 110, 30)
CAR_EDGE = (120, 50, 0)
RAY = (40, 170, 40)
RAY_FAR = (170, 200, 170)
TEXT = (20, 20, 20)
PANEL = 56 + 2 * 22  # px under the map: two lines of text, two rows of the trail's legend
FONT = cv2.FONT_HERSHEY_SIMPLEX
#: The baseline of the video's legend (the trail's colours), px under the map.
LEGEND_Y = 72
#: Video file suffixes and the OpenCV fourcc each stands for (mp4v means H.264 when ffmpeg is available).
VIDEO_FORMATS = {".avi": "MJPG", ".mp4": "mp4v", ".m4v": "mp4v", ".mov": "mp4v"}


def _scratch_next_to(target: Path, suffix: str) -> Path:
    """A new, uniquely named file beside ``target`` (two runs writing the same video never share it)."""
    directory = target.parent if str(target.parent) else Path(".")
    fd, name = tempfile.mkstemp(prefix=f".{target.name[:80]}.", suffix=f".part{suffix}", dir=directory)
    os.close(fd)
    return Path(name)


#: Colours told apart at a glance on the light floor and the white legend: Tableau 10 (Tableau's categorical palette,
#: designed for this), then ten of Kelly's and D3's colours, each picked for the largest CIELAB distance to those
#: before it: any two of the twenty differ by a CIELAB distance (delta E) of at least 25 (hex RGB).
DISTINCT = ("4e79a7", "f28e2b", "e15759", "76b7b2", "59a14f", "edc948", "b07aa1", "ff9da7", "9c755f", "bab0ac",
            "000080", "1b1b1b", "8db600", "800000", "808000", "604e97", "b3446c", "a1caf1", "e25822", "843c39")


def palette(n: int) -> list[tuple[int, int, int]]:
    """``n`` BGR colours: :data:`DISTINCT` first, then golden-ratio hues (beyond 20 states, some look alike)."""
    out = [(int(h[4:6], 16), int(h[2:4], 16), int(h[0:2], 16)) for h in DISTINCT[:n]]
    for k in range(n - len(out)):
        r, g, b = colorsys.hsv_to_rgb((0.07 + 0.618034 * k) % 1.0, 0.8, 0.75 if k % 2 else 0.55)
        out.append((int(b * 255), int(g * 255), int(r * 255)))
    return out


def leaf_name(path: str) -> str:
    """The state a trail is coloured by: the active path's leaf id (``lap2/right_turn/arc`` -> ``arc``), so that the
    same state in each lap has one colour, in the plot and in the video."""
    return path.rsplit("/", 1)[-1]


class TopDown:
    """Maps world metres to image pixels and draws the static world once."""

    def __init__(self, world: World, width: int = 1280, margin: float = 0.6) -> None:
        self.world = world
        x0, y0, x1, y1 = world.bounds()
        self.x0, self.y0 = x0 - margin, y0 - margin
        span_x, span_y = (x1 - x0) + 2 * margin, (y1 - y0) + 2 * margin
        self.scale = (width - 1) / span_x
        map_h = int(math.ceil(span_y * self.scale))
        # Codecs want even sizes (mp4v: multiples of 2; keep to 16 for the widest compatibility).
        self.width = width - width % 16
        self.map_h = map_h
        self.height = map_h + PANEL
        self.height += (-self.height) % 16
        self.background = self._draw_world()

    def px(self, x: float, y: float) -> tuple[int, int]:
        return int(round((x - self.x0) * self.scale)), int(round(self.map_h - (y - self.y0) * self.scale))

    def _draw_world(self) -> np.ndarray:
        img = np.full((self.height, self.width, 3), FLOOR, np.uint8)
        img[self.map_h:] = (255, 255, 255)
        thick = max(2, int(round(0.03 * self.scale)))
        for ob in self.world.obstacles:
            poly = ob.polygon()
            if poly is not None:
                cv2.fillPoly(img, [np.array([self.px(*p) for p in poly], np.int32)], OBSTACLE, cv2.LINE_AA)
            elif ob.center is not None and ob.radius is not None:
                cv2.circle(img, self.px(*ob.center), int(ob.radius * self.scale), OBSTACLE, -1, cv2.LINE_AA)
        for wall in self.world.walls:
            for a, b in wall_segments(wall):
                cv2.line(img, self.px(*a), self.px(*b), WALL, thick, cv2.LINE_AA)
        for gate in self.world.gates:
            h = math.radians(gate.heading)
            nx, ny = -math.sin(h), math.cos(h)
            for side in (-1, 1):
                cx = gate.center[0] + side * nx * gate.width / 2
                cy = gate.center[1] + side * ny * gate.width / 2
                cv2.circle(img, self.px(cx, cy), max(3, int(0.08 * self.scale)), (0, 0, 0), -1)
            a = self.px(gate.center[0] + nx * gate.width / 2, gate.center[1] + ny * gate.width / 2)
            b = self.px(gate.center[0] - nx * gate.width / 2, gate.center[1] - ny * gate.width / 2)
            cv2.line(img, a, b, (0, 170, 255), 1, cv2.LINE_AA)  # the segment the car must cross
        for marker in getattr(self.world, "markers", ()):  # standalone signs: a square and the direction they face
            p = self.px(*marker.position)
            r = max(3, int(0.07 * self.scale))
            cv2.rectangle(img, (p[0] - r, p[1] - r), (p[0] + r, p[1] + r), (0, 0, 0), -1)
            f = math.radians(marker.facing)
            q = self.px(marker.position[0] + 0.3 * math.cos(f), marker.position[1] + 0.3 * math.sin(f))
            cv2.arrowedLine(img, p, q, (0, 120, 255), 1, cv2.LINE_AA)
            cv2.putText(img, str(marker.id), (p[0] + r + 2, p[1] - r), FONT, 0.45, TEXT, 1, cv2.LINE_AA)
        # scale bar: 1 m
        x, y = 10, self.map_h - 10
        cv2.line(img, (x, y), (x + int(self.scale), y), TEXT, 2)
        cv2.putText(img, "1 m", (x, y - 6), FONT, 0.45, TEXT, 1, cv2.LINE_AA)
        return img

    def car_polygon(self, x: float, y: float, th: float) -> np.ndarray:
        return np.array([self.px(*p) for p in car_footprint(self.world.car, x, y, th)], np.int32)


class VideoRecorder:
    """Renders a frame every ``period`` seconds of simulated time and writes the video (``close`` to finish)."""

    def __init__(self, sim: Simulation, path: str | os.PathLike[str], *, speed: float = 4.0, fps: float = 25.0,
                 width: int = 1280, scratch: str | os.PathLike[str] | None = None, fmt: str | None = None) -> None:
        """``path`` is the video's name; with ``scratch`` the encoder writes there and the caller puts the file in
        place after :meth:`close`; ``fmt`` (a suffix such as ``.mp4``) overrides the suffix of ``path``."""
        self.sim = sim
        self.path = Path(path)
        self.view = TopDown(sim.car.world, width)
        self._inset_at: tuple[int, int] | None = None  # the camera inset's corner (it moves away from the car)
        self.trail = self.view.background.copy()
        self.colors = palette(40)
        #: The trail's states in the order they appeared (their colour is ``colors`` at that index).
        self.leaves: list[str] = []
        self._last_px: tuple[int, int] | None = None
        self.frames = 0
        self.period = speed / fps
        suffix = (fmt or self.path.suffix).lower()
        fourcc = VIDEO_FORMATS.get(suffix)
        if fourcc is None:
            raise FsmError(f"--video {self.path}: unsupported format '{suffix}'; use .mp4 or .avi")
        self._move = scratch is None
        self._tmp = Path(scratch) if scratch is not None else _scratch_next_to(self.path, suffix)
        size = (self.view.width, self.view.height)
        self.writer: Any = H264Writer.open(self._tmp, fps, size) if fourcc == "mp4v" else None
        self.codec = "h264" if self.writer is not None else fourcc
        if self.writer is None:
            self.writer = cv2.VideoWriter(str(self._tmp), cv2.VideoWriter.fourcc(*fourcc), fps, size)
        if not self.writer.isOpened():
            self.discard()
            raise FsmError(f"--video {self.path}: OpenCV cannot write {fourcc} video here")
        self.pipe = FramePipe(self.writer, self.trail.shape)
        sim.add_observer(self.period, self)

    def __call__(self, sim: Simulation) -> None:
        self._send(sim)

    def _send(self, sim: Simulation) -> None:
        """Draw the frame into a free buffer (waiting only when the encoder is that many frames behind) and hand it
        to the writer thread."""
        buf = self.pipe.buffer()
        self.render(sim, buf)
        self.pipe.submit(buf)
        self.frames += 1

    def render(self, sim: Simulation, out: np.ndarray | None = None) -> np.ndarray:
        """The frame now, drawn into ``out`` (an array of the frame's shape) or a new array."""
        view = self.view
        car = sim.car
        x, y, th = car.true_pose()
        p = view.px(x, y)
        leaf = leaf_name(sim.active_path)
        if leaf not in self.leaves:
            self.leaves.append(leaf)
            # the legend changes only here: drawn into the trail image (under the map), not into every frame
            top = view.map_h + LEGEND_Y - 16
            self.trail[top:] = view.background[top:]
            self._legend(self.trail, view.map_h + LEGEND_Y)
        color = self.colors[self.leaves.index(leaf) % len(self.colors)]
        if self._last_px is not None:
            cv2.line(self.trail, self._last_px, p, color, 2, cv2.LINE_AA)
        self._last_px = p
        if out is None:
            img = self.trail.copy()
        else:
            img = out
            np.copyto(img, self.trail)
        c, s = math.cos(th), math.sin(th)
        us = car.params.ultrasonic
        half = math.radians(us.cone) / 2
        for sensor in car.sensors:
            reading = getattr(car, sensor.name)
            ox, oy = x + c * sensor.mx - s * sensor.my, y + s * sensor.mx + c * sensor.my
            look = th + math.atan2(sensor.rays[0][1], sensor.rays[0][0])
            far = reading >= us.max_range - 1e-9
            pts = [view.px(ox, oy)]
            for k in range(7):
                a = look - half + 2 * half * k / 6
                pts.append(view.px(ox + reading * math.cos(a), oy + reading * math.sin(a)))
            overlay_color = RAY_FAR if far else RAY
            cv2.polylines(img, [np.array(pts, np.int32)], True, overlay_color, 1, cv2.LINE_AA)
            if not far:
                cv2.line(img, pts[0], pts[4], overlay_color, 1, cv2.LINE_AA)
        poly = view.car_polygon(x, y, th)
        cv2.fillPoly(img, [poly], CAR, cv2.LINE_AA)
        cv2.polylines(img, [poly], True, CAR_EDGE, 1, cv2.LINE_AA)
        nose = view.px(x + c * car.length / 2, y + s * car.length / 2)
        cv2.circle(img, nose, 3, (0, 0, 200), -1, cv2.LINE_AA)
        self._camera_inset(img, car, view.px(x, y))
        self._panel(img, sim)
        return img

    def _camera_inset(self, img: np.ndarray, car: SimCar, at: tuple[int, int]) -> None:
        """The camera view, when the car has a camera, in the corner of the map farthest from the car (``at``,
        its pixel), so that the inset never hides the car."""
        frame = car.camera_image() if hasattr(car, "camera_image") else None
        if not isinstance(frame, np.ndarray):
            return
        h = max(60, self.view.map_h // 3)
        w = int(frame.shape[1] * h / frame.shape[0])
        inset = cv2.resize(frame, (w, h))
        if inset.ndim == 2:
            inset = cv2.cvtColor(inset, cv2.COLOR_GRAY2BGR)
        corners = [(x0, max(0, y0)) for y0 in (8, self.view.map_h - h - 8) for x0 in (self.view.width - w - 8, 8)]
        here = self._inset_at
        near = 60  # px: move only when the car comes this close to the inset, so it does not flicker
        if here not in corners or (here[0] - near <= at[0] <= here[0] + w + near
                                   and here[1] - near <= at[1] <= here[1] + h + near):
            here = max(corners, key=lambda c: (c[0] + w / 2 - at[0]) ** 2 + (c[1] + h / 2 - at[1]) ** 2)
            self._inset_at = here
        x0, y0 = here
        img[y0:y0 + h, x0:x0 + w] = inset

    def _panel(self, img: np.ndarray, sim: Simulation) -> None:
        car = sim.car
        y0 = self.view.map_h
        line1 = f"t = {sim.now:7.2f} s   state: {sim.active_path}"
        line2 = (f"speed {car.speed:4.2f} m/s   steering {car.steering:+.2f}   distance {car.distance:7.2f} m   "
                 f"L {car.left:4.2f}  F {car.front:4.2f}  R {car.right:4.2f} m   collisions {car.collisions}")
        cv2.putText(img, line1, (10, y0 + 22), FONT, 0.6, TEXT, 1, cv2.LINE_AA)
        cv2.putText(img, line2, (10, y0 + 46), FONT, 0.5, TEXT, 1, cv2.LINE_AA)

    def _legend(self, img: np.ndarray, y: int) -> None:
        """The trail's colours: a box and the state's name each, in two rows at most (then "+N more")."""
        x, row = 10, 0
        cv2.putText(img, "trail:", (x, y), FONT, 0.45, TEXT, 1, cv2.LINE_AA)
        x0 = x = 10 + cv2.getTextSize("trail:", FONT, 0.45, 1)[0][0] + 8
        for i, name in enumerate(self.leaves):
            w = 20 + cv2.getTextSize(name, FONT, 0.45, 1)[0][0] + 14
            if x + w > self.view.width - 70:
                row, x = row + 1, x0
                if row == 2:
                    cv2.putText(img, f"+{len(self.leaves) - i} more", (x0, y + 22), FONT, 0.45, TEXT, 1,
                                cv2.LINE_AA)
                    return
            yy = y + 22 * row
            cv2.rectangle(img, (x, yy - 10), (x + 14, yy + 2), self.colors[i % len(self.colors)], -1)
            cv2.putText(img, name, (x + 20, yy), FONT, 0.45, TEXT, 1, cv2.LINE_AA)
            x += w

    def close(self) -> None:
        """Finish the file: render the last state, wait for the frames still queued, release the writer, move the
        file into place."""
        if self.writer is None:
            return
        self._send(self.sim)
        self.writer = None
        self.pipe.close()
        if self._move:
            os.replace(self._tmp, self.path)

    def discard(self) -> None:
        if self.writer is not None:
            pipe = getattr(self, "pipe", None)
            try:
                if pipe is not None:
                    pipe.close()
                else:
                    self.writer.release()
            except FsmError:
                pass  # the file is thrown away anyway
            self.writer = None
        if self._move and self._tmp.exists():
            self._tmp.unlink()


class FramePipe:
    """Frames from the simulation to an encoder without stopping the simulation: ``depth`` reusable frame buffers
    (a fresh 3 MB array per frame cost as much as drawing it), a writer thread that hands each filled buffer to
    ``writer.write`` (OpenCV's conversion and the pipe to ffmpeg release the GIL, so it runs beside the
    simulation) and returns it. :meth:`close` writes what is queued, then releases the writer; an error of the
    writer is raised there, in the caller's thread."""

    def __init__(self, writer: Any, shape: tuple[int, ...], depth: int = 4) -> None:
        self.writer = writer
        self._free: queue.SimpleQueue[np.ndarray] = queue.SimpleQueue()
        for _ in range(depth):
            self._free.put(np.empty(shape, np.uint8))
        self._full: queue.SimpleQueue[np.ndarray | None] = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="video-writer", daemon=True)
        self._thread.start()

    def buffer(self) -> np.ndarray:
        """A free frame buffer (blocks while every buffer waits for the encoder)."""
        return self._free.get()

    def submit(self, frame: np.ndarray) -> None:
        self._full.put(frame)

    def _run(self) -> None:
        while True:
            frame = self._full.get()
            if frame is None:
                return
            if self._error is None:
                try:
                    self.writer.write(frame)
                except BaseException as exc:  # raised again by close(), in the caller's thread
                    self._error = exc
            self._free.put(frame)

    def close(self) -> None:
        """Write the frames queued, stop the thread, release the writer (raising the first error of either)."""
        if self._thread.is_alive():
            self._full.put(None)
            self._thread.join()
        self.writer.release()
        if self._error is not None:
            raise self._error


class H264Writer:
    """H.264 MP4 (plays in browsers, unlike OpenCV's mp4v) through the ffmpeg that imageio-ffmpeg ships.

    Frames go to ffmpeg's standard input as raw YUV 4:2:0 (OpenCV converts BGR to it, BT.601 video range as ffmpeg
    would, at half the bytes of BGR through the pipe), encoded with x264's ``ultrafast`` preset (the drawn frames
    are flat colours: a fifth of ``veryfast``'s processor time for a file about three times the size, 3-4 MB for
    the hallway lap); ``open`` returns ``None`` when no such ffmpeg is installed, and the recorder falls back to
    OpenCV's MPEG-4 Part 2. Width and height must be even (:class:`TopDown` makes them multiples of 16).
    """

    def __init__(self, proc: subprocess.Popen[bytes], size: tuple[int, int] = (0, 0)) -> None:
        self.proc = proc
        w, h = size
        self._yuv = np.empty((h * 3 // 2, w), np.uint8) if w and h else None

    @classmethod
    def open(cls, path: Path, fps: float, size: tuple[int, int]) -> H264Writer | None:
        try:
            import imageio_ffmpeg

            exe = imageio_ffmpeg.get_ffmpeg_exe()
        except (ImportError, RuntimeError):
            return None
        w, h = size
        cmd = [exe, "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "yuv420p",
               "-s", f"{w}x{h}", "-r", f"{fps:g}", "-i", "-", "-an", "-c:v", "libx264", "-preset", "ultrafast",
               "-crf", "23", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
               "-movflags", "+faststart", "-f", "mp4", str(path)]
        try:
            # its own session: a terminal's Ctrl-C (SIGINT to the process group) must not kill the encoder
            # mid-file; fsmctl stops the run and closes the video itself
            proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    start_new_session=True)
        except OSError:
            return None
        return cls(proc, size)

    def isOpened(self) -> bool:  # noqa: N802 - the cv2.VideoWriter interface
        return self.proc.poll() is None

    def write(self, frame: np.ndarray) -> None:
        """Write one BGR frame of the size given to :meth:`open`."""
        assert self.proc.stdin is not None and self._yuv is not None
        cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420, dst=self._yuv)
        try:
            self.proc.stdin.write(self._yuv.data)
        except BrokenPipeError:
            self.release()

    def release(self) -> None:
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
        code = self.proc.wait()
        if code != 0:
            err = self.proc.stderr.read().decode(errors="replace").strip() if self.proc.stderr else ""
            raise FsmError(f"video encoding failed (ffmpeg exit {code}): {err[-300:]}")


def plot(sim: Simulation, path: str | os.PathLike[str], width: int = 1600) -> None:
    """Write :func:`plot_png` to ``path`` (a uniquely named temporary file renamed over it)."""
    target = Path(path)
    tmp = _scratch_next_to(target, ".png")
    try:
        tmp.write_bytes(plot_png(sim, width))
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


def plot_png(sim: Simulation, width: int = 1600) -> bytes:
    """A PNG of the trajectory coloured by the active state (leaf id), with a legend."""
    view = TopDown(sim.car.world, width)
    img = view.background.copy()
    leaf_names: list[str] = []
    index_of: dict[int, int] = {}
    for k, path_k in enumerate(sim.states_seen):
        leaf = leaf_name(path_k)
        if leaf not in leaf_names:
            leaf_names.append(leaf)
        index_of[k] = leaf_names.index(leaf)
    colors = palette(max(1, len(leaf_names)))
    prev = None
    for _, x, y, k in sim.track:
        p = view.px(x, y)
        if prev is not None:
            cv2.line(img, prev, p, colors[index_of.get(k, 0)], 3, cv2.LINE_AA)
        prev = p
    s = sim.car.world.start
    cv2.polylines(img, [view.car_polygon(s.x, s.y, math.radians(s.heading))], True, CAR_EDGE, 1, cv2.LINE_AA)
    x, y, th = sim.car.true_pose()
    cv2.fillPoly(img, [view.car_polygon(x, y, th)], CAR, cv2.LINE_AA)
    # legend under the map, in as many rows as needed
    box_w = 34 + max((cv2.getTextSize(n, FONT, 0.5, 1)[0][0] for n in leaf_names), default=40)
    per_row = max(1, (view.width - 20) // box_w)
    rows = (len(leaf_names) + per_row - 1) // per_row
    legend_h = 20 * rows + 12
    img = np.vstack([img[:view.map_h], np.full((legend_h, view.width, 3), 255, np.uint8), img[view.map_h:]])
    for i, name in enumerate(leaf_names):
        row, col = divmod(i, per_row)
        px, py = 10 + col * box_w, view.map_h + 18 + row * 20
        cv2.rectangle(img, (px, py - 10), (px + 14, py + 2), colors[i], -1)
        cv2.putText(img, name, (px + 20, py), FONT, 0.5, TEXT, 1, cv2.LINE_AA)
    m = sim.metrics()
    text = (f"{sim.machine.name or 'machine'}: outcome {sim.machine.outcome}, {m['distance_m']:.1f} m in "
            f"{m['sim_time']:.1f} s, collisions {m['collisions']}")
    if m["wall_error_rms_m"] is not None:
        text += f", wall error on straights {m['wall_error_rms_m'] * 100:.1f} cm RMS"
    cv2.putText(img, text, (10, view.map_h + legend_h + 26), FONT, 0.6, TEXT, 1, cv2.LINE_AA)
    ok, data = cv2.imencode(".png", img)
    if not ok:  # pragma: no cover
        raise FsmError("cannot encode the plot as PNG")
    return data.tobytes()
