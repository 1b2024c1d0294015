"""A new patient: photo intake and the guided landmark-click session (no viser).

:class:`AnnotationSession` is everything the browser page needs to turn four photos into a
case directory (SPEC §3), written so that it can be tested without a browser:

- **Photo intake** (:func:`decode_photo`): JPEG/PNG bytes -> (H, W, 3) uint8 BGR with the
  EXIF orientation applied (OpenCV ``IMREAD_COLOR`` does that), longest side capped at
  :data:`MAX_SIDE_PX` (clicks are in the pixels of the *stored* photo), then re-encoded
  from the pixels only (:func:`encode_photo`), so no EXIF, GPS, maker notes, text chunks
  or ICC profile reach the disk. Anything else gets one line saying what to do.
- **Click order** (:data:`CLICK_ORDER`, :data:`VIEW_ORDER`): per photo, the landmarks in
  the order they lie along the paper's boundary curves, so the hand moves little.
- **Editing**: place / move / skip / undo; one undo entry per action (a drag is one move).
- **Autosave**: after every change ``annotation.json`` is rewritten atomically in the
  in-progress folder (photos are written once, at intake); :meth:`AnnotationSession.open`
  resumes it after a reload or a server restart, undo history included.
- **Guidance** (:func:`quick_stage1`): once at least 6 landmarks are clicked in at least
  two photos, a quick stage 1 (:func:`naseview.stage1_landmarks.solve`) reconstructs what is
  there and the 3D landmarks are reprojected into each photo as hints for the remaining
  clicks (a photo with only 4-5 clicks is placed by PnP resection on those 3D points).
- **Output**: :meth:`AnnotationSession.write_case` writes the SPEC §3 case directory with
  :func:`naseview.case.write_case`, ready for ``naseview reconstruct``.

Click order and why
-------------------
Photos: ``front``, ``bottom``, ``left``, ``right`` (:data:`VIEW_ORDER`). The bottom photo
comes second because stage 1 fixes its 3D frame with a left/right pair and ``g`` seen in
two photos each: after front + bottom the pairs are there, and the sixth click in the
left photo (``g n k r prn c``) already brings ``g`` into a second photo, so the remaining
8 left clicks and most right clicks are shown with a reprojected hint.

Within a photo (subject's right = image left in the front and bottom photos):

- ``front``: down the mid-curve ``g n k r prn c sn``; round the lobule from the subject's
  right to left along the nostril / C-curve (``alpp_r md_r alp_r`` then ``alp_l md_l
  alpp_l``); then one loop over the sides: up the left ala-curve (``ac_l al_l int_l``) and
  side-curve (``mf_l``), across the nasal root (``mf_r``) and down the right side-curve and
  ala-curve (``int_r al_r ac_r``).
- ``left`` / ``right``: the profile (mid-curve) ``g n k r prn c sn``, then that side's
  lobule points next to ``sn`` (``alpp md alp``), then the ala-curve backwards and the
  side-curve up (``ac al int mf``).
- ``bottom``: the bottom curve from end to end (``ac_r al_r alp_r add_r prn add_l alp_l
  al_l ac_l``, with the ``add`` helpers between ``al'`` and ``prn`` where SPEC §5 puts
  them), then back through the inside of the base: ``alpp_l md_l c md_r alpp_r sn``.

Every landmark can be skipped where it is not visible (a profile hides the far side).

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
import logging
import math
import os
import re
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera
from naseview.case import Case, View, parse_scale_key
from naseview.case import write_case as _write_case
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, atomic_write_json, read_image, read_json
from naseview.landmarks import ALL_IDS, HELPER_IDS, LANDMARK_IDS, LANDMARKS, VIEWS

log = logging.getLogger(__name__)

ANNOTATION_FORMAT = "naseview.annotation/1"
ANNOTATION_FILE = "annotation.json"

MAX_SIDE_PX = 2048
"""Photos whose longest side exceeds this are downscaled to it at intake (px)."""

MIN_SIDE_PX = 64
"""Smaller photos are refused: no landmark can be placed on them reliably."""

MAX_UPLOAD_BYTES = 60 * 1024 * 1024
"""Larger uploads are refused before decoding."""

JPEG_QUALITY = 95
"""Quality of re-encoded JPEG photos (PNG uploads stay PNG, lossless)."""

HINT_MIN_CLICKS = 6
"""Landmark clicks a photo needs to enter the guidance bundle adjustment."""

HINT_MIN_RESECTION = 4
"""Clicks of reconstructed landmarks needed to place a further photo by PnP."""

VIEW_ORDER: tuple[str, ...] = ("front", "bottom", "left", "right")
"""Guided order of the photos (see the module docstring for why bottom is second)."""

CLICK_ORDER: dict[str, tuple[str, ...]] = {
    "front": ("g", "n", "k", "r", "prn", "c", "sn",
              "alpp_r", "md_r", "alp_r", "alp_l", "md_l", "alpp_l",
              "ac_l", "al_l", "int_l", "mf_l", "mf_r", "int_r", "al_r", "ac_r"),
    "bottom": ("ac_r", "al_r", "alp_r", "add_r", "prn", "add_l", "alp_l", "al_l", "ac_l",
               "alpp_l", "md_l", "c", "md_r", "alpp_r", "sn"),
    "left": ("g", "n", "k", "r", "prn", "c", "sn",
             "alpp_l", "md_l", "alp_l", "ac_l", "al_l", "int_l", "mf_l"),
    "right": ("g", "n", "k", "r", "prn", "c", "sn",
              "alpp_r", "md_r", "alp_r", "ac_r", "al_r", "int_r", "mf_r"),
}
"""Per photo, the landmarks asked for, in click order (module docstring)."""

VIEW_TITLES: dict[str, str] = {
    "front": "Front photo", "bottom": "Bottom (basal) photo",
    "left": "Left profile (camera on the subject's left)",
    "right": "Right profile (camera on the subject's right)",
}


def _check_tables() -> None:
    for v, ids in CLICK_ORDER.items():
        assert v in VIEWS and len(set(ids)) == len(ids), v
        assert all(i in ALL_IDS for i in ids), v
    assert set(VIEW_ORDER) == set(VIEWS)
    asked = {i for ids in CLICK_ORDER.values() for i in ids}
    assert asked == set(ALL_IDS), set(ALL_IDS) - asked


_check_tables()


def describe(landmark_id: str, view: str | None = None) -> str:
    """One line for the page: paper name, SPEC id, soft-tissue definition and, for the
    front and bottom photos, on which side of the image a left/right landmark lies."""
    lm = LANDMARKS[landmark_id]
    text = f"{lm.paper} ({lm.id}): {lm.description}"
    if view in ("front", "bottom") and lm.side in ("l", "r"):
        text += "; image " + ("right" if lm.side == "l" else "left") + " side"
    if lm.helper:
        text += "; 2D helper, halfway along the outline"
    return text


# ----------------------------------------------------------------------------- photos
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
        NaseviewError: empty, too large, not a JPEG/PNG (HEIC gets its own hint), or
            unreadable.
    """
    import cv2

    if not data:
        raise NaseviewError(f"{name}: the file is empty; choose the JPEG or PNG photo again")
    if len(data) > MAX_UPLOAD_BYTES:
        raise NaseviewError(f"{name}: {len(data) / 2**20:.0f} MB is too large (limit "
                            f"{MAX_UPLOAD_BYTES // 2**20} MB); export the photo as JPEG")
    kind = photo_kind(data)
    if kind == "heic":
        raise NaseviewError(f"{name}: HEIC/HEIF photos cannot be read; export it as JPEG "
                            "(on an iPhone: Settings > Camera > Formats > Most Compatible)")
    if kind not in ("jpeg", "png"):
        raise NaseviewError(f"{name}: not a JPEG or PNG image; choose the photo file "
                            "(.jpg or .png)")
    img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if img is None or img.ndim != 3:
        raise NaseviewError(f"{name}: the {kind.upper()} file is damaged or truncated; "
                            "copy the photo again from the camera")
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
    import cv2

    if kind == "png":
        ok, buf = cv2.imencode(".png", image)
    else:
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise NaseviewError("could not encode the photo")
    return buf.tobytes()


