"""Camera calibration files: OpenCV FileStorage YAML/XML (``!!opencv-matrix``), JSON, and ROS ``camera_info`` YAML.

All forms store ``camera_matrix`` and ``distortion_coefficients`` as ``{rows, cols, data}`` (OpenCV adds
``dt``), and the image size as ``image_width`` / ``image_height``; a matrix may also be a plain list (flat or
nested). JSON goes through the project's strict JSON reader (repeated keys refused, problems at line:column).
YAML and XML are parsed with ``cv2.FileStorage`` (it reads YAML 1.0 with or without the ``%YAML:1.0`` header),
so no YAML library is needed; but FileStorage crashes on deep nesting and slows down on long lists, so the text
is first checked to be small and simple (:func:`check_text`). Then the values must describe a camera: focal
lengths > 0 giving a field of view in :data:`~fsm.vision.camera.FOV_RANGE`, the principal point inside the
image, the image within the pixel limit. Every problem is a located :class:`fsm.model.errors.DiagramError`: the
file, the line of the key, and what to fix.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fsm.model.errors import DiagramError, Problem
from fsm.vision.camera import CameraModel, pinhole_problems
from fsm.vision.images import PIXELS_ENV, max_pixels

#: A calibration is a few hundred bytes (OpenCV's sample with every view's extrinsics and image points: 15-20 KB).
MAX_BYTES = 64 * 1024
#: Nesting levels (the file's mapping, a matrix's mapping, its data list, a row: 4).
MAX_DEPTH = 8
#: Values in the whole file (a calibration has a few dozen).
MAX_ITEMS = 10_000
#: Characters of one unquoted value (a number has at most about 25).
MAX_TOKEN = 256
#: Values of one matrix we read (a 3x3 camera matrix, at most 14 distortion coefficients).
MAX_VALUES = 16
#: The only YAML tag a calibration uses (OpenCV's matrices).
TAGS = ("!!opencv-matrix",)
#: Distortion vector lengths OpenCV understands (plumb_bob is 5, rational_polynomial 8).
DIST_LENGTHS = (0, 4, 5, 8, 12, 14)
#: Largest distortion coefficient taken (real lenses' are under a few hundred; beyond this no pose comes out).
MAX_DISTORTION = 1e6
#: The keys we read; everything else in the file (ROS's projection matrix, OpenCV's per-view data) is ignored.
KEYS = ("image_width", "image_height", "camera_matrix", "distortion_coefficients", "distortion_model")
_HINT = ("expected an OpenCV or ROS calibration: camera_matrix {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, "
         "0, 0, 1]}, distortion_coefficients {rows: 1, cols: 5, data: [...]}, image_width, image_height")
_SIMPLE = "keep camera_matrix, distortion_coefficients, image_width and image_height"
#: Where a top-level key is written: (line, column), either unknown.
_Where = Callable[[str], tuple[int | None, int | None]]


class _Bad(Exception):
    """A value that does not describe a camera, at top-level ``key``."""

    def __init__(self, message: str, key: str = "", hint: str | None = None) -> None:
        super().__init__(message)
        self.key, self.hint = key, hint


class _Bads(Exception):
    """Several such values, reported together."""

    def __init__(self, bads: list[_Bad]) -> None:
        super().__init__("; ".join(str(b) for b in bads))
        self.bads = bads


def load_calibration(path: str | Path, *, image_size: tuple[int, int] | None = None) -> CameraModel:
    """The camera described by a calibration file; ``image_size`` (width, height) is used when the file
    names none. Every problem raises a located :class:`DiagramError`."""
    from fsm.loading.reading import read_file_bytes

    return parse_calibration(read_file_bytes(Path(path), "calibration"), str(path), image_size=image_size)


def parse_calibration(raw: bytes, name: str, *, image_size: tuple[int, int] | None = None) -> CameraModel:
    """The camera described by the calibration text ``raw`` (read from ``name``); see :func:`load_calibration`."""
    if len(raw) > MAX_BYTES:
        raise DiagramError([Problem(f"file is {len(raw):,} bytes; a calibration is a few hundred (the limit is "
                                    f"{MAX_BYTES:,})", name, hint=_SIMPLE)])
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise DiagramError([Problem(f"not a text file: byte 0x{raw[exc.start]:02x} cannot be decoded as UTF-8",
                                    name, line=line, hint=_HINT)]) from None
    if not text.strip():
        raise DiagramError([Problem("file is empty", name, line=1, hint=_HINT)])
    if text.lstrip().startswith("{"):
        data, where = _read_json(raw, text, name)
    else:
        data, where = _read_filestorage(text, name)
    try:
        return _camera(data, image_size)
    except _Bad as bad:
        raise DiagramError([_problem(bad, name, where)]) from None
    except _Bads as bads:
        raise DiagramError([_problem(bad, name, where) for bad in bads.bads]) from None


def _problem(bad: _Bad, name: str, where: _Where) -> Problem:
    line, column = where(bad.key) if bad.key else (None, None)
    return Problem(str(bad), name, pointer=f"/{bad.key}" if bad.key else "", line=line, column=column,
                   hint=bad.hint)


# -- reading ------------------------------------------------------------------------------------------------
def _read_json(raw: bytes, text: str, name: str) -> tuple[dict[str, Any], _Where]:
    """A JSON calibration through the strict reader; the text is checked first, as for YAML (a number of
    thousands of digits would otherwise stop Python's parser with an error of its own)."""
    from fsm.loading.reading import parse_json_bytes

    check_text(text, name)
    data, source = parse_json_bytes(raw, name)
    if not isinstance(data, dict):
        raise DiagramError([Problem("not a calibration: the file is not a JSON object", name, line=1, hint=_HINT)])

    def where(key: str) -> tuple[int | None, int | None]:
        pos = source.locator({f"/{key}"}).get(f"/{key}")
        return (pos[0], pos[1]) if pos else (None, None)

    return {k: data[k] for k in KEYS if k in data}, where


def _read_filestorage(text: str, name: str) -> tuple[dict[str, Any], _Where]:
    """The keys we read from a YAML or XML calibration, as Python values, through ``cv2.FileStorage`` once the
    text passed :func:`check_text`."""
    check_text(text, name)
    fs = _open(text, name)
    try:
        _refuse_repeated_keys(fs.root(), text, name)
        data: dict[str, Any] = {}
        for key in KEYS:
            node = _node(fs, key)
            if node is not None:
                data[key] = _value(node, key)
        return data, lambda key: (_line_of(text, key), None)
    except _Bad as bad:
        raise DiagramError([Problem(str(bad), name, pointer=f"/{bad.key}", line=_line_of(text, bad.key),
                                    hint=bad.hint)]) from None
    finally:
        fs.release()


def _open(text: str, name: str) -> Any:
    import cv2

    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError) as exc:  # the binding wraps cv2.error in SystemError
        cause = exc.__cause__ if isinstance(exc, SystemError) and exc.__cause__ is not None else exc
        message = str(cause).strip()
        m = re.search(r"'[^']*\((\d+)\): ([^']*)'", message)
        line, what = (int(m.group(1)), m.group(2)) if m else (None, message.splitlines()[-1] if message else "")
        raise DiagramError([Problem(f"malformed calibration file: {what.strip() or 'cannot parse'}", name,
                                    line=line, hint=_HINT)]) from None
    if not fs.isOpened() or not fs.root().isMap():
        fs.release()
        raise DiagramError([Problem("not a calibration: the file is not a YAML/JSON mapping", name, line=1,
                                    hint=_HINT)])
    return fs


