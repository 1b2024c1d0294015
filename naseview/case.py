"""Case directories (SPEC §3): reading, validating and writing.

A case is four photos (front, left, right, bottom), optionally one or both oblique photos
(``oblique_left``, ``oblique_right``), the 2D landmark clicks on them and at least one
calliper distance. :func:`read_case` validates everything at the boundary and raises
:class:`~naseview.errors.NaseviewError` with one line naming the file, the key and what
was expected; the rest of naseview can then trust a :class:`Case`.

Example
-------
    case = read_case("assets/demo-case")
    case.views["front"].landmarks["prn"]
    # -> array([511.2, 610. ])
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import intrinsics
from naseview.errors import NaseviewError
from naseview.fileio import (
    atomic_write_bytes,
    atomic_write_json,
    read_json,
    resolve_stored_path,
    write_error,
)
from naseview.imagefile import image_size, read_image, write_image
from naseview.landmarks import ALL_IDS, LANDMARK_IDS, OBLIQUE_VIEWS, VIEWS
from naseview.params import PHOTO_SIDE_PX, Range, first_outside, focal_range

CASE_FORMAT = "naseview.case/1"

SCALE_MM_RANGE = Range(0.0, 500.0, low_open=True, high_open=True)
"""Accepted calliper distances (mm): positive, and below 500 mm (no nose is that large;
a larger value is a typing error, e.g. micrometres)."""

FOCAL_UNKNOWN_SIZE = Range(focal_range(1, 1).low,
                           focal_range(PHOTO_SIDE_PX.high, PHOTO_SIDE_PX.high).high)
"""Focal lengths accepted when the photo's size is not known (``check_images=False``)."""


@dataclass
class View:
    """One photo of a case.

    Attributes:
        name: ``front``, ``left``, ``right``, ``bottom``, ``oblique_left`` or
            ``oblique_right`` (:data:`naseview.landmarks.ALL_VIEWS`).
        image: file name relative to the case directory.
        landmarks: id -> (2,) pixel ``[x, y]`` (SPEC §2), only where marked.
        width, height: image size in pixels.
        camera: optional known intrinsics, ``{"focal_px": f}`` or ``{"K": 3x3}``.
    """

    name: str
    image: str
    landmarks: dict[str, np.ndarray]
    width: int
    height: int
    camera: dict[str, Any] | None = None

    def known_K(self) -> np.ndarray | None:
        """(3, 3) intrinsics if the case gives them, else ``None``."""
        if not self.camera:
            return None
        if "K" in self.camera:
            return np.asarray(self.camera["K"], dtype=np.float64)
        return intrinsics(float(self.camera["focal_px"]), self.width, self.height)


@dataclass
class Case:
    """A validated case directory.

    Attributes:
        root: the case directory.
        id: anonymised id.
        views: view name -> :class:`View`: the four of
            :data:`~naseview.landmarks.VIEWS`, then the obliques the case has, in
            :data:`~naseview.landmarks.ALL_VIEWS` order.
        scale_mm: ``(id_a, id_b)`` -> measured distance in mm (at least one).
        notes: free text.
        extra: unknown top-level keys of ``case.json``, kept and written back verbatim.
    """

    root: Path
    id: str
    views: dict[str, View]
    scale_mm: dict[tuple[str, str], float]
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    def image_path(self, view: str) -> Path:
        """The photo file of ``view``."""
        return self.root / self.views[view].image

    def load_image(self, view: str) -> np.ndarray:
        """(H, W, 3) uint8 BGR photo of ``view``."""
        return read_image(self.image_path(view))

    def observations(self) -> list[tuple[str, str, np.ndarray]]:
        """All clicks of the 21 landmarks as (view, landmark id, (2,) px)."""
        return [(v, lid, xy) for v, view in self.views.items()
                for lid, xy in view.landmarks.items() if lid in LANDMARK_IDS]

    def to_json(self) -> dict[str, Any]:
        """The ``case.json`` object (SPEC §3) of this case."""
        views = {}
        for name, v in self.views.items():
            entry: dict[str, Any] = {
                "image": v.image,
                "landmarks": {k: [float(x) for x in xy] for k, xy in v.landmarks.items()},
            }
            if v.camera:
                entry["camera"] = v.camera
            views[name] = entry
        out: dict[str, Any] = {
            "format": CASE_FORMAT,
            "id": self.id,
            "views": views,
            "scale_mm": {f"{a}-{b}": float(d) for (a, b), d in self.scale_mm.items()},
        }
        if self.notes:
            out["notes"] = self.notes
        out.update(self.extra)
        return out


def _err(path: Path, key: str, expected: str) -> NaseviewError:
    """The one-line error ``<file>: key '<key>': <what was expected>``."""
    return NaseviewError(f"{path}: key {key!r}: {expected}")