# ----------------------------------------------------------------------------- guidance
@dataclass
class Guidance:
    """Result of the quick stage 1 on the clicks so far.

    Attributes:
        landmarks: id -> (3,) reconstructed position (SPEC frame; mm only if the scale
            distance was usable, otherwise an arbitrary scale).
        cameras: view -> camera, for every photo that could be placed.
        residuals_px: view -> id -> reprojection residual of each click.
        suspect: (view, id, residual px) of clicks far from where the others put them.
        message: one line for the page (why there are no hints yet, or the RMS).
        revision: the session revision it was computed for.
    """

    landmarks: dict[str, np.ndarray] = field(default_factory=dict)
    cameras: dict[str, Camera] = field(default_factory=dict)
    residuals_px: dict[str, dict[str, float]] = field(default_factory=dict)
    suspect: list[tuple[str, str, float]] = field(default_factory=list)
    message: str = ""
    revision: int = -1

    def hints(self, view: str, clicked: set[str] | None = None) -> dict[str, np.ndarray]:
        """Reprojection into ``view`` of the reconstructed landmarks asked for there that
        are not in ``clicked``: id -> (2,) px (only points in front of the camera)."""
        cam = self.cameras.get(view)
        if cam is None:
            return {}
        ids = [i for i in CLICK_ORDER[view] if i in self.landmarks
               and (clicked is None or i not in clicked)]
        if not ids:
            return {}
        X = np.array([self.landmarks[i] for i in ids])
        ok = cam.depth(X) > 0
        uv = cam.project(X)
        inside = ((uv[:, 0] >= -0.5) & (uv[:, 0] <= cam.width - 0.5)
                  & (uv[:, 1] >= -0.5) & (uv[:, 1] <= cam.height - 0.5))
        return {i: uv[k] for k, i in enumerate(ids) if ok[k] and inside[k]}