def _refuse_repeated_keys(root: Any, text: str, name: str) -> None:
    """Two values for one key mean two cameras to two tools (OpenCV keeps the first, most YAML readers the last)."""
    keys = root.keys()
    repeated = sorted({k for k in keys if keys.count(k) > 1}, key=keys.index)
    problems = []
    for key in repeated:
        lines = _lines_of(text, key)
        first = f" (first at line {lines[0]})" if lines else ""
        problems.append(Problem(f"duplicate key '{key}'{first}", name, pointer=f"/{key}",
                                line=lines[1] if len(lines) > 1 else None,
                                hint="a key may appear once per mapping; delete one of the two"))
    if problems:
        raise DiagramError(problems)


def _node(fs_or_node: Any, key: str) -> Any | None:
    node = fs_or_node.getNode(key)
    return None if node.empty() or node.isNone() else node


def _value(node: Any, key: str) -> Any:
    """A FileStorage node as a Python value (int, float, str, list, dict, None); lists of at most
    :data:`MAX_VALUES` (checked before reading them: reading a list's items one by one takes quadratic time)."""
    import cv2

    kind = node.type()
    if kind == cv2.FILE_NODE_INT:
        return int(node.real())
    if kind == cv2.FILE_NODE_REAL:
        return float(node.real())
    if kind == cv2.FILE_NODE_STRING:
        return node.string()
    if node.isSeq():
        if node.size() > MAX_VALUES:
            raise _Bad(f"{key} has {node.size()} values; a calibration matrix has at most {MAX_VALUES}", key)
        return [_value(node.at(i), key) for i in range(node.size())]
    if node.isMap():
        keys = node.keys()
        if len(keys) > MAX_VALUES:
            raise _Bad(f"{key} has {len(keys)} entries; a matrix has rows, cols, dt and data", key)
        for k in keys:
            if keys.count(k) > 1:
                raise _Bad(f"{key}: duplicate key '{k}'", key, hint="a key may appear once per mapping")
        return {k: _value(node.getNode(k), key) for k in keys}
    return None


