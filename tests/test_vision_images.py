"""Image files (fsm.vision.images): the size comes from the header of every format we read and agrees with what
OpenCV decodes; an image over the pixel limit is refused before it is decoded; damaged files are located errors
without the decoders' own complaints on standard error; random and cut bytes never raise anything else."""

from __future__ import annotations

import os
import struct
import time
import zlib
from unittest import mock

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.model.errors import DiagramError
from fsm.vision import images
from fsm.vision.images import MAX_PIXELS, ImageHeader, decode_image, image_header, max_pixels


def frame(width: int = 64, height: int = 48, channels: int = 3, dtype: type = np.uint8) -> np.ndarray:
    rng = np.random.default_rng(width * height)
    shape = (height, width) if channels == 1 else (height, width, channels)
    top = 255 if dtype == np.uint8 else 65535
    return rng.integers(0, top, shape, endpoint=True).astype(dtype)


def encoded(suffix: str, image: np.ndarray, params: tuple[int, ...] = ()) -> bytes:
    ok, data = cv2.imencode(suffix, image, list(params))
    assert ok
    return data.tobytes()


def chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_of_zeros(width: int, height: int, rows: int | None = None) -> bytes:
    """A grey PNG of zeros, compressed row by row (a 30000x30000 one is under 1 MB), ``rows`` of its data."""
    z = zlib.compressobj(9)
    row = b"\0" * (width + 1)
    data = b"".join(z.compress(row) for _ in range(height if rows is None else rows)) + z.flush()
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", data) + chunk(b"IEND", b""))


SAMPLES = {
    "png grey": (encoded(".png", frame(64, 48, 1)), "PNG"),
    "png colour": (encoded(".png", frame(64, 48, 3)), "PNG"),
    "png rgba": (encoded(".png", frame(64, 48, 4)), "PNG"),
    "png 16-bit": (encoded(".png", frame(64, 48, 3, np.uint16)), "PNG"),
    "jpeg": (encoded(".jpg", frame(64, 48, 3)), "JPEG"),
    "jpeg progressive": (encoded(".jpg", frame(64, 48, 3), (cv2.IMWRITE_JPEG_PROGRESSIVE, 1)), "JPEG"),
    "jpeg grey": (encoded(".jpg", frame(64, 48, 1)), "JPEG"),
    "bmp": (encoded(".bmp", frame(64, 48, 3)), "BMP"),
    "bmp grey": (encoded(".bmp", frame(64, 48, 1)), "BMP"),
    "tiff": (encoded(".tif", frame(64, 48, 3)), "TIFF"),
    "tiff 16-bit": (encoded(".tif", frame(64, 48, 1, np.uint16)), "TIFF"),
    "webp": (encoded(".webp", frame(64, 48, 3)), "WebP"),
    "webp lossless": (encoded(".webp", frame(64, 48, 3), (cv2.IMWRITE_WEBP_QUALITY, 101)), "WebP"),
    "pgm": (encoded(".pgm", frame(64, 48, 1)), "PNM"),
    "ppm": (encoded(".ppm", frame(64, 48, 3)), "PNM"),
}


@pytest.mark.parametrize("name", list(SAMPLES))
def test_the_header_gives_the_size_opencv_decodes(name: str) -> None:
    raw, kind = SAMPLES[name]
    assert image_header(raw, name) == ImageHeader(kind, 64, 48)
    image = decode_image(raw, name)
    assert image.dtype == np.uint8 and image.shape[:2] == (48, 64) and image.ndim in (2, 3)
    assert image.ndim == 2 or image.shape[2] == 3


def test_a_bottom_up_and_a_top_down_bmp() -> None:
    raw = bytearray(SAMPLES["bmp"][0])
    raw[22:26] = struct.pack("<i", -48)  # negative height: rows stored top-down
    assert image_header(bytes(raw)) == ImageHeader("BMP", 64, 48)


