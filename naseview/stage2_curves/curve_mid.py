"""The mid-curve g-n-k-r-prn-c-sn from the silhouettes of the side photos (paper eq. 2-3).

In each of the ``left`` and ``right`` photos the background colour is taken from the
border and the subject's mask is what differs from it (eq. 2,
:mod:`~naseview.stage2_curves.mask`); the silhouette between g and sn on the anterior side
is the profile (eq. 3, or the contour, ``CurveParams.mid_trace``). It is split at the
points nearest to the landmarks, which must all lie close to it and in order, and every
piece is lifted to 3D (eq. 4-10). A segment seen in both photos is the mean of the two
liftings; one seen in neither is interpolated through its landmarks.
"""

from __future__ import annotations

import time
from itertools import pairwise

import numpy as np

from naseview.camera import Camera
from naseview.geometry.polyline import polyline_length, resample_by_count
from naseview.landmarks import CURVE_VIEWS
from naseview.stage2_curves import mask as M
from naseview.stage2_curves.cache import digest
from naseview.stage2_curves.edges import roi_around, smooth_polyline
from naseview.stage2_curves.lift import lift_to_lines
from naseview.stage2_curves.run import CurveRun, Segment

ViewSegments = tuple[dict[tuple[str, str], np.ndarray], np.ndarray]
"""(a, b) -> (n, 3) lifted segment of one photo, and its whole (N, 2) path (px)."""

_UNUSED = "this photo is not used for the mid-curve"

_MASK_FIELDS: tuple[str, ...] = ("border_px", "hue_tol", "sat_tol", "val_tol", "grey_sat",
                                 "border_min_inlier", "mask_clean_px")
_TRACE_FIELDS: tuple[str, ...] = ("border_px", "hue_tol", "sat_tol", "val_tol", "grey_sat",
                                  "mask_clean_px", "mid_trace", "silhouette_tol")


def background(run: CurveRun, view: str, roi: tuple[int, int, int, int]
               ) -> tuple[M.Background, np.ndarray]:
    """Background colour of the photo and the (H, W) bool foreground mask inside ``roi``
    (cached on the photo, the box and the mask fields)."""
    p = run.params
    key = digest(run.image_key(view), roi, p.subset(*_MASK_FIELDS))

    def compute() -> tuple[M.Background, np.ndarray]:
        img = run.image(view)
        bg = M.estimate_background(img, p.border_px, p.hue_tol, p.sat_tol, p.val_tol,
                                   p.grey_sat, p.border_min_inlier)
        return bg, M.foreground_mask(img, bg, p.mask_clean_px, roi)

    return run.cache.get("mask", key, compute)


def _usable_chain(run: CurveRun, view: str, an: dict[str, np.ndarray]) -> list[str] | None:
    """The mid-curve landmarks seen in ``view``, from g to sn; None (warned) if unusable."""
    chain = [i for i in run.landmark_chain("mid") if i in an]
    if run.cams.get(view) is None or len(chain) < 2 or chain[0] != "g" or chain[-1] != "sn":
        run.warn("mid", view, "the camera or the landmarks g and sn are missing", _UNUSED)
        return None
    return chain


def _masked(run: CurveRun, view: str, an: dict[str, np.ndarray], chain: list[str],
            span: float) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
    """The box around the profile and the foreground mask in it (kept as evidence);
    None (warned) when the photo's border is not a uniform background."""
    t0 = time.perf_counter()
    img = run.image(view)
    roi = roi_around(np.array([an[i] for i in chain]),
                     int(max(run.params.roi_margin_px, 0.25 * span)), img.shape[1],
                     img.shape[0])
    bg, mask = background(run, view, roi)
    run.timed("mask", t0)
    ev = run.res.evidence.setdefault(view, {})
    ev["background"], ev["mask"] = bg, mask
    if not bg.uniform:
        run.warn("mid", view, f"the photo's border is not a uniform background (only "
                 f"{100 * bg.inlier_fraction:.0f}% of border pixels match its colour)", _UNUSED)
        return None
    return roi, mask