# -- the text before FileStorage sees it --------------------------------------------------------------------
def check_text(text: str, name: str) -> None:
    """Refuse a YAML, JSON or XML text that is not small and simple (a located :class:`DiagramError`): control
    characters, nesting deeper than :data:`MAX_DEPTH`, more than :data:`MAX_ITEMS` values, an unquoted value
    longer than :data:`MAX_TOKEN`, YAML anchors, aliases, directives and tags other than :data:`TAGS`, XML
    declarations (``<!DOCTYPE``, ``<!ENTITY``)."""
    bad = re.search(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]", text)
    if bad:
        raise _shape_error(f"control character U+{ord(bad.group()):04X}", name, text.count("\n", 0, bad.start()) + 1)
    if text.lstrip().startswith("<"):
        _XmlShape(text, name).run()
    else:
        _YamlShape(text, name).run()


def _shape_error(message: str, name: str, line: int, hint: str | None = None) -> DiagramError:
    return DiagramError([Problem(f"not a simple calibration: {message}", name, line=line, hint=hint or _SIMPLE)])


class _Shape:
    """What both scanners count: nesting, values, their lengths; the first excess is a located error."""

    def __init__(self, text: str, name: str) -> None:
        self.text, self.name = text, name
        self.pos, self.line, self.items = 0, 1, 0

    def fail(self, message: str, hint: str | None = None) -> DiagramError:
        return _shape_error(message, self.name, self.line, hint)

    def depth(self, depth: int) -> None:
        if depth > MAX_DEPTH:
            raise self.fail(f"nested more than {MAX_DEPTH} levels deep")

    def value(self, token: str = "") -> None:
        self.items += 1
        if self.items > MAX_ITEMS:
            raise self.fail(f"more than {MAX_ITEMS:,} values")
        if len(token) > MAX_TOKEN:
            raise self.fail(f"a value of {len(token):,} characters (at most {MAX_TOKEN})")


_DQ = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
_SQ = re.compile(r"'(?:[^']|'')*'")
_PLAIN_END = re.compile(r"[\s,\[\]{}]|:(?=[\s,\[\]{}]|$)")
_DIRECTIVE = re.compile(r"%YAML[: ]\s*1\.\d+\s*$")
_DASHES = re.compile(r"(?:-(?:[ \t]+|$))*")  # "- - - " opening nested block sequences on one line


