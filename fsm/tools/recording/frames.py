"""``fsmctl run --frames DIR``: the simulated camera's raw frames as PNG files, with the calibration beside them, so
that ``fsmctl detect DIR/frame_000040.png --calibration DIR/camera.yaml`` runs the car's detector on them.

The folder holds ``camera.yaml`` (OpenCV FileStorage: ``camera_matrix``, ``distortion_coefficients`` (none: the
simulated camera is a pinhole), ``image_width``, ``image_height``), ``frame_NNNNNN.png`` (the grey frame as the
detector saw it, before any annotation; NNNNNN is the camera's frame number) for every Nth rendered frame, and
``frames.jsonl``: per saved frame its file, time, frame number, the car's true pose (world frame, heading in
degrees), the camera's position and yaw in the world, and the marker ids the simulator's detector found.
"""

from __future__ import annotations

import json
import math
from typing import Any

from ..files import NewFolder


def calibration_yaml(camera: Any) -> str:
    """The car camera's calibration (``car.params.camera``) as OpenCV writes one."""
    import cv2
    import numpy as np

    fy = camera.fy if camera.fy is not None else camera.fx
    # the principal point where the simulator's camera has it: the image centre, (w - 1) / 2 and (h - 1) / 2
    matrix = np.array([[camera.fx, 0.0, (camera.width - 1) / 2], [0.0, fy, (camera.height - 1) / 2],
                       [0.0, 0.0, 1.0]])
    fs = cv2.FileStorage(".yaml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    fs.write("image_width", int(camera.width))
    fs.write("image_height", int(camera.height))
    fs.write("camera_matrix", matrix)
    fs.write("distortion_coefficients", np.zeros((1, 5)))
    text: str = fs.releaseAndGetString()
    return text


class FrameSaver:
    """Saves every ``every``-th rendered camera frame of ``car`` into ``folder`` (a :class:`NewFolder`, opened);
    call it after each tick (``Simulation.add_observer``), then :meth:`finish`."""

    def __init__(self, car: Any, folder: NewFolder, every: int = 10) -> None:
        self.car = car
        self.folder = folder
        self.every = every
        self.rendered = 0
        self.saved = 0
        self._last = -1
        self._lines: list[str] = []
        folder.write("camera.yaml", calibration_yaml(car.params.camera))

    def __call__(self, _sim: Any = None) -> None:
        view = self.car.camera()
        if view is None or view.frame == self._last:
            return
        self._last = view.frame
        image = self.car.camera_frame()
        if image is None:
            return  # nothing in view: nothing was rendered
        self.rendered += 1
        if (self.rendered - 1) % self.every:
            return
        import cv2

        ok, png = cv2.imencode(".png", image)
        if not ok:  # pragma: no cover - OpenCV encodes any 8-bit image
            return
        name = f"frame_{view.frame:06d}.png"
        self.folder.write(name, png.tobytes())
        self.saved += 1
        x, y, th = self.car.true_pose()
        cam = self.car.params.camera
        c, s = math.cos(th), math.sin(th)
        self._lines.append(json.dumps({
            "file": name, "time": round(view.time, 6), "frame": view.frame,
            "pose": [round(x, 4), round(y, 4), round(math.degrees(th), 3)],
            "camera": [round(x + c * cam.x - s * cam.y, 4), round(y + s * cam.x + c * cam.y, 4),
                       round(math.degrees(th) + cam.yaw, 3)],
            "markers": sorted(int(d.id) for d in view.detections)}))

    def finish(self) -> None:
        self.folder.write("frames.jsonl", "".join(line + "\n" for line in self._lines))
