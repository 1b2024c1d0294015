"""Files on disk: atomic writes, all-or-nothing file sets, JSON and photos, paths that stay
inside their folder, all with one-line errors.

- :func:`atomic_write_bytes`: one file; the data lands in a temporary file in the target
  folder and is renamed over the target, so a crash never leaves a half-written file and
  never destroys the previous one.
- :func:`write_file_set`: several files that belong together (``reconstruction.json`` with
  its meshes, a report with its PNGs). The new set is written into a hidden staging folder
  inside the target folder and fsynced; renaming that folder to a *commit* folder is the
  single step that makes the new set the current one; its files are then moved in. A
  reader asks :func:`current_set_file` where a file of the current set is, so it sees the
  old set or the new set, never a mix, even when the writer was killed half-way; the next
  writer finishes (commit folder) or discards (staging folder) what a killed one left.
- :func:`read_json`: a JSON object; duplicate keys, ``NaN`` and a wrong top level are
  errors naming the file; a UTF-8 byte-order mark is accepted.
- :func:`read_image` / :func:`decode_image`: PNG or JPEG photos, their declared size
  checked against :data:`MAX_IMAGE_PIXELS` before anything is decoded.
- :func:`stored_path` / :func:`resolve_stored_path`: paths written relative to the file
  that stores them, and read back only if they stay inside an allowed folder.
"""

from __future__ import annotations

import contextlib
import errno
import glob
import hashlib
import json
import os
import shutil
import struct
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from naseview.errors import NaseviewError
from naseview.image_data import too_little_data

try:  # POSIX: writers of one folder take turns; elsewhere they are not serialised
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

MAX_IMAGE_PIXELS = 64_000_000
"""Largest photo naseview decodes, in pixels (width x height): 64 megapixels.

Phone and camera photos are 12 to 61 megapixels (a 48 MP phone photo is 8064 x 6048, a
61 MP camera 9504 x 6336), and naseview needs far less (1000 px is plenty). Decoding
allocates 3 bytes per pixel whatever the file size, so a 120 KB PNG declaring 32000 x
32000 px would cost 3 GB: the declared size is read from the PNG / JPEG header and
refused above this limit before anything is decoded."""

STAGING_PREFIX = ".naseview-staging-"
"""Hidden folder holding a file set being written (incomplete: the next writer deletes it)."""

COMMIT_PREFIX = ".naseview-commit-"
"""Hidden folder holding a complete file set being moved in (the next writer finishes it)."""

_PROBE_PREFIX = ".naseview-probe-"
_MANIFEST = ".manifest.json"  # inside a staging / commit folder: the set's file order


def one_line(e: object) -> str:
    """``e`` (an exception or a reason) as one line of text, for a one-line error.

    >>> one_line(OSError("disk\\n  full"))
    'disk full'
    """
    return " ".join(str(e).split()) or type(e).__name__


def _write_problem(e: OSError) -> str:
    """What went wrong writing, and the fix, from the errno of ``e``."""
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        return "the disk is full; free some space and run again"
    if e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "the folder is not writable; choose a folder you can write to"
    return f"{one_line(e.strerror or e)}; check the folder and run again"


def write_error(path: str | os.PathLike[str], e: OSError, kept: bool = True) -> NaseviewError:
    """The one-line error of a failed write of ``path``: the reason (disk full, not
    writable, ...), the fix and, with ``kept``, that the previous file is unchanged."""
    tail = "; the previous result is unchanged" if kept else ""
    return NaseviewError(f"{path}: cannot write: {_write_problem(e)}{tail}")


