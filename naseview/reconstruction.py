"""The reconstruction result (SPEC §5), its ``reconstruction.json`` and the output folder.

Each stage fills part of a :class:`Reconstruction`: stage 1 the landmarks and cameras,
stage 2 the curves and ad-landmarks, stage 3 the meshes and measurements. Synthetic ground
truth (``truth.json``, SPEC §7) uses the same schema.

An output folder (``naseview reconstruct CASE -o OUT``) is one set: ``reconstruction.json``
records the SHA-256 of each mesh file written with it (key :data:`FILES_KEY`), the set is
written all or nothing (:func:`naseview.fileio.write_file_set`), and
:func:`read_output_set` hands a reader the files of one set only, or a one-line error.
Its ``case_dir`` is stored relative to the output folder and read back by
:func:`output_case_dir` only if it stays inside the output folder.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import Camera
from naseview.errors import NaseviewError
from naseview.fileio import (
    atomic_write_json,
    current_set_file,
    parse_json,
    read_json,
    resolve_stored_path,
    set_version,
    sha256_hex,
)
from naseview.params import (
    CAMERA_POSITION_MM,
    MEASUREMENT_VALUE,
    PHOTO_SIDE_PX,
    PIXEL_ERROR_PX,
    POSITION_MM,
    ROTATION_ENTRY,
    Range,
    first_outside,
    focal_range,
)

RECONSTRUCTION_FORMAT = "naseview.reconstruction/1"

RECONSTRUCTION_FILE = "reconstruction.json"
"""The index file of an output folder (written last, read first)."""

FILES_KEY = "files"
"""Key of ``reconstruction.json``: file name -> SHA-256 (hex) of each file written with it
(``face.ply``, ``nose.ply``, exports). Absent in files of older versions."""

CASE_DIR_KEY = "case_dir"
"""Key of ``reconstruction.json``: the case folder, relative to the output folder."""

CASE_SHA256_KEY = "case_sha256"
"""Key of ``reconstruction.json``: the SHA-256 (hex) of the ``case.json`` it was made from.
A ``case_dir`` outside the output folder is followed only to a ``case.json`` with this
hash, so an edited path cannot pull another patient's photos in."""