def _guidance_scale(seen: dict[str, list[str]], scale_mm: dict[tuple[str, str], float]
                    ) -> dict[tuple[str, str], float]:
    """A scale distance usable by stage 1 on a partial case: the user's if both ends are
    in two photos, otherwise a nominal one (hints do not depend on the scale)."""
    two = {i for i, vs in seen.items() if len(vs) >= 2}
    usable = {k: d for k, d in scale_mm.items() if k[0] in two and k[1] in two}
    if usable:
        return usable
    for a, b, d in (("al_l", "al_r", 34.0), ("g", "sn", 60.0), ("n", "prn", 45.0),
                    ("g", "prn", 50.0)):
        if a in two and b in two:
            return {(a, b): d}
    return dict(scale_mm) or {("al_l", "al_r"): 34.0}


def resect_camera(points: dict[str, np.ndarray], clicks: dict[str, np.ndarray],
                  width: int, height: int, focal_px: float) -> Camera | None:
    """Place one photo by PnP on already reconstructed landmarks.

    Args:
        points: id -> (3,) reconstructed positions.
        clicks: id -> (2,) px clicks in this photo.
        width, height: photo size (px).
        focal_px: focal length to assume (px), e.g. from the other photos of the phone.
    Returns:
        the camera, or ``None`` with fewer than :data:`HINT_MIN_RESECTION` shared points,
        a failed PnP or a reprojection RMS above 2 % of the photo size.
    """
    import cv2

    from naseview.camera import intrinsics

    ids = [i for i in clicks if i in points]
    if len(ids) < HINT_MIN_RESECTION:
        return None
    X = np.array([points[i] for i in ids], dtype=np.float64)
    uv = np.array([clicks[i] for i in ids], dtype=np.float64)
    K = intrinsics(focal_px, width, height)
    try:
        ok, rvec, tvec = cv2.solvePnP(X, uv, K, None, flags=cv2.SOLVEPNP_SQPNP)
        if ok and len(ids) >= 6:
            ok, rvec, tvec = cv2.solvePnP(X, uv, K, None, rvec, tvec, useExtrinsicGuess=True,
                                          flags=cv2.SOLVEPNP_ITERATIVE)
    except cv2.error:
        return None
    if not ok or not np.all(np.isfinite(tvec)):
        return None
    R, _ = cv2.Rodrigues(rvec)
    cam = Camera(K, R, tvec.ravel(), int(width), int(height))
    if np.any(cam.depth(X) <= 0):
        return None
    rms = float(np.sqrt(np.mean(np.sum((cam.project(X) - uv) ** 2, axis=1))))
    if rms > 0.02 * max(width, height):
        return None
    return cam


