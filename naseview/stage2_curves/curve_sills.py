"""The nasal sills from the dark nostrils of the bottom photo (paper eq. 13-14).

The border of the dark region next to al'' (:func:`~naseview.stage2_curves.nostrils.
nostril_contour`) is smoothed as a loop and lifted onto the sill plane through al''
(normal perpendicular to md-c and parallel to Oxy,
:func:`~naseview.stage2_curves.nostrils.sill_plane`). Where no plausible nostril is seen
(none, too large, or the plane seen edge-on) the sill is an ellipse in that plane
(:func:`~naseview.stage2_curves.fallback.sill_ellipse`, warning, flag ``"fallback"``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping

import numpy as np

from naseview.camera import Camera
from naseview.geometry.polyline import polyline_length, resample_by_count
from naseview.landmarks import CURVE_LANDMARKS, CURVE_VIEWS
from naseview.stage2_curves import nostrils as N
from naseview.stage2_curves.cache import digest
from naseview.stage2_curves.edges import roi_around
from naseview.stage2_curves.fallback import sill_ellipse
from naseview.stage2_curves.lift import lift_to_plane
from naseview.stage2_curves.run import CurveRun

_NOSTRIL_FIELDS: tuple[str, ...] = ("dark_ratio", "dark_threshold", "closing_px",
                                    "nostril_min_area_px", "nostril_search_frac")
_ROI_IDS: tuple[str, ...] = CURVE_LANDMARKS["bottom"] + ("alpp_l", "alpp_r", "sn", "c")
"""Clicks whose box (plus ``roi_margin_px``) bounds the nostril search."""


def smooth_loop(P: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing (``sigma`` in points) of a closed (N, D) loop; short loops
    (N < 8) and ``sigma <= 0`` unchanged."""
    if sigma <= 0 or len(P) < 8:
        return P
    k = int(np.ceil(3 * sigma))
    x = np.arange(-k, k + 1)
    g = np.exp(-0.5 * (x / sigma) ** 2)
    g /= g.sum()
    ext = np.vstack([P[-k:], P, P[:k]])
    return np.stack([np.convolve(ext[:, j], g, mode="valid") for j in range(P.shape[1])], 1)


def resample_loop(P: np.ndarray, spacing: float) -> np.ndarray:
    """A closed (N, D) loop resampled to at least 8 points at most ``spacing`` apart
    (first point kept, not repeated)."""
    Q = np.vstack([P, P[:1]])
    n = max(8, int(np.ceil(polyline_length(Q) / spacing)))
    return resample_by_count(Q, n + 1)[:-1]


def sill_scale(an: Mapping[str, np.ndarray]) -> float:
    """Expected nostril size in the bottom photo (px): al''-al'' distance, else half of
    al-al or al'-al', else 50."""
    for a, b in (("alpp_l", "alpp_r"), ("al_l", "al_r"), ("alp_l", "alp_r")):
        if a in an and b in an:
            d = float(np.linalg.norm(an[a] - an[b]))
            return d if a.startswith("alpp") else 0.5 * d
    return 50.0


def _plane(run: CurveRun, side: str) -> tuple[np.ndarray, np.ndarray]:
    """Point (3,) and unit normal (3,) of the sill plane; horizontal (normal +y) through
    al'' when md or c is missing."""
    alpp, md, c = f"alpp_{side}", f"md_{side}", "c"
    if md in run.L3 and c in run.L3:
        return N.sill_plane(run.L3[alpp], run.L3[md], run.L3[c])
    return run.L3[alpp].copy(), np.array([0.0, 1.0, 0.0])


def _detect(run: CurveRun, view: str, an: Mapping[str, np.ndarray], alpp: str,
            ref: float) -> np.ndarray | None:
    """(N, 2) nostril border next to al'' in the photo (cached), or None; the dark
    threshold used is kept as evidence."""
    p = run.params
    img = run.image(view)
    roi = roi_around(np.array([an[i] for i in _ROI_IDS if i in an]), p.roi_margin_px,
                     img.shape[1], img.shape[0])
    key = digest(run.image_key(view), roi, an[alpp], ref, p.subset(*_NOSTRIL_FIELDS))

    def compute() -> tuple[np.ndarray | None, float]:
        thr = p.dark_threshold if p.dark_threshold is not None else \
            N.auto_dark_threshold(img, roi, p.dark_ratio)
        loop = N.nostril_contour(img, an[alpp], thr, p.closing_px,
                                 p.nostril_search_frac * ref, p.nostril_min_area_px, roi)
        return loop, thr

    loop2d, thr = run.cache.get("nostril", key, compute)
    run.res.evidence.setdefault(view, {})["nostril_threshold"] = thr
    return loop2d


