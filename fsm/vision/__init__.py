"""Perception for the TRAL car: ArUco markers and gates seen by a camera, with poses in the car's frame.

OpenCV and numpy only; never pymunk or :mod:`fsm.sim`, so the same code serves the simulated camera
(:mod:`fsm.sim.camera` renders frames and hands them here) and a real one (``fsmctl detect`` on photos).

Frames and units (what states drive on):

* **image**: pixels, x right, y down, integer coordinates at pixel centres (OpenCV).
* **optical** (OpenCV camera frame): x right, y down, z forward, metres. ``rvec``/``tvec`` of a
  :class:`Detection` are in this frame (``solvePnP``'s output, unchanged).
* **car**: x forward, y left, z up, metres, origin at the car's reference point (the simulator: the
  car's centre on the floor). A :class:`CameraMount` says where the camera sits in it. Positions,
  ``distance``, ``bearing`` and a gate's ``heading`` are in this frame; angles are radians,
  counter-clockwise (left) positive, 0 = straight ahead.

Modules: :mod:`.camera` (intrinsics, mount, frame changes), :mod:`.calibration` (OpenCV / ROS YAML, XML, JSON),
:mod:`.images` (image files: the size from the header, checked before decoding),
:mod:`.detector` (markers and their poses, optional region-of-interest tracking), :mod:`.gates`
(two markers make a gate), :mod:`.draw` (annotated images).
"""

from __future__ import annotations

from fsm.vision.calibration import load_calibration
from fsm.vision.camera import CameraModel, CameraMount
from fsm.vision.detector import DEFAULT_DICTIONARY, Detection, MarkerDetector, dictionary_names
from fsm.vision.gates import Gate, GateRule, find_gates

__all__ = [
    "CameraModel", "CameraMount", "load_calibration", "Detection", "MarkerDetector", "DEFAULT_DICTIONARY",
    "dictionary_names", "Gate", "GateRule", "find_gates",
]
