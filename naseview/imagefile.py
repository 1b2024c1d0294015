"""Photos on disk: PNG and JPEG read, checked and written, with one-line errors.

- :func:`image_header`: the size a PNG / JPEG declares, read from its header and checked
  against :data:`MAX_IMAGE_PIXELS` and :data:`MAX_PIXELS_PER_BYTE` before anything is
  decoded (a decompression bomb or a lying header is refused without allocating);
- :func:`decode_image` / :func:`read_image` / :func:`image_size`: (H, W, 3) uint8 BGR;
- :func:`image_bytes` / :func:`write_image`: PNG or JPEG encoded, written all or nothing
  (:func:`naseview.fileio.atomic_write_bytes`, the one home of atomic writes).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import cv2
import numpy as np

from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, read_bytes
from naseview.image_data import too_little_data

MAX_IMAGE_PIXELS = 64_000_000
"""Largest photo naseview decodes, in pixels (width x height): 64 megapixels.

Phone and camera photos are 12 to 61 megapixels (a 48 MP phone photo is 8064 x 6048, a
61 MP camera 9504 x 6336), and naseview needs far less (1000 px is plenty). Decoding
allocates 3 bytes per pixel whatever the file size, so a 120 KB PNG declaring 32000 x
32000 px would cost 3 GB: the declared size is read from the PNG / JPEG header and
refused above this limit before anything is decoded."""

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_NOT_AN_IMAGE = "not a readable PNG or JPEG image; re-export the photo as JPEG or PNG"


MAX_PIXELS_PER_BYTE = 2048
"""A PNG / JPEG declaring ``W x H`` px must hold at least ``W * H / 2048`` bytes (a PNG:
its uncompressed rows / 2048), half of what any real file of that size needs.

Huffman-coded JPEG spends at least one bit on each 8x8 block of each component (the DC
difference; progressive end-of-band runs cover the rest), i.e. at least ``W * H / 512``
bytes; deflate (PNG) compresses at most 1032:1. A file below this cannot hold the pixels
its header declares: it is truncated or its header lies (a 1.3 KB JPEG declaring 8000 x
8000 px, which libjpeg would "decode" as 192 MB of grey after printing "Corrupt JPEG
data"), and it is refused before anything is allocated. (An arithmetic-coded JPEG of a
nearly uniform picture could be smaller; no camera writes one, and it is no photo.)"""

_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # colour type -> samples per pixel


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from the first SOF segment of a JPEG, or None if there is none."""
    frame = _jpeg_frame(data)
    return None if frame is None else frame[:2]


def _jpeg_frame(data: bytes) -> tuple[int, int, int] | None:
    """(width, height, offset of the first start-of-scan or -1) of a JPEG, from its
    markers, or None if it has no frame header."""
    i = 2
    size: tuple[int, int] | None = None
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None if size is None else (*size, -1)
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:  # markers without a length
            i += 2
            continue
        if marker == 0xD9:  # end of image before any scan
            return None if size is None else (*size, -1)
        if marker == 0xDA:  # start of scan: the frame header must come before it
            return None if size is None else (*size, i)
        length = (data[i + 2] << 8) | data[i + 3]
        if marker in _JPEG_SOF and size is None:
            if i + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            size = (int(width), int(height))
        i += 2 + length
    return None if size is None else (*size, -1)


def _megapixels(pixels: int) -> str:
    """``pixels`` in megapixels, rounded to a whole number unless that would make it look
    equal to the limit (8001 x 8000 px is "64.008", not "64", megapixels).

    >>> _megapixels(1024 * 10**6), _megapixels(8001 * 8000), _megapixels(MAX_IMAGE_PIXELS)
    ('1024', '64.008', '64')
    """
    whole = f"{pixels / 1e6:.0f}"
    if pixels == MAX_IMAGE_PIXELS or whole != f"{MAX_IMAGE_PIXELS / 1e6:.0f}":
        return whole
    return f"{pixels / 1e6:.6f}".rstrip("0").rstrip(".")


def _damaged(name: str | os.PathLike[str], kind: str, why: str) -> NaseviewError:
    return NaseviewError(f"{name}: the {kind} file is damaged or truncated ({why}); copy "
                         "the photo again from the camera")