@dataclass
class Reconstruction:
    """Everything naseview knows about one nose, in the SPEC frame (mm).

    Attributes:
        landmarks: id -> (3,) position (mm), the 21 landmarks that could be placed.
        cameras: view -> :class:`~naseview.camera.Camera`.
        curves: curve name (SPEC §5) -> (N, 3) polyline (mm).
        ad_landmarks: (M, 3) the ad-landmarks (21 landmarks + sub-landmarks).
        ad_landmark_tags: M dicts ``{"curve", "t", "id"}`` describing each ad-landmark.
        reprojection_rmse_px: RMS reprojection error of the clicks.
        measurements: name -> value (mm or degrees).
        extra: further keys written verbatim (diagnostics, per-landmark uncertainty...).
    """

    landmarks: dict[str, np.ndarray] = field(default_factory=dict)
    cameras: dict[str, Camera] = field(default_factory=dict)
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ad_landmark_tags: list[dict[str, Any]] = field(default_factory=list)
    reprojection_rmse_px: float | None = None
    measurements: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The ``reconstruction.json`` object: the SPEC §5 keys, then :attr:`extra`."""
        out: dict[str, Any] = {
            "format": RECONSTRUCTION_FORMAT,
            "units": "mm",
            "landmarks": {k: np.asarray(v, dtype=float).tolist()
                          for k, v in self.landmarks.items()},
            "curves": {k: np.asarray(v, dtype=float).reshape(-1, 3).tolist()
                       for k, v in self.curves.items()},
            "ad_landmarks": np.asarray(self.ad_landmarks, dtype=float).reshape(-1, 3).tolist(),
            "ad_landmark_tags": self.ad_landmark_tags,
            "cameras": {k: c.to_json() for k, c in self.cameras.items()},
            "reprojection_rmse_px": self.reprojection_rmse_px,
            "measurements": {k: float(v) for k, v in self.measurements.items()},
        }
        out.update(self.extra)
        return out

    @staticmethod
    def from_json(obj: dict[str, Any], where: str = "reconstruction.json") -> Reconstruction:
        """Parse a ``reconstruction.json`` object; keys beyond SPEC §5 land in ``extra``.

        Raises:
            NaseviewError: wrong ``format`` or malformed points, naming ``where``.
        """
        if not isinstance(obj, dict):
            raise NaseviewError(f"{where}: expected a reconstruction.json object")
        fmt = obj.get("format")
        if fmt != RECONSTRUCTION_FORMAT:
            raise NaseviewError(f"{where}: key 'format': expected {RECONSTRUCTION_FORMAT!r}, "
                                f"found {fmt!r}")
        landmarks = {k: v.reshape(3) for k, v in
                     _named_points(obj, "landmarks", where, single=True).items()}
        curves = _named_points(obj, "curves", where)
        ad = points_array(obj.get("ad_landmarks", []), where, "ad_landmarks")
        cams = _mapping(obj, "cameras", where)
        cameras = {k: _finite_camera(Camera.from_json(c, f"{where}: cameras.{k}"),
                                     f"{where}: cameras.{k}")
                   for k, c in cams.items()}
        tags = obj.get("ad_landmark_tags", [])
        if not isinstance(tags, list) or not all(isinstance(t, dict) for t in tags):
            raise NaseviewError(f"{where}: key 'ad_landmark_tags': expected a list of objects")
        rmse = obj.get("reprojection_rmse_px")
        if rmse is not None and (not _finite_number(rmse) or rmse not in PIXEL_ERROR_PX):
            raise NaseviewError(f"{where}: key 'reprojection_rmse_px': expected a number in "
                                f"{PIXEL_ERROR_PX} (px) or null")
        measurements = numbers_dict(obj.get("measurements", {}), where, "measurements")
        known = {"format", "units", "landmarks", "curves", "ad_landmarks", "ad_landmark_tags",
                 "cameras", "reprojection_rmse_px", "measurements"}
        return Reconstruction(
            landmarks=landmarks, cameras=cameras, curves=curves, ad_landmarks=ad,
            ad_landmark_tags=list(tags),
            reprojection_rmse_px=None if rmse is None else float(rmse),
            measurements=measurements,
            extra={k: v for k, v in obj.items() if k not in known},
        )


SCALE_KEY = "scale_mm"
"""``reconstruction.json`` key (beyond SPEC §5) echoing the case's calliper distances
(``{"al_l-al_r": 34.5}``): the result was scaled to them, so the measurements equal to them
are inputs, not findings (:func:`naseview.measurements.calliper_inputs`)."""


def calliper_distances(rec: Reconstruction) -> dict[str, float]:
    """The calliper distances ``"<id>-<id>" -> mm`` the reconstruction was scaled to, as
    echoed in :data:`SCALE_KEY` (``{}`` for a result written before it, or a malformed
    value: the key is informative, never trusted for anything but labelling)."""
    value = rec.extra.get(SCALE_KEY)
    if not isinstance(value, dict):
        return {}
    return {str(k): float(v) for k, v in value.items()
            if isinstance(k, str) and len(k) <= 40 and _finite_number(v)}


def _finite_number(v: object) -> bool:
    """True for an int or float (not a bool) that is finite."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _mapping(obj: dict[str, Any], key: str, where: str) -> dict[str, Any]:
    """``obj[key]`` (default ``{}``), which must be a JSON object."""
    value = obj.get(key, {})
    if not isinstance(value, dict):
        raise NaseviewError(f"{where}: key {key!r}: expected an object")
    return value


def points_array(value: object, where: str, key: str, count: int | None = None
                 ) -> np.ndarray:
    """``[[x, y, z], ...]`` as a finite (N, 3) float64 array (N = ``count`` if given).

    Raises:
        NaseviewError: not a list of three finite numbers each (or not ``count`` of them),
            naming ``where`` and ``key``.
    """
    try:
        raw = np.asarray(value)        # numbers only: "1" or true are not coordinates
        arr = np.asarray(raw, dtype=np.float64) if raw.dtype.kind in "iuf" \
            else np.zeros((0, 0))
    except (TypeError, ValueError, OverflowError):
        arr = np.zeros((0, 0))
    if arr.size == 0 and isinstance(value, list) and not value:
        arr = np.zeros((0, 3))
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise NaseviewError(f"{where}: key {key!r}: expected a list of [x, y, z] numbers")
    if not np.isfinite(arr).all():
        raise NaseviewError(f"{where}: key {key!r}: coordinates must be finite numbers")
    bad = first_outside(arr, POSITION_MM)
    if bad is not None:
        raise NaseviewError(f"{where}: key {key!r}: coordinate {bad:g} is outside "
                            f"{POSITION_MM}; points of the face are mm within a metre of "
                            "its origin (the file is damaged: save or reconstruct again)")
    if count is not None and len(arr) != count:
        raise NaseviewError(f"{where}: key {key!r}: expected {count} points, found "
                            f"{len(arr)}")
    return arr