def _implausible(loop2d: np.ndarray, ref: float, cam: Camera,
                 normal: np.ndarray) -> str | None:
    """Why a detected loop is not taken (too large, plane seen edge-on), or None."""
    ext = np.ptp(loop2d, axis=0).max()
    if ext > 1.5 * ref:
        return f"the dark region next to al'' is {ext:.0f} px wide, too large for a nostril"
    if np.abs(cam.rays(loop2d)[1] @ normal).min() < 0.15:
        return "the sill plane is seen almost edge-on from this photo"
    return None


def _nostril(run: CurveRun, view: str, cam: Camera | None, alpp: str,
             normal: np.ndarray) -> tuple[np.ndarray | None, str]:
    """The plausible (N, 2) nostril border in the photo, or None and the reason."""
    an = run.anchors(view)
    if cam is None or alpp not in an:
        return None, "no camera or no al'' in this photo"
    t0 = time.perf_counter()
    ref = sill_scale(an)
    loop2d = _detect(run, view, an, alpp, ref)
    reason: str | None = "the nostril is not visible (no dark region next to al'')"
    if loop2d is not None:
        reason = _implausible(loop2d, ref, cam, normal)
        if reason is not None:
            loop2d = None
    run.timed("nostrils", t0)
    return loop2d, reason or ""


def _ellipse(run: CurveRun, curve: str, view: str, cam: Camera | None, point: np.ndarray,
             normal: np.ndarray, reason: str) -> np.ndarray:
    """The fallback sill (warned): an ellipse in the plane from al'' across the nostril."""
    side = curve[-1]
    run.warn(curve, view, reason, "the sill is an ellipse in the sill plane")
    across = run.L3.get(f"md_{side}", run.L3.get(f"alp_{side}", point + [0.0, 0.0, 8.0]))
    P = resample_loop(sill_ellipse(point, across, normal), run.params.curve_spacing_mm)
    run.res.flags[curve] = "fallback"
    if cam is not None:
        run.res.curves_2d[curve] = {view: cam.project(P)}
    return P


def _lifted(run: CurveRun, curve: str, view: str, cam: Camera, loop2d: np.ndarray,
            point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The sill from the photo: the smoothed loop on the plane, starting next to al''."""
    side = curve[-1]
    loop2d = smooth_loop(loop2d, run.params.path_smooth_px)
    P = lift_to_plane(loop2d, cam, point, normal)
    P = resample_loop(P, run.params.curve_spacing_mm)
    P = np.roll(P, -int(np.argmin(np.linalg.norm(P - point, axis=1))), axis=0)
    run.res.flags[curve] = "estimated" if {f"md_{side}", f"alpp_{side}"} & run.estimated \
        else "image"
    run.res.curves_2d[curve] = {view: loop2d}
    return P


def sill(run: CurveRun, curve: str) -> None:
    """Make ``sill_l`` or ``sill_r`` (a closed loop starting at al'')."""
    view = CURVE_VIEWS[curve][0]
    alpp = f"alpp_{curve[-1]}"
    if alpp not in run.L3:
        run.res.warnings.append(f"{curve}: landmark {alpp} was not reconstructed; "
                                "the curve is left out")
        run.res.flags[curve] = "missing"
        return
    point, normal = _plane(run, curve[-1])
    cam = run.cams.get(view)
    loop2d, reason = _nostril(run, view, cam, alpp, normal)
    if loop2d is None or cam is None:
        P = _ellipse(run, curve, view, cam, point, normal, reason)
    else:
        P = _lifted(run, curve, view, cam, loop2d, point, normal)
    run.res.curves[curve] = P
    run.res.anchors[curve] = [(alpp, 0)]
