"""Guidance hints while a new patient is being clicked: a quick stage 1 on the clicks so far.

Once at least :data:`HINT_MIN_CLICKS` landmarks are clicked in at least two photos,
:func:`quick_stage1` runs stage 1 (:func:`naseview.stage1_landmarks.bundle_adjust`, the
bundle adjustment of paper §3.2, eq. 1) on what is there; a further photo with only
:data:`HINT_MIN_RESECTION` or more clicks is placed by PnP resection on those 3D points
(:func:`resect_camera`). The 3D landmarks are then reprojected into each photo as hints for
the remaining clicks (:meth:`Guidance.hints`), and clicks far from where the other photos
put them are reported as suspect. An mf clicked in the front photo only is asked for in
its profile photo (:func:`radix_notes`), without blocking Reconstruct.

Example
-------
>>> g = quick_stage1({"front": {}}, {"front": (800, 600)})
>>> g.message
'Hints start once 6 landmarks are clicked in two photos.'
"""

from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from naseview.camera import Camera, intrinsics
from naseview.case import Case, View
from naseview.errors import NaseviewError
from naseview.intake.click_order import CLICK_ORDER
from naseview.landmarks import ALL_VIEWS, LANDMARK_IDS
from naseview.stage1_landmarks import SfmResult, bundle_adjust

log = logging.getLogger(__name__)

HINT_MIN_CLICKS = 6
"""Landmark clicks a photo needs to enter the guidance bundle adjustment."""

HINT_MIN_RESECTION = 4
"""Clicks of reconstructed landmarks needed to place a further photo by PnP."""

