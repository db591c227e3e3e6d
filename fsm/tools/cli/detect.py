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
from typing import TYPE_CHECKING, Any

from fsm.model.errors import DiagramError, Problem, UsageError

from .common import EXIT_OK, Subcommands, input_name

if TYPE_CHECKING:
    from ..files import Outputs

#: The side of a marker, metres: above 1 mm (a speck no camera resolves) and at most 10 m.
MARKER_SIZE_RANGE = (0.001, 10.0)


def gate_pair(text: str) -> tuple[int, int]:
    left, sep, right = text.partition(",")
    try:
        pair = int(left), int(right)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LEFT,RIGHT marker ids, got {text!r}") from None
    if not sep or pair[0] == pair[1] or min(pair) < 0:
        raise argparse.ArgumentTypeError(f"expected two different ids LEFT,RIGHT >= 0, got {text!r}")
    return pair


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def fov_degrees(text: str) -> float:
    """``--fov``: a horizontal field of view a rectilinear lens can have (``ASSUMED_FOV_RANGE``, degrees)."""
    from fsm.vision.camera import ASSUMED_FOV_RANGE

    value, (low, high) = _number(text), ASSUMED_FOV_RANGE
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be between {low:g} and {high:g} degrees, got {text} (a wider lens "
                                         "is a fisheye: give its --calibration)")
    return value


def marker_size(text: str) -> float:
    """``--marker-size``: metres, in :data:`MARKER_SIZE_RANGE` (more than 1 mm, at most 10 m)."""
    value, (low, high) = _number(text), MARKER_SIZE_RANGE
    if not low < value <= high:
        raise argparse.ArgumentTypeError(f"must be more than {low:g} m and at most {high:g} m, got {text} (the side "
                                         "of the black square, in metres)")
    return value


def register(sub: Subcommands) -> None:
    p = sub.add_parser("detect", help="find ArUco markers and gates in images and print their poses")
    p.add_argument("images", nargs="+", metavar="IMAGE",
                   help="PNG, JPEG, BMP, TIFF, WebP or PGM/PPM file ('-': one image from standard input); at most "
                        "50 megapixels (FSM_MAX_IMAGE_PIXELS changes the limit)")
    p.add_argument("--calibration", metavar="FILE",
                   help="camera calibration (OpenCV FileStorage YAML, XML or JSON, or ROS camera_info YAML: "
                        "camera_matrix, distortion_coefficients, image_width, image_height; '-': standard input)")
    p.add_argument("--fov", type=fov_degrees, default=None, metavar="DEG",
                   help="without --calibration: horizontal field of view of the assumed pinhole, 1-170 (default 60)")
    p.add_argument("--dictionary", default="DICT_4X4_50", metavar="DICT", help="ArUco dictionary (DICT_4X4_50)")
    p.add_argument("--marker-size", type=marker_size, default=0.15, metavar="M",
                   help="side of the black marker square in metres, over 0.001 and up to 10 (default 0.15)")
    p.add_argument("--gate", type=gate_pair, action="append", metavar="LEFT,RIGHT",
                   help="a gate's marker ids (repeatable); default: any two markers 0.3-1.5 m apart")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.add_argument("-o", "--output", metavar="ANNOTATED.png",
                   help="write the image with the markers, their axes and the gates drawn (one IMAGE only)")
    p.set_defaults(func=cmd_detect)


IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def read_image(path: str) -> Any:
    """The image at ``path`` (BGR or grey, uint8), or a located error: read through the reading rule, its size
    checked from the header before anything is decoded (:mod:`fsm.vision.images`)."""
    from fsm.loading.reading import read_file_bytes
    from fsm.vision.images import decode_image

    return decode_image(read_file_bytes(Path(path), "image"), path)


def read_stdin(args: argparse.Namespace) -> dict[str, bytes]:
    """Standard input, when ``-`` names one IMAGE or the calibration: ``{"<stdin>": bytes}`` to preload."""
    from fsm.loading.reading import STDIN_NAME, read_stdin_bytes

    users = args.images.count("-") + (args.calibration == "-")
    if not users:
        return {}
    if users > 1:
        raise UsageError("'-' (standard input) can be given once: for one IMAGE or for --calibration")
    if sys.stdin is None or (sys.stdin.isatty() if hasattr(sys.stdin, "isatty") else False):
        raise UsageError("'-' reads from standard input, but standard input is a terminal; pipe a file in "
                         "(fsmctl detect - < frame.png)")
    return {STDIN_NAME: read_stdin_bytes()}