class _YamlShape(_Shape):
    """One pass over a YAML (or JSON) text: block indentation and flow brackets give the nesting; quoted
    strings and comments are skipped; every other token is a value, an anchor, an alias or a tag."""

    def __init__(self, text: str, name: str) -> None:
        super().__init__(text, name)
        self.flow = 0
        self.block = 0
        self.indents: list[int] = []

    def run(self) -> None:
        text, n = self.text, len(self.text)
        self.line_start()
        while self.pos < n:
            c = text[self.pos]
            if c == "\n":
                self.pos += 1
                self.line += 1
                if self.flow == 0:
                    self.line_start()
            elif c in " \t\r,:" or (c == "-" and (self.pos + 1 == n or text[self.pos + 1] in " \t\r\n")):
                self.pos += 1
            elif c == "#":
                end = text.find("\n", self.pos)
                self.pos = n if end < 0 else end
            elif c in "[{":
                self.flow += 1
                self.depth(self.block + self.flow)
                self.pos += 1
            elif c in "]}":
                self.flow = max(0, self.flow - 1)
                self.pos += 1
            elif c in "\"'":
                self.quoted(_DQ if c == '"' else _SQ)
            else:
                self.plain()

    def line_start(self) -> None:
        """At the start of a line outside brackets: a directive, a document marker, or the indentation that
        nests block mappings and sequences (``- - x`` nests twice on one line)."""
        text, start = self.text, self.pos
        eol = text.find("\n", start)
        eol = len(text) if eol < 0 else eol
        content = text[start:eol].lstrip(" \t")
        if not content.strip() or content.startswith("#"):
            self.pos = eol
            return
        if len(content) == eol - start:  # column 0
            if content.startswith("%"):
                if not _DIRECTIVE.match(content.rstrip()):
                    raise self.fail(f"YAML directive {content.split()[0]!r}", hint="only %YAML:1.0 is read")
                self.pos = eol
                return
            if content[:3] in ("---", "...") and (len(content) == 3 or content[3] in " \t\r"):
                self.indents = []
                self.pos = start + 3
                return
        indent = eol - start - len(content)
        while self.indents and self.indents[-1] > indent:
            self.indents.pop()
        if not self.indents or self.indents[-1] < indent:
            self.indents.append(indent)
        dashes = _DASHES.match(content)
        self.block = len(self.indents) + (content[:dashes.end()].count("-") if dashes else 0)
        self.depth(self.block)
        self.pos = eol - len(content)

    def quoted(self, pattern: re.Pattern[str]) -> None:
        m = pattern.match(self.text, self.pos)
        end = m.end() if m else len(self.text)  # unterminated: FileStorage says so
        self.line += self.text.count("\n", self.pos, end)
        self.pos = end
        self.value()

    def plain(self) -> None:
        m = _PLAIN_END.search(self.text, self.pos + 1)
        end = m.start() if m else len(self.text)
        token = self.text[self.pos:end]
        self.pos = end
        if token[0] in "&*":
            raise self.fail(f"YAML {'anchor' if token[0] == '&' else 'alias'} {token[:40]!r}",
                            hint="write each value out; anchors and aliases are not read")
        if token[0] == "!":
            if token not in TAGS:
                raise self.fail(f"YAML tag {token[:40]!r}", hint=f"only {', '.join(TAGS)} is read")
            return
        self.value(token)


_XML_TAG = re.compile(r"<(/?)([^\s/>]*)([^>]*?)(/?)>")
_TYPE_ID = re.compile(r"""type_id\s*=\s*["']([^"']*)["']""")