def quick_stage1(clicks: dict[str, dict[str, np.ndarray]],
                 sizes: dict[str, tuple[int, int]],
                 scale_mm: dict[tuple[str, str], float] | None = None,
                 root: str | os.PathLike[str] = ".") -> Guidance:
    """Reconstruct what the clicks so far allow, for hints (never raises).

    Photos with at least :data:`HINT_MIN_CLICKS` landmark clicks go into
    :func:`naseview.stage1_landmarks.solve` (needs two of them, ``g`` in two, a left/right
    pair in two); any other photo with at least :data:`HINT_MIN_RESECTION` clicks of
    reconstructed landmarks is placed by :func:`resect_camera` with the median focal
    length (relative to the photo size) of the adjusted photos.

    Args:
        clicks: view -> id -> (2,) px.
        sizes: view -> (width, height) px of the photos present.
        scale_mm: the user's calliper distances (used when both ends are reconstructed).
        root: folder named in messages.
    Returns:
        :class:`Guidance`; without hints its ``message`` says what is still missing.
    """
    from naseview.stage1_landmarks.solve import bundle_adjust

    lm_clicks = {v: {i: np.asarray(p, float) for i, p in c.items() if i in LANDMARK_IDS}
                 for v, c in clicks.items() if v in sizes}
    views = [v for v in VIEWS if len(lm_clicks.get(v, {})) >= HINT_MIN_CLICKS]
    if len(views) < 2:
        return Guidance(message=f"Hints start once {HINT_MIN_CLICKS} landmarks are clicked "
                                "in two photos.")
    seen: dict[str, list[str]] = {}
    for v in views:
        for i in lm_clicks[v]:
            seen.setdefault(i, []).append(v)
    case = Case(root=Path(root), id="guidance",
                views={v: View(v, f"{v}.png", lm_clicks[v], *sizes[v]) for v in views},
                scale_mm=_guidance_scale(seen, dict(scale_mm or {})))
    try:
        res = bundle_adjust(case)
    except NaseviewError as e:
        msg = str(e).split(": key ", 1)[-1]
        return Guidance(message=f"No hints yet: {msg}")
    except Exception as e:  # a partial case the solver does not support: no hints
        log.debug("naseview: guidance failed: %r", e)
        return Guidance(message="No hints yet (the clicks so far cannot be reconstructed).")
    cams = dict(res.cameras)
    ratios = [c.focal_px / max(c.width, c.height) for c in cams.values()]
    for v in VIEWS:
        if v in cams or v not in sizes:
            continue
        w, h = sizes[v]
        cam = resect_camera(res.landmarks, lm_clicks.get(v, {}), w, h,
                            float(np.median(ratios)) * max(w, h))
        if cam is not None:
            cams[v] = cam
    residuals: dict[str, dict[str, float]] = {}
    for v, cam in cams.items():
        ids = [i for i in lm_clicks.get(v, {}) if i in res.landmarks]
        if ids:
            uv = cam.project(np.array([res.landmarks[i] for i in ids]))
            residuals[v] = {i: float(np.linalg.norm(uv[k] - lm_clicks[v][i]))
                            for k, i in enumerate(ids)}
    suspect = [(s.view, s.landmark, float(s.residual_px)) for s in res.suspect_clicks]
    msg = (f"Hints from {len(res.landmarks)} reconstructed landmarks "
           f"(reprojection RMS {res.reprojection_rmse_px:.1f} px).")
    return Guidance(dict(res.landmarks), cams, residuals, suspect, msg)


