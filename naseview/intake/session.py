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
- **Autosave**: after every change ``annotation.json`` (format ``naseview.annotation/1``,
  :mod:`naseview.intake.annotation_file`) is rewritten atomically in the in-progress
  folder; a change whose save fails is undone in memory too. Photos are written once, at
  intake; replacing one is all or nothing with its clicks
  (:meth:`AnnotationSession.add_photo`). :meth:`AnnotationSession.open` validates the
  file and resumes it after a reload or a server restart, undo history included;
- **Guidance** (:mod:`naseview.intake.guidance`): hints from a quick stage 1 (paper §3.2);
- **Output**: :meth:`AnnotationSession.write_case` writes the SPEC §3 case directory with
  :func:`naseview.case.write_case`, ready for ``naseview reconstruct``: all or nothing,
  and never over a case another session wrote (:mod:`naseview.intake.case_writer`).

The unfinished annotations of a work folder are listed by
:func:`naseview.intake.in_progress.list_in_progress`.

Example
-------
    s = AnnotationSession.create("/tmp/in-progress/p1", case_id="p1")
    s.add_photo("front", open("front.jpg", "rb").read())
    s.place("front", "g", (512.0, 300.0))
    s.next_target()
    # -> ('front', 'n')
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import logging
import math
import os
import re
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.case import Case, View, parse_scale_key
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, atomic_write_json, one_line, read_json
from naseview.imagefile import read_image
from naseview.intake.annotation_file import (
    ANNOTATION_FILE,
    ANNOTATION_FORMAT,
    AnnotationState,
    UndoEntry,
    annotation_json,
    is_photo_name,
    new_uid,
    parse_annotation,
    safe_case_id,
)
from naseview.intake.case_writer import write_case_dir
from naseview.intake.click_order import CLICK_ORDER, PHOTO_ORDER, VIEW_ORDER
from naseview.intake.guidance import HINT_MIN_CLICKS, Guidance, quick_stage1
from naseview.intake.photos import PhotoInfo, decode_photo, encode_photo, photo_kind
from naseview.landmarks import ALL_VIEWS, LANDMARK_IDS, VIEW_LANDMARKS, VIEWS
from naseview.stage1_landmarks.template import TEMPLATE_MM, plausible_distance, typical_distance_mm

log = logging.getLogger(__name__)


def _now() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def default_work_dir() -> Path:
    """Where new patients are kept: ``$NASEVIEW_WORK_DIR`` or ``~/naseview-patients``
    (unfinished annotations in its ``in-progress/`` folder)."""
    env = os.environ.get("NASEVIEW_WORK_DIR")
    return Path(env).expanduser() if env else Path.home() / "naseview-patients"


def default_case_id() -> str:
    """``patient-YYYYMMDD-HHMMSS`` (local time): anonymous and unique enough."""
    return _dt.datetime.now().strftime("patient-%Y%m%d-%H%M%S")


def _is_leftover(name: str) -> bool:
    """A temporary file of an interrupted write in an in-progress folder: the atomic
    writes of :mod:`naseview.fileio` use ``.<target>.<random>.tmp``."""
    if not (name.startswith(".") and name.endswith(".tmp")):
        return False
    target = name[1:].rsplit(".", 2)[0]
    return target == ANNOTATION_FILE or is_photo_name(target)


def _unlink(path: Path) -> None:
    """Remove a file the session no longer needs; a failure only leaves an orphan that
    the next :meth:`AnnotationSession.open` removes."""
    try:
        path.unlink()
    except FileNotFoundError:
        pass
    except OSError as e:
        log.warning("naseview: could not remove %s: %s", path, one_line(e))


