"""Image files read safely: the pixel count is taken from the header and checked before anything is decoded,
and decoding works on bytes already read (``cv2.imdecode``), with the decoders' own complaints silenced.

A 30000x30000 PNG of zeros is under 1 MB on disk and 900 MB once decoded, so the size of the file says
nothing about the memory decoding takes; the header does. Formats: PNG, JPEG, BMP, TIFF, WebP and
PBM/PGM/PPM; anything else is refused rather than handed to a decoder we cannot bound.
"""

from __future__ import annotations

import os
import re
import struct
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, NamedTuple

import numpy as np

from fsm.model.errors import DiagramError, Problem

#: Largest image decoded, pixels (width x height): a 50-megapixel photo; 16-bit RGBA at this size is 400 MB.
MAX_PIXELS = 50_000_000
#: Environment variable that changes :data:`MAX_PIXELS`.
PIXELS_ENV = "FSM_MAX_IMAGE_PIXELS"
#: The formats whose headers we read, as messages name them.
FORMATS = "PNG, JPEG, BMP, TIFF, WebP or PBM/PGM/PPM"
#: PNG chunks we walk (a 64 MB PNG written in libpng's 8 KB IDAT chunks has 8,000).
_MAX_PNG_CHUNKS = 100_000
#: JPEG segments before the frame header we look at (real files have a dozen: APPn, DQT, DHT).
_MAX_JPEG_SEGMENTS = 1000
#: Scans of a progressive JPEG (encoders write about 10; each is another pass over the image, so thousands make
#: a small file take minutes to decode; libjpeg-turbo's own optional limit is 500).
_MAX_JPEG_SCANS = 100
#: TIFF directory entries we look at (real files have a few dozen).
_MAX_TIFF_ENTRIES = 4096
#: Bytes of a PBM/PGM/PPM header (magic, comments, width, height).
_MAX_PNM_HEADER = 4096


class ImageHeader(NamedTuple):
    """What an image file's header says: its format and size in pixels."""

    format: str
    width: int
    height: int

    @property
    def pixels(self) -> int:
        return self.width * self.height


class _Bad(Exception):
    """A header that cannot be read (the message says why); turned into a located problem by the caller."""


def max_pixels() -> int:
    """The pixel limit: :data:`MAX_PIXELS`, or the whole number in ``FSM_MAX_IMAGE_PIXELS``."""
    try:
        return max(1, int(os.environ.get(PIXELS_ENV, "")))
    except ValueError:
        return MAX_PIXELS


def image_header(raw: bytes, name: str | None = None) -> ImageHeader:
    """The format and size of the image in ``raw``, from its header alone; a :class:`DiagramError` naming
    ``name`` when the format is not one we read or the header is damaged."""
    reader = _reader_for(raw)
    if reader is None:
        raise DiagramError([Problem("not an image format detect reads" if raw else "file is empty", name,
                                    hint=f"give a {FORMATS} file")])
    try:
        header = reader(raw)
    except (_Bad, struct.error, IndexError, OverflowError) as exc:
        what = str(exc) if isinstance(exc, _Bad) else "header cut short"
        raise DiagramError([Problem(f"damaged {_format_name(reader)} file: {what}", name,
                                    hint="the file is truncated or not what its name says")]) from None
    if header.width <= 0 or header.height <= 0:
        raise DiagramError([Problem(f"damaged {header.format} file: its header says {header.width}x{header.height} "
                                    "pixels", name, hint="the file is truncated or not what its name says")])
    return header


def check_pixels(header: ImageHeader, name: str | None) -> None:
    """Refuse an image larger than :func:`max_pixels` (a located :class:`DiagramError`)."""
    limit = max_pixels()
    if header.pixels > limit:
        raise DiagramError([Problem(
            f"{header.format} image of {header.width}x{header.height} = {header.pixels:,} pixels; the limit is "
            f"{limit:,}", name, hint=f"scale it down, or set {PIXELS_ENV} to a larger number of pixels")])


def decode_image(raw: bytes, name: str | None = None) -> np.ndarray:
    """The image in ``raw`` as 8-bit BGR or grey, decoded only after its header passed :func:`check_pixels`;
    every problem is a located :class:`DiagramError`."""
    import cv2

    header = image_header(raw, name)
    check_pixels(header, name)
    with _quiet_decoders():
        image = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.ndim not in (2, 3) or image.size == 0:
        raise DiagramError([Problem(f"damaged {header.format} file: its header says {header.width}x{header.height} "
                                    "but the image data cannot be decoded", name,
                                    hint="the file is truncated or corrupt; export it again")])
    if image.shape[0] * image.shape[1] > max_pixels():  # the decoder disagreed with the header
        check_pixels(ImageHeader(header.format, image.shape[1], image.shape[0]), name)
    return _to_8bit(image, name)