def test_a_big_endian_and_a_bigtiff_header() -> None:
    entries = [(256, 3, 1, 640), (257, 4, 1, 480)]
    classic = b"MM\x00*" + struct.pack(">I", 8) + struct.pack(">H", len(entries)) + b"".join(
        struct.pack(">HHI", tag, kind, count)
        + (struct.pack(">HH", value, 0) if kind == 3 else struct.pack(">I", value))
        for tag, kind, count, value in entries)
    assert image_header(classic) == ImageHeader("TIFF", 640, 480)
    big = b"II+\x00" + struct.pack("<HHQ", 8, 0, 16) + struct.pack("<Q", 2) + b"".join(
        struct.pack("<HHQQ", tag, 16, 1, value) for tag, value in ((256, 4000), (257, 3000)))
    assert image_header(big) == ImageHeader("TIFF", 4000, 3000)


def test_a_30000_by_30000_png_is_refused_from_its_header_without_decoding() -> None:
    raw = png_of_zeros(30000, 30000, rows=300)  # the data would be 0.9 MB; its first rows are enough here
    t0 = time.perf_counter()
    with mock.patch.object(cv2, "imdecode", side_effect=AssertionError("decoded")), \
            pytest.raises(DiagramError) as info:
        decode_image(raw, "huge.png")
    assert time.perf_counter() - t0 < 1.0
    (problem,) = info.value.problems
    assert problem.file == "huge.png"
    assert "30000x30000 = 900,000,000 pixels; the limit is 50,000,000" in problem.message
    assert "FSM_MAX_IMAGE_PIXELS" in (problem.hint or "")


def test_the_pixel_limit_comes_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    raw = SAMPLES["png grey"][0]
    monkeypatch.setenv("FSM_MAX_IMAGE_PIXELS", str(64 * 48 - 1))
    assert max_pixels() == 64 * 48 - 1
    with pytest.raises(DiagramError, match="the limit is 3,071"):
        decode_image(raw, "a.png")
    monkeypatch.setenv("FSM_MAX_IMAGE_PIXELS", str(64 * 48))
    assert decode_image(raw, "a.png").shape == (48, 64)
    monkeypatch.setenv("FSM_MAX_IMAGE_PIXELS", "lots")
    assert max_pixels() == MAX_PIXELS


def test_damaged_files_are_located_and_the_decoders_stay_quiet(capfd: pytest.CaptureFixture[str]) -> None:
    cases = {
        "short.png": (png_of_zeros(100, 100, rows=10), "damaged PNG file: its header says 100x100 but the image "
                                                        "data cannot be decoded"),
        "cut.png": (SAMPLES["png colour"][0][:200], "damaged PNG file"),
        "cut.jpg": (SAMPLES["jpeg"][0][:300], "damaged JPEG file"),
        "cut.tif": (SAMPLES["tiff"][0][:100], "damaged TIFF file"),
        "cut.bmp": (SAMPLES["bmp"][0][:60], "damaged BMP file"),
        "header.png": (SAMPLES["png colour"][0][:20], "damaged PNG file: header cut short"),
        "empty.png": (b"", "file is empty"),
        "anim.gif": (b"GIF89a" + bytes(20), "not an image format detect reads"),
        "text.png": (b"this is text, not a PNG\n", "not an image format detect reads"),
        "nosof.jpg": (b"\xff\xd8\xff\xe0\x00\x04ab\xff\xda\x00\x02", "no frame header (SOF) before the image data"),
        "dnl.jpg": (b"\xff\xd8\xff\xc0\x00\x0b\x08\x00\x00\x00\x40\x01\x01\x11\x00", "DNL marker"),
        "zero.png": (png_of_zeros(0, 5), "its header says 0x5 pixels"),
        "4gb-chunk.png": (SAMPLES["png colour"][0][:33] + b"\xf8" + SAMPLES["png colour"][0][34:],
                          "bytes, but the file ends"),
        "no-iend.png": (SAMPLES["png colour"][0][:-12], "without the closing IEND chunk"),
        "float.tif": (b"II*\x00\x08\x00\x00\x00\x03\x00" + struct.pack("<HHIHH", 256, 3, 1, 8, 0)
                      + struct.pack("<HHIHH", 257, 3, 1, 8, 0) + struct.pack("<HHIHH", 258, 3, 1, 32, 0),
                      "1 samples of 32 bits per pixel"),
    }
    capfd.readouterr()
    for name, (raw, message) in cases.items():
        with pytest.raises(DiagramError) as info:
            decode_image(raw, name)
        (problem,) = info.value.problems
        assert problem.file == name and message in problem.message, (name, str(problem))
    out, err = capfd.readouterr()
    assert out == "" and err == "", err  # no "libpng error: ..." before our message


