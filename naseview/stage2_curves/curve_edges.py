"""The bottom-, ala- and C-curves along image edges (paper eq. 11-12).

In the curve's photo (``bottom`` for the bottom-curve, ``front`` for the others) the
Scharr edge strength of the nose region is computed once
(:func:`~naseview.stage2_curves.edges.edge_map`); between every two consecutive clicks
(helpers ``add_*`` included) a least-cost path follows the edge, optionally kept near the
smooth curve through the clicks (``CurveParams.path_prior_weight``). A path whose mean
edge strength is too low is not trusted. The pieces between two 3D landmarks are smoothed
and lifted (eq. 4-10); a segment without a trusted path is interpolated through its
landmarks (warning, flag ``"partial"`` or ``"fallback"``).
"""

from __future__ import annotations

import time
from itertools import pairwise

import cv2
import numpy as np

from naseview.camera import Camera
from naseview.landmarks import CURVE_LANDMARKS, CURVE_VIEWS, HELPER_IDS
from naseview.stage2_curves import edges as E
from naseview.stage2_curves.cache import digest
from naseview.stage2_curves.fallback import catmull_rom_segments
from naseview.stage2_curves.lift import lift_to_lines
from naseview.stage2_curves.run import CurveRun, Segment

EDGE_CURVES: tuple[str, ...] = ("bottom", "ala_l", "ala_r", "c")
"""Curves found by Scharr edges and least-cost paths (eq. 11-12)."""

Prior = tuple[str, np.ndarray | None]
"""Cache key and (h, w) squared distance (px^2) to the prior curve, or None (no prior)."""

_EDGE_FIELDS: tuple[str, ...] = ("edge_blur_sigma", "edge_ref_percentile")
_PATH_FIELDS: tuple[str, ...] = ("path_cost_exponent", "path_cost_floor", "corridor_px",
                                 "corridor_frac", "path_prior_weight")
_INTERPOLATED = "the segment {a}-{b} is interpolated through its landmarks"


def edge_map(run: CurveRun, view: str) -> E.EdgeMap:
    """Edge strength around the landmarks of every edge curve of ``view`` (cached)."""
    p = run.params
    an = run.anchors(view)
    img = run.image(view)
    ids = sorted({i for c in EDGE_CURVES if view in CURVE_VIEWS[c]
                  for i in CURVE_LANDMARKS[c] if i in an})
    roi = E.roi_around(np.array([an[i] for i in ids]), p.roi_margin_px, img.shape[1],
                       img.shape[0])
    key = digest(run.image_key(view), roi, p.subset(*_EDGE_FIELDS))
    em = run.cache.get("edges", key, lambda: E.edge_map(
        img, roi, p.edge_blur_sigma, p.edge_ref_percentile))
    run.res.evidence.setdefault(view, {})["edges"] = em
    return em


def prior_penalty(run: CurveRun, em: E.EdgeMap, anchors: np.ndarray) -> Prior:
    """Squared distance (px^2) to the Catmull-Rom curve through a curve's (K, 2) anchors
    over the edge region (cached), with its cache key; None when the prior is off."""
    key = digest(em.origin, em.strength.shape, anchors)
    if run.params.path_prior_weight <= 0 or len(anchors) < 2:
        return key, None

    def compute() -> np.ndarray:
        o = np.array(em.origin, dtype=np.float64)
        segs = catmull_rom_segments(anchors - o, 24)
        canvas = np.ones(em.strength.shape, np.uint8)
        pts = np.round(np.vstack(segs)).astype(np.int32)
        cv2.polylines(canvas, [pts], False, 0, 1)
        D = cv2.distanceTransform(canvas, cv2.DIST_L2, 5)
        return (D * D).astype(np.float64)

    return key, run.cache.get("prior", key, compute)


def _too_faint(run: CurveRun, em: E.EdgeMap, ekey: str, path: np.ndarray) -> bool:
    """Mean edge strength along the (N, 2) photo path below ``path_min_contrast`` times
    the median strength of the region (no edge to follow)."""
    o = np.array(em.origin, dtype=np.float64)
    ij = np.round(path - o).astype(int)
    h, w = em.strength.shape
    ij[:, 0] = np.clip(ij[:, 0], 0, w - 1)
    ij[:, 1] = np.clip(ij[:, 1], 0, h - 1)
    floor = run.cache.get("edge_median", ekey, lambda: float(np.median(em.strength[::2, ::2])))
    return float(em.strength[ij[:, 1], ij[:, 0]].mean()) < run.params.path_min_contrast * floor