class AnnotationSession:
    """The unfinished annotation of one new patient, autosaved in ``folder``.

    Use :meth:`create` for a new patient and :meth:`open` to resume one. Every method that
    changes something rewrites ``folder/annotation.json`` atomically before it returns;
    if that write fails, the session is left exactly as it was (in memory and on disk).
    Thread-safe (one lock).

    Attributes:
        folder: the in-progress folder (photos + ``annotation.json``).
        case_id: anonymised id (file-name safe).
        uid: random token of this session; the case directory it writes carries it, so
            that it rewrites its own case and never another patient's.
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
        self._make_folder: Callable[[str], Path] | None = None
        self._lock = threading.RLock()
        self._images: dict[str, np.ndarray] = {}
        now = _now()
        self._load(AnnotationState(
            case_id=safe_case_id(case_id) or safe_case_id(self.folder.name)
            or default_case_id(), uid=new_uid(), created=now, updated=now))

    # state
    def _load(self, st: AnnotationState) -> None:
        self.case_id = st.case_id
        self.uid = st.uid
        self.created, self.updated, self.revision = st.created, st.updated, st.revision
        self.photos: dict[str, PhotoInfo] = dict(st.photos)
        self.clicks: dict[str, dict[str, np.ndarray]] = {
            v: dict(st.clicks.get(v, {})) for v in ALL_VIEWS}
        self.skipped: dict[str, set[str]] = {v: set(st.skipped.get(v, ())) for v in ALL_VIEWS}
        self.scale_mm: dict[tuple[str, str], float] = dict(st.scale_mm)
        self.notes = st.notes
        self.active_view = st.active_view
        self.case_dir: Path | None = st.case_dir
        self.stats: dict[str, Any] = dict(st.stats)
        self._undo: list[UndoEntry] = list(st.undo)

    def _state(self) -> AnnotationState:
        """A snapshot of the session (inner containers copied)."""
        return AnnotationState(
            case_id=self.case_id, uid=self.uid, created=self.created, updated=self.updated,
            revision=self.revision, photos=dict(self.photos),
            clicks={v: dict(c) for v, c in self.clicks.items()},
            skipped={v: set(s) for v, s in self.skipped.items()},
            scale_mm=dict(self.scale_mm), notes=self.notes, active_view=self.active_view,
            case_dir=self.case_dir, stats=dict(self.stats), undo=list(self._undo))

    @contextlib.contextmanager
    def _edit(self, bump: bool = True) -> Iterator[None]:
        """Change the session inside the block, then save: all or nothing. If the block
        or the save raises (disk full, a kill signal...), the session returns to its
        state before the block and ``annotation.json`` still holds that state."""
        with self._lock:
            before = self._state()
            try:
                yield
                if bump:
                    self.revision += 1
                    self.updated = _now()
                self.save()
            except BaseException:
                self._load(before)
                raise

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
    def pending(cls, folder: str | os.PathLike[str], case_id: str,
                make_folder: Callable[[str], Path]) -> AnnotationSession:
        """A new patient whose folder does not exist yet: ``make_folder(case_id)`` creates
        it (and returns it) on the first real input, a photo or a distance
        (:meth:`has_input`); until then nothing is written, and a page opened and left
        leaves no empty patient behind. ``folder`` is where it is expected."""
        s = cls(folder, case_id)
        s._make_folder = make_folder
        return s

    def has_input(self) -> bool:
        """Whether the patient holds anything worth keeping (photos, distances, clicks)."""
        return bool(self.photos or self.scale_mm or any(self.clicks.values()))

    @property
    def on_disk(self) -> bool:
        """Whether the in-progress folder exists (False for a :meth:`pending` patient
        without input yet)."""
        return self._make_folder is None

    def _materialize(self) -> None:
        """Create the folder of a :meth:`pending` patient (under the lock)."""
        if self._make_folder is not None:
            self.folder = self._make_folder(self.case_id)
            self._make_folder = None

    @classmethod
    def open(cls, folder: str | os.PathLike[str]) -> AnnotationSession:
        """Resume the annotation autosaved in ``folder``; leftovers of an interrupted
        write (temporary files, a photo no longer referenced) are removed.

        Raises:
            NaseviewError: no ``annotation.json``, or one that is malformed or hand-edited
                out of range (:func:`~naseview.intake.annotation_file.parse_annotation`:
                one line naming the file and the key).
        """
        folder = Path(folder)
        path = folder / ANNOTATION_FILE
        state = parse_annotation(read_json(path), path, folder)
        s = cls(folder, state.case_id)
        s._load(state)
        s._remove_leftovers()
        return s

    def _remove_leftovers(self) -> None:
        """Temporary files of interrupted writes and photos no view refers to (a photo
        replacement interrupted before or after its commit)."""
        keep = {p.file for p in self.photos.values()}
        try:
            names = [p.name for p in self.folder.iterdir() if p.is_file()]
        except OSError:
            return
        for name in names:
            if _is_leftover(name) or (is_photo_name(name) and name not in keep):
                _unlink(self.folder / name)

    def to_json(self) -> dict[str, Any]:
        """The ``annotation.json`` object (``case_dir`` relative to :attr:`folder`)."""
        return annotation_json(self._state(), self.folder)

    def save(self) -> Path:
        """Write ``annotation.json`` atomically (called after every change); a
        :meth:`pending` patient gets its folder with its first input (nothing before)."""
        with self._lock:
            if self._make_folder is not None:
                if not self.has_input():
                    return self.folder / ANNOTATION_FILE
                self._materialize()
            return atomic_write_json(self.folder / ANNOTATION_FILE, self.to_json())

    # photos
    def _new_photo_name(self, view: str, ext: str) -> str:
        """A file name for a new photo of ``view`` that no view refers to and no file
        has: the photo it replaces stays intact until the new one is committed."""
        used = {p.file for p in self.photos.values()}
        for k in range(1, 10_000):
            name = f"{view}{ext}" if k == 1 else f"{view}-{k}{ext}"
            if name not in used and not (self.folder / name).exists():
                return name
        raise NaseviewError(f"{self.folder}: too many photo files of the {view} view; "
                            "remove the old ones")

    def add_photo(self, view: str, data: bytes, name: str = "") -> PhotoInfo:
        """Take an uploaded photo for ``view`` (see :func:`decode_photo`).

        The pixels are re-encoded (JPEG stays JPEG at quality 95, PNG stays PNG) without
        any metadata. Replacing a photo removes that view's clicks and skips, all or
        nothing: the new photo goes to a new file, ``annotation.json`` then switches to
        it with no clicks for the view (the commit), and only then is the old photo
        removed. A crash at any step leaves the old photo with its clicks or the new one
        without; :meth:`open` removes the file the crash left behind.

        Raises:
            NaseviewError: unknown view or unusable file (nothing is changed then).
        """
        self._check_view(view)
        label = f"photo for the {view} view" + (f" ({name})" if name else "")
        img, (w0, h0) = decode_photo(data, label)
        kind = "png" if photo_kind(data) == "png" else "jpeg"
        encoded = encode_photo(img, kind)
        with self._lock:
            self._materialize()
            file = self._new_photo_name(view, ".png" if kind == "png" else ".jpg")
            old = self.photos.get(view)
            try:
                atomic_write_bytes(self.folder / file, encoded)
                with self._edit():
                    self.photos[view] = PhotoInfo(file, int(img.shape[1]),
                                                  int(img.shape[0]), w0, h0)
                    self.clicks[view] = {}
                    self.skipped[view] = set()
                    self._undo = [u for u in self._undo if u.view != view]
            except BaseException:
                _unlink(self.folder / file)
                raise
            self._images[view] = img
            if old is not None:
                _unlink(self.folder / old.file)
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
        if view not in ALL_VIEWS:
            raise NaseviewError(f"unknown view {view!r}; expected one of "
                                f"{', '.join(ALL_VIEWS)}")

    def _check_click(self, view: str, landmark: str, xy: ArrayLike) -> np.ndarray:
        self._check_view(view)
        if landmark not in VIEW_LANDMARKS[view]:
            raise NaseviewError(f"landmark {landmark!r} is not marked in the {view} photo; "
                                f"it is asked for in: " + ", ".join(
                                    v for v in PHOTO_ORDER if landmark in VIEW_LANDMARKS[v]))
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
        self._undo.append(UndoEntry(view, landmark, None if before is None else
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
        with self._edit():
            moving = landmark in self.clicks[view]
            self._record(view, landmark, "move" if moving else "place")
            self.clicks[view][landmark] = p
            self.skipped[view].discard(landmark)
            self.stats["moves" if moving else "places"] += 1
            self._stamp()

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
            with self._edit():
                self._record(view, landmark, "skip")
                self.clicks[view].pop(landmark, None)
                self.skipped[view].add(landmark)
                self.stats["skips"] += 1

    def remove(self, view: str, landmark: str) -> None:
        """Delete a click (it becomes "to do" again); undoable."""
        with self._lock:
            if landmark not in self.clicks.get(view, {}) and \
                    landmark not in self.skipped.get(view, set()):
                return
            with self._edit():
                self._record(view, landmark, "remove")
                self.clicks[view].pop(landmark, None)
                self.skipped[view].discard(landmark)

    def undo(self) -> tuple[str, str] | None:
        """Undo the last place / move / skip / remove; returns its (view, id) or None."""
        with self._lock:
            if not self._undo:
                return None
            with self._edit():
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
        order = list(PHOTO_ORDER)
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
        views = [view] if view else [v for v in ALL_VIEWS
                                     if v in VIEWS or v in self.photos]
        done = sum(1 for v in views for i in CLICK_ORDER[v] if self.status(v, i) != "todo")
        return done, sum(len(CLICK_ORDER[v]) for v in views)

    def set_active_view(self, view: str) -> None:
        self._check_view(view)
        with self._lock:
            if view != self.active_view:
                with self._edit(bump=False):
                    self.active_view = view

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
        if mm is not None and mm != 0 and not (
                isinstance(mm, (int, float)) and math.isfinite(mm) and 0 < mm < 500):
            raise NaseviewError(f"distance {a}-{b}: {mm!r} mm is out of range; enter the "
                                "calliper reading in mm, between 0 and 500")
        with self._lock:
            if mm is None or mm == 0:
                if pair in self.scale_mm:
                    with self._edit():
                        del self.scale_mm[pair]
                return
            with self._edit():
                self.scale_mm[pair] = float(mm)

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
                raise NaseviewError(f"distance {part!r}: expected a distance in mm, "
                                    "between 0 and 500")
            parsed[pair] = d
        with self._lock:
            keep = {k: v for k, v in self.scale_mm.items() if k == ("al_l", "al_r")}
            keep.update(parsed)
            if keep != self.scale_mm:
                with self._edit():
                    self.scale_mm = keep

    def set_case_id(self, case_id: str) -> None:
        """Rename the patient (made file-name safe, :func:`safe_case_id`). Whether another
        patient already has the id is for :class:`~naseview.intake.patients.PatientFolders`
        to check; :meth:`write_case` never overwrites another patient's case anyway."""
        cid = safe_case_id(case_id)
        if not cid:
            raise NaseviewError(f"case id {case_id!r}: use letters, digits, '-', '_' "
                                "(no patient names)")
        with self._lock:
            if cid != self.case_id:
                with self._edit():
                    self.case_id = cid

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
        out += [f"the distance {a}-{b} of {d:g} mm is not a nose's (about "   # beside the
                f"{typical_distance_mm(a, b):.0f} mm); enter the calliper reading in mm"
                for (a, b), d in self.scale_mm.items()                    # entry it is about
                if a in TEMPLATE_MM and b in TEMPLATE_MM and not plausible_distance(a, b, d)]
        out += self._too_few_clicks()
        if not self.missing_photos() and not any("g" in self.clicks[v] for v in ALL_VIEWS):
            out.append("click glabella g (the origin of the 3D frame) in the front photo "
                       "and in a profile photo")
        out += self._unclicked_scale_ends()
        return out

    def cautions(self) -> list[str]:
        """What reconstructs but less well, one line each (blocks nothing; the command
        line warns of the same): glabella clicked in one photo only is placed from that
        photo and the face model, uncertain by a few mm."""
        seen = [v for v in VIEW_ORDER if "g" in self.clicks[v]]
        if len(seen) == 1 and not self.missing_photos():
            other = "a profile photo" if seen[0] == "front" else "the front photo"
            return [f"glabella (g) is clicked in the {seen[0]} photo only: click it in "
                    f"{other} too if it shows there, else its depth is an estimate"]
        return []

    def _too_few_clicks(self) -> list[str]:
        """Photos with fewer than :data:`HINT_MIN_CLICKS` landmark clicks (stage 1 needs
        them)."""
        out = []
        for v in PHOTO_ORDER:
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
                for i in (a, b) if not any(i in self.clicks[v] for v in ALL_VIEWS)]

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
                     for v in ALL_VIEWS if v in self.photos}
            extra = {"annotation": {"tool": "naseview annotate", "session": self.uid,
                                    "skipped": {v: sorted(s) for v, s in
                                                self.skipped.items() if s}}}
            return Case(self.folder, self.case_id, views, dict(self.scale_mm), self.notes,
                        extra)

    def owns(self, case_dir: str | os.PathLike[str]) -> bool:
        """Whether ``case_dir`` may be (re)written by this session: it does not exist, is
        an empty folder, or holds a case this session wrote (its ``case.json`` carries
        :attr:`uid`)."""
        out = Path(case_dir)
        if not out.exists():
            return True
        if not out.is_dir() or out.is_symlink():
            return False
        if not any(out.iterdir()):
            return True
        try:
            ann = read_json(out / "case.json").get("annotation")
        except NaseviewError:
            return False
        return isinstance(ann, dict) and ann.get("session") == self.uid

    def write_case(self, out_dir: str | os.PathLike[str]) -> Path:
        """Write the case directory: all or nothing, and never over another patient.

        The case (photos copied byte for byte, ``case.json`` last) is written into a
        temporary folder beside ``out_dir`` and renamed to it, so readers see the old
        case or the new one, never a mix. ``out_dir`` must not hold a case this session
        did not write (:meth:`owns`); leftovers of an interrupted write are removed.

        Returns:
            the path of ``case.json``.
        Raises:
            NaseviewError: the case is not ready (:meth:`problems`), ``out_dir`` holds
                another patient's case, or the disk refused the write.
        """
        case = self.to_case()
        out = Path(out_dir)
        with self._lock:
            write_case_dir(case, out, self.owns)
            with self._edit():
                self.case_dir = out
        return out / "case.json"


__all__ = ["ANNOTATION_FILE", "ANNOTATION_FORMAT", "AnnotationSession", "default_case_id",
           "default_work_dir"]