def _write_synced(path: Path, data: bytes) -> None:
    """Create ``path`` (it must not exist), write ``data`` and fsync it."""
    with open(path, "xb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())


def _fsync_dir(path: Path) -> None:
    """fsync a folder, so the renames inside it survive a power cut (POSIX only)."""
    if os.name != "posix":  # pragma: no cover
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _normal_mode() -> int:
    """The mode a new file gets under the current umask (mkstemp creates 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file + rename). Returns the path.

    Raises:
        NaseviewError: the disk is full or the folder is not writable (the previous file
            is unchanged and no temporary file is left).
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as e:
        raise write_error(path, e) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _normal_mode())
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise write_error(path, e) from None
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


def json_bytes(obj: Any) -> bytes:
    """``obj`` as indented UTF-8 JSON (numpy arrays become lists; NaN is refused)."""
    text = json.dumps(obj, indent=1, default=_json_default, allow_nan=False)
    return (text + "\n").encode("utf-8")


def atomic_write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write ``obj`` as indented JSON (numpy arrays become lists), atomically."""
    return atomic_write_bytes(path, json_bytes(obj))


class _DuplicateKey(ValueError):
    """A JSON object names ``key`` twice."""

    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook`` of :func:`parse_json`: a dict, or :class:`_DuplicateKey`."""
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


def _no_constant(name: str) -> Any:
    """``parse_constant`` of :func:`parse_json`: ``NaN`` / ``Infinity`` are not JSON."""
    raise ValueError(name)


def parse_json(data: bytes, where: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse the bytes of a JSON object file; ``where`` names it in errors.

    A UTF-8 byte-order mark (what Windows editors write) is accepted.

    Raises:
        NaseviewError: not UTF-8, invalid JSON (with line and column), a key twice in one
            object (naming the key), ``NaN`` / ``Infinity``, or not an object at the top.
    """
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise NaseviewError(f"{where}: not a UTF-8 text file; expected JSON") from None
    try:
        obj = json.loads(text, object_pairs_hook=_unique_pairs, parse_constant=_no_constant)
    except _DuplicateKey as e:
        raise NaseviewError(f"{where}: key {e.key!r} appears twice in one object; keep "
                            "only one of them") from None
    except json.JSONDecodeError as e:
        raise NaseviewError(
            f"{where}: invalid JSON at line {e.lineno} column {e.colno}: {e.msg}") from None
    except ValueError as e:
        raise NaseviewError(f"{where}: {e.args[0]} is not a JSON number; write a finite "
                            "number") from None
    except RecursionError:
        raise NaseviewError(f"{where}: arrays or objects nested too deeply; this is not a "
                            "naseview file") from None
    if not isinstance(obj, dict):
        raise NaseviewError(f"{where}: expected a JSON object at the top level")
    return obj


def read_bytes(path: str | os.PathLike[str], what: str = "file") -> bytes:
    """The bytes of ``path``, or a one-line :class:`NaseviewError` (``<path>: <what> not
    found`` / ``cannot read``)."""
    path = Path(path)
    if not path.is_file():
        raise NaseviewError(f"{path}: {what} not found")
    try:
        return path.read_bytes()
    except OSError as e:
        raise NaseviewError(f"{path}: cannot read ({one_line(e.strerror or e)})") from None


def read_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a JSON object, or raise :class:`NaseviewError` naming the file and the problem
    (see :func:`parse_json`)."""
    path = Path(path)
    return parse_json(read_bytes(path), path)


# photos

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


# paths stored in files

def stored_path(target: str | os.PathLike[str], folder: str | os.PathLike[str],
                root: str | os.PathLike[str]) -> str | None:
    """How a file in ``folder`` stores the path of ``target``: relative to ``folder``
    (POSIX separators), or None when ``target`` does not lie inside ``root``.

    >>> stored_path("/data/p/case", "/data/p", "/data/p")
    'case'
    >>> stored_path("/data/q/case", "/data/p", "/data/p") is None
    True
    """
    t = Path(os.path.realpath(target))
    r = Path(os.path.realpath(root))
    if t != r and r not in t.parents:
        return None
    return Path(os.path.relpath(t, os.path.realpath(folder))).as_posix()


def resolve_stored_path(value: object, folder: str | os.PathLike[str],
                        root: str | os.PathLike[str], where: str | os.PathLike[str],
                        key: str, allow_absolute: bool = False) -> Path:
    """The path a file stores under ``key``, resolved against ``folder`` (the file's
    folder); it must lie inside ``root`` once symlinks are followed.

    Args:
        value: the stored string (relative to ``folder``; absolute only with
            ``allow_absolute``, for files written by older versions).
        folder: the folder relative paths start from.
        root: the folder the path must stay in.
        where: the file, for the error; key: its key.
    Raises:
        NaseviewError: not a string, absolute (without ``allow_absolute``), or pointing
            outside ``root`` (``..`` or a symlink escaping it).
    """
    if not isinstance(value, str) or not value or "\0" in value:
        raise NaseviewError(f"{where}: key {key!r}: expected a path relative to "
                            f"{Path(folder).name or folder}")
    p = Path(value)
    inner = list(p.parts)
    while inner and inner[0] == "..":      # leading '..' is checked against ``root`` below
        inner.pop(0)
    if ".." in inner:
        raise NaseviewError(f"{where}: key {key!r}: {value!r} goes down and back up with "
                            "'..'; write the path without it")
    if p.is_absolute() and not allow_absolute:
        raise NaseviewError(f"{where}: key {key!r}: {value!r} is an absolute path; paths "
                            "must be relative to the file's folder")
    resolved = Path(os.path.realpath(Path(folder) / p))
    r = Path(os.path.realpath(root))
    if resolved != r and r not in resolved.parents:
        raise NaseviewError(f"{where}: key {key!r}: {value!r} points outside {r}; naseview "
                            "follows no path leaving the folder of the file")
    return resolved


# output folders

def check_output_dir(path: str | os.PathLike[str], option: str = "-o") -> Path:
    """Check, before any work, that ``path`` can be a folder naseview writes into.

    The folder need not exist yet (it is created when the output is written); its nearest
    existing ancestor must be a folder this user can create files in (tried for real, so
    read-only mounts and permissions are both caught).

    Raises:
        NaseviewError: ``path`` (or an ancestor) is a file, or the folder is not writable.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise NaseviewError(f"{p}: is a file, not a folder; give {option} a folder name")
    probe_in = p
    while not probe_in.exists():
        if probe_in.parent == probe_in:
            break
        probe_in = probe_in.parent
    if not probe_in.is_dir():
        raise NaseviewError(f"{p}: {probe_in} is a file, not a folder; give {option} a "
                            "folder name")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=_PROBE_PREFIX, dir=probe_in))
    except OSError as e:
        raise NaseviewError(f"{p}: cannot write in {probe_in}: {_write_problem(e)} "
                            f"(give {option} another folder)") from None
    return p


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str]) -> Iterator[None]:
    """Exclusive lock on ``folder`` (flock on the folder itself: no lock file is left),
    held until the ``with`` block ends; writers of one folder, in this process or in
    another server, take turns. The lock dies with its process (a killed writer never
    leaves it held). The folder must exist.

    Raises:
        NaseviewError: the folder cannot be opened (one line: path, reason, fix).
    """
    if fcntl is None:  # pragma: no cover
        yield
        return
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError as e:
        raise write_error(folder, e) from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _set_dirs(folder: Path, prefix: str) -> list[Path]:
    """naseview's hidden set folders with ``prefix`` in ``folder``, oldest name first."""
    return sorted(p for p in folder.glob(glob.escape(prefix) + "*") if p.is_dir())


