"""``annotation.json`` (format ``naseview.annotation/1``): the autosave of a new patient.

One home for the file: :func:`parse_annotation` validates a hand-edited or damaged file at
the boundary, once, and raises :class:`~naseview.errors.NaseviewError` with one line that
names the file and the key (like ``case.json``, :mod:`naseview.case`); the session can then
trust an :class:`AnnotationState`. :func:`annotation_json` writes the same object back.

Checked: the case id is file-name safe; every photo is a plain file name inside the
in-progress folder (no ``/``, ``..``, hidden names or symbolic links out of it), of a
plausible size, used by one view only; clicks, skips and undo entries name a landmark asked
for in that photo and lie inside it; numbers are finite; distances are in (0, 500) mm.

Example
-------
>>> from pathlib import Path
>>> parse_annotation({"format": "naseview.annotation/1", "id": "p 1"}, Path("a.json"),
...                  Path("."))
Traceback (most recent call last):
...
naseview.errors.NaseviewError: a.json: key 'id': expected a file-name-safe case id \
(letters, digits, '.', '_', '-'), found 'p 1'
"""

from __future__ import annotations

import math
import re
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.case import parse_scale_key
from naseview.errors import NaseviewError
from naseview.fileio import one_line, resolve_stored_path, stored_path
from naseview.imagefile import image_header
from naseview.intake.click_order import PHOTO_ORDER, VIEW_ORDER
from naseview.intake.photos import MAX_SIDE_PX, PhotoInfo
from naseview.landmarks import ALL_VIEWS, VIEW_LANDMARKS

ANNOTATION_FORMAT = "naseview.annotation/1"
ANNOTATION_FILE = "annotation.json"

UNDO_ACTIONS = ("place", "move", "skip", "remove")
"""What an undo entry may undo."""

MAX_ORIGINAL_SIDE_PX = 100_000
"""Largest original photo side an annotation may record (px)."""

_ID_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")
_PHOTO_RE = re.compile("(" + "|".join(ALL_VIEWS) + r")(-[0-9]{1,9})?\.(jpg|png)")
_COUNTERS = ("places", "moves", "skips", "undos")
_HEADER_BYTES = 1 << 18  # enough for the size in the header of the photos the session writes


def safe_case_id(text: str) -> str:
    """``text`` made file-name safe: runs of other characters become ``-``, at most 64.

    >>> safe_case_id(" P 001 / left ")
    'P-001-left'
    """
    s = re.sub(r"[^A-Za-z0-9._-]+", "-", text.strip()).strip("-.")
    return s[:64].rstrip("-.")


def is_photo_name(name: str) -> bool:
    """Whether ``name`` is a photo file name the session writes (``front.jpg``,
    ``left-2.png``...)."""
    return _PHOTO_RE.fullmatch(name) is not None


def new_uid() -> str:
    """A random token that marks the files one session wrote (no patient data)."""
    return uuid.uuid4().hex


@dataclass
class UndoEntry:
    """One undoable action: the landmark's state before it."""

    view: str
    landmark: str
    before: list[float] | None     # position before the action (None: not placed)
    skipped_before: bool
    action: str                    # one of UNDO_ACTIONS

    def to_json(self) -> dict[str, Any]:
        return {"view": self.view, "landmark": self.landmark, "before": self.before,
                "skipped_before": self.skipped_before, "action": self.action}


@dataclass
class AnnotationState:
    """Everything ``annotation.json`` holds, validated (see :func:`parse_annotation`)."""

    case_id: str
    uid: str
    created: str
    updated: str
    revision: int = 0
    photos: dict[str, PhotoInfo] = field(default_factory=dict)
    clicks: dict[str, dict[str, np.ndarray]] = field(
        default_factory=lambda: {v: {} for v in ALL_VIEWS})
    skipped: dict[str, set[str]] = field(default_factory=lambda: {v: set() for v in ALL_VIEWS})
    scale_mm: dict[tuple[str, str], float] = field(default_factory=dict)
    notes: str = ""
    active_view: str = VIEW_ORDER[0]
    case_dir: Path | None = None
    stats: dict[str, Any] = field(default_factory=lambda: {
        "places": 0, "moves": 0, "skips": 0, "undos": 0,
        "first_click": None, "last_click": None})
    undo: list[UndoEntry] = field(default_factory=list)