def index_array(value: object, where: str, key: str, n: int, width: int | None = None
                ) -> np.ndarray:
    """A JSON list of vertex ids (``width`` None: (K,); else (K, width) rows, e.g. the
    triangles) as int64, every id in ``0..n-1``.

    Raises:
        NaseviewError: not integers, the wrong shape or an id outside the range, naming
            ``where``, ``key`` and the range.
    """
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        arr = np.zeros((0, 0), dtype=object)
    if arr.size == 0 and isinstance(value, list):
        arr = np.zeros((0,) if width is None else (0, width), dtype=np.int64)
    shape_ok = arr.ndim == 1 if width is None else (arr.ndim == 2 and arr.shape[1] == width)
    if arr.dtype.kind not in "iu" or not shape_ok:
        what = "integer vertex ids" if width is None else f"rows of {width} integer vertex ids"
        raise NaseviewError(f"{where}: key {key!r}: expected a list of {what}")
    if arr.size and (arr.min() < 0 or arr.max() >= n):
        bad = int(arr.min()) if arr.min() < 0 else int(arr.max())
        raise NaseviewError(f"{where}: key {key!r}: vertex id {bad} is outside "
                            f"[0, {n - 1}]")
    return arr.astype(np.int64)


def _named_points(obj: dict[str, Any], key: str, where: str, single: bool = False
                  ) -> dict[str, np.ndarray]:
    """``obj[key]``: name -> one ``[x, y, z]`` (``single``) or a list of them, finite."""
    out = {}
    for name, v in _mapping(obj, key, where).items():
        out[name] = points_array([v] if single else v, f"{where}", f"{key}.{name}",
                                 1 if single else None)
    return out


def numbers_dict(value: object, where: str, key: str) -> dict[str, float]:
    """``{"name": number}`` with finite numbers, as floats.

    Raises:
        NaseviewError: not an object of finite numbers, naming ``where`` and the key.
    """
    if not isinstance(value, dict):
        raise NaseviewError(f"{where}: key {key!r}: expected an object of numbers")
    for k, v in value.items():
        if not _finite_number(v):
            raise NaseviewError(f"{where}: key '{key}.{k}': expected a finite number")
        if float(v) not in MEASUREMENT_VALUE:
            raise NaseviewError(f"{where}: key '{key}.{k}': {v!r} is outside "
                                f"{MEASUREMENT_VALUE}; no facial measurement is that large")
    return {k: float(v) for k, v in value.items()}


def _finite_camera(cam: Camera, where: str) -> Camera:
    """``cam`` after checking every number against its physical range
    (:mod:`naseview.params`): size, focal lengths within the photo's scale, the rest of
    ``K`` within that scale too, ``R`` a rotation's entries, ``t`` within 100 m."""
    if not (np.isfinite(cam.K).all() and np.isfinite(cam.R).all()
            and np.isfinite(cam.t).all()):
        raise NaseviewError(f"{where}: K, R and t must be finite numbers")
    for name, size in (("width", cam.width), ("height", cam.height)):
        if size not in PHOTO_SIDE_PX:
            raise NaseviewError(f"{where}.{name}: {size!r} is outside {PHOTO_SIDE_PX}; "
                                "expected the photo's size in pixels")
    focal = focal_range(cam.width, cam.height)
    checks = ((".K (fx, fy)", [cam.K[0, 0], cam.K[1, 1]], focal,
               "the focal length in pixels, within the photo's scale"),
              (".K", cam.K, Range(-focal.high, focal.high),
               "intrinsics in pixels, within the photo's scale"),
              (".R", cam.R, ROTATION_ENTRY, "a rotation matrix"),
              (".t", cam.t, CAMERA_POSITION_MM, "mm, within 100 m of the face"))
    for key, values, allowed, meaning in checks:
        bad = first_outside(values, allowed)
        if bad is not None:
            raise NaseviewError(f"{where}{key}: {bad:g} is outside {allowed}; expected "
                                f"{meaning}")
    return cam


def write_reconstruction(rec: Reconstruction, path: str | os.PathLike[str]) -> Path:
    """Write ``rec`` as JSON atomically."""
    return atomic_write_json(path, rec.to_json())


def read_reconstruction(path: str | os.PathLike[str]) -> Reconstruction:
    """Read a ``reconstruction.json`` or ``truth.json``."""
    path = Path(path)
    return Reconstruction.from_json(read_json(path), str(path))


@dataclass(frozen=True)
class OutputSet:
    """What :func:`read_output_set` read from one output folder: files of one set.

    Attributes:
        folder: the output folder.
        reconstruction: its ``reconstruction.json``.
        files: file name -> content of each requested file that belongs to the set.
        recorded: the file names ``reconstruction.json`` records (None for a file written
            by an older version, which records none; its files are then read unchecked).
    """

    folder: Path
    reconstruction: Reconstruction
    files: dict[str, bytes]
    recorded: tuple[str, ...] | None


