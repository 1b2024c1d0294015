"""issue 26 items 8 and 10: a photo whose header lies about its size, or that is cut
short, is refused from its header (nothing decoded, nothing on stderr from libjpeg), in
one line naming the file (and, from case.json, the key); the pixel-limit message never
says "64 megapixels is over the limit of 64 megapixels"."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import write_projected_case

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.imagefile import MAX_PIXELS_PER_BYTE, decode_image, read_image
from naseview.intake.photos import decode_photo

SCAN_CASES = Path(__file__).resolve().parents[3] / "shared" / "data" / "scan-cases"


def _jpeg(h: int = 64, w: int = 64, seed: int = 0) -> bytes:
    img = np.random.default_rng(seed).integers(0, 255, (h, w, 3)).astype(np.uint8)
    return cv2.imencode(".jpg", img)[1].tobytes()


def lying_jpeg(width: int = 8000, height: int = 8000) -> bytes:
    """A real 64x64 JPEG (a few KB) whose frame header is patched to ``width`` x ``height``."""
    data = bytearray(_jpeg())
    i = data.find(b"\xff\xc0")
    data[i + 5:i + 9] = struct.pack(">HH", height, width)
    return bytes(data)


def padded_lying_jpeg(where: str = "comment") -> bytes:
    """:func:`lying_jpeg` made larger than the file-size floor (8000 x 8000 / 2048 = 31.25
    KB) with a 48 KB comment before its frame or 48 KB of bytes after its end marker:
    a valid end marker, few bytes of pixels."""
    data = lying_jpeg()
    pad = bytes(range(256)) * 64
    if where == "comment":
        com = b"".join(b"\xff\xfe" + struct.pack(">H", len(pad) + 2) + pad for _ in range(3))
        return data[:2] + com + data[2:]
    return data + pad * 3


@pytest.fixture()
def no_decoding(monkeypatch):
    def boom(*args, **kwargs):
        raise AssertionError("cv2.imdecode was called: the header check came too late")
    monkeypatch.setattr(cv2, "imdecode", boom)


def test_small_jpeg_declaring_8000_by_8000_is_refused_before_decoding(tmp_path, no_decoding):
    path = tmp_path / "front.jpg"
    path.write_bytes(lying_jpeg())
    assert path.stat().st_size < 10_000
    with pytest.raises(NaseviewError) as e:
        read_image(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path))
    assert "8000x8000" in msg and "damaged or truncated" in msg
    with pytest.raises(NaseviewError, match=r"^front\.jpg: .*8000x8000"):
        decode_photo(lying_jpeg(), "front.jpg")          # the upload path


@pytest.mark.parametrize("where", ["comment", "after the end"])
def test_large_lying_jpeg_with_an_end_marker_is_refused_before_decoding(tmp_path, where,
                                                                        no_decoding):
    """A lying JPEG above the file-size floor (49 KB), end marker in place: its scan data
    (5 KB) cannot be 8000x8000 px; libjpeg would give 192 MB of grey."""
    data = padded_lying_jpeg(where)
    assert len(data) > 8000 * 8000 // MAX_PIXELS_PER_BYTE and b"\xff\xd9" in data
    path = tmp_path / "front.jpg"
    path.write_bytes(data)
    with pytest.raises(NaseviewError) as e:
        read_image(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path)), msg
    assert "8000x8000" in msg and "image data holds only" in msg
    with pytest.raises(NaseviewError, match=r"^front\.jpg: .*8000x8000"):
        decode_photo(data, "front.jpg")                  # the upload path


def test_large_png_with_too_little_pixel_data_is_refused_before_decoding(no_decoding):
    raw = b"".join(b"\x00" + bytes(64 * 3) for _ in range(64))

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2000, 2000, 8, 2,
                                                               0, 0, 0))
           + chunk(b"tEXt", b"c\x00" + b"x" * 40_000) + chunk(b"IDAT", zlib.compress(raw))
           + chunk(b"IEND", b""))
    with pytest.raises(NaseviewError, match=r"^p\.png: .*2000x2000 px but its image data"):
        decode_image(png, "p.png")


def test_real_photos_of_the_scan_cases_still_load() -> None:
    files = sorted(SCAN_CASES.glob("*/*.jpg"))
    assert len(files) >= 8, f"{SCAN_CASES}: the shared scan cases are missing"
    for f in files:
        assert read_image(f).shape[2] == 3


def test_truncated_jpeg_and_png_are_refused_before_decoding(no_decoding):
    jpg = _jpeg(400, 300)
    img = np.random.default_rng(1).integers(0, 255, (400, 300, 3)).astype(np.uint8)
    png = cv2.imencode(".png", img)[1].tobytes()
    for name, data in (("a.jpg", jpg[:len(jpg) // 2]), ("b.png", png[:len(png) // 2]),
                       ("c.jpg", jpg[:len(jpg) - 2])):
        with pytest.raises(NaseviewError, match=rf"^{name}: the (JPEG|PNG) file is damaged "
                                                 r"or truncated \(.*\); copy the photo"):
            decode_image(data, name)


def test_real_photos_even_uniform_ones_still_decode() -> None:
    for h, w in ((2000, 3000), (64, 64)):
        flat = np.full((h, w, 3), 128, np.uint8)
        for data in (cv2.imencode(".jpg", flat, [cv2.IMWRITE_JPEG_QUALITY, 10])[1].tobytes(),
                     cv2.imencode(".png", flat, [cv2.IMWRITE_PNG_COMPRESSION, 9])[1].tobytes(),
                     cv2.imencode(".png", flat[:, :, :1])[1].tobytes()):
            assert decode_image(data, "flat").shape == (h, w, 3)
    progressive = cv2.imencode(".jpg", np.zeros((1500, 1500, 3), np.uint8),
                               [cv2.IMWRITE_JPEG_PROGRESSIVE, 1,
                                cv2.IMWRITE_JPEG_OPTIMIZE, 1])[1].tobytes()
    assert decode_image(progressive, "p").shape == (1500, 1500, 3)


@pytest.mark.parametrize("padded", [False, True])
def test_reconstruct_refuses_a_lying_photo_in_one_line_naming_file_and_key(tmp_path: Path,
                                                                           capfd, padded):
    case = write_projected_case(tmp_path / "case", seed=82)
    image = json.loads((case / "case.json").read_text())["views"]["front"]["image"]
    (case / image).write_bytes(padded_lying_jpeg() if padded else lying_jpeg())
    rc = main(["reconstruct", str(case), "-o", str(tmp_path / "out"), "--stages", "1"])
    err = capfd.readouterr().err.strip()
    assert rc == 2
    assert err.startswith("naseview: error:") and "\n" not in err, err
    assert "case.json" in err and "views.front.image" in err and image in err
    assert "Corrupt JPEG" not in err and ("image data holds only" in err) == padded
    assert not (tmp_path / "out").exists()


def test_pixel_limit_message_does_not_round_to_the_limit() -> None:
    data = lying_jpeg(8001, 8000)
    with pytest.raises(NaseviewError) as e:
        decode_image(data, "big.jpg")
    msg = str(e.value)
    assert "8001x8000 px (64.008 megapixels) is over the limit of 64 megapixels" in msg