def _check_names(names: Iterable[str]) -> list[str]:
    """The file names of a set: plain names, not hidden, no folder part."""
    out = list(names)
    for n in out:
        if not n or n.startswith(".") or "/" in n or "\\" in n or n != Path(n).name:
            raise NaseviewError(f"{n!r}: a file set holds plain file names only")
    return out


class _Blocked(NaseviewError):
    """A folder holds the name of a file of the set (:func:`_check_not_blocked`)."""


def _check_not_blocked(folder: Path, names: Iterable[str]) -> None:
    """Raise when a file of the set cannot take its place: a folder (not a link to one)
    holds its name, and a rename cannot replace a folder with a file. Called before
    anything moves, so the previous set stays whole."""
    for name in names:
        p = folder / name
        if p.is_dir() and not p.is_symlink():
            raise _Blocked(f"{p}: is a folder where naseview writes its file {name!r}; "
                                "move or rename that folder and run again; the previous "
                                "result is unchanged")


def _finish_commit(commit: Path, folder: Path) -> None:
    """Move the files of a complete set into ``folder`` (in the recorded order, the index
    file last), delete the files it replaces, then the commit folder."""
    manifest = json.loads((commit / _MANIFEST).read_text(encoding="utf-8"))
    _check_not_blocked(folder, [*_check_names(manifest["files"]),
                                *_check_names(manifest["remove"])])
    for name in _check_names(manifest["files"]):
        src = commit / name
        if src.exists():
            os.replace(src, folder / name)
    for name in _check_names(manifest["remove"]):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(folder / name)
    _fsync_dir(folder)
    os.unlink(commit / _MANIFEST)
    os.rmdir(commit)


def recover_file_sets(folder: str | os.PathLike[str], names: Iterable[str] = ()) -> None:
    """Clean what killed writers left in ``folder``: finish a complete set (commit
    folder), delete incomplete ones (staging folders), probes of
    :func:`check_output_dir` and the temporary files of :func:`atomic_write_bytes` for
    ``names``. Call it holding the folder lock (:func:`write_file_set` does)."""
    folder = Path(folder)
    left = folder
    try:
        for left in _set_dirs(folder, COMMIT_PREFIX):
            if (left / _MANIFEST).is_file():
                _finish_commit(left, folder)
            else:  # the manifest is removed last: only the empty folder is left
                shutil.rmtree(left)
        for left in _set_dirs(folder, STAGING_PREFIX) + _set_dirs(folder, _PROBE_PREFIX):
            shutil.rmtree(left)
        for name in names:
            for left in folder.glob(f".{glob.escape(name)}.*.tmp"):
                with contextlib.suppress(FileNotFoundError):
                    left.unlink()
    except _Blocked:  # a folder in the way: its own message names it, not the commit
        raise
    except (OSError, ValueError, KeyError, TypeError, NaseviewError) as e:
        raise NaseviewError(f"{left}: left by an interrupted write and cannot be cleaned "
                            f"up ({one_line(e)}); delete it and run again") from None