class _XmlShape(_Shape):
    """One pass over an OpenCV XML text: element nesting, the values between tags, and no declarations
    (``<!DOCTYPE``, ``<!ENTITY``: entity expansion is how small XML files grow huge)."""

    def run(self) -> None:
        text, n, depth = self.text, len(self.text), 0
        while self.pos < n:
            lt = text.find("<", self.pos)
            end = n if lt < 0 else lt
            for token in text[self.pos:end].split():
                self.value(token)
            self.line += text.count("\n", self.pos, end)
            self.pos = end
            if lt < 0:
                return
            if text.startswith("<!--", lt) or text.startswith("<?", lt):
                terminator = "-->" if text[lt + 1] == "!" else "?>"
                close = text.find(terminator, lt)
                if close < 0:
                    raise self.fail("an unterminated comment or declaration")
                self.line += text.count("\n", lt, close)
                self.pos = close + len(terminator)
                continue
            if text.startswith("<!", lt):
                raise self.fail(f"XML declaration {text[lt:lt + 12]!r}", hint="DOCTYPE and ENTITY are not read")
            m = _XML_TAG.match(text, lt)
            if m is None:
                raise self.fail("an unterminated tag")
            type_id = _TYPE_ID.search(m.group(3))
            if type_id and type_id.group(1) not in ("opencv-matrix",):
                raise self.fail(f"type_id {type_id.group(1)!r}", hint="only opencv-matrix is read")
            if not m.group(1) and not m.group(4):
                depth += 1
                self.depth(depth - 1)  # the opencv_storage root is no level of its own
            elif m.group(1):
                depth = max(0, depth - 1)
            self.line += text.count("\n", lt, m.end())
            self.pos = m.end()


# -- the camera ---------------------------------------------------------------------------------------------
def _camera(data: dict[str, Any], image_size: tuple[int, int] | None) -> CameraModel:
    K = _matrix(data, "camera_matrix", required=True)
    assert K is not None
    if K.shape != (3, 3):
        raise _Bad(f"camera_matrix must be 3x3, got {K.shape[0]}x{K.shape[1]}", "camera_matrix")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise _Bad(f"camera_matrix focal lengths must be > 0, got fx={K[0, 0]:g}, fy={K[1, 1]:g}", "camera_matrix")
    if abs(K[2, 0]) > 1e-9 or abs(K[2, 1]) > 1e-9 or abs(K[2, 2] - 1) > 1e-6 or abs(K[1, 0]) > 1e-9:
        raise _Bad("camera_matrix must have the form [fx, s, cx; 0, fy, cy; 0, 0, 1]", "camera_matrix")
    model = data.get("distortion_model")
    if isinstance(model, str) and model not in ("plumb_bob", "rational_polynomial"):
        raise _Bad(f"distortion_model {model!r} is not supported (only plumb_bob and rational_polynomial)",
                   "distortion_model", hint="fisheye (equidistant) calibrations need cv2.fisheye; undistort first")
    dist = _distortion(data)
    width, height = _int(data, "image_width"), _int(data, "image_height")
    if (width is None) != (height is None):
        raise _Bad("image_width and image_height come together", "image_height" if width is None else "image_width")
    if width is None or height is None:
        if image_size is None:
            raise _Bad("the file names no image size", "image_width",
                       hint="add image_width and image_height (the resolution the camera was calibrated at)")
        width, height = image_size
    else:
        _check_pixels(width, height)
    bads = [_Bad(f"camera_matrix: {p}", "camera_matrix",
                 hint=f"fx, fy, cx, cy are in pixels of the {width}x{height} image the camera was calibrated at")
            for p in pinhole_problems(width, height, K[0, 0], K[1, 1], K[0, 2], K[1, 2])]
    if bads:
        raise _Bads(bads)
    return CameraModel(int(width), int(height), K, dist)


def _check_pixels(width: int, height: int) -> None:
    limit, pixels = max_pixels(), width * height
    if pixels > limit:
        shown = f"{pixels:,}" if pixels < 10**15 else f"{pixels:.3g}"
        raise _Bad(f"image_width x image_height is {width}x{height} = {shown} pixels; the limit is {limit:,}",
                   "image_width", hint=f"the resolution the camera was calibrated at, in pixels; {PIXELS_ENV} "
                                       "raises the limit")