Clicks = dict[str, dict[str, np.ndarray]]
"""View -> landmark id -> (2,) pixel ``[x, y]`` (SPEC §2)."""


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
        notes: further hint lines that block nothing (:func:`radix_notes`).
    """

    landmarks: dict[str, np.ndarray] = field(default_factory=dict)
    cameras: dict[str, Camera] = field(default_factory=dict)
    residuals_px: dict[str, dict[str, float]] = field(default_factory=dict)
    suspect: list[tuple[str, str, float]] = field(default_factory=list)
    message: str = ""
    revision: int = -1
    notes: list[str] = field(default_factory=list)

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


def _partial_case(lm_clicks: Clicks, views: list[str], sizes: dict[str, tuple[int, int]],
                  scale_mm: dict[tuple[str, str], float], root: str | os.PathLike[str]
                  ) -> Case:
    """The photos ``views`` with their landmark clicks as a stage-1 case (SPEC §3)."""
    seen: dict[str, list[str]] = {}
    for v in views:
        for i in lm_clicks[v]:
            seen.setdefault(i, []).append(v)
    return Case(root=Path(root), id="guidance",
                views={v: View(v, f"{v}.png", lm_clicks[v], *sizes[v]) for v in views},
                scale_mm=_guidance_scale(seen, scale_mm))


def _adjust(case: Case) -> SfmResult | Guidance:
    """Stage 1 on the partial case, or a :class:`Guidance` saying why there are no hints
    (never raises)."""
    try:
        return bundle_adjust(case)
    except NaseviewError as e:
        return Guidance(message=f"No hints yet: {plain_words(str(e))}")
    except Exception as e:  # a partial case the solver does not support: no hints
        log.debug("naseview: guidance failed: %r", e)
        return Guidance(message="No hints yet (the clicks so far cannot be reconstructed).")


def plain_words(message: str) -> str:
    """A stage-1 error in the page's words: without the file and the ``case.json`` key
    (a surgeon clicking photos has neither), photos named as the page names them.

    >>> plain_words("/w/case.json: key 'views.front.landmarks': only 5 landmark clicks in "
    ...             "photo 'front'; click at least 6")
    'only 5 landmark clicks in the front photo; click at least 6'
    """
    msg = message.split(": key ", 1)[-1]
    msg = re.sub(r"^'[^']*':\s*", "", msg)
    msg = re.sub(r"photos? '(\w+)' and '(\w+)'", r"the \1 and \2 photos", msg)
    msg = re.sub(r"photo '(\w+)'", r"the \1 photo", msg)
    msg = re.sub(r"the photos of '(\w+)' and '(\w+)'", r"the \1 and \2 photos", msg)
    msg = msg.replace(" in case.json", "").replace("case.json", "the case")
    return msg


def _place_cameras(res: SfmResult, lm_clicks: Clicks, sizes: dict[str, tuple[int, int]]
                   ) -> dict[str, Camera]:
    """The adjusted cameras plus every other photo :func:`resect_camera` can place, with
    the median focal length (relative to the photo size) of the adjusted ones."""
    cams = dict(res.cameras)
    ratios = [c.focal_px / max(c.width, c.height) for c in cams.values()]
    for v in ALL_VIEWS:
        if v in cams or v not in sizes:
            continue
        w, h = sizes[v]
        cam = resect_camera(res.landmarks, lm_clicks.get(v, {}), w, h,
                            float(np.median(ratios)) * max(w, h))
        if cam is not None:
            cams[v] = cam
    return cams


def _residuals(cams: dict[str, Camera], landmarks: dict[str, np.ndarray],
               lm_clicks: Clicks) -> dict[str, dict[str, float]]:
    """View -> id -> reprojection residual (px) of each click of a reconstructed landmark."""
    residuals: dict[str, dict[str, float]] = {}
    for v, cam in cams.items():
        ids = [i for i in lm_clicks.get(v, {}) if i in landmarks]
        if ids:
            uv = cam.project(np.array([landmarks[i] for i in ids]))
            residuals[v] = {i: float(np.linalg.norm(uv[k] - lm_clicks[v][i]))
                            for k, i in enumerate(ids)}
    return residuals


PROFILE_OF = {"mf_l": "left", "mf_r": "right"}
"""The profile photo that can show each medial orbital rim."""


def radix_notes(clicks: Clicks, sizes: dict[str, tuple[int, int]]) -> list[str]:
    """Hint lines asking for mf in a profile photo (blocking nothing): one per mf clicked
    in the front photo but not in its profile photo, once that profile photo is there and
    has at least :data:`HINT_MIN_CLICKS` clicks (the user is at work in it). Without it
    mf's depth comes from the face model and the radix height is only an estimate
    (:func:`naseview.measurements.estimated_measurements`).

    >>> radix_notes({"front": {"mf_l": (1, 2)}, "left": {i: (0, 0) for i in "abcdef"}},
    ...             {"front": (8, 8), "left": (8, 8)})[0][:60]
    'mf_l is clicked in the front photo only: click it in the lef'
    """
    out = []
    for k, v in PROFILE_OF.items():
        if (k in clicks.get("front", {}) and v in sizes and k not in clicks.get(v, {})
                and len(clicks.get(v, {})) >= HINT_MIN_CLICKS):
            out.append(f"{k} is clicked in the front photo only: click it in the {v} "
                       "profile too if the inner corner of the eye socket shows there "
                       "(skip it if hidden); otherwise the radix height is only an "
                       "estimate, uncertain by a few mm.")
    return out


def quick_stage1(clicks: Clicks, sizes: dict[str, tuple[int, int]],
                 scale_mm: dict[tuple[str, str], float] | None = None,
                 root: str | os.PathLike[str] = ".") -> Guidance:
    """Reconstruct what the clicks so far allow, for hints (never raises).

    Photos with at least :data:`HINT_MIN_CLICKS` landmark clicks go into
    :func:`naseview.stage1_landmarks.bundle_adjust` (needs two of them, ``g`` in two, a
    left/right pair in two); any other photo with at least :data:`HINT_MIN_RESECTION`
    clicks of reconstructed landmarks is placed by :func:`resect_camera` with the median
    focal length (relative to the photo size) of the adjusted photos.

    Args:
        clicks: view -> id -> (2,) px.
        sizes: view -> (width, height) px of the photos present.
        scale_mm: the user's calliper distances (used when both ends are reconstructed).
        root: folder named in messages.
    Returns:
        :class:`Guidance`; without hints its ``message`` says what is still missing; its
        ``notes`` ask for mf in a profile photo (:func:`radix_notes`).
    """
    lm_clicks = {v: {i: np.asarray(p, float) for i, p in c.items() if i in LANDMARK_IDS}
                 for v, c in clicks.items() if v in sizes}
    notes = radix_notes(lm_clicks, sizes)
    views = [v for v in ALL_VIEWS if len(lm_clicks.get(v, {})) >= HINT_MIN_CLICKS]
    if len(views) < 2:
        return Guidance(message=f"Hints start once {HINT_MIN_CLICKS} landmarks are clicked "
                                "in two photos.", notes=notes)
    res = _adjust(_partial_case(lm_clicks, views, sizes, dict(scale_mm or {}), root))
    if isinstance(res, Guidance):
        res.notes = notes
        return res
    cams = _place_cameras(res, lm_clicks, sizes)
    suspect = [(s.view, s.landmark, float(s.residual_px)) for s in res.suspect_clicks]
    msg = (f"Hints from {len(res.landmarks)} reconstructed landmarks "
           f"(reprojection RMS {res.reprojection_rmse_px:.1f} px).")
    return Guidance(dict(res.landmarks), cams, _residuals(cams, res.landmarks, lm_clicks),
                    suspect, msg, notes=notes)