def test_a_progressive_jpeg_of_many_scans_is_refused() -> None:
    raw = SAMPLES["jpeg progressive"][0]
    last = raw.rfind(b"\xff\xda")
    scans = raw.count(b"\xff\xda")
    assert 1 < scans < 100 and decode_image(raw).shape == (48, 64, 3)
    bomb = raw[:-2] + raw[last:-2] * (101 - scans) + b"\xff\xd9"  # each scan is another pass over the image
    with pytest.raises(DiagramError, match="progressive image of 101 scans"):
        image_header(bomb, "bomb.jpg")
    assert image_header(bomb[:-2 - (len(raw) - 2 - last)] + b"\xff\xd9").format == "JPEG"  # 100 scans are fine


def test_the_decoders_may_print_again_afterwards(capfd: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(DiagramError):
        decode_image(png_of_zeros(100, 100, rows=10), "short.png")
    os.write(2, b"still here\n")
    assert capfd.readouterr().err == "still here\n"


# -- fuzz ---------------------------------------------------------------------------------------------------
MAGICS = [b"\x89PNG\r\n\x1a\n", b"\xff\xd8", b"BM", b"II*\x00", b"MM\x00*", b"II+\x00", b"RIFF\0\0\0\0WEBPVP8 ",
          b"RIFF\0\0\0\0WEBPVP8L", b"RIFF\0\0\0\0WEBPVP8X", b"P5\n", b"P6 "]
REAL = [SAMPLES[k][0] for k in ("png colour", "png 16-bit", "jpeg", "jpeg progressive", "bmp", "tiff", "webp",
                                "webp lossless", "ppm")]
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def only_our_error(raw: bytes) -> None:
    """Decoding ``raw`` gives an 8-bit image of at most the limit, or a DiagramError; nothing else."""
    with mock.patch.dict(os.environ, {images.PIXELS_ENV: "20000"}):  # a flipped size decodes fast
        try:
            image = decode_image(raw, "fuzz")
        except DiagramError as exc:
            assert exc.problems and all(p.file == "fuzz" for p in exc.problems)
            return
    assert image.dtype == np.uint8 and image.ndim in (2, 3) and image.shape[0] * image.shape[1] <= 20000


@FUZZ
@given(st.binary(max_size=200))
def test_fuzz_random_bytes(raw: bytes) -> None:
    only_our_error(raw)


@FUZZ
@given(st.sampled_from(MAGICS), st.binary(max_size=120))
def test_fuzz_a_known_magic_then_random_bytes(magic: bytes, tail: bytes) -> None:
    only_our_error(magic + tail)


@FUZZ
@given(st.sampled_from(REAL), st.floats(0, 1))
def test_fuzz_truncated_real_images(raw: bytes, cut: float) -> None:
    only_our_error(raw[:int(len(raw) * cut)])


@FUZZ
@given(st.sampled_from(REAL), st.lists(st.tuples(st.integers(0, 63), st.integers(0, 255)), min_size=1, max_size=4))
def test_fuzz_flipped_header_bytes(raw: bytes, flips: list[tuple[int, int]]) -> None:
    data = bytearray(raw)
    for at, value in flips:
        data[at] = value
    only_our_error(bytes(data))