def _anterior(run: CurveRun, cam: Camera, chain: list[str]) -> int:
    """+1 when the face points to the image right in this photo, -1 to the left."""
    prn = run.L3.get("prn", run.L3[chain[len(chain) // 2]])
    dx = cam.project(np.array([prn, prn - [0.0, 0.0, 30.0]]))
    return 1 if dx[0, 0] > dx[1, 0] else -1


def _profile(run: CurveRun, view: str, roi: tuple[int, int, int, int], mask: np.ndarray,
             g2: np.ndarray, sn2: np.ndarray, anterior: int, tol: float) -> np.ndarray | None:
    """(N, 2) silhouette from g to sn (eq. 3 rows or the contour), cached; None (warned)
    when it does not pass by g and sn."""
    p = run.params
    t0 = time.perf_counter()
    key = digest("mid", run.image_key(view), roi, p.subset(*_TRACE_FIELDS), g2, sn2, anterior)

    def trace() -> np.ndarray | None:
        if p.mid_trace == "rows":
            return M.profile_rows(mask, g2[1], sn2[1], anterior)
        return M.profile_contour(mask, g2, sn2, anterior, max_snap_px=3 * tol)

    path = run.cache.get("mid_trace", key, trace)
    run.timed("mid_trace", t0)
    if path is None or len(path) < 4:
        run.warn("mid", view, "the silhouette does not pass by g and sn", _UNUSED)
        return None
    return path


def _split_at_landmarks(run: CurveRun, view: str, path: np.ndarray,
                        an: dict[str, np.ndarray], chain: list[str],
                        tol: float) -> list[int] | None:
    """Index into ``path`` of each landmark of ``chain``; None (warned) when one is more
    than ``tol`` px from the silhouette or they are out of order."""
    idx = []
    for lid in chain:
        d = np.linalg.norm(path - an[lid], axis=1)
        idx.append(int(np.argmin(d)))
        if d.min() > tol:
            run.warn("mid", view, f"landmark {lid} is {d.min():.0f} px from the silhouette",
                     _UNUSED)
            return None
    idx[0], idx[-1] = 0, len(path) - 1
    if any(b <= a for a, b in pairwise(idx)):
        run.warn("mid", view, "the landmarks are not in order along the silhouette", _UNUSED)
        return None
    return idx


def _lift_pieces(run: CurveRun, cam: Camera, path: np.ndarray, chain: list[str],
                 idx: list[int]) -> ViewSegments:
    """Smooth each piece between two landmarks and lift it to 3D (eq. 4-10)."""
    p = run.params
    segs: dict[tuple[str, str], np.ndarray] = {}
    full2d: list[np.ndarray] = []
    for (a, b), (ia, ib) in zip(pairwise(chain), pairwise(idx), strict=True):
        uv = smooth_polyline(path[ia:ib + 1], p.path_smooth_px)
        full2d.append(uv if not full2d else uv[1:])
        segs[(a, b)] = lift_to_lines(uv, cam, run.L3[a], run.L3[b], p.lift_weight)
    return segs, np.vstack(full2d)


def mid_from_view(run: CurveRun, view: str) -> ViewSegments | None:
    """3D segments of the mid-curve seen in one side photo, and its 2D path; None (with a
    warning naming the photo) when the photo cannot be used."""
    an = run.anchors(view)
    chain = _usable_chain(run, view, an)
    if chain is None:
        return None
    cam = run.cams[view]
    g2, sn2 = an[chain[0]], an[chain[-1]]
    span = float(np.linalg.norm(sn2 - g2))
    tol = run.params.silhouette_tol * span
    masked = _masked(run, view, an, chain, span)
    if masked is None:
        return None
    roi, mask = masked
    path = _profile(run, view, roi, mask, g2, sn2, _anterior(run, cam, chain), tol)
    if path is None:
        return None
    idx = _split_at_landmarks(run, view, path, an, chain, tol)
    if idx is None:
        return None
    return _lift_pieces(run, cam, path, chain, idx)


def _mean_segment(Ps: list[np.ndarray], spacing: float) -> np.ndarray:
    """Pointwise mean of the liftings of one segment from several photos, each resampled
    to the same count (the longest at most ``spacing`` mm apart)."""
    n = max(2, int(np.ceil(max(polyline_length(P) for P in Ps) / spacing)) + 1)
    return np.asarray(np.mean([resample_by_count(P, n) for P in Ps], axis=0))


def mid_curve(run: CurveRun) -> None:
    """Make the mid-curve from both side photos (fallback where neither serves)."""
    if run.left_out("mid"):
        return
    chain = run.landmark_chain("mid")
    per_view: dict[str, ViewSegments] = {}
    for view in CURVE_VIEWS["mid"]:
        if view not in run.case.views:
            continue
        out = mid_from_view(run, view)
        if out is not None:
            per_view[view] = out
    fb = run.fallback_segments("mid")
    segments: list[Segment] = []
    ok = 0
    for a, b in pairwise(chain):
        Ps = [segs[(a, b)] for segs, _ in per_view.values() if (a, b) in segs]
        if Ps:
            segments.append((a, b, _mean_segment(Ps, run.params.curve_spacing_mm)))
            ok += 1
        else:
            segments.append((a, b, fb[(a, b)]))
    run.finish_open("mid", segments, {v: o[1] for v, o in per_view.items()}, ok_segments=ok)