def write_file_set(folder: str | os.PathLike[str], files: Mapping[str, bytes],
                   remove: Iterable[str] = (), overwrite: bool = True) -> list[Path]:
    """Write files that belong together into ``folder``, all or nothing.

    The files are written (and fsynced) into a hidden staging folder; renaming it to a
    commit folder makes the new set current in one step; the files are then moved in, in
    the order of ``files`` (put the index file, e.g. ``reconstruction.json``, last), and
    the files named in ``remove`` (outputs of an earlier run that the new set does not
    replace) are deleted. Readers use :func:`current_set_file`. Leftovers of killed writers
    are cleaned first (:func:`recover_file_sets`); writers of one folder take turns.

    Args:
        folder: the folder (created if needed).
        files: file name -> content, in the order they are moved in.
        remove: file names to delete when the new set is in.
        overwrite: False: refuse (nothing written) when a file of the set already
            exists, e.g. an earlier report the user may still want (the error names the
            last such file of ``files``, the index file).
    Returns:
        the paths written, in order.
    Raises:
        NaseviewError: the folder is not writable, the disk is full or a folder holds the
            name of one of the files, or (``overwrite`` False) one of them exists; the
            previous set is then unchanged and nothing is left behind.
    """
    folder = Path(folder)
    names = _check_names(files)
    stale = [n for n in _check_names(remove) if n not in files]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise write_error(folder, e, kept=False) from None
    with folder_lock(folder):
        recover_file_sets(folder, names + stale)
        _check_not_blocked(folder, names + stale)
        if not overwrite:
            taken = [n for n in names if os.path.lexists(folder / n)]
            if taken:
                raise NaseviewError(f"{folder / taken[-1]}: already exists and is not "
                                    "overwritten; choose another name or move it away "
                                    "(nothing was written)")
        try:
            staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=folder))
        except OSError as e:
            raise write_error(folder, e) from None
        current = folder
        try:
            for name in names:
                current = folder / name
                _write_synced(staging / name, files[name])
            current = folder
            _write_synced(staging / _MANIFEST, json.dumps(
                {"files": names, "remove": stale}).encode("utf-8"))
            _fsync_dir(staging)
            commit = folder / (COMMIT_PREFIX + staging.name[len(STAGING_PREFIX):])
            os.rename(staging, commit)  # the commit point: the new set is now current
        except BaseException as e:
            shutil.rmtree(staging, ignore_errors=True)
            if isinstance(e, OSError):
                raise write_error(current, e) from None
            raise
        try:
            _fsync_dir(folder)
            _finish_commit(commit, folder)
        except OSError as e:
            raise NaseviewError(f"{folder}: the new result is complete but could not be "
                                f"moved in ({one_line(e.strerror or e)}); run again to "
                                "finish it") from None
    return [folder / n for n in names]


def current_set_file(folder: str | os.PathLike[str], name: str) -> Path:
    """Where file ``name`` of the current set in ``folder`` is: in a commit folder while a
    writer is moving a new set in (or was killed doing so), else ``folder / name``."""
    folder = Path(folder)
    for commit in _set_dirs(folder, COMMIT_PREFIX):
        if (commit / name).is_file():
            return commit / name
    return folder / name


SetVersion = tuple[tuple[str, ...], tuple[int, int, int] | None]
"""What :func:`set_version` returns: the commit folders present and (inode, mtime in ns,
size) of the index file."""


def set_version(folder: str | os.PathLike[str], index: str) -> SetVersion:
    """A value that changes whenever a writer commits a file set in ``folder`` whose index
    file (written last) is ``index``; its first item is non-empty while a commit is under
    way. A reader that found a mismatch reads again only if this changed."""
    folder = Path(folder)
    commits = tuple(p.name for p in _set_dirs(folder, COMMIT_PREFIX))
    try:
        st = os.stat(folder / index)
    except OSError:
        return commits, None
    return commits, (st.st_ino, st.st_mtime_ns, st.st_size)


def sha256_hex(data: bytes) -> str:
    """The SHA-256 of ``data`` as 64 hex digits."""
    return hashlib.sha256(data).hexdigest()