def parse_scale_key(key: str) -> tuple[str, str] | None:
    """``"al_l-al_r"`` -> ``("al_l", "al_r")``; ``None`` if not two known landmark ids."""
    parts = key.split("-")
    if len(parts) != 2 or parts[0] == parts[1]:
        return None
    if parts[0] not in LANDMARK_IDS or parts[1] not in LANDMARK_IDS:
        return None
    return parts[0], parts[1]


def _parse_point(path: Path, key: str, value: Any, width: int, height: int) -> np.ndarray:
    """A click ``[x, y]`` (px) that must lie inside the ``width`` x ``height`` photo."""
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in value)):
        raise _err(path, key, "expected [x, y] pixel coordinates (two numbers)")
    x, y = float(value[0]), float(value[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise _err(path, key, "coordinates must be finite numbers")
    if not (-0.5 <= x <= width - 0.5 and -0.5 <= y <= height - 0.5):
        raise _err(path, key, f"point [{x:g}, {y:g}] lies outside the {width}x{height} "
                              "image; re-click it inside the photo")
    return np.array([x, y])


def _parse_camera(path: Path, key: str, value: Any, width: int, height: int
                  ) -> dict[str, Any]:
    """``{"focal_px": f}`` or ``{"K": 3x3}`` of a view, normalised to plain numbers; the
    focal length within the ``width`` x ``height`` photo's scale (:func:`focal_range`)."""
    if not isinstance(value, dict):
        raise _err(path, key, 'expected {"focal_px": f} or {"K": 3x3 matrix}')
    focal = focal_range(width, height) if width and height else FOCAL_UNKNOWN_SIZE
    if "K" in value:
        try:
            K = np.asarray(value["K"], dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            K = np.zeros(0)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise _err(path, key + ".K", "expected a 3x3 intrinsics matrix of finite numbers")
        bad = first_outside([K[0, 0], K[1, 1]], focal)
        if bad is not None:
            raise _err(path, key + ".K", f"focal length {bad:g} px is outside {focal}; "
                                         "expected fx, fy in pixels of this photo")
        if first_outside(K, Range(-focal.high, focal.high)) is not None:
            raise _err(path, key + ".K", f"an entry is outside {Range(-focal.high, focal.high)}"
                                         "; expected intrinsics in pixels of this photo")
        return {"K": K.tolist()}
    if "focal_px" in value:
        f = value["focal_px"]
        if not isinstance(f, (int, float)) or isinstance(f, bool):
            raise _err(path, key + ".focal_px", f"{f!r} is not a number; expected the focal "
                                                f"length in pixels in {focal}")
        if float(f) not in focal:
            raise _err(path, key + ".focal_px", f"{f!r} is outside {focal}; expected the "
                                                "focal length in pixels of this photo "
                                                "(0.05 to 100 times its longest side)")
        return {"focal_px": float(f)}
    raise _err(path, key, 'expected {"focal_px": f} or {"K": 3x3 matrix}')


def parse_case(obj: dict[str, Any], root: Path, json_path: Path | None = None,
               check_images: bool = True) -> Case:
    """Validate a parsed ``case.json`` object whose photos live in ``root``.

    Raises:
        NaseviewError: one line naming the file, the key and what was expected.
    """
    path = json_path or root / "case.json"
    fmt = obj.get("format")
    if fmt != CASE_FORMAT:
        raise _err(path, "format", f"expected {CASE_FORMAT!r}, found {fmt!r}")
    views_obj = obj.get("views")
    if not isinstance(views_obj, dict):
        raise _err(path, "views", "expected an object with front, left, right, bottom "
                                  "(and optionally oblique_left, oblique_right)")
    views = {name: _parse_view(path, name, views_obj, root, check_images) for name in VIEWS}
    for name in OBLIQUE_VIEWS:  # optional: used when present (SPEC §2)
        if views_obj.get(name) is not None:
            views[name] = _parse_view(path, name, views_obj, root, check_images)
    scale = _parse_scale(path, obj.get("scale_mm"))
    case_id = obj.get("id", root.name)
    if not isinstance(case_id, str):
        raise _err(path, "id", "expected a string")
    notes = obj.get("notes", "")
    known = {"format", "id", "views", "scale_mm", "notes"}
    extra = {k: val for k, val in obj.items() if k not in known}
    return Case(root=root, id=case_id, views=views, scale_mm=scale,
                notes=notes if isinstance(notes, str) else "", extra=extra)


def _parse_view(path: Path, name: str, views_obj: dict[str, Any], root: Path,
                check_images: bool) -> View:
    """``views.<name>``: the photo (its size read from the file when ``check_images``),
    the clicks and the optional camera."""
    if name not in views_obj:
        raise _err(path, f"views.{name}", "missing; all four views are required "
                                          "(front, left, right, bottom)")
    v = views_obj[name]
    if not isinstance(v, dict):
        optional = (" (or leave this optional oblique view out)" if name in OBLIQUE_VIEWS
                    else "")
        raise _err(path, f"views.{name}", "expected an object with image and landmarks"
                   + optional)
    image = v.get("image")
    if not isinstance(image, str) or not image:
        raise _err(path, f"views.{name}.image", "expected the photo's file name")
    img_path = resolve_stored_path(image, root, root, path, f"views.{name}.image")
    if check_images:
        if not img_path.is_file():
            raise _err(path, f"views.{name}.image",
                       f"photo {img_path} not found; put it next to case.json")
        try:
            width, height = image_size(img_path)
        except NaseviewError as e:   # damaged, truncated, a lying header, too large
            raise _err(path, f"views.{name}.image", str(e)) from None
    else:
        width, height = int(v.get("width", 0)), int(v.get("height", 0))
    lms = v.get("landmarks", {})
    if not isinstance(lms, dict):
        raise _err(path, f"views.{name}.landmarks", 'expected {"id": [x, y], ...}')
    points: dict[str, np.ndarray] = {}
    for lid, xy in lms.items():
        key = f"views.{name}.landmarks.{lid}"
        if lid not in ALL_IDS:
            raise _err(path, key, "unknown landmark id; known ids: " + ", ".join(ALL_IDS))
        points[lid] = _parse_point(path, key, xy, width or 10**9, height or 10**9)
    camera = _parse_camera(path, f"views.{name}.camera", v["camera"], width, height) \
        if v.get("camera") is not None else None
    return View(name, image, points, width, height, camera)


def _parse_scale(path: Path, scale_obj: Any) -> dict[tuple[str, str], float]:
    """``scale_mm``: at least one ``"<id>-<id>": mm`` calliper distance."""
    if not isinstance(scale_obj, dict) or not scale_obj:
        raise _err(path, "scale_mm", 'missing; give at least one calliper distance in mm, '
                                     'e.g. "scale_mm": {"al_l-al_r": 34.5}')
    scale: dict[tuple[str, str], float] = {}
    for key, d in scale_obj.items():
        pair = parse_scale_key(key)
        if pair is None:
            raise _err(path, f"scale_mm.{key}",
                       'expected "<id>-<id>" of two different landmarks, e.g. "al_l-al_r"')
        if not isinstance(d, (int, float)) or isinstance(d, bool) or not math.isfinite(d):
            raise _err(path, f"scale_mm.{key}", f"{d!r} is not a number; expected a positive "
                                                f"calliper distance in mm in {SCALE_MM_RANGE}")
        if float(d) not in SCALE_MM_RANGE:
            raise _err(path, f"scale_mm.{key}", f"{d!r} is outside {SCALE_MM_RANGE}; expected "
                                                "a positive calliper distance in mm")
        scale[pair] = float(d)
    return scale


def read_case(case_dir: str | os.PathLike[str]) -> Case:
    """Read and validate a case directory (SPEC §3).

    Args:
        case_dir: directory holding ``case.json`` and the four photos (and the optional
            obliques).
    Raises:
        NaseviewError: missing file, unreadable image, unknown landmark id, coordinates
            outside the image, missing ``scale_mm``, ...
    """
    root = Path(case_dir)
    if not root.is_dir():
        raise NaseviewError(f"{root}: case directory not found")
    json_path = root / "case.json"
    if not json_path.is_file():
        raise NaseviewError(f"{json_path}: file not found; a case directory needs case.json "
                            "(SPEC §3)")
    return parse_case(read_json(json_path), root, json_path)


def write_case(case: Case, out_dir: str | os.PathLike[str],
               images: dict[str, np.ndarray] | None = None) -> Path:
    """Write ``case`` to ``out_dir`` (photos, then ``case.json`` last), each file atomically.

    ``images`` maps view -> (H, W, 3) uint8 BGR; views missing from it are copied from
    ``case.root``. Everything is validated before the first byte is written.

    Returns:
        the path of the written ``case.json``.
    """
    out = Path(out_dir)
    images = images or {}
    for name, v in case.views.items():
        if name not in images and not (case.root / v.image).is_file():
            raise NaseviewError(f"{case.root / v.image}: photo for view {name!r} not found")
    parse_case(case.to_json(), case.root, check_images=False)  # validates ids and values
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise write_error(out, e, kept=False) from None
    for name, v in case.views.items():
        if name in images:
            write_image(out / v.image, images[name])
        elif (case.root / v.image).resolve() != (out / v.image).resolve():
            atomic_write_bytes(out / v.image, (case.root / v.image).read_bytes())
    return atomic_write_json(out / "case.json", case.to_json())