# ----------------------------------------------------------------------------- session
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

    # ------------------------------------------------------------------ lifecycle
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
            for v, p in obj.get("photos", {}).items():
                if v not in VIEWS:
                    continue
                info = PhotoInfo.from_json(p)
                if not (folder / info.file).is_file():
                    raise NaseviewError(f"{folder / info.file}: photo of view {v!r} is "
                                        "missing; upload that photo again")
                s.photos[v] = info
            for v, c in obj.get("clicks", {}).items():
                if v in VIEWS:
                    s.clicks[v] = {i: np.array(xy, dtype=np.float64).reshape(2)
                                   for i, xy in c.items() if i in ALL_IDS}
            for v, ids in obj.get("skipped", {}).items():
                if v in VIEWS:
                    s.skipped[v] = {i for i in ids if i in ALL_IDS}
            for key, d in obj.get("scale_mm", {}).items():
                pair = parse_scale_key(key)
                if pair is not None:
                    s.scale_mm[pair] = float(d)
            s.notes = str(obj.get("notes", ""))
            av = obj.get("active_view")
            s.active_view = av if av in VIEWS else VIEW_ORDER[0]
            s.case_dir = Path(obj["case_dir"]) if obj.get("case_dir") else None
            s.created = str(obj.get("created", s.created))
            s.updated = str(obj.get("updated", s.updated))
            s.revision = int(obj.get("revision", 0))
            s.stats.update(obj.get("stats", {}))
            s._undo = [_Undo(u["view"], u["landmark"], u["before"], bool(u["skipped_before"]),
                             u["action"]) for u in obj.get("undo", [])]
        except (KeyError, TypeError, ValueError) as e:
            raise NaseviewError(f"{path}: malformed annotation ({type(e).__name__}: {e}); "
                                "start the patient again") from None
        return s

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

    # ------------------------------------------------------------------ photos
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

    # ------------------------------------------------------------------ clicks
    def _check_view(self, view: str) -> None:
        if view not in VIEWS:
            raise NaseviewError(f"unknown view {view!r}; expected one of {', '.join(VIEWS)}")

    def _check_click(self, view: str, landmark: str, xy: ArrayLike) -> np.ndarray:
        self._check_view(view)
        if landmark not in CLICK_ORDER[view]:
            raise NaseviewError(f"landmark {landmark!r} is not marked in the {view} photo; "
                                f"it is asked for in: " + ", ".join(
                                    v for v in VIEW_ORDER if landmark in CLICK_ORDER[v]))
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
        if landmark not in CLICK_ORDER[view]:
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

    # ------------------------------------------------------------------ progress
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

    # ------------------------------------------------------------------ scale and notes
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

    def set_notes(self, notes: str) -> None:
        with self._lock:
            if notes != self.notes:
                self.notes = notes
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

    # ------------------------------------------------------------------ guidance
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

    # ------------------------------------------------------------------ output
    def problems(self) -> list[str]:
        """What still prevents reconstruction, one line each (empty = ready)."""
        out = [f"the {v} photo is missing; upload it" for v in VIEW_ORDER
               if v not in self.photos]
        if not self.scale_mm:
            out.append("enter the measured alar width al_l-al_r (calliper, mm)")
        for v in VIEW_ORDER:
            if v not in self.photos:
                continue
            n = sum(1 for i in self.clicks[v] if i in LANDMARK_IDS)
            if n < HINT_MIN_CLICKS:
                out.append(f"the {v} photo has {n} landmark clicks; at least "
                           f"{HINT_MIN_CLICKS} are needed")
        seen_g = [v for v in VIEWS if "g" in self.clicks[v]]
        if len(seen_g) < 2 and not [p for p in out if "photo is missing" in p]:
            out.append("click glabella g in at least two photos (front and a profile)")
        for (a, b) in self.scale_mm:
            for i in (a, b):
                if not any(i in self.clicks[v] for v in VIEWS):
                    out.append(f"the distance {a}-{b} needs {i} clicked")
        return out

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

    def summary(self) -> dict[str, Any]:
        """Counts for the page: clicks, skips, helpers and time between first and last
        click (s)."""
        n = sum(len(c) for c in self.clicks.values())
        t0, t1 = self.stats.get("first_click"), self.stats.get("last_click")
        secs = None
        if t0 and t1:
            secs = (_dt.datetime.fromisoformat(t1) - _dt.datetime.fromisoformat(t0)
                    ).total_seconds()
        return {"clicks": n, "helpers": sum(1 for c in self.clicks.values()
                                            for i in c if i in HELPER_IDS),
                "skipped": sum(len(s) for s in self.skipped.values()),
                "places": self.stats["places"], "moves": self.stats["moves"],
                "undos": self.stats["undos"], "seconds": secs}


def list_in_progress(root: str | os.PathLike[str]) -> list[tuple[Path, dict[str, Any]]]:
    """Unfinished annotations under ``root`` (folders holding ``annotation.json``), newest
    first, as (folder, parsed json); unreadable ones are left out."""
    root = Path(root)
    out = []
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


__all__ = ["ANNOTATION_FORMAT", "AnnotationSession", "CLICK_ORDER", "Guidance",
           "MAX_SIDE_PX", "PhotoInfo", "VIEW_ORDER", "decode_photo", "default_case_id",
           "default_work_dir",
           "describe", "encode_photo", "list_in_progress", "photo_kind", "quick_stage1",
           "resect_camera"]