def edge_path(run: CurveRun, view: str, em: E.EdgeMap, start: np.ndarray, end: np.ndarray,
              prior: Prior) -> np.ndarray | None:
    """(N, 2) least-cost path from ``start`` to ``end`` in photo px (cached), or None
    when there is none or it is not trusted."""
    p = run.params
    o = np.array(em.origin, dtype=np.float64)
    corridor = max(p.corridor_px, p.corridor_frac * float(np.linalg.norm(end - start)))
    ekey = digest(em.origin, em.strength.shape, run.image_key(view), p.subset(*_EDGE_FIELDS))
    key = digest(ekey, start, end, prior[0], p.subset(*_PATH_FIELDS))

    def compute() -> np.ndarray | None:
        cost = run.cache.get("cost", digest(ekey, p.subset(*_PATH_FIELDS[:2])),
                             lambda: E.edge_cost(em.strength, p.path_cost_exponent,
                                                 p.path_cost_floor))
        path = E.least_cost_path(cost, start - o, end - o, corridor, prior[1],
                                 p.path_prior_weight / corridor ** 2)
        return None if path is None else path + o

    path = run.cache.get("path", key, compute)
    if path is None or _too_faint(run, em, ekey, path):
        return None
    return path


def _segment_uv(run: CurveRun, curve: str, view: str, em: E.EdgeMap,
                an: dict[str, np.ndarray], stops: list[str], prior: Prior,
                a: str, b: str) -> np.ndarray | None:
    """(N, 2) smoothed path through the clicks ``stops`` from landmark a to b; None
    (warned) when one piece has no trusted edge."""
    parts: list[np.ndarray] = []
    for s, e in pairwise(stops):
        path = edge_path(run, view, em, an[s], an[e], prior)
        if path is None:
            run.warn(curve, view, f"no edge found between {s} and {e}",
                     _INTERPOLATED.format(a=a, b=b))
            return None
        parts.append(path if not parts else path[1:])
    return E.smooth_polyline(np.vstack(parts), run.params.path_smooth_px)


def _all_interpolated(run: CurveRun, curve: str, view: str) -> None:
    """No camera for the photo: the whole curve through its landmarks (warned)."""
    run.warn(curve, view, "no camera for this photo",
             "the curve is interpolated through its landmarks")
    fb = run.fallback_segments(curve)
    chain = run.landmark_chain(curve)
    run.finish_open(curve, [(a, b, fb[(a, b)]) for a, b in pairwise(chain)], {}, 0)


def _segments(run: CurveRun, curve: str, view: str, cam: Camera, em: E.EdgeMap,
              prior: Prior, full: list[str]) -> tuple[list[Segment], list[np.ndarray], int]:
    """Every segment between two 3D landmarks: lifted path, else interpolated.

    Returns:
        the segments, their 2D paths (the projected fallback where no path was found,
        nothing where a landmark is not in the photo) and the number found in the photo.
    """
    an = run.anchors(view)
    fb = run.fallback_segments(curve)
    segments: list[Segment] = []
    paths_2d: list[np.ndarray] = []
    ok = 0
    for a, b in pairwise(run.landmark_chain(curve)):
        if a not in an or b not in an:
            run.warn(curve, view, f"{a if a not in an else b} is not in this photo",
                     _INTERPOLATED.format(a=a, b=b))
            segments.append((a, b, fb[(a, b)]))
            continue
        stops = full[full.index(a):full.index(b) + 1]
        uv = _segment_uv(run, curve, view, em, an, stops, prior, a, b)
        if uv is None:
            segments.append((a, b, fb[(a, b)]))
            paths_2d.append(cam.project(fb[(a, b)]))
            continue
        paths_2d.append(uv)
        segments.append((a, b, lift_to_lines(uv, cam, run.L3[a], run.L3[b],
                                             run.params.lift_weight)))
        ok += 1
    return segments, paths_2d, ok


def edge_curve(run: CurveRun, curve: str) -> None:
    """Make one of :data:`EDGE_CURVES` from its photo (fallback where no edge serves)."""
    view = CURVE_VIEWS[curve][0]
    cam = run.cams.get(view)
    if run.left_out(curve):
        return
    if cam is None or view not in run.case.views:
        _all_interpolated(run, curve, view)
        return
    t0 = time.perf_counter()
    em = edge_map(run, view)
    run.timed("edges", t0)
    t0 = time.perf_counter()
    an = run.anchors(view)
    full = [i for i in CURVE_LANDMARKS[curve] if i in an and (i in run.L3 or i in HELPER_IDS)]
    prior = prior_penalty(run, em, np.array([an[i] for i in full]))
    segments, paths_2d, ok = _segments(run, curve, view, cam, em, prior, full)
    run.timed("paths", t0)
    run.finish_open(curve, segments, {view: np.vstack(paths_2d)} if paths_2d else {}, ok)