def _to_8bit(image: np.ndarray, name: str | None) -> np.ndarray:
    """8-bit grey or BGR: 16-bit images scaled to 8 bits, alpha dropped."""
    import cv2

    if image.ndim == 3 and image.shape[2] not in (1, 3, 4):
        raise DiagramError([Problem(f"image has {image.shape[2]} channels; detect reads grey, BGR and BGRA images",
                                    name)])
    if image.dtype != np.uint8:
        peak = float(np.nan_to_num(image.max()))
        image = cv2.convertScaleAbs(np.nan_to_num(image), alpha=255.0 / max(1.0, peak))
    if image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    elif image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    return image


@contextmanager
def _quiet_decoders() -> Iterator[None]:
    """While decoding: OpenCV's log silenced, and the process's standard error (file descriptor 2) pointed at
    /dev/null, since libpng prints its own complaints there ("libpng error: ...") before ours."""
    import cv2

    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    level = logging.getLogLevel() if logging is not None else None
    if logging is not None:
        logging.setLogLevel(logging.LOG_LEVEL_SILENT)
    saved = devnull = -1
    try:
        try:
            sys.stderr.flush()
            saved = os.dup(2)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)
        except (OSError, ValueError, AttributeError):
            pass  # no standard error to silence
        yield
    finally:
        if saved >= 0:
            os.dup2(saved, 2)
            os.close(saved)
        if devnull >= 0:
            os.close(devnull)
        if logging is not None and level is not None:
            logging.setLogLevel(level)


# -- headers ------------------------------------------------------------------------------------------------
def _png(raw: bytes) -> ImageHeader:
    length, kind = struct.unpack_from(">I4s", raw, 8)
    if kind != b"IHDR" or length != 13:
        raise _Bad("the first chunk is not the image header (IHDR)")
    width, height = struct.unpack_from(">II", raw, 16)
    _png_chunks(raw)
    return ImageHeader("PNG", width, height)


def _png_chunks(raw: bytes) -> None:
    """Every chunk fits in the file, up to IEND: OpenCV's PNG reader allocates what a chunk's length field says
    (an 18 KB file whose IDAT claims 4 GB takes 4 GB and 6 s)."""
    at, size = 8, len(raw)
    for _ in range(_MAX_PNG_CHUNKS):
        if at + 12 > size:
            raise _Bad(f"the file ends at byte {size:,} without the closing IEND chunk")
        length, kind = struct.unpack_from(">I4s", raw, at)
        if length > size - at - 12:
            raise _Bad(f"chunk '{kind.decode('latin-1')}' at byte {at:,} says {length:,} bytes, but the file ends "
                       f"{max(0, size - at - 12):,} bytes later")
        if kind == b"IEND":
            return
        at += 12 + length
    raise _Bad(f"more than {_MAX_PNG_CHUNKS:,} chunks")


#: JPEG frame headers (SOF0-SOF15 but DHT, JPG and DAC), which carry the image size.
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
#: Progressive frame headers (SOF2, SOF6, SOF10, SOF14).
_PROGRESSIVE = frozenset((0xC2, 0xC6, 0xCA, 0xCE))
_FILL = re.compile(rb"\xff+")


def _jpeg(raw: bytes) -> ImageHeader:
    i = 2
    for _ in range(_MAX_JPEG_SEGMENTS):
        fill = _FILL.match(raw, i)
        if fill is None:
            raise _Bad(f"no marker at byte {i}")
        i = fill.end()
        marker = raw[i]
        i += 1
        if 0xD0 <= marker <= 0xD7 or marker == 0x01:  # markers without a length
            continue
        if marker in (0xD9, 0xDA):
            raise _Bad("no frame header (SOF) before the image data")
        (length,) = struct.unpack_from(">H", raw, i)
        if length < 2:
            raise _Bad(f"segment of length {length} at byte {i}")
        if marker in _SOF:
            height, width = struct.unpack_from(">HH", raw, i + 3)
            if height == 0:
                raise _Bad("the height is given after the image data (DNL marker), which is not supported")
            scans = raw.count(b"\xff\xda")  # 0xFF in coded data is followed by 0x00: only markers match
            if marker in _PROGRESSIVE and scans > _MAX_JPEG_SCANS:
                raise _Bad(f"progressive image of {scans:,} scans (at most {_MAX_JPEG_SCANS:,}: each scan is "
                           "another pass over the whole image)")
            return ImageHeader("JPEG", width, height)
        i += length
    raise _Bad(f"no frame header (SOF) in the first {_MAX_JPEG_SEGMENTS} segments")


