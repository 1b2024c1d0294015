"""Atomic file writes and image reading with one-line errors.

Every output naseview writes goes through :func:`atomic_write_bytes`: the data lands in a
temporary file in the target folder and is renamed over the target, so a crash never
leaves a half-written file and never destroys the previous one.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from naseview.errors import NaseviewError


def one_line(e: object) -> str:
    """``e`` (an exception or a reason) as one line of text, for a one-line error.

    >>> one_line(OSError("disk\\n  full"))
    'disk full'
    """
    return " ".join(str(e).split()) or type(e).__name__


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file + rename). Returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give a normal file's mode
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def _json_default(obj: Any) -> Any:
    """JSON value of what :mod:`json` cannot encode: numpy arrays and scalars, paths."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def atomic_write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write ``obj`` as indented JSON (numpy arrays become lists), atomically."""
    text = json.dumps(obj, indent=1, default=_json_default, allow_nan=False)
    return atomic_write_bytes(path, (text + "\n").encode("utf-8"))


def read_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a JSON object, or raise :class:`NaseviewError` naming the file and the problem."""
    path = Path(path)
    if not path.is_file():
        raise NaseviewError(f"{path}: file not found")
    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise NaseviewError(f"{path}: not a UTF-8 text file; expected JSON") from None
    except json.JSONDecodeError as e:
        raise NaseviewError(
            f"{path}: invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
    if not isinstance(obj, dict):
        raise NaseviewError(f"{path}: expected a JSON object at the top level")
    return obj


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a PNG/JPEG photo as an (H, W, 3) uint8 BGR array (OpenCV order).

    EXIF orientation is honoured. Raises :class:`NaseviewError` when the file is missing or
    is not a readable image.
    """
    path = Path(path)
    if not path.is_file():
        raise NaseviewError(f"{path}: image file not found")
    data = np.fromfile(path, dtype=np.uint8)
    img = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if img is None or img.ndim != 3 or img.shape[0] < 16 or img.shape[1] < 16:
        raise NaseviewError(
            f"{path}: not a readable PNG or JPEG image; re-export the photo as JPEG or PNG")
    return img


def image_size(path: str | os.PathLike[str]) -> tuple[int, int]:
    """(width, height) of an image file; raises :class:`NaseviewError` like :func:`read_image`."""
    img = read_image(path)
    return int(img.shape[1]), int(img.shape[0])


def write_image(path: str | os.PathLike[str], image: np.ndarray, quality: int = 92) -> Path:
    """Encode (H, W, 3) uint8 BGR as PNG or JPEG by the suffix of ``path``, atomically."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext in (".jpg", ".jpeg"):
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    elif ext == ".png":
        ok, buf = cv2.imencode(".png", image)
    else:
        raise NaseviewError(f"{path}: unsupported image type {ext!r}; use .png or .jpg")
    if not ok:
        raise NaseviewError(f"{path}: could not encode image")
    return atomic_write_bytes(path, buf.tobytes())
