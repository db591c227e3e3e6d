"""``fsmctl detect``: find ArUco markers and gates in images with the car's own detector (fsm.vision).

For checking real markers and a real calibration before the car drives: each marker's id and pose,
each gate's centre, heading and width, in the camera's frame (x forward, y left, z up, metres; angles
in degrees, left positive). Without ``--calibration`` the camera is a distortion-free pinhole with the
stated field of view, and distances are only as good as that guess.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from fsm.errors import DiagramError, Problem, UsageError

from .common import EXIT_OK, positive_float

#: Largest image file we read, bytes (a photo is a few MB).
MAX_IMAGE_BYTES = 200_000_000


def gate_pair(text: str) -> tuple[int, int]:
    left, sep, right = text.partition(",")
    try:
        pair = int(left), int(right)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LEFT,RIGHT marker ids, got {text!r}") from None
    if not sep or pair[0] == pair[1] or min(pair) < 0:
        raise argparse.ArgumentTypeError(f"expected two different ids LEFT,RIGHT >= 0, got {text!r}")
    return pair


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("detect", help="find ArUco markers and gates in images and print their poses")
    p.add_argument("images", nargs="+", metavar="IMAGE", help="PNG, JPEG or any image OpenCV reads")
    p.add_argument("--calibration", metavar="FILE",
                   help="camera calibration (OpenCV FileStorage or ROS camera_info YAML: camera_matrix, "
                        "distortion_coefficients)")
    p.add_argument("--fov", type=positive_float, default=None, metavar="DEG",
                   help="without --calibration: horizontal field of view of the assumed pinhole (default 60)")
    p.add_argument("--dictionary", default="DICT_4X4_50", metavar="DICT", help="ArUco dictionary (DICT_4X4_50)")
    p.add_argument("--marker-size", type=positive_float, default=0.15, metavar="M",
                   help="side of the black marker square in metres (default 0.15)")
    p.add_argument("--gate", type=gate_pair, action="append", metavar="LEFT,RIGHT",
                   help="a gate's marker ids (repeatable); default: any two markers 0.3-1.5 m apart")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("-o", "--output", metavar="ANNOTATED.png",
                   help="write the image with the markers, their axes and the gates drawn (one IMAGE only)")
    p.set_defaults(func=cmd_detect)


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def read_image(path: str) -> Any:
    """The image at ``path`` (BGR or grey, uint8), or a located error."""
    import cv2
    import numpy as np

    from fsm.reading import read_file_bytes

    p = Path(path)
    try:
        size = p.stat().st_size
    except OSError:
        size = 0
    if size > MAX_IMAGE_BYTES:
        raise DiagramError([Problem(f"file is {size} bytes; too large for an image", path)])
    raw = read_file_bytes(p, "image")
    image = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_UNCHANGED) if raw else None
    if image is None or image.ndim not in (2, 3) or image.size == 0:
        raise DiagramError([Problem("not an image OpenCV can read", path, hint="give a PNG, JPEG, BMP or TIFF file")])
    if image.dtype != np.uint8:  # 16-bit PNGs: scale to 8 bits
        image = cv2.convertScaleAbs(image, alpha=255.0 / max(1.0, float(image.max())))
    if image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    elif image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    return image


def cmd_detect(args: argparse.Namespace) -> int:
    from fsm.vision import CameraModel, GateRule, MarkerDetector, dictionary_names, find_gates, load_calibration
    from fsm.vision.camera import DEFAULT_FOV

    if args.dictionary not in dictionary_names():
        raise UsageError(f"--dictionary: unknown {args.dictionary!r}; choose one of {', '.join(dictionary_names())}")
    if args.output and len(args.images) != 1:
        raise UsageError("-o/--output takes one IMAGE")
    if args.calibration and args.fov is not None:
        raise UsageError("--fov is for images without --calibration")
    outputs = None
    if args.output:
        from ..files import Outputs

        if Path(args.output).suffix.lower() not in IMAGE_SUFFIXES:
            raise UsageError(f"-o: {args.output}: name an image file (.png, .jpg, ...)")
        outputs = Outputs()
        outputs.add(args.output, "-o", binary=True)
        outputs.items[0].classify()  # a folder, a missing folder: refused before any work
    calibration = load_calibration(args.calibration, image_size=None) if args.calibration else None
    images: list[tuple[str, Any]] = []
    problems: list[Problem] = []
    for file in args.images:
        try:
            images.append((file, read_image(file)))
        except DiagramError as exc:
            problems += exc.problems
    if problems:
        raise DiagramError(problems)
    rule = GateRule(pairs=args.gate) if args.gate else GateRule()
    results = []
    for file, image in images:
        h, w = image.shape[:2]
        note = None
        if calibration is None:
            fov = args.fov if args.fov is not None else DEFAULT_FOV
            camera = CameraModel.from_fov(w, h, fov)
            note = f"assumed pinhole, {fov:g} deg horizontal field of view (no --calibration): distances scale with it"
        elif (calibration.width, calibration.height) != (w, h):
            if abs(calibration.width / calibration.height - w / h) > 0.01:
                raise DiagramError([Problem(
                    f"the calibration is for {calibration.width}x{calibration.height}, the image is {w}x{h} "
                    "(another aspect ratio)", file, hint=f"calibrate at this resolution; calibration: {args.calibration}")])
            camera = calibration.scaled(w, h)
            note = f"calibration made at {calibration.width}x{calibration.height}, scaled to {w}x{h}"
        else:
            camera = calibration
        detector = MarkerDetector(camera, dictionary=args.dictionary, marker_size=args.marker_size)
        markers = detector.detect(image)
        gates = find_gates(markers, rule)
        results.append((file, image, camera, note, markers, gates))
    if outputs is not None:
        import cv2

        from fsm.vision.draw import annotate

        file, image, camera, _note, markers, gates = results[0]
        ok, png = cv2.imencode(Path(args.output).suffix.lower(), annotate(image, markers, camera, gates))
        if not ok:  # pragma: no cover - OpenCV encodes every suffix we allow
            raise DiagramError([Problem("cannot encode the annotated image", args.output)])
        inputs = list(args.images) + ([args.calibration] if args.calibration else [])
        outputs.open(inputs)  # the same file as the image read: refused
        try:
            outputs.items[0].write(png.tobytes())
            outputs.commit()
        finally:
            outputs.discard()
    if args.format == "json":
        print(json.dumps([{
            "file": file, "width": camera.width, "height": camera.height,
            "camera": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy,
                       "distortion": [float(d) for d in camera.dist], "note": note},
            "frame": "camera: x forward, y left, z up (m); angles in degrees, left positive",
            "markers": [d.to_dict() for d in markers], "gates": [g.to_dict() for g in gates],
        } for file, _image, camera, note, markers, gates in results], indent=2))
        return EXIT_OK
    print("poses in the camera frame: x forward, y left, z up (m); angles in degrees, left positive")
    for file, _image, camera, note, markers, gates in results:
        print(f"{file}: {camera.width}x{camera.height}, {len(markers)} marker{'s' * (len(markers) != 1)}, "
              f"{len(gates)} gate{'s' * (len(gates) != 1)}")
        print(f"  camera: {camera.describe()}" + (f" ({note})" if note else ""))
        for d in markers:
            x, y, z = d.position
            print(f"  marker {d.id}: distance {d.distance:.3f} m, bearing {math.degrees(d.bearing):+.1f} deg, "
                  f"x={x:.3f} y={y:+.3f} z={z:+.3f} m, facing {math.degrees(d.facing):+.1f} deg, "
                  f"reprojection {d.error:.2f} px")
        for g in gates:
            print(f"  gate {g.ids[0]}/{g.ids[1]}: centre x={g.center[0]:.3f} y={g.center[1]:+.3f} m, "
                  f"distance {g.distance:.3f} m, heading {math.degrees(g.heading):+.1f} deg, width {g.width:.3f} m")
    if args.output:
        print(f"wrote {args.output}", file=sys.stderr)
    return EXIT_OK