def _bmp(raw: bytes) -> ImageHeader:
    (dib,) = struct.unpack_from("<I", raw, 14)
    if dib == 12:  # OS/2 BITMAPCOREHEADER: 16-bit sizes
        width, height = struct.unpack_from("<HH", raw, 18)
    elif 16 <= dib <= 4096:
        width, height = struct.unpack_from("<ii", raw, 18)
        height = abs(height)  # negative: rows stored top-down
    else:
        raise _Bad(f"unknown header size {dib}")
    return ImageHeader("BMP", width, height)


def _tiff(raw: bytes) -> ImageHeader:
    order = "<" if raw[:2] == b"II" else ">"
    (version,) = struct.unpack_from(order + "H", raw, 2)
    big = version == 43
    if big:  # BigTIFF: 8-byte offsets and counts, 20-byte entries
        (offset,) = struct.unpack_from(order + "Q", raw, 8)
        (count,) = struct.unpack_from(order + "Q", raw, offset)
        start, size = offset + 8, 20
    else:
        (offset,) = struct.unpack_from(order + "I", raw, 4)
        (count,) = struct.unpack_from(order + "H", raw, offset)
        start, size = offset + 2, 12
    if count > _MAX_TIFF_ENTRIES:
        raise _Bad(f"{count} directory entries")
    tags: dict[int, int] = {}
    for k in range(count):
        at = start + k * size
        tag, kind = struct.unpack_from(order + "HH", raw, at)
        if tag in (256, 257, 258, 277):  # ImageWidth, ImageLength, BitsPerSample, SamplesPerPixel
            tags[tag] = _tiff_value(raw, order, kind, at + (12 if big else 8), big)
    if 256 not in tags or 257 not in tags:
        raise _Bad("no image width or length in the first directory")
    bits, samples = tags.get(258, 8), tags.get(277, 1)
    if bits > 16 or samples > 4:
        raise _Bad(f"{samples} samples of {bits} bits per pixel; detect reads 8- and 16-bit images of up to "
                   "4 samples")
    return ImageHeader("TIFF", tags[256], tags[257])


def _tiff_value(raw: bytes, order: str, kind: int, at: int, big: bool) -> int:
    """The first value of a directory entry whose value field starts at ``at`` (SHORT, LONG or LONG8)."""
    code = {3: "H", 4: "I", 16: "Q"}.get(kind)
    if code is None:
        raise _Bad(f"a size field of type {kind}")
    (count,) = struct.unpack_from(order + ("Q" if big else "I"), raw, at - (8 if big else 4))
    if count * struct.calcsize(code) > (8 if big else 4):  # the values live elsewhere: the field is their offset
        (at,) = struct.unpack_from(order + ("Q" if big else "I"), raw, at)
    (value,) = struct.unpack_from(order + code, raw, at)
    return int(value)


def _webp(raw: bytes) -> ImageHeader:
    chunk = raw[12:16]
    if chunk == b"VP8 ":
        if raw[23:26] != b"\x9d\x01\x2a":
            raise _Bad("no VP8 start code")
        width, height = struct.unpack_from("<HH", raw, 26)
        return ImageHeader("WebP", width & 0x3FFF, height & 0x3FFF)
    if chunk == b"VP8L":
        if raw[20] != 0x2F:
            raise _Bad("no VP8L signature")
        (bits,) = struct.unpack_from("<I", raw, 21)
        return ImageHeader("WebP", (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1)
    if chunk == b"VP8X":
        if len(raw) < 30:
            raise _Bad("header cut short")
        return ImageHeader("WebP", int.from_bytes(raw[24:27], "little") + 1, int.from_bytes(raw[27:30], "little") + 1)
    raise _Bad(f"unknown chunk {chunk!r}")


_PNM = re.compile(rb"P[1-6](?:\s|#[^\n]*\n)+(\d{1,10})(?:\s|#[^\n]*\n)+(\d{1,10})\s")


def _pnm(raw: bytes) -> ImageHeader:
    m = _PNM.match(raw[:_MAX_PNM_HEADER])
    if m is None:
        raise _Bad(f"no width and height in the first {_MAX_PNM_HEADER} bytes")
    return ImageHeader("PNM", int(m.group(1)), int(m.group(2)))


def _reader_for(raw: bytes) -> Callable[[bytes], ImageHeader] | None:
    if raw.startswith(b"\x89PNG\r\n\x1a\n"):
        return _png
    if raw.startswith(b"\xff\xd8"):
        return _jpeg
    if raw.startswith(b"BM"):
        return _bmp
    if raw[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return _tiff
    if raw.startswith(b"RIFF") and raw[8:12] == b"WEBP":
        return _webp
    if len(raw) > 2 and raw[:1] == b"P" and raw[1:2] in b"123456" and raw[2:3].isspace():
        return _pnm
    return None


def _format_name(reader: Any) -> str:
    return {_png: "PNG", _jpeg: "JPEG", _bmp: "BMP", _tiff: "TIFF", _webp: "WebP", _pnm: "PNM"}.get(reader, "image")