def _err(path: Path, key: str, expected: str) -> NaseviewError:
    return NaseviewError(f"{path}: key {key!r}: {expected}")


def _short(value: Any) -> str:
    r = repr(value)
    return r if len(r) <= 40 else r[:37] + "..."


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _int(path: Path, key: str, value: Any, lo: int, hi: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise _err(path, key, f"expected a whole number in [{lo}, {hi}], found "
                              f"{_short(value)}")
    return value


def _obj(path: Path, key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise _err(path, key, f"expected an object, found {_short(value)}")
    return value


def _text(path: Path, key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise _err(path, key, f"expected a string, found {_short(value)}")
    return value


def _view(path: Path, key: str, view: Any) -> str:
    if view not in ALL_VIEWS:
        raise _err(path, key, f"unknown view {_short(view)}; expected one of "
                              + ", ".join(PHOTO_ORDER))
    return str(view)


def _landmark(path: Path, key: str, view: str, lid: Any) -> str:
    if lid not in VIEW_LANDMARKS[view]:
        raise _err(path, key, f"{_short(lid)} is not a landmark of the {view} photo; "
                              "expected one of " + ", ".join(VIEW_LANDMARKS[view]))
    return str(lid)


def _point(path: Path, key: str, value: Any, info: PhotoInfo) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 2 or not all(map(_number, value)):
        raise _err(path, key, f"expected [x, y] pixel coordinates, found {_short(value)}")
    x, y = float(value[0]), float(value[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise _err(path, key, "coordinates must be finite numbers")
    if not (-0.5 <= x <= info.width - 0.5 and -0.5 <= y <= info.height - 0.5):
        raise _err(path, key, f"point [{x:g}, {y:g}] lies outside the "
                              f"{info.width}x{info.height} photo")
    return np.array([x, y])


def _photo(path: Path, folder: Path, view: str, value: Any) -> PhotoInfo:
    key = f"photos.{view}"
    p = _obj(path, key, value)
    file = p.get("file")
    if not isinstance(file, str) or not is_photo_name(file):
        raise _err(path, f"{key}.file", f"expected a photo file name such as "
                                        f"'{view}.jpg' in the same folder, found "
                                        f"{_short(file)}")
    where = folder / file
    if where.is_symlink() or not where.is_file():
        raise _err(path, f"{key}.file", f"photo {where} is missing (or not a plain file "
                                        f"in {folder}); upload the {view} photo again")
    w = _int(path, f"{key}.width", p.get("width"), 1, MAX_SIDE_PX)
    h = _int(path, f"{key}.height", p.get("height"), 1, MAX_SIDE_PX)
    try:
        with open(where, "rb") as f:
            head = f.read(_HEADER_BYTES)
    except OSError as e:
        raise _err(path, f"{key}.file", f"cannot read {where} ({one_line(e)})") from None
    _, w_file, h_file = image_header(head, where, whole=len(head) < _HEADER_BYTES)
    if (w_file, h_file) != (w, h):
        raise _err(path, f"{key}.width", f"the photo {where} is {w_file}x{h_file} px, not "
                                         f"{w}x{h}; upload the {view} photo again")
    w0 = _int(path, f"{key}.original_width", p.get("original_width", w), w,
              MAX_ORIGINAL_SIDE_PX)
    h0 = _int(path, f"{key}.original_height", p.get("original_height", h), h,
              MAX_ORIGINAL_SIDE_PX)
    return PhotoInfo(file, w, h, w0, h0)


def _parse_photos(path: Path, folder: Path, value: Any) -> dict[str, PhotoInfo]:
    photos: dict[str, PhotoInfo] = {}
    files: dict[str, str] = {}
    for v, p in _obj(path, "photos", value).items():
        _view(path, f"photos.{v}", v)
        file = p.get("file") if isinstance(p, dict) else None
        if isinstance(file, str) and file in files:
            raise _err(path, f"photos.{v}.file", f"{file!r} is already the photo of the "
                                                 f"{files[file]} view")
        photos[v] = _photo(path, folder, v, p)
        files[photos[v].file] = v
    return photos


def _parse_clicks(path: Path, value: Any, photos: dict[str, PhotoInfo]
                  ) -> dict[str, dict[str, np.ndarray]]:
    clicks: dict[str, dict[str, np.ndarray]] = {v: {} for v in ALL_VIEWS}
    for v, c in _obj(path, "clicks", value).items():
        key = f"clicks.{v}"
        _view(path, key, v)
        c = _obj(path, key, c)
        if c and v not in photos:
            raise _err(path, key, f"clicks on the {v} photo, which is not in 'photos'")
        clicks[v] = {_landmark(path, f"{key}.{i}", v, i):
                     _point(path, f"{key}.{i}", xy, photos[v]) for i, xy in c.items()}
    return clicks


def _parse_skipped(path: Path, value: Any) -> dict[str, set[str]]:
    skipped: dict[str, set[str]] = {v: set() for v in ALL_VIEWS}
    for v, ids in _obj(path, "skipped", value).items():
        key = f"skipped.{v}"
        _view(path, key, v)
        if not isinstance(ids, list):
            raise _err(path, key, f"expected a list of landmark ids, found {_short(ids)}")
        skipped[v] = {_landmark(path, key, v, i) for i in ids}
    return skipped


def _parse_scale(path: Path, value: Any) -> dict[tuple[str, str], float]:
    scale: dict[tuple[str, str], float] = {}
    for k, d in _obj(path, "scale_mm", value).items():
        pair = parse_scale_key(k)
        if pair is None:
            raise _err(path, f"scale_mm.{k}", 'expected "<id>-<id>" of two different '
                                              'landmarks, e.g. "al_l-al_r"')
        if not _number(d) or not (math.isfinite(d) and 0 < d < 500):
            raise _err(path, f"scale_mm.{k}", f"expected a distance in (0, 500) mm, found "
                                              f"{_short(d)}")
        scale[pair] = float(d)
    return scale


def _parse_stats(path: Path, value: Any) -> dict[str, Any]:
    s = _obj(path, "stats", value)
    out: dict[str, Any] = {k: _int(path, f"stats.{k}", s.get(k, 0), 0, 10**9)
                           for k in _COUNTERS}
    for k in ("first_click", "last_click"):
        t = s.get(k)
        out[k] = None if t is None else _text(path, f"stats.{k}", t)
    return out


def _parse_undo(path: Path, value: Any, photos: dict[str, PhotoInfo]) -> list[UndoEntry]:
    if not isinstance(value, list):
        raise _err(path, "undo", f"expected a list of actions, found {_short(value)}")
    out = []
    for k, u in enumerate(value):
        key = f"undo.{k}"
        u = _obj(path, key, u)
        v = _view(path, f"{key}.view", u.get("view"))
        if v not in photos:
            raise _err(path, f"{key}.view", f"an action on the {v} photo, which is not in "
                                            "'photos'")
        lid = _landmark(path, f"{key}.landmark", v, u.get("landmark"))
        before = u.get("before")
        if before is not None:
            before = [float(c) for c in _point(path, f"{key}.before", before, photos[v])]
        sk = u.get("skipped_before")
        if not isinstance(sk, bool):
            raise _err(path, f"{key}.skipped_before", f"expected true or false, found "
                                                      f"{_short(sk)}")
        action = u.get("action")
        if action not in UNDO_ACTIONS:
            raise _err(path, f"{key}.action", f"expected one of {', '.join(UNDO_ACTIONS)}, "
                                              f"found {_short(action)}")
        out.append(UndoEntry(v, lid, before, sk, str(action)))
    return out


def _parse_case_dir(path: Path, folder: Path, value: Any) -> Path | None:
    """``case_dir``: relative to the in-progress folder and inside the work folder
    (``WORK/in-progress/<name>/../../<id>/case``); absolute in files of older versions."""
    if value is None:
        return None
    return resolve_stored_path(value, folder, folder.parent.parent, path, "case_dir",
                               allow_absolute=True)


def parse_annotation(obj: dict[str, Any], path: Path, folder: Path) -> AnnotationState:
    """Validate the parsed ``annotation.json`` object ``obj`` of the in-progress ``folder``.

    Args:
        obj: the JSON object (:func:`naseview.fileio.read_json`).
        path: the file, for messages.
        folder: the in-progress folder; every photo must be a file in it.
    Raises:
        NaseviewError: one line naming ``path`` and the key, e.g. a landmark id not asked
            for in that photo, a click outside the photo or not finite, a photo path that
            leaves the folder.
    """
    fmt = obj.get("format")
    if fmt != ANNOTATION_FORMAT:
        raise _err(path, "format", f"expected {ANNOTATION_FORMAT!r}, found {_short(fmt)}")
    cid = obj.get("id")
    if not isinstance(cid, str) or not _ID_RE.fullmatch(cid):
        raise _err(path, "id", "expected a file-name-safe case id (letters, digits, '.', "
                               f"'_', '-'), found {_short(cid)}")
    uid = obj.get("uid", None)
    if uid is not None and not (isinstance(uid, str) and re.fullmatch(r"[0-9a-f]{32}", uid)):
        raise _err(path, "uid", f"expected 32 hexadecimal digits, found {_short(uid)}")
    photos = _parse_photos(path, folder, obj.get("photos", {}))
    active = obj.get("active_view", VIEW_ORDER[0])
    return AnnotationState(
        case_id=cid, uid=uid or new_uid(),
        created=_text(path, "created", obj.get("created", "")),
        updated=_text(path, "updated", obj.get("updated", "")),
        revision=_int(path, "revision", obj.get("revision", 0), 0, 2**53),
        photos=photos,
        clicks=_parse_clicks(path, obj.get("clicks", {}), photos),
        skipped=_parse_skipped(path, obj.get("skipped", {})),
        scale_mm=_parse_scale(path, obj.get("scale_mm", {})),
        notes=_text(path, "notes", obj.get("notes", "")),
        active_view=_view(path, "active_view", active),
        case_dir=_parse_case_dir(path, folder, obj.get("case_dir")),
        stats=_parse_stats(path, obj.get("stats", {})),
        undo=_parse_undo(path, obj.get("undo", []), photos))


def annotation_json(state: AnnotationState, folder: Path, max_undo: int = 500
                    ) -> dict[str, Any]:
    """The ``annotation.json`` object of ``state``; ``case_dir`` relative to ``folder``
    (no absolute path, which often holds a name, is stored), and only when it lies in the
    work folder ``folder/../..`` (:func:`parse_annotation` refuses any other)."""
    case_dir = (stored_path(state.case_dir, folder, folder.parent.parent)
                if state.case_dir is not None else None)
    return {
        "format": ANNOTATION_FORMAT,
        "id": state.case_id,
        "uid": state.uid,
        "created": state.created,
        "updated": state.updated,
        "revision": state.revision,
        "photos": {v: p.to_json() for v, p in state.photos.items()},
        "clicks": {v: {i: [float(x) for x in xy] for i, xy in c.items()}
                   for v, c in state.clicks.items() if c},
        "skipped": {v: sorted(s) for v, s in state.skipped.items() if s},
        "scale_mm": {f"{a}-{b}": float(d) for (a, b), d in state.scale_mm.items()},
        "notes": state.notes,
        "active_view": state.active_view,
        "case_dir": case_dir,
        "stats": state.stats,
        "undo": [u.to_json() for u in state.undo[-max_undo:]],
    }


__all__ = ["ANNOTATION_FILE", "ANNOTATION_FORMAT", "AnnotationState", "UndoEntry",
           "annotation_json", "is_photo_name", "new_uid", "parse_annotation",
           "safe_case_id"]
