"""Photos and JSON files as naseview reads them: a decompression bomb is refused from its
header before anything is decoded, a damaged photo or JSON file is one line naming the
file, a key given twice is named, a Windows byte-order mark is fine."""

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
from naseview.fileio import read_json
from naseview.imagefile import MAX_IMAGE_PIXELS, read_image


def _chunk(kind: bytes, data: bytes) -> bytes:
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def png_declaring(width: int, height: int, idat: bytes = b"") -> bytes:
    """A PNG whose header declares ``width`` x ``height`` RGB pixels, with ``idat`` as its
    (usually far too short) compressed image data."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat)
            + _chunk(b"IEND", b""))


def jpeg_declaring(width: int, height: int) -> bytes:
    """The start of a JPEG whose frame header (SOF0) declares ``width`` x ``height``."""
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 17, 8, height, width, 3) + bytes(9)
    return b"\xff\xd8" + app0 + sof + b"\xff\xda" + bytes(200)


@pytest.fixture()
def no_decoding(monkeypatch):
    """Fail if OpenCV is asked to decode anything."""
    def boom(*args, **kwargs):
        raise AssertionError("cv2.imdecode was called: the header check came too late")
    monkeypatch.setattr(cv2, "imdecode", boom)


def test_png_declaring_32000_by_32000_is_refused_before_decoding(tmp_path: Path,
                                                                  no_decoding):
    bomb = tmp_path / "front.png"
    bomb.write_bytes(png_declaring(32000, 32000, zlib.compress(bytes(100_000), 9)))
    with pytest.raises(NaseviewError) as e:
        read_image(bomb)
    msg = str(e.value)
    assert "\n" not in msg and str(bomb) in msg
    assert "32000x32000" in msg and f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixels" in msg
    jpg = tmp_path / "left.jpg"
    jpg.write_bytes(jpeg_declaring(12000, 9000))             # 108 MP
    with pytest.raises(NaseviewError, match=r"left\.jpg: 12000x9000 px .* over the limit"):
        read_image(jpg)


def test_reconstruct_refuses_a_bomb_photo_in_one_line(tmp_path: Path, capsys):
    case = write_projected_case(tmp_path / "case", seed=82)
    (case / "bottom.png").write_bytes(png_declaring(32000, 32000, zlib.compress(bytes(10**6))))
    assert main(["reconstruct", str(case), "-o", str(tmp_path / "out"), "--stages", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("naseview: error:") and "\n" not in err
    assert "bottom.png" in err and "megapixels" in err
    assert not (tmp_path / "out").exists()


def test_damaged_photos_are_one_line_errors(tmp_path: Path):
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (120, 160, 3)).astype(np.uint8)
    jpg = cv2.imencode(".jpg", img)[1].tobytes()
    png = cv2.imencode(".png", img)[1].tobytes()
    cases = {
        "cut.jpg": jpg[: len(jpg) // 2],
        "cut.png": png[: len(png) // 2],
        "header-only.png": png[:30],
        "no-ihdr.png": png[:8] + b"\x00" * 40,
        "zero.png": png_declaring(0, 100),
        "lying.png": png_declaring(4000, 3000, zlib.compress(bytes(5000))),
        "text.jpg": b"hello, not a photo",
        "empty.png": b"",
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(NaseviewError) as e:
            read_image(tmp_path / name)
        msg = str(e.value)
        assert "\n" not in msg and name in msg, msg
        assert "error:" not in msg and "(-215" not in msg, msg   # no raw OpenCV text
    ok = tmp_path / "ok.jpg"
    ok.write_bytes(jpg)
    assert read_image(ok).shape == (120, 160, 3)


def test_json_key_given_twice_is_named(tmp_path: Path):
    p = tmp_path / "x.json"
    p.write_text('{"views": {"front": {"landmarks": {"prn": [1, 2], "prn": [3, 4]}}}}')
    with pytest.raises(NaseviewError) as e:
        read_json(p)
    msg = str(e.value)
    assert str(p) in msg and "'prn'" in msg and "twice" in msg and "\n" not in msg


def test_json_with_a_windows_byte_order_mark_reads(tmp_path: Path):
    p = tmp_path / "x.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps({"format": "x", "n": 1}).encode())
    assert read_json(p) == {"format": "x", "n": 1}


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_json_nan_is_refused(tmp_path: Path, literal: str):
    p = tmp_path / "x.json"
    p.write_text('{"scale_mm": {"al_l-al_r": ' + literal + "}}")
    with pytest.raises(NaseviewError, match=f"{literal} is not a JSON number"):
        read_json(p)


def test_json_nested_too_deeply_is_one_line_not_a_crash(tmp_path: Path):
    p = tmp_path / "x.json"
    p.write_text('{"edit": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(NaseviewError) as e:
        read_json(p)
    msg = str(e.value)
    assert str(p) in msg and "nested too deeply" in msg and "\n" not in msg