def _distortion(data: dict[str, Any]) -> np.ndarray:
    dist = _matrix(data, "distortion_coefficients", required=False)
    if dist is None:
        return np.zeros(5)
    if 1 not in dist.shape and dist.size:
        raise _Bad(f"distortion_coefficients must be one row or column, got {dist.shape[0]}x{dist.shape[1]}",
                   "distortion_coefficients")
    dist = dist.reshape(-1)
    if dist.size not in DIST_LENGTHS:
        raise _Bad(f"distortion_coefficients has {dist.size} values; OpenCV takes "
                   f"{', '.join(str(n) for n in DIST_LENGTHS[1:])}", "distortion_coefficients")
    for i, d in enumerate(dist):
        if abs(d) > MAX_DISTORTION:
            raise _Bad(f"distortion_coefficients: element {i} is {d:g}; a lens's coefficients are far below "
                       f"{MAX_DISTORTION:g}", "distortion_coefficients")
    return dist


def _numbers(values: list[Any], key: str) -> list[float]:
    if len(values) > MAX_VALUES:
        raise _Bad(f"{key} has {len(values)} values; a calibration matrix has at most {MAX_VALUES}", key)
    out = []
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise _Bad(f"{key}: element {i} is not a number", key)
        v = float(v)
        if not math.isfinite(v):
            raise _Bad(f"{key}: element {i} is {v} (values must be finite)", key)
        out.append(v)
    return out


def _matrix(data: dict[str, Any], key: str, required: bool) -> np.ndarray | None:
    value = data.get(key)
    if value is None:
        if required:
            raise _Bad(f"no '{key}' in the file", "", hint=_HINT)
        return None
    if isinstance(value, dict):
        rows, cols, values = _int(value, "rows", key), _int(value, "cols", key), value.get("data")
        if rows is None or cols is None or not isinstance(values, list):
            raise _Bad(f"{key} needs rows, cols and a data list", key)
        numbers = _numbers(values, key)
        if rows <= 0 or cols <= 0 or len(numbers) != rows * cols:
            raise _Bad(f"{key} says {rows}x{cols} but has {len(numbers)} values", key)
        return np.array(numbers, dtype=np.float64).reshape(rows, cols)
    if isinstance(value, list):
        if value and isinstance(value[0], list):  # nested rows
            rows_ = [_numbers(r if isinstance(r, list) else [r], key) for r in value[:MAX_VALUES + 1]]
            if len(rows_) > MAX_VALUES or len({len(r) for r in rows_}) != 1:
                raise _Bad(f"{key}: rows of different lengths" if len(rows_) <= MAX_VALUES else
                           f"{key} has more than {MAX_VALUES} rows", key)
            return np.array(rows_, dtype=np.float64)
        numbers = _numbers(value, key)
        if key == "camera_matrix" and len(numbers) == 9:
            return np.array(numbers, dtype=np.float64).reshape(3, 3)
        if key == "camera_matrix":
            raise _Bad(f"camera_matrix must be 3x3, got a list of {len(numbers)} values", key)
        return np.array(numbers, dtype=np.float64).reshape(1, -1)
    raise _Bad(f"{key} must be a matrix ({{rows, cols, data}} or a list)", key)


def _int(data: dict[str, Any], key: str, where: str | None = None) -> int | None:
    value = data.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise _Bad(f"{key} must be a whole number", where or key)
    if where is None and value <= 0:
        raise _Bad(f"{key} must be > 0, got {value}", key)
    return value


def _lines_of(text: str, key: str) -> list[int]:
    """The 1-based lines where ``key`` is written (FileStorage keeps no positions), for messages: YAML
    ``key:`` and XML ``<key>``."""
    if not key:
        return []
    pattern = rf'^\s*"?{re.escape(key)}"?\s*:|<{re.escape(key)}[\s/>]'
    return [text.count("\n", 0, m.start()) + 1 for m in re.finditer(pattern, text, re.M)]


def _line_of(text: str, key: str) -> int | None:
    lines = _lines_of(text, key)
    return lines[0] if lines else None