def _read_set_once(folder: Path, names: tuple[str, ...]) -> OutputSet | str:
    """One attempt of :func:`read_output_set`: the set, or the name of the file that did
    not match (it changed while reading, or the set is mixed)."""
    index = current_set_file(folder, RECONSTRUCTION_FILE)
    try:
        data = index.read_bytes()
    except FileNotFoundError:
        return RECONSTRUCTION_FILE
    obj = parse_json(data, folder / RECONSTRUCTION_FILE)
    rec = Reconstruction.from_json(obj, str(folder / RECONSTRUCTION_FILE))
    recorded = obj.get(FILES_KEY)
    if recorded is None:  # an older version: no checksums
        files = {n: (folder / n).read_bytes() for n in names if (folder / n).is_file()}
        return OutputSet(folder, rec, files, None)
    if not isinstance(recorded, dict) or not all(
            isinstance(v, str) and len(v) == 64 for v in recorded.values()):
        raise NaseviewError(f"{folder / RECONSTRUCTION_FILE}: key {FILES_KEY!r}: expected "
                            "file name -> SHA-256 (64 hex digits); run `naseview "
                            f"reconstruct CASE -o {folder}` again")
    files = {}
    for name in names:
        if name not in recorded:
            continue
        try:
            content = current_set_file(folder, name).read_bytes()
        except FileNotFoundError:
            return name
        if sha256_hex(content) != recorded[name]:
            return name
        files[name] = content
    return OutputSet(folder, rec, files, tuple(recorded))


def read_output_set(out_dir: str | os.PathLike[str], names: tuple[str, ...] = (),
                    attempts: int = 4) -> OutputSet:
    """Read ``reconstruction.json`` and the files ``names`` of one output folder, all
    from the same set: each file's SHA-256 must be the one ``reconstruction.json``
    records. A set being replaced right now is read again (up to ``attempts`` times); a
    mismatch while no writer is at work is refused at once.

    Args:
        out_dir: a ``naseview reconstruct`` output folder.
        names: files wanted besides ``reconstruction.json`` (e.g. ``face.ply``); one the
            set does not hold (stage 3 did not run) is left out of ``files``.
    Raises:
        NaseviewError: no ``reconstruction.json``, or a file that does not match it (a
            mixed or damaged set), naming the file and the fix.
    """
    folder = Path(out_dir)
    if not current_set_file(folder, RECONSTRUCTION_FILE).is_file():
        raise NaseviewError(f"{folder / RECONSTRUCTION_FILE}: file not found; run "
                            f"`naseview reconstruct CASE -o {folder}`")
    bad = RECONSTRUCTION_FILE
    for attempt in range(attempts):
        before = set_version(folder, RECONSTRUCTION_FILE)
        got = _read_set_once(folder, names)
        if isinstance(got, OutputSet):
            return got
        bad = got
        if not before[0] and set_version(folder, RECONSTRUCTION_FILE) == before:
            break  # nothing was being written: the folder really mixes two runs
        time.sleep(0.05 * (attempt + 1))
    raise NaseviewError(f"{folder / bad}: does not match {RECONSTRUCTION_FILE} (SHA-256); "
                        "the output folder mixes two runs or was changed by hand; run "
                        f"`naseview reconstruct CASE -o {folder}` again")


def output_case_dir(out_dir: str | os.PathLike[str], rec: Reconstruction | None
                    ) -> Path | None:
    """The case folder an output folder names (key ``case_dir``), or None if it names none.

    The path is relative to the output folder (files of older versions: absolute). Inside
    the output folder (``naseview reconstruct PATIENT/case -o PATIENT``) it is followed as
    it is; outside (``naseview reconstruct case -o out``, side by side) only to a folder
    whose ``case.json`` has the SHA-256 recorded at reconstruction (key ``case_sha256``),
    so that a hand-edited ``reconstruction.json`` cannot pull another patient's photos
    from elsewhere on the disk.

    Raises:
        NaseviewError: the path is not a string, or points outside the output folder to a
            case that is not the one reconstructed.
    """
    value = rec.extra.get(CASE_DIR_KEY) if rec is not None else None
    if value is None or rec is None:
        return None
    out = Path(out_dir)
    where = out / RECONSTRUCTION_FILE
    digest = rec.extra.get(CASE_SHA256_KEY)
    if not isinstance(digest, str) or isinstance(value, str) and Path(value).is_absolute():
        return resolve_stored_path(value, out, out, where, CASE_DIR_KEY, allow_absolute=True)
    case_dir = resolve_stored_path(value, out, Path(os.path.abspath(os.sep)), where,
                                   CASE_DIR_KEY)
    case_json = case_dir / "case.json"
    try:
        found = sha256_hex(case_json.read_bytes())
    except OSError:
        found = None
    if found != digest:
        raise NaseviewError(f"{where}: key {CASE_DIR_KEY!r}: {value!r} lies outside the output "
                            "folder and is not the case this output was reconstructed from "
                            "(its case.json is missing or differs); re-run `naseview "
                            "reconstruct` or pass the case folder")
    return case_dir
