"""Photo intake of a new patient: EXIF orientation applied, metadata stripped, huge photos
downscaled (clicks in stored pixels), anything else refused with one line."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import bomb_png, png_bytes

from naseview.errors import NaseviewError
from naseview.intake.photos import MAX_SIDE_PX, decode_photo
from naseview.intake.session import AnnotationSession


def jpeg_with_exif(image_bgr: np.ndarray, orientation: int, description: str) -> bytes:
    """A JPEG whose APP1 EXIF segment holds an orientation and an ImageDescription."""
    ok, buf = cv2.imencode(".jpg", image_bgr, [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    jpg = buf.tobytes()
    desc = description.encode("ascii") + b"\x00"
    n = 2
    ifd_size = 2 + 12 * n + 4
    desc_off = 8 + ifd_size
    tiff = b"MM\x00\x2a" + struct.pack(">I", 8) + struct.pack(">H", n)
    tiff += struct.pack(">HHI", 0x010E, 2, len(desc)) + struct.pack(">I", desc_off)
    tiff += struct.pack(">HHI", 0x0112, 3, 1) + struct.pack(">HH", orientation, 0)
    tiff += struct.pack(">I", 0) + desc
    app1 = b"Exif\x00\x00" + tiff
    seg = b"\xff\xe1" + struct.pack(">H", len(app1) + 2) + app1
    return jpg[:2] + seg + jpg[2:]


def png_with_text(image_bgr: np.ndarray, key: str, text: str) -> bytes:
    """A PNG with a tEXt chunk inserted after IHDR."""
    ok, buf = cv2.imencode(".png", image_bgr)
    assert ok
    png = buf.tobytes()
    data = key.encode("latin-1") + b"\x00" + text.encode("latin-1")
    chunk = struct.pack(">I", len(data)) + b"tEXt" + data + struct.pack(
        ">I", zlib.crc32(b"tEXt" + data) & 0xFFFFFFFF)
    ihdr_end = 8 + 8 + 13 + 4
    return png[:ihdr_end] + chunk + png[ihdr_end:]


def test_exif_orientation_applied_and_metadata_stripped(tmp_path: Path):
    img = np.zeros((120, 200, 3), np.uint8)
    img[:, :100] = (0, 0, 255)                       # left half red (BGR)
    data = jpeg_with_exif(img, 6, "Patient Jane Doe, born 1970")
    assert b"Jane Doe" in data
    s = AnnotationSession.create(tmp_path / "p")
    info = s.add_photo("front", data, "IMG_0001.JPG")
    # orientation 6: rotate 90 degrees clockwise -> 120 wide, 200 high, red on top
    assert (info.width, info.height) == (120, 200)
    stored = (tmp_path / "p" / info.file).read_bytes()
    assert info.file == "front.jpg"
    assert b"Jane Doe" not in stored and b"Exif" not in stored
    got = s.image("front")
    assert got.shape == (200, 120, 3)
    assert got[20, 60, 2] > 200 and got[20, 60, 0] < 60      # top is red
    assert got[180, 60, 2] < 60                               # bottom is black
    # a PNG's text chunks are dropped as well; PNG stays PNG (lossless)
    png = png_with_text(img, "Author", "Dr Who, patient Jane Doe")
    info = s.add_photo("left", png)
    stored = (tmp_path / "p" / info.file).read_bytes()
    assert info.file == "left.png" and b"Jane Doe" not in stored and b"tEXt" not in stored
    np.testing.assert_array_equal(s.image("left"), img)
    # nothing identifying in the autosave either
    assert b"IMG_0001" not in (tmp_path / "p" / "annotation.json").read_bytes()


def test_huge_photo_is_downscaled_and_clicks_are_in_stored_pixels(tmp_path: Path):
    big = np.full((1800, 3000, 3), 128, np.uint8)
    big[:, :1500] = 30
    s = AnnotationSession.create(tmp_path / "p")
    info = s.add_photo("front", png_bytes(big))
    assert info.downscaled and max(info.width, info.height) == MAX_SIDE_PX
    assert (info.original_width, info.original_height) == (3000, 1800)
    assert (info.width, info.height) == (2048, 1229)
    s.place("front", "g", (2047.0, 1228.0))
    with pytest.raises(NaseviewError, match="outside"):
        s.place("front", "n", (2100.0, 10.0))
    img, orig = decode_photo(png_bytes(big), max_side=1000)
    assert img.shape == (600, 1000, 3) and orig == (3000, 1800)


@pytest.mark.parametrize("data, match", [
    (b"", "empty"),
    (b"hello, this is a text file\n" * 10, "not a JPEG or PNG"),
    (b"\x00\x00\x00\x18ftypheic" + b"\x00" * 64, "HEIC"),
    (b"\xff\xd8\xff\xe0" + b"\x00" * 100, "damaged"),
    (bomb_png(32000, 32000), r"32000x32000 px \(1024 megapixels\) is over the limit"),
])
def test_not_an_image_gives_one_line_and_changes_nothing(tmp_path: Path, data, match):
    s = AnnotationSession.create(tmp_path / "p")
    with pytest.raises(NaseviewError, match=match) as e:
        s.add_photo("bottom", data, "notes.txt")
    assert "\n" not in str(e.value) and "bottom" in str(e.value)
    assert "bottom" not in s.photos
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == ["annotation.json"]