def detect_in(file: str, image: Any, calibration: Any, calibration_name: str | None, rule: Any,
              args: argparse.Namespace, keep: bool) -> Detected:
    """Markers and gates in one image: (file, the image if ``keep`` else None, camera, note, markers, gates)."""
    from fsm.vision import CameraModel, MarkerDetector, find_gates
    from fsm.vision.camera import DEFAULT_FOV

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
                "(another aspect ratio)", file, hint=f"calibrate at this resolution; calibration: {calibration_name}")])
        camera = calibration.scaled(w, h)
        note = f"calibration made at {calibration.width}x{calibration.height}, scaled to {w}x{h}"
    else:
        camera = calibration
    markers = MarkerDetector(camera, dictionary=args.dictionary, marker_size=args.marker_size).detect(image)
    return file, image if keep else None, camera, note, markers, find_gates(markers, rule)


def _check_detect_usage(args: argparse.Namespace) -> None:
    """The options that do not go together, refused before any image is read."""
    from fsm.vision import dictionary_names

    if args.dictionary not in dictionary_names():
        raise UsageError(f"--dictionary: unknown {args.dictionary!r}; choose one of {', '.join(dictionary_names())}")
    if args.output and len(args.images) != 1:
        raise UsageError("-o/--output takes one IMAGE")
    if args.calibration and args.fov is not None:
        raise UsageError("--fov is for images without --calibration")


def _image_output(args: argparse.Namespace) -> Outputs | None:
    """``-o IMAGE``: the annotated image's output, checked (a folder, a missing folder: refused before any work)."""
    if not args.output:
        return None
    from ..files import Outputs

    if Path(args.output).suffix.lower() not in IMAGE_SUFFIXES:
        raise UsageError(f"-o: {args.output}: name an image file (.png, .jpg, ...)")
    outputs = Outputs()
    outputs.add(args.output, "-o", binary=True)
    outputs.items[0].classify()
    return outputs


def _write_annotated(args: argparse.Namespace, outputs: Outputs, result: tuple[Any, ...]) -> None:
    """The one image with its markers and gates drawn, written to ``-o``."""
    import cv2

    from fsm.vision.draw import annotate

    _file, image, camera, _note, markers, gates = result
    ok, png = cv2.imencode(Path(args.output).suffix.lower(), annotate(image, markers, camera, gates))
    if not ok:  # pragma: no cover - OpenCV encodes every suffix we allow
        raise DiagramError([Problem("cannot encode the annotated image", args.output)])
    inputs = [f for f in args.images + [args.calibration or "-"] if f != "-"]
    outputs.open(inputs)  # the same file as the image read: refused
    try:
        outputs.items[0].write(png.tobytes())
        outputs.commit()
    finally:
        outputs.discard()


def cmd_detect(args: argparse.Namespace) -> int:
    from fsm.loading.reading import preloaded
    from fsm.vision import GateRule, load_calibration

    _check_detect_usage(args)
    outputs = _image_output(args)
    stdin = read_stdin(args)
    calibration_name = input_name(args.calibration) if args.calibration else None
    rule = GateRule(pairs=args.gate) if args.gate else GateRule()
    results: list[Detected] = []
    problems: list[Problem] = []
    with preloaded(stdin):
        calibration = load_calibration(calibration_name) if calibration_name else None
        for file in map(input_name, args.images):
            try:
                image = read_image(file)
                if not problems:  # once one file failed, the others are only checked
                    results.append(detect_in(file, image, calibration, calibration_name, rule, args,
                                             keep=outputs is not None))
                del image  # one decoded image in memory at a time
            except DiagramError as exc:
                problems += exc.problems
    if problems:
        raise DiagramError(problems)
    if outputs is not None:
        _write_annotated(args, outputs, results[0])
    if args.format == "json":
        print(json.dumps([_as_json(*r) for r in results], indent=2))
        return EXIT_OK
    print("poses in the camera frame: x forward, y left, z up (m); angles in degrees, left positive")
    for r in results:
        _print_detected(*r)
    if args.output:
        print(f"wrote {args.output}", file=sys.stderr)
    return EXIT_OK


#: What one image gave: its file, the image (kept for an annotated output), the camera, the calibration's note,
#: the markers and the gates.
Detected = tuple[str, Any, Any, str | None, list[Any], list[Any]]


def _as_json(file: str, _image: Any, camera: Any, note: str | None, markers: list[Any], gates: list[Any]
             ) -> dict[str, Any]:
    return {
        "file": file, "width": camera.width, "height": camera.height,
        "camera": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy,
                   "distortion": [float(d) for d in camera.dist], "note": note},
        "frame": "camera: x forward, y left, z up (m); angles in degrees, left positive",
        "markers": [d.to_dict() for d in markers], "gates": [g.to_dict() for g in gates],
    }


def _print_detected(file: str, _image: Any, camera: Any, note: str | None, markers: list[Any], gates: list[Any]
                    ) -> None:
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
