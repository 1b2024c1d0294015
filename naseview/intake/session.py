"""A new patient's guided annotation, autosaved: the state behind the "New patient" page.

:class:`AnnotationSession` is everything the browser page needs to turn four photos into a
case directory (SPEC §3), written so that it can be tested without a browser (no viser
here):

- **Photo intake** (:mod:`naseview.intake.photos`): uploads are decoded, oriented, capped
  in size and stored without metadata;
- **Click order** (:mod:`naseview.intake.click_order`): per photo, the landmarks of
  :data:`naseview.landmarks.VIEW_LANDMARKS` in the order they lie along the paper's
  boundary curves;
- **Editing**: place / move / skip / undo; one undo entry per action (a drag is one move);
- **Autosave**: after every change ``annotation.json`` (format ``naseview.annotation/1``)
  is rewritten atomically in the in-progress folder (photos are written once, at intake);
  :meth:`AnnotationSession.open` resumes it after a reload or a server restart, undo
  history included;
- **Guidance** (:mod:`naseview.intake.guidance`): hints from a quick stage 1 (paper §3.2);
- **Output**: :meth:`AnnotationSession.write_case` writes the SPEC §3 case directory with
  :func:`naseview.case.write_case`, ready for ``naseview reconstruct``.

Example
-------
>>> s = AnnotationSession.create("/tmp/in-progress/p1", case_id="p1")   # doctest: +SKIP
>>> s.add_photo("front", open("front.jpg", "rb").read())                 # doctest: +SKIP
>>> s.place("front", "g", (512.0, 300.0))                                # doctest: +SKIP
>>> s.next_target()                                                      # doctest: +SKIP
('front', 'n')
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import re
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.case import Case, View, parse_scale_key
from naseview.case import write_case as _write_case
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, atomic_write_json, read_image, read_json
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.intake.guidance import HINT_MIN_CLICKS, Guidance, quick_stage1
from naseview.intake.photos import PhotoInfo, decode_photo, encode_photo, photo_kind
from naseview.landmarks import ALL_IDS, LANDMARK_IDS, VIEW_LANDMARKS, VIEWS

ANNOTATION_FORMAT = "naseview.annotation/1"
ANNOTATION_FILE = "annotation.json"


def _now() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def _safe_id(text: str) -> str:
    s = re.sub(r"[^A-Za-z0-9._-]+", "-", text.strip()).strip("-.")
    return s[:64]


def default_work_dir() -> Path:
    """Where new patients are kept: ``$NASEVIEW_WORK_DIR`` or ``~/naseview-patients``
    (unfinished annotations in its ``in-progress/`` folder)."""
    env = os.environ.get("NASEVIEW_WORK_DIR")
    return Path(env).expanduser() if env else Path.home() / "naseview-patients"


def default_case_id() -> str:
    """``patient-YYYYMMDD-HHMMSS`` (local time): anonymous and unique enough."""
    return _dt.datetime.now().strftime("patient-%Y%m%d-%H%M%S")


@dataclass
class _Undo:
    view: str
    landmark: str
    before: list[float] | None     # position before the action (None: not placed)
    skipped_before: bool
    action: str                    # "place", "move", "skip"

    def to_json(self) -> dict[str, Any]:
        return {"view": self.view, "landmark": self.landmark, "before": self.before,
                "skipped_before": self.skipped_before, "action": self.action}


class AnnotationSession:
    """The unfinished annotation of one new patient, autosaved in ``folder``.

    Use :meth:`create` for a new patient and :meth:`open` to resume one. Every method that
    changes something rewrites ``folder/annotation.json`` atomically before it returns.
    Thread-safe (one lock).

    Attributes:
        folder: the in-progress folder (photos + ``annotation.json``).
        case_id: anonymised id (file-name safe).
        photos: view -> :class:`PhotoInfo`.
        clicks: view -> id -> (2,) px in the stored photo.
        skipped: view -> ids marked "not visible".
        scale_mm: (id, id) -> calliper distance (mm).
        notes: free text.
        active_view: the photo being annotated.
        case_dir: where the case was last written (``None`` before).
        revision: increases with every change (guidance caching).
        stats: counters (places, moves, skips, undos) and first / last click times.
    """

    def __init__(self, folder: str | os.PathLike[str], case_id: str = "") -> None:
        self.folder = Path(folder)
        self.case_id = _safe_id(case_id) or _safe_id(self.folder.name) or default_case_id()
        self.photos: dict[str, PhotoInfo] = {}
        self.clicks: dict[str, dict[str, np.ndarray]] = {v: {} for v in VIEWS}
        self.skipped: dict[str, set[str]] = {v: set() for v in VIEWS}
        self.scale_mm: dict[tuple[str, str], float] = {}
        self.notes = ""
        self.active_view = VIEW_ORDER[0]
        self.case_dir: Path | None = None
        self.created = _now()
        self.updated = self.created
        self.revision = 0
        self.stats: dict[str, Any] = {"places": 0, "moves": 0, "skips": 0, "undos": 0,
                                      "first_click": None, "last_click": None}
        self._undo: list[_Undo] = []
        self._lock = threading.RLock()
        self._images: dict[str, np.ndarray] = {}

    # lifecycle
    @classmethod
    def create(cls, folder: str | os.PathLike[str], case_id: str = "") -> AnnotationSession:
        """Start a new patient in ``folder`` (created; must not hold an annotation yet)."""
        folder = Path(folder)
        if (folder / ANNOTATION_FILE).exists():
            raise NaseviewError(f"{folder / ANNOTATION_FILE}: an annotation is already in "
                                "progress here; resume it or choose another folder")
        s = cls(folder, case_id)
        s.save()
        return s

    @classmethod
    def open(cls, folder: str | os.PathLike[str]) -> AnnotationSession:
        """Resume the annotation autosaved in ``folder``.

        Raises:
            NaseviewError: no or malformed ``annotation.json``, or a photo missing.
        """
        folder = Path(folder)
        path = folder / ANNOTATION_FILE
        obj = read_json(path)
        if obj.get("format") != ANNOTATION_FORMAT:
            raise NaseviewError(f"{path}: key 'format': expected {ANNOTATION_FORMAT!r}, "
                                f"found {obj.get('format')!r}")
        s = cls(folder, str(obj.get("id", "")))
        try:
            s._restore_photos(obj.get("photos", {}))
            s._restore_marks(obj)
            s._restore_state(obj)
        except (KeyError, TypeError, ValueError) as e:
            raise NaseviewError(f"{path}: malformed annotation ({type(e).__name__}: {e}); "
                                "start the patient again") from None
        return s

    def _restore_photos(self, photos: dict[str, Any]) -> None:
        """``photos`` of ``annotation.json``; every photo file must still be there."""
        for v, p in photos.items():
            if v not in VIEWS:
                continue
            info = PhotoInfo.from_json(p)
            if not (self.folder / info.file).is_file():
                raise NaseviewError(f"{self.folder / info.file}: photo of view {v!r} is "
                                    "missing; upload that photo again")
            self.photos[v] = info

    def _restore_marks(self, obj: dict[str, Any]) -> None:
        """``clicks``, ``skipped`` and ``scale_mm`` (unknown views and ids are dropped)."""
        for v, c in obj.get("clicks", {}).items():
            if v in VIEWS:
                self.clicks[v] = {i: np.array(xy, dtype=np.float64).reshape(2)
                                  for i, xy in c.items() if i in ALL_IDS}
        for v, ids in obj.get("skipped", {}).items():
            if v in VIEWS:
                self.skipped[v] = {i for i in ids if i in ALL_IDS}
        for key, d in obj.get("scale_mm", {}).items():
            pair = parse_scale_key(key)
            if pair is not None:
                self.scale_mm[pair] = float(d)

    def _restore_state(self, obj: dict[str, Any]) -> None:
        """Notes, active view, case folder, times, revision, counters and undo history."""
        self.notes = str(obj.get("notes", ""))
        av = obj.get("active_view")
        self.active_view = av if av in VIEWS else VIEW_ORDER[0]
        self.case_dir = Path(obj["case_dir"]) if obj.get("case_dir") else None
        self.created = str(obj.get("created", self.created))
        self.updated = str(obj.get("updated", self.updated))
        self.revision = int(obj.get("revision", 0))
        self.stats.update(obj.get("stats", {}))
        self._undo = [_Undo(u["view"], u["landmark"], u["before"], bool(u["skipped_before"]),
                            u["action"]) for u in obj.get("undo", [])]

    def to_json(self) -> dict[str, Any]:
        return {
            "format": ANNOTATION_FORMAT,
            "id": self.case_id,
            "created": self.created,
            "updated": self.updated,
            "revision": self.revision,
            "photos": {v: p.to_json() for v, p in self.photos.items()},
            "clicks": {v: {i: [float(x) for x in xy] for i, xy in c.items()}
                       for v, c in self.clicks.items() if c},
            "skipped": {v: sorted(s) for v, s in self.skipped.items() if s},
            "scale_mm": {f"{a}-{b}": float(d) for (a, b), d in self.scale_mm.items()},
            "notes": self.notes,
            "active_view": self.active_view,
            "case_dir": str(self.case_dir) if self.case_dir else None,
            "stats": self.stats,
            "undo": [u.to_json() for u in self._undo[-500:]],
        }

    def save(self) -> Path:
        """Write ``annotation.json`` atomically (called after every change)."""
        with self._lock:
            return atomic_write_json(self.folder / ANNOTATION_FILE, self.to_json())

    def _changed(self) -> None:
        self.revision += 1
        self.updated = _now()
        self.save()

    # photos
    def add_photo(self, view: str, data: bytes, name: str = "") -> PhotoInfo:
        """Take an uploaded photo for ``view`` (see :func:`decode_photo`).

        The pixels are re-encoded (JPEG stays JPEG at quality 95, PNG stays PNG) without
        any metadata. Replacing a photo removes that view's clicks and skips.

        Raises:
            NaseviewError: unknown view or unusable file (nothing is changed then).
        """
        self._check_view(view)
        label = f"photo for the {view} view" + (f" ({name})" if name else "")
        img, (w0, h0) = decode_photo(data, label)
        kind = "png" if photo_kind(data) == "png" else "jpeg"
        ext = ".png" if kind == "png" else ".jpg"
        file = f"{view}{ext}"
        with self._lock:
            atomic_write_bytes(self.folder / file, encode_photo(img, kind))
            old = self.photos.get(view)
            if old is not None and old.file != file:
                try:
                    (self.folder / old.file).unlink()
                except FileNotFoundError:
                    pass
            self.photos[view] = PhotoInfo(file, int(img.shape[1]), int(img.shape[0]), w0, h0)
            self._images[view] = img
            self.clicks[view] = {}
            self.skipped[view] = set()
            self._undo = [u for u in self._undo if u.view != view]
            self._changed()
            return self.photos[view]

    def image(self, view: str) -> np.ndarray:
        """(H, W, 3) uint8 BGR stored photo of ``view`` (cached)."""
        with self._lock:
            if view not in self.photos:
                raise NaseviewError(f"no photo for the {view} view yet; upload it first")
            if view not in self._images:
                self._images[view] = read_image(self.folder / self.photos[view].file)
            return self._images[view]

    def missing_photos(self) -> list[str]:
        return [v for v in VIEW_ORDER if v not in self.photos]

    # clicks
    def _check_view(self, view: str) -> None:
        if view not in VIEWS:
            raise NaseviewError(f"unknown view {view!r}; expected one of {', '.join(VIEWS)}")

    def _check_click(self, view: str, landmark: str, xy: ArrayLike) -> np.ndarray:
        self._check_view(view)
        if landmark not in VIEW_LANDMARKS[view]:
            raise NaseviewError(f"landmark {landmark!r} is not marked in the {view} photo; "
                                f"it is asked for in: " + ", ".join(
                                    v for v in VIEW_ORDER if landmark in VIEW_LANDMARKS[v]))
        info = self.photos.get(view)
        if info is None:
            raise NaseviewError(f"no photo for the {view} view yet; upload it first")
        p = np.asarray(xy, dtype=np.float64).reshape(-1)
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise NaseviewError(f"click for {landmark!r}: expected two finite pixel "
                                "coordinates")
        x, y = float(p[0]), float(p[1])
        if not (-0.5 <= x <= info.width - 0.5 and -0.5 <= y <= info.height - 0.5):
            raise NaseviewError(f"click for {landmark!r} at [{x:.0f}, {y:.0f}] is outside the "
                                f"{info.width}x{info.height} {view} photo; click on the photo")
        return np.array([x, y])

    def _record(self, view: str, landmark: str, action: str) -> None:
        before = self.clicks[view].get(landmark)
        self._undo.append(_Undo(view, landmark, None if before is None else
                                [float(before[0]), float(before[1])],
                                landmark in self.skipped[view], action))

    def _stamp(self) -> None:
        t = _now()
        if self.stats.get("first_click") is None:
            self.stats["first_click"] = t
        self.stats["last_click"] = t

    def place(self, view: str, landmark: str, xy: ArrayLike) -> None:
        """Click ``landmark`` at ``xy`` (px, SPEC §2) in ``view`` (re-clicking moves it).

        Raises:
            NaseviewError: no photo, landmark not asked in this view, or outside the photo.
        """
        p = self._check_click(view, landmark, xy)
        with self._lock:
            moving = landmark in self.clicks[view]
            self._record(view, landmark, "move" if moving else "place")
            self.clicks[view][landmark] = p
            self.skipped[view].discard(landmark)
            self.stats["moves" if moving else "places"] += 1
            self._stamp()
            self._changed()

    def move(self, view: str, landmark: str, xy: ArrayLike) -> None:
        """Move an existing click (e.g. at the end of a drag); one undo entry.

        Raises:
            NaseviewError: as :meth:`place`, or the landmark is not placed in ``view``.
        """
        if landmark not in self.clicks.get(view, {}):
            raise NaseviewError(f"{landmark!r} is not placed in the {view} photo yet; "
                                "click it first")
        self.place(view, landmark, xy)

    def skip(self, view: str, landmark: str) -> None:
        """Mark ``landmark`` as not visible in ``view`` (removes its click, if any)."""
        self._check_view(view)
        if landmark not in VIEW_LANDMARKS[view]:
            raise NaseviewError(f"landmark {landmark!r} is not marked in the {view} photo")
        with self._lock:
            if landmark in self.skipped[view] and landmark not in self.clicks[view]:
                return
            self._record(view, landmark, "skip")
            self.clicks[view].pop(landmark, None)
            self.skipped[view].add(landmark)
            self.stats["skips"] += 1
            self._changed()

    def remove(self, view: str, landmark: str) -> None:
        """Delete a click (it becomes "to do" again); undoable."""
        with self._lock:
            if landmark not in self.clicks.get(view, {}) and \
                    landmark not in self.skipped.get(view, set()):
                return
            self._record(view, landmark, "remove")
            self.clicks[view].pop(landmark, None)
            self.skipped[view].discard(landmark)
            self._changed()

    def undo(self) -> tuple[str, str] | None:
        """Undo the last place / move / skip / remove; returns its (view, id) or None."""
        with self._lock:
            if not self._undo:
                return None
            u = self._undo.pop()
            if u.before is None:
                self.clicks[u.view].pop(u.landmark, None)
            else:
                self.clicks[u.view][u.landmark] = np.array(u.before, dtype=np.float64)
            if u.skipped_before:
                self.skipped[u.view].add(u.landmark)
            else:
                self.skipped[u.view].discard(u.landmark)
            self.stats["undos"] += 1
            self._changed()
            return u.view, u.landmark

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    # progress
    def status(self, view: str, landmark: str) -> str:
        """``"placed"``, ``"skipped"`` or ``"todo"``."""
        if landmark in self.clicks[view]:
            return "placed"
        if landmark in self.skipped[view]:
            return "skipped"
        return "todo"

    def next_target(self, view: str | None = None) -> tuple[str, str] | None:
        """The next landmark to click: the first "to do" one of ``view`` (default the
        active view), else of the following photos in :data:`VIEW_ORDER` that have a
        photo; ``None`` when every uploaded photo is done."""
        start = view or self.active_view
        order = list(VIEW_ORDER)
        i = order.index(start)
        for v in order[i:] + order[:i]:
            if v not in self.photos:
                continue
            for lid in CLICK_ORDER[v]:
                if self.status(v, lid) == "todo":
                    return v, lid
        return None

    def progress(self, view: str | None = None) -> tuple[int, int]:
        """(done, asked) where done counts placed and skipped landmarks (one view or all
        four)."""
        views = [view] if view else list(VIEWS)
        done = sum(1 for v in views for i in CLICK_ORDER[v] if self.status(v, i) != "todo")
        return done, sum(len(CLICK_ORDER[v]) for v in views)

    def set_active_view(self, view: str) -> None:
        self._check_view(view)
        with self._lock:
            if view != self.active_view:
                self.active_view = view
                self.save()

    # scale and notes
    def set_scale(self, a: str, b: str, mm: float | None) -> None:
        """Set (or with ``None`` / 0 remove) the calliper distance ``a-b`` in mm.

        Raises:
            NaseviewError: unknown ids or a distance outside (0, 500) mm.
        """
        pair = parse_scale_key(f"{a}-{b}")
        if pair is None:
            raise NaseviewError(f"distance {a}-{b}: expected two different landmark ids, "
                                "e.g. al_l-al_r")
        with self._lock:
            if mm is None or mm == 0:
                if pair in self.scale_mm:
                    del self.scale_mm[pair]
                    self._changed()
                return
            if not (isinstance(mm, (int, float)) and math.isfinite(mm) and 0 < mm < 500):
                raise NaseviewError(f"distance {a}-{b}: {mm!r} mm is not a plausible "
                                    "measurement; enter the calliper reading in mm")
            self.scale_mm[pair] = float(mm)
            self._changed()

    def set_scale_text(self, text: str) -> None:
        """Replace the optional distances (all but al_l-al_r) from text such as
        ``"n-prn=45.2, mf_l-mf_r 18"``.

        Raises:
            NaseviewError: an entry that is not ``<id>-<id>=<mm>`` (nothing changes).
        """
        parsed: dict[tuple[str, str], float] = {}
        for part in re.split(r"[,;\n]+", text or ""):
            part = part.strip()
            if not part:
                continue
            m = re.fullmatch(r"([A-Za-z_]+)\s*-\s*([A-Za-z_]+)\s*[=: ]\s*([0-9.]+)\s*(mm)?",
                             part)
            pair = parse_scale_key(f"{m.group(1)}-{m.group(2)}") if m else None
            if m is None or pair is None:
                raise NaseviewError(f"distance {part!r}: expected <id>-<id>=<mm>, e.g. "
                                    "n-prn=45.2")
            d = float(m.group(3))
            if not 0 < d < 500:
                raise NaseviewError(f"distance {part!r}: expected a value in mm")
            parsed[pair] = d
        with self._lock:
            keep = {k: v for k, v in self.scale_mm.items() if k == ("al_l", "al_r")}
            keep.update(parsed)
            if keep != self.scale_mm:
                self.scale_mm = keep
                self._changed()

    def set_case_id(self, case_id: str) -> None:
        cid = _safe_id(case_id)
        if not cid:
            raise NaseviewError(f"case id {case_id!r}: use letters, digits, '-', '_' "
                                "(no patient names)")
        with self._lock:
            if cid != self.case_id:
                self.case_id = cid
                self._changed()

    # guidance
    def guidance(self) -> Guidance:
        """Quick stage 1 on the clicks so far (:func:`quick_stage1`); a snapshot is taken
        under the lock, the solve runs outside it."""
        with self._lock:
            clicks = {v: dict(c) for v, c in self.clicks.items()}
            sizes = {v: (p.width, p.height) for v, p in self.photos.items()}
            scale = dict(self.scale_mm)
            rev = self.revision
        g = quick_stage1(clicks, sizes, scale, self.folder)
        g.revision = rev
        return g

    # output
    def problems(self) -> list[str]:
        """What still prevents reconstruction, one line each (empty = ready)."""
        out = [f"the {v} photo is missing; upload it" for v in self.missing_photos()]
        if not self.scale_mm:
            out.append("enter the measured alar width al_l-al_r (calliper, mm)")
        out += self._too_few_clicks()
        if sum(1 for v in VIEWS if "g" in self.clicks[v]) < 2 and not self.missing_photos():
            out.append("click glabella g in at least two photos (front and a profile)")
        out += self._unclicked_scale_ends()
        return out

    def _too_few_clicks(self) -> list[str]:
        """Photos with fewer than :data:`HINT_MIN_CLICKS` landmark clicks (stage 1 needs
        them)."""
        out = []
        for v in VIEW_ORDER:
            if v not in self.photos:
                continue
            n = sum(1 for i in self.clicks[v] if i in LANDMARK_IDS)
            if n < HINT_MIN_CLICKS:
                out.append(f"the {v} photo has {n} landmark clicks; at least "
                           f"{HINT_MIN_CLICKS} are needed")
        return out

    def _unclicked_scale_ends(self) -> list[str]:
        """Calliper distances one of whose landmarks is clicked in no photo."""
        return [f"the distance {a}-{b} needs {i} clicked" for (a, b) in self.scale_mm
                for i in (a, b) if not any(i in self.clicks[v] for v in VIEWS)]

    def to_case(self) -> Case:
        """The case (SPEC §3) as it stands; photos are read from :attr:`folder`.

        Raises:
            NaseviewError: the first of :meth:`problems`.
        """
        probs = self.problems()
        if probs:
            raise NaseviewError(f"{self.folder}: cannot build the case yet: {probs[0]}")
        with self._lock:
            views = {v: View(v, self.photos[v].file, {i: xy.copy() for i, xy in
                                                      self.clicks[v].items()},
                             self.photos[v].width, self.photos[v].height)
                     for v in VIEWS}
            extra = {"annotation": {"tool": "naseview annotate",
                                    "skipped": {v: sorted(s) for v, s in
                                                self.skipped.items() if s}}}
            return Case(self.folder, self.case_id, views, dict(self.scale_mm), self.notes,
                        extra)

    def write_case(self, out_dir: str | os.PathLike[str]) -> Path:
        """Write the case directory (photos copied byte for byte, ``case.json`` last).

        Returns:
            the path of ``case.json``.
        """
        path = _write_case(self.to_case(), out_dir)
        with self._lock:
            self.case_dir = Path(out_dir)
            self._changed()
        return path


def list_in_progress(root: str | os.PathLike[str]) -> list[tuple[Path, dict[str, Any]]]:
    """Unfinished annotations under ``root`` (folders holding ``annotation.json``), newest
    first, as (folder, parsed json); unreadable ones are left out."""
    root = Path(root)
    out: list[tuple[Path, dict[str, Any]]] = []
    if not root.is_dir():
        return out
    for p in root.iterdir():
        f = p / ANNOTATION_FILE
        if f.is_file():
            try:
                obj = read_json(f)
            except NaseviewError:
                continue
            if obj.get("format") == ANNOTATION_FORMAT:
                out.append((p, obj))
    out.sort(key=lambda po: str(po[1].get("updated", "")), reverse=True)
    return out


__all__ = ["ANNOTATION_FILE", "ANNOTATION_FORMAT", "AnnotationSession", "default_case_id",
           "default_work_dir", "list_in_progress"]
