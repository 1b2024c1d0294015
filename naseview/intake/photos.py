"""Photo intake of a new patient: uploaded bytes -> stored photo without metadata.

:func:`decode_photo` turns JPEG/PNG bytes into (H, W, 3) uint8 BGR with the EXIF
orientation applied (OpenCV ``IMREAD_COLOR`` does that) through
:func:`naseview.imagefile.decode_image`, which refuses a declared size over its pixel limit
before decoding (a decompression bomb), the longest side capped at
:data:`MAX_SIDE_PX` (clicks are in the pixels of the *stored* photo, SPEC §2), and
:func:`encode_photo` re-encodes the pixels only, so no EXIF, GPS, maker notes, text chunks
or ICC profile reach the disk. Anything else gets one line saying what to do.

Example
-------
>>> import numpy as np
>>> data = encode_photo(np.zeros((100, 80, 3), np.uint8), "png")
>>> photo_kind(data)
'png'
>>> img, (w, h) = decode_photo(data, max_side=50)
>>> img.shape, (w, h)
((50, 40, 3), (80, 100))
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from naseview.errors import NaseviewError
from naseview.imagefile import decode_image

MAX_SIDE_PX = 2048
"""Photos whose longest side exceeds this are downscaled to it at intake (px)."""

MIN_SIDE_PX = 64
"""Smaller photos are refused: no landmark can be placed on them reliably."""

MAX_UPLOAD_BYTES = 60 * 1024 * 1024
"""Larger uploads are refused: by the page while they stream in, before any decoding."""

JPEG_QUALITY = 95
"""Quality of re-encoded JPEG photos (PNG uploads stay PNG, lossless)."""


@dataclass(frozen=True)
class PhotoInfo:
    """A stored photo of the session.

    Attributes:
        file: file name in the in-progress folder (and later in the case directory).
        width, height: stored size (px); clicks are in these pixels.
        original_width, original_height: size after EXIF rotation, before downscaling.
    """

    file: str
    width: int
    height: int
    original_width: int
    original_height: int

    @property
    def downscaled(self) -> bool:
        return (self.width, self.height) != (self.original_width, self.original_height)

    def to_json(self) -> dict[str, Any]:
        return {"file": self.file, "width": self.width, "height": self.height,
                "original_width": self.original_width,
                "original_height": self.original_height}

    @staticmethod
    def from_json(obj: dict[str, Any]) -> PhotoInfo:
        return PhotoInfo(str(obj["file"]), int(obj["width"]), int(obj["height"]),
                         int(obj.get("original_width", obj["width"])),
                         int(obj.get("original_height", obj["height"])))


def upload_too_large(name: str, nbytes: int) -> str:
    """The one-line message for an upload over :data:`MAX_UPLOAD_BYTES`.

    >>> upload_too_large("front.jpg", 80 * 2**20)
    'front.jpg: 80.0 MB is too large (limit 60 MB); export the photo as JPEG'
    """
    return (f"{name}: {nbytes / 2**20:.1f} MB is too large (limit "
            f"{MAX_UPLOAD_BYTES // 2**20} MB); export the photo as JPEG")


def photo_kind(data: bytes) -> str | None:
    """``"jpeg"``, ``"png"``, ``"heic"``, ``"webp"``, ``"tiff"``... from the magic bytes,
    ``None`` if unknown."""
    if data[:3] == b"\xff\xd8\xff":
        return "jpeg"
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return "png"
    if len(data) > 12 and data[4:8] == b"ftyp" and data[8:12] in (
            b"heic", b"heix", b"hevc", b"heim", b"heis", b"mif1", b"msf1", b"avif"):
        return "heic"
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "webp"
    if data[:4] in (b"II*\x00", b"MM\x00*"):
        return "tiff"
    if data[:2] == b"BM":
        return "bmp"
    return None


def decode_photo(data: bytes, name: str = "photo", max_side: int = MAX_SIDE_PX
                 ) -> tuple[np.ndarray, tuple[int, int]]:
    """Decode an uploaded photo.

    The EXIF orientation is applied (OpenCV ``IMREAD_COLOR``); grey, 16-bit and RGBA
    images become 8-bit BGR; a longest side above ``max_side`` is downscaled to it
    (``INTER_AREA``).

    Args:
        data: file content.
        name: file name, for messages only.
        max_side: cap on the longest side (px).
    Returns:
        (H, W, 3) uint8 BGR and the (width, height) before downscaling.
    Raises:
        NaseviewError: empty, too large, not a JPEG/PNG (HEIC gets its own hint), over
            :data:`naseview.imagefile.MAX_IMAGE_PIXELS` (read from the header, before
            decoding: a decompression bomb costs nothing), or unreadable.
    """
    if not data:
        raise NaseviewError(f"{name}: the file is empty; choose the JPEG or PNG photo again")
    if len(data) > MAX_UPLOAD_BYTES:
        raise NaseviewError(upload_too_large(name, len(data)))
    kind = photo_kind(data)
    if kind == "heic":
        raise NaseviewError(f"{name}: HEIC/HEIF photos cannot be read; export it as JPEG "
                            "(on an iPhone: Settings > Camera > Formats > Most Compatible)")
    if kind not in ("jpeg", "png"):
        raise NaseviewError(f"{name}: not a JPEG or PNG image; choose the photo file "
                            "(.jpg or .png)")
    img = decode_image(data, name)   # the declared size is checked before decoding
    h, w = img.shape[:2]
    if min(h, w) < MIN_SIDE_PX:
        raise NaseviewError(f"{name}: {w}x{h} px is too small; use the original photo "
                            f"(at least {MIN_SIDE_PX} px, ideally 1000 px or more)")
    if img.dtype != np.uint8:
        img = (img / 257.0).round().astype(np.uint8)
    side = max(h, w)
    if side > max_side:
        s = max_side / float(side)
        size = (max(1, int(round(w * s))), max(1, int(round(h * s))))
        img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(img), (int(w), int(h))


def encode_photo(image: np.ndarray, kind: str = "jpeg", quality: int = JPEG_QUALITY) -> bytes:
    """Encode (H, W, 3) uint8 BGR pixels only (no metadata) as JPEG or PNG bytes."""
    if kind == "png":
        ok, buf = cv2.imencode(".png", image)
    else:
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise NaseviewError("could not encode the photo")
    return buf.tobytes()