def image_header(data: bytes, name: str | os.PathLike[str],
                 whole: bool = True) -> tuple[str, int, int]:
    """``(kind, width, height)`` declared by a PNG or JPEG header, without decoding.

    The file must also be complete (a JPEG's end-of-image marker after its first scan, a
    PNG's ``IEND`` chunk) and large enough for the pixels it declares
    (:data:`MAX_PIXELS_PER_BYTE`), so a header that lies is refused here, not
    "decoded" as a grey picture. ``whole=False``: ``data`` is only the file's first bytes
    (a header read of a photo that was checked whole when it was written): those two
    checks are left out.

    Raises:
        NaseviewError: not a PNG or JPEG, a damaged header, a truncated file, fewer bytes
            than the declared size needs, or more than :data:`MAX_IMAGE_PIXELS` pixels
            (naming ``name`` and the limit).
    """
    if data[:8] == _PNG_SIGNATURE:
        if len(data) < 26 or data[12:16] != b"IHDR":
            raise NaseviewError(f"{name}: the PNG file is damaged (no image header); "
                                "copy the photo again")
        kind = "png"
        width, height = struct.unpack(">II", data[16:24])
        channels = _PNG_CHANNELS.get(data[25], 4)
        needed = height * (1 + (width * channels * max(data[24], 1) + 7) // 8)
        incomplete = (None if b"\x00\x00\x00\x00IEND" in data
                      else "it ends before its IEND chunk")
    elif data[:3] == b"\xff\xd8\xff":
        kind = "jpeg"
        frame = _jpeg_frame(data)
        if frame is None:
            raise NaseviewError(f"{name}: the JPEG file is damaged or truncated (no frame "
                                "header); copy the photo again")
        width, height, scan = frame
        incomplete = None if scan >= 0 and data.find(b"\xff\xd9", scan) >= 0 else (
            "no image data, or it ends before its end-of-image marker")
        needed = width * height
    else:
        raise NaseviewError(f"{name}: {_NOT_AN_IMAGE}")
    if width <= 0 or height <= 0:
        raise NaseviewError(f"{name}: the {kind.upper()} header declares {width}x{height} "
                            "px; copy the photo again")
    if width * height > MAX_IMAGE_PIXELS:
        raise NaseviewError(
            f"{name}: {width}x{height} px ({_megapixels(width * height)} megapixels) is over "
            f"the limit of {_megapixels(MAX_IMAGE_PIXELS)} megapixels; downscale the photo "
            "(12 megapixels is plenty)")
    if not whole:
        return kind, int(width), int(height)
    if incomplete is not None:
        raise _damaged(name, kind.upper(), incomplete)
    if len(data) < needed // MAX_PIXELS_PER_BYTE:
        raise _damaged(name, kind.upper(),
                       f"its header declares {width}x{height} px but the file holds only "
                       f"{len(data):,} bytes, fewer than such an image needs")
    if (why := too_little_data(data, kind, width, height, needed)) is not None:
        raise _damaged(name, kind.upper(), why)  # a big file, but its pixels are few
    return kind, int(width), int(height)


def decode_image(data: bytes, name: str | os.PathLike[str]) -> np.ndarray:
    """Decode PNG / JPEG bytes as an (H, W, 3) uint8 BGR array (OpenCV order).

    The declared size is checked first (:func:`image_header`), so a decompression bomb is
    refused before anything is allocated. EXIF orientation is honoured. ``name`` names the
    file in errors.

    Raises:
        NaseviewError: not a PNG / JPEG, over :data:`MAX_IMAGE_PIXELS`, damaged or
            truncated, or smaller than 16 px.
    """
    kind, width, height = image_header(data, name)
    try:
        img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    except cv2.error:
        img = None
    if img is None or img.ndim != 3 or img.shape[2] != 3 \
            or sorted(img.shape[:2]) != sorted((height, width)):
        raise NaseviewError(f"{name}: the {kind.upper()} file is damaged or truncated; copy "
                            "the photo again from the camera")
    if min(img.shape[:2]) < 16:
        raise NaseviewError(f"{name}: {width}x{height} px is too small for a photo; use the "
                            "original photo")
    return img


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a PNG/JPEG photo as an (H, W, 3) uint8 BGR array (OpenCV order).

    Every photo naseview reads from disk comes through here (:func:`decode_image` checks).

    Raises:
        NaseviewError: the file is missing, not a PNG / JPEG, over
            :data:`MAX_IMAGE_PIXELS`, damaged or truncated.
    """
    path = Path(path)
    data = read_bytes(path, "image file")
    if not data:
        raise NaseviewError(f"{path}: the file is empty; {_NOT_AN_IMAGE}")
    return decode_image(data, path)


def image_size(path: str | os.PathLike[str]) -> tuple[int, int]:
    """(width, height) of an image file; raises :class:`NaseviewError` like :func:`read_image`."""
    img = read_image(path)
    return int(img.shape[1]), int(img.shape[0])


def image_bytes(image: np.ndarray, suffix: str, quality: int = 92,
                where: str | os.PathLike[str] = "image") -> bytes:
    """Encode (H, W, 3) uint8 BGR as PNG (``.png``) or JPEG (``.jpg`` / ``.jpeg``)."""
    ext = suffix.lower()
    if ext in (".jpg", ".jpeg"):
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    elif ext == ".png":
        ok, buf = cv2.imencode(".png", image)
    else:
        raise NaseviewError(f"{where}: unsupported image type {ext!r}; use .png or .jpg")
    if not ok:
        raise NaseviewError(f"{where}: could not encode image")
    return buf.tobytes()


def write_image(path: str | os.PathLike[str], image: np.ndarray, quality: int = 92) -> Path:
    """Encode (H, W, 3) uint8 BGR as PNG or JPEG by the suffix of ``path``, atomically."""
    path = Path(path)
    return atomic_write_bytes(path, image_bytes(image, path.suffix, quality, path))


__all__ = ["MAX_IMAGE_PIXELS", "MAX_PIXELS_PER_BYTE", "decode_image", "image_bytes",
           "image_header", "image_size", "read_image", "write_image"]
