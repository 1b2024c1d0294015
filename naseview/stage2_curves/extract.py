"""Stage 2 orchestration: the six boundary curves and the ad-landmarks (paper 3.3).

Which photo gives which curve (paper Fig. 14):

- ``mid`` (g-n-k-r-prn-c-sn): the silhouette against the background in the ``left`` and
  ``right`` photos (eq. 2-3), lifted in each and averaged;
- ``bottom`` (ac_r-al_r-al'_r-add_r-prn-add_l-al'_l-al_l-ac_l) and ``sill_l`` /
  ``sill_r``: the ``bottom`` photo (Scharr edges + least-cost paths, eq. 11-12; dark
  nostrils, eq. 13-14);
- ``ala_l`` / ``ala_r`` (ac-al-int), ``c`` (md_r-c-md_l): the ``front`` photo (eq. 11-12);
- ``side_l`` / ``side_r`` (int-mf): circle through int, tmp, mf in the ``front`` photo
  (eq. 15-17).

Every 2D point is lifted to 3D with its photo's stage-1 camera and the line through the
two nearest landmarks along the curve (eq. 4-10); the sills on the paper's plane. Where a
photo gives no usable evidence the curve (or the failing segment) falls back to a
Catmull-Rom interpolation through its 3D landmarks, a warning names the curve and the
photo, and the curve is flagged. A landmark stage 1 could not place (clicked in one photo
only) is put on its line of sight at the depth of a reference landmark for the curves
(warning; not an ad-landmark).

Where naseview departs from the paper's defaults (each a :class:`CurveParams` field; the
paper's behaviour is one setting away):

- ``lift_weight = 1``: the point on the line of sight rather than the midpoint of eq. 10,
  so a curve reprojects exactly onto its image evidence (paper: 0.5);
- ``path_prior_weight = 1``: the least-cost path also pays for straying from the smooth
  curve through the landmarks, so it does not jump to a stronger edge nearby (paper: 0);
- ``side_bulge = 0.06``: the side-curve's tmp point is moved towards the midline (paper: 0);
- ``mid_trace = "contour"``: the mid-curve follows the silhouette contour, which keeps
  the near-horizontal c-sn stretch that eq. 3's row scan loses (paper: ``"rows"``).

Example
-------
>>> from naseview.case import read_case
>>> from naseview.stage1_landmarks.solve import bundle_adjust
>>> case = read_case("case_dir")                              # doctest: +SKIP
>>> res = extract_curves(case, None, bundle_adjust(case))     # doctest: +SKIP
>>> res.ad_landmarks.shape, res.flags["mid"]                  # doctest: +SKIP
((76, 3), 'image')
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any, Protocol

import cv2
import numpy as np

from naseview.camera import Camera
from naseview.case import Case
from naseview.landmarks import (
    ALL_IDS,
    CURVE_LANDMARKS,
    CURVE_NAMES,
    HELPER_IDS,
    LANDMARK_IDS,
    mirror_id,
)
from naseview.stage2_curves import edges as E
from naseview.stage2_curves import mask as M
from naseview.stage2_curves import nostrils as N
from naseview.stage2_curves.cache import StepCache, digest
from naseview.stage2_curves.fallback import catmull_rom_segments, sill_ellipse
from naseview.stage2_curves.lift import lift_to_lines, lift_to_plane
from naseview.stage2_curves.params import CurveParams
from naseview.stage2_curves.side import side_curve_2d
from naseview.stage2_curves.sublandmarks import ad_landmarks

CURVE_VIEWS: dict[str, tuple[str, ...]] = {
    "mid": ("left", "right"), "bottom": ("bottom",), "ala_l": ("front",),
    "ala_r": ("front",), "c": ("front",), "sill_l": ("bottom",), "sill_r": ("bottom",),
    "side_l": ("front",), "side_r": ("front",),
}
"""The photo(s) each curve is taken from (paper Fig. 14; SPEC §7 truth_boundaries)."""

EDGE_CURVES: tuple[str, ...] = ("bottom", "ala_l", "ala_r", "c")
"""Curves found by Scharr edges and least-cost paths (eq. 11-12)."""

_DEPTH_REFS: dict[str, tuple[str, ...]] = {
    "mf": ("n",), "md": ("c", "alp"), "int": ("al",), "al": ("alp", "ac"), "alp": ("prn",),
    "alpp": ("alp",), "ac": ("al",), "n": ("g",), "k": ("n", "r"), "r": ("k", "prn"),
    "c": ("prn", "sn"), "sn": ("c",), "prn": ("r", "c"),
}
"""Landmarks whose camera depth stands in for a landmark stage 1 could not place."""
_SIDED = {"mf", "md", "int", "al", "alp", "alpp", "ac"}


class StageOne(Protocol):
    """What stage 2 needs from stage 1 (an SfmResult or a Reconstruction)."""

    landmarks: Mapping[str, np.ndarray]
    cameras: Mapping[str, Camera]


@dataclass
class CurvesResult:
    """Stage-2 result.

    Attributes:
        curves: SPEC §5 curve name -> (N, 3) polyline (mm), spacing ``curve_spacing_mm``;
            sills are closed loops starting at al'' (first point not repeated).
        curves_2d: curve name -> view -> (N, 2) the curve in that photo (px): the
            detected path, or the projection of the fallback where detection failed.
        anchors: curve name -> [(landmark id, index into ``curves[name]``)].
        ad_landmarks: (M, 3) the 21 landmarks then the sub-landmarks (M = 76 by default).
        ad_landmark_tags: M dicts ``{"id", "curve", "t", "between", "s"}``.
        flags: curve name -> ``"image"`` (from the photos), ``"circle"`` (side-curve
            regression), ``"estimated"`` (one of its landmarks was not placed by stage 1
            and stands on its line of sight at an estimated depth), ``"partial"`` (some segments
            interpolated), ``"fallback"`` (interpolated) or ``"missing"`` (left out).
        warnings: one-line messages naming the curve and the photo.
        evidence: view -> {"background": Background, "mask": (H, W) bool,
            "edges": EdgeMap, "nostril_threshold": float} for display.
        seconds: step name -> wall time (s) of this call.
    """

    curves: dict[str, np.ndarray] = field(default_factory=dict)
    curves_2d: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    anchors: dict[str, list[tuple[str, int]]] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ad_landmark_tags: list[dict[str, Any]] = field(default_factory=list)
    flags: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    evidence: dict[str, dict[str, Any]] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)


# ------------------------------------------------------------------------ helpers


def anchors_2d(case: Case, view: str, landmarks: Mapping[str, np.ndarray],
               camera: Camera | None) -> dict[str, np.ndarray]:
    """Landmark id -> (2,) px in ``view``: the click, else the reprojected 3D landmark."""
    out: dict[str, np.ndarray] = {}
    clicks = case.views[view].landmarks if view in case.views else {}
    for lid in ALL_IDS:
        if lid in clicks:
            out[lid] = np.asarray(clicks[lid], dtype=np.float64)
        elif camera is not None and lid in landmarks:
            out[lid] = camera.project(np.asarray(landmarks[lid]).reshape(1, 3))[0]
    return out


def _resample_segment(P: np.ndarray, spacing: float) -> np.ndarray:
    n = max(2, int(np.ceil(E.polyline_length(P) / spacing)) + 1)
    return E.resample_polyline(P, n)


def _assemble(segments: Sequence[tuple[str, str, np.ndarray]],
              spacing: float) -> tuple[np.ndarray, list[tuple[str, int]]]:
    """Join (a, b, (n, 3)) segments into one polyline with landmark indices."""
    pts: list[np.ndarray] = []
    anchors: list[tuple[str, int]] = []
    for i, (a, b, P) in enumerate(segments):
        Q = _resample_segment(P, spacing)
        if i == 0:
            anchors.append((a, 0))
            pts.append(Q)
        else:
            pts.append(Q[1:])
        anchors.append((b, sum(len(p) for p in pts) - 1))
    return (np.vstack(pts) if pts else np.zeros((0, 3))), anchors


def _smooth_loop(P: np.ndarray, sigma: float) -> np.ndarray:
    if sigma <= 0 or len(P) < 8:
        return P
    k = int(np.ceil(3 * sigma))
    x = np.arange(-k, k + 1)
    g = np.exp(-0.5 * (x / sigma) ** 2)
    g /= g.sum()
    ext = np.vstack([P[-k:], P, P[:k]])
    return np.stack([np.convolve(ext[:, j], g, mode="valid") for j in range(P.shape[1])], 1)


def _resample_loop(P: np.ndarray, spacing: float) -> np.ndarray:
    Q = np.vstack([P, P[:1]])
    n = max(8, int(np.ceil(E.polyline_length(Q) / spacing)))
    return E.resample_polyline(Q, n + 1)[:-1]


def _photo(case: Case, view: str) -> str:
    return f"photo {view!r} ({case.views[view].image})" if view in case.views else \
        f"photo {view!r}"


# ------------------------------------------------------------------------ the stage


class _Run:
    """One call of :func:`extract_curves` (holds the inputs; not part of the API)."""

    def __init__(self, case: Case, images: Mapping[str, np.ndarray] | None, stage1: StageOne,
                 params: CurveParams, cache: StepCache) -> None:
        self.case = case
        self.params = params
        self.cache = cache
        self.L3 = {k: np.asarray(v, dtype=np.float64) for k, v in stage1.landmarks.items()}
        self.cams = dict(stage1.cameras)
        self._images = dict(images) if images else {}
        self._img_keys: dict[str, str] = {}
        self.res = CurvesResult()
        self._anchors: dict[str, dict[str, np.ndarray]] = {}
        self.estimated: set[str] = set()
        self._estimate_missing()

    def _estimate_missing(self) -> None:
        """Place landmarks that stage 1 could not (clicked in one photo only) on their line
        of sight at the depth of a reference landmark, for use by the curves only."""
        for lid in LANDMARK_IDS:
            if lid in self.L3:
                continue
            base, side = (lid[:-2], lid[-2:]) if lid[-2:] in ("_l", "_r") else (lid, "")
            refs = [mirror_id(lid)] if mirror_id(lid) in self.L3 else \
                [r + (side if r in _SIDED else "") for r in _DEPTH_REFS.get(base, ())]
            refs = [r for r in refs if r in self.L3]
            views = [v for v, vw in self.case.views.items()
                     if lid in vw.landmarks and v in self.cams]
            if not refs or not views:
                continue
            cam = self.cams[views[0]]
            C, d = cam.rays(self.case.views[views[0]].landmarks[lid][None])
            depth = float(np.mean(cam.depth(np.array([self.L3[r] for r in refs]))))
            self.L3[lid] = C + d[0] * depth / float(d[0] @ cam.R[2])
            self.estimated.add(lid)
            self.res.warnings.append(
                f"landmark {lid} was not reconstructed in 3D (clicked in "
                f"{_photo(self.case, views[0])} only); for the curves it is placed on its line "
                f"of sight at the depth of {', '.join(refs)}")

    # -- inputs
    def image(self, view: str) -> np.ndarray:
        if view not in self._images:
            self._images[view] = self.case.load_image(view)
        return self._images[view]

    def image_key(self, view: str) -> str:
        if view not in self._img_keys:
            self._img_keys[view] = digest(self.image(view))
        return self._img_keys[view]

    def anchors(self, view: str) -> dict[str, np.ndarray]:
        if view not in self._anchors:
            self._anchors[view] = anchors_2d(self.case, view, self.L3, self.cams.get(view))
        return self._anchors[view]

    def warn(self, curve: str, view: str, reason: str, consequence: str) -> None:
        self.res.warnings.append(f"{curve}: {_photo(self.case, view)}: {reason}; {consequence}")

    def timed(self, name: str, t0: float) -> None:
        self.res.seconds[name] = self.res.seconds.get(name, 0.0) + time.perf_counter() - t0

    # -- fallback
    def landmark_chain(self, curve: str) -> list[str]:
        return [lid for lid in CURVE_LANDMARKS[curve] if lid not in HELPER_IDS and lid in self.L3]

    def left_out(self, curve: str) -> bool:
        """Flag and warn when fewer than two of the curve's landmarks could be placed."""
        chain = self.landmark_chain(curve)
        if len(chain) >= 2:
            return False
        lost = [i for i in CURVE_LANDMARKS[curve] if i not in HELPER_IDS and i not in self.L3]
        self.res.warnings.append(f"{curve}: landmarks {', '.join(lost)} could not be placed "
                                 "in 3D; the curve is left out")
        self.res.flags[curve] = "missing"
        return True

    def fallback_segments(self, curve: str) -> dict[tuple[str, str], np.ndarray]:
        chain = self.landmark_chain(curve)
        segs = catmull_rom_segments(np.array([self.L3[i] for i in chain]), 32)
        return {(a, b): s for (a, b), s in zip(pairwise(chain), segs, strict=True)}

    # -- background and the mid-curve
    def background(self, view: str, roi: tuple[int, int, int, int]
                   ) -> tuple[M.Background, np.ndarray]:
        """Background colour of the photo and the foreground mask inside ``roi``."""
        p = self.params
        keys = ("border_px", "hue_tol", "sat_tol", "val_tol", "grey_sat",
                "border_min_inlier", "mask_clean_px")
        key = digest(self.image_key(view), roi, p.subset(*keys))

        def compute() -> tuple[M.Background, np.ndarray]:
            bg = M.estimate_background(self.image(view), p.border_px, p.hue_tol, p.sat_tol,
                                       p.val_tol, p.grey_sat, p.border_min_inlier)
            return bg, M.foreground_mask(self.image(view), bg, p.mask_clean_px, roi)

        return self.cache.get("mask", key, compute)

    def mid_from_view(self, view: str) -> tuple[dict[tuple[str, str], np.ndarray],
                                                np.ndarray] | None:
        """3D segments of the mid-curve seen in one side photo, and its 2D path."""
        p = self.params
        cam = self.cams.get(view)
        an = self.anchors(view)
        chain = [i for i in self.landmark_chain("mid") if i in an]
        if cam is None or len(chain) < 2 or chain[0] != "g" or chain[-1] != "sn":
            self.warn("mid", view, "the camera or the landmarks g and sn are missing",
                      "this photo is not used for the mid-curve")
            return None
        t0 = time.perf_counter()
        g2, sn2 = an[chain[0]], an[chain[-1]]
        span = float(np.linalg.norm(sn2 - g2))
        tol = p.silhouette_tol * span
        img = self.image(view)
        roi = E.roi_around(np.array([an[i] for i in chain]),
                           int(max(p.roi_margin_px, 0.25 * span)), img.shape[1], img.shape[0])
        bg, mask = self.background(view, roi)
        self.timed("mask", t0)
        ev = self.res.evidence.setdefault(view, {})
        ev["background"], ev["mask"] = bg, mask
        if not bg.uniform:
            self.warn("mid", view, f"the photo's border is not a uniform background (only "
                      f"{100 * bg.inlier_fraction:.0f}% of border pixels match its colour)",
                      "this photo is not used for the mid-curve")
            return None
        t0 = time.perf_counter()
        prn = self.L3.get("prn", self.L3[chain[len(chain) // 2]])
        dx = cam.project(np.array([prn, prn - [0.0, 0.0, 30.0]]))
        anterior = 1 if dx[0, 0] > dx[1, 0] else -1
        key = digest("mid", self.image_key(view), roi, p.subset("border_px", "hue_tol", "sat_tol",
                     "val_tol", "grey_sat", "mask_clean_px", "mid_trace", "silhouette_tol"),
                     g2, sn2, anterior)

        def trace() -> np.ndarray | None:
            if p.mid_trace == "rows":
                return M.profile_rows(mask, g2[1], sn2[1], anterior)
            return M.profile_contour(mask, g2, sn2, anterior, max_snap_px=3 * tol)

        path = self.cache.get("mid_trace", key, trace)
        self.timed("mid_trace", t0)
        if path is None or len(path) < 4:
            self.warn("mid", view, "the silhouette does not pass by g and sn",
                      "this photo is not used for the mid-curve")
            return None
        # split at the landmarks; all must lie close to the silhouette, in order
        idx = []
        for lid in chain:
            d = np.linalg.norm(path - an[lid], axis=1)
            idx.append(int(np.argmin(d)))
            if d.min() > tol:
                self.warn("mid", view, f"landmark {lid} is {d.min():.0f} px from the "
                          "silhouette", "this photo is not used for the mid-curve")
                return None
        idx[0], idx[-1] = 0, len(path) - 1
        if any(b <= a for a, b in pairwise(idx)):
            self.warn("mid", view, "the landmarks are not in order along the silhouette",
                      "this photo is not used for the mid-curve")
            return None
        segs: dict[tuple[str, str], np.ndarray] = {}
        full2d = []
        for (a, b), (ia, ib) in zip(pairwise(chain), pairwise(idx), strict=True):
            uv = E.smooth_polyline(path[ia:ib + 1], p.path_smooth_px)
            full2d.append(uv if not full2d else uv[1:])
            segs[(a, b)] = lift_to_lines(uv, cam, self.L3[a], self.L3[b], p.lift_weight)
        return segs, np.vstack(full2d)

    def mid_curve(self) -> None:
        if self.left_out("mid"):
            return
        chain = self.landmark_chain("mid")
        per_view = {}
        for view in CURVE_VIEWS["mid"]:
            if view not in self.case.views:
                continue
            out = self.mid_from_view(view)
            if out is not None:
                per_view[view] = out
        fb = self.fallback_segments("mid")
        segments = []
        for a, b in pairwise(chain):
            views = [v for v, (segs, _) in per_view.items() if (a, b) in segs]
            if not views:
                segments.append((a, b, fb[(a, b)]))
                continue
            Ps = [per_view[v][0][(a, b)] for v in views]
            n = max(2, int(np.ceil(max(E.polyline_length(P) for P in Ps)
                                   / self.params.curve_spacing_mm)) + 1)
            segments.append((a, b, np.mean([E.resample_polyline(P, n) for P in Ps], axis=0)))
        self.finish_open("mid", segments, {v: o[1] for v, o in per_view.items()},
                         ok_segments=sum(1 for a, b in pairwise(chain)
                                         if any((a, b) in o[0] for o in per_view.values())))

    def finish_open(self, curve: str, segments: list[tuple[str, str, np.ndarray]],
                    paths_2d: dict[str, np.ndarray], ok_segments: int,
                    good_flag: str = "image") -> None:
        P, anchors = _assemble(segments, self.params.curve_spacing_mm)
        self.res.curves[curve] = P
        self.res.anchors[curve] = anchors
        total = len(segments)
        self.res.flags[curve] = (good_flag if ok_segments == total and total else
                                 "partial" if ok_segments else "fallback")
        if self.res.flags[curve] == good_flag and self.estimated & set(CURVE_LANDMARKS[curve]):
            self.res.flags[curve] = "estimated"
        views = dict(paths_2d)
        for view in CURVE_VIEWS[curve]:
            if view not in views and view in self.cams and len(P):
                views[view] = self.cams[view].project(P)
        self.res.curves_2d[curve] = views

    # -- edge-based curves
    def edge_map(self, view: str) -> E.EdgeMap:
        p = self.params
        an = self.anchors(view)
        img = self.image(view)
        ids = sorted({i for c in EDGE_CURVES if view in CURVE_VIEWS[c]
                      for i in CURVE_LANDMARKS[c] if i in an})
        roi = E.roi_around(np.array([an[i] for i in ids]), p.roi_margin_px, img.shape[1],
                           img.shape[0])
        key = digest(self.image_key(view), roi, p.subset("edge_blur_sigma",
                                                         "edge_ref_percentile"))
        em = self.cache.get("edges", key, lambda: E.edge_map(
            img, roi, p.edge_blur_sigma, p.edge_ref_percentile))
        self.res.evidence.setdefault(view, {})["edges"] = em
        return em

    def prior_penalty(self, view: str, em: E.EdgeMap,
                      anchors: np.ndarray) -> tuple[str, np.ndarray | None]:
        """Squared distance (px^2) to the Catmull-Rom curve through a curve's 2D anchors,
        over the edge region; and its cache key."""
        p = self.params
        key = digest(em.origin, em.strength.shape, anchors)
        if p.path_prior_weight <= 0 or len(anchors) < 2:
            return key, None

        def compute() -> np.ndarray:
            o = np.array(em.origin, dtype=np.float64)
            segs = catmull_rom_segments(anchors - o, 24)
            canvas = np.ones(em.strength.shape, np.uint8)
            pts = np.round(np.vstack(segs)).astype(np.int32)
            cv2.polylines(canvas, [pts], False, 0, 1)
            D = cv2.distanceTransform(canvas, cv2.DIST_L2, 5)
            return (D * D).astype(np.float64)

        return key, self.cache.get("prior", key, compute)

    def edge_path(self, view: str, em: E.EdgeMap, start: np.ndarray, end: np.ndarray,
                  prior: tuple[str, np.ndarray | None]) -> np.ndarray | None:
        """Least-cost path in photo coordinates, or None if missing / not trusted."""
        p = self.params
        o = np.array(em.origin, dtype=np.float64)
        length = float(np.linalg.norm(end - start))
        corridor = max(p.corridor_px, p.corridor_frac * length)
        keys = ("path_cost_exponent", "path_cost_floor", "corridor_px", "corridor_frac",
                "path_prior_weight")
        ekey = digest(em.origin, em.strength.shape, self.image_key(view),
                      p.subset("edge_blur_sigma", "edge_ref_percentile"))
        key = digest(ekey, start, end, prior[0], p.subset(*keys))

        def compute() -> np.ndarray | None:
            cost = self.cache.get("cost", digest(ekey, p.subset(*keys[:2])), lambda: E.edge_cost(
                em.strength, p.path_cost_exponent, p.path_cost_floor))
            path = E.least_cost_path(cost, start - o, end - o, corridor, prior[1],
                                     p.path_prior_weight / corridor ** 2)
            return None if path is None else path + o

        path = self.cache.get("path", key, compute)
        if path is None:
            return None
        ij = np.round(path - o).astype(int)
        h, w = em.strength.shape
        ij[:, 0] = np.clip(ij[:, 0], 0, w - 1)
        ij[:, 1] = np.clip(ij[:, 1], 0, h - 1)
        floor = self.cache.get("edge_median", ekey, lambda: float(np.median(em.strength[::2, ::2])))
        if float(em.strength[ij[:, 1], ij[:, 0]].mean()) < p.path_min_contrast * floor:
            return None
        return path

    def edge_curve(self, curve: str) -> None:
        p = self.params
        view = CURVE_VIEWS[curve][0]
        cam = self.cams.get(view)
        an = self.anchors(view) if view in self.case.views else {}
        if self.left_out(curve):
            return
        chain3 = self.landmark_chain(curve)
        fb = self.fallback_segments(curve)
        if cam is None or view not in self.case.views:
            self.warn(curve, view, "no camera for this photo",
                      "the curve is interpolated through its landmarks")
            self.finish_open(curve, [(a, b, fb[(a, b)]) for a, b in pairwise(chain3)], {}, 0)
            return
        t0 = time.perf_counter()
        em = self.edge_map(view)
        self.timed("edges", t0)
        t0 = time.perf_counter()
        full = [i for i in CURVE_LANDMARKS[curve] if i in an and (i in self.L3 or i in HELPER_IDS)]
        prior = self.prior_penalty(view, em, np.array([an[i] for i in full]))
        segments: list[tuple[str, str, np.ndarray]] = []
        paths_2d: list[np.ndarray] = []
        ok = 0
        for a, b in pairwise(chain3):
            if a not in an or b not in an:
                self.warn(curve, view, f"{a if a not in an else b} is not in this photo",
                          f"the segment {a}-{b} is interpolated through its landmarks")
                segments.append((a, b, fb[(a, b)]))
                continue
            ia, ib = full.index(a), full.index(b)
            stops = full[ia:ib + 1]
            parts = []
            for s, e in pairwise(stops):
                path = self.edge_path(view, em, an[s], an[e], prior)
                if path is None:
                    parts = None
                    self.warn(curve, view, f"no edge found between {s} and {e}",
                              f"the segment {a}-{b} is interpolated through its landmarks")
                    break
                parts.append(path if not parts else path[1:])
            if parts is None:
                segments.append((a, b, fb[(a, b)]))
                paths_2d.append(cam.project(fb[(a, b)]))
                continue
            uv = E.smooth_polyline(np.vstack(parts), p.path_smooth_px)
            paths_2d.append(uv)
            segments.append((a, b, lift_to_lines(uv, cam, self.L3[a], self.L3[b],
                                                 p.lift_weight)))
            ok += 1
        self.timed("paths", t0)
        self.finish_open(curve, segments, {view: np.vstack(paths_2d)} if paths_2d else {}, ok)

    # -- side-curves
    def side_curve(self, curve: str) -> None:
        p = self.params
        view = CURVE_VIEWS[curve][0]
        cam = self.cams.get(view)
        a, b = CURVE_LANDMARKS[curve]
        an = self.anchors(view) if view in self.case.views else {}
        if self.left_out(curve):
            return
        if cam is None or a not in an or b not in an:
            self.warn(curve, view, "int or mf is not available in this photo",
                      "the curve is interpolated through its landmarks")
            self.finish_open(curve, [(a, b, np.array([self.L3[a], self.L3[b]]))], {}, 0)
            return
        mids = [an[i] for i in ("n", "k", "r", "prn") if i in an]
        toward = np.mean(mids, axis=0) if mids else None
        uv = side_curve_2d(an[a], an[b], p.side_w_ratio, p.side_h_ratio, 64, p.side_bulge,
                           toward)
        P = lift_to_lines(uv, cam, self.L3[a], self.L3[b], p.lift_weight)
        self.finish_open(curve, [(a, b, P)], {view: uv}, 1, good_flag="circle")

    # -- nasal sills
    def sill(self, curve: str) -> None:
        p = self.params
        side = curve[-1]
        view = CURVE_VIEWS[curve][0]
        alpp, md, c = f"alpp_{side}", f"md_{side}", "c"
        if alpp not in self.L3:
            self.res.warnings.append(f"{curve}: landmark {alpp} was not reconstructed; "
                                     "the curve is left out")
            self.res.flags[curve] = "missing"
            return
        if md in self.L3 and c in self.L3:
            point, normal = N.sill_plane(self.L3[alpp], self.L3[md], self.L3[c])
        else:  # no md-c line: a horizontal plane (normal +y) through al''
            point, normal = self.L3[alpp].copy(), np.array([0.0, 1.0, 0.0])
        cam = self.cams.get(view)
        an = self.anchors(view) if view in self.case.views else {}
        loop2d = None
        reason = "no camera or no al'' in this photo"
        if cam is not None and alpp in an:
            t0 = time.perf_counter()
            img = self.image(view)
            ids = [i for i in CURVE_LANDMARKS["bottom"] + ("alpp_l", "alpp_r", "sn", "c")
                   if i in an]
            roi = E.roi_around(np.array([an[i] for i in ids]), p.roi_margin_px,
                               img.shape[1], img.shape[0])
            ref = self._sill_scale(an)
            key = digest(self.image_key(view), roi, an[alpp], ref,
                         p.subset("dark_ratio", "dark_threshold", "closing_px",
                                  "nostril_min_area_px", "nostril_search_frac"))

            def compute() -> tuple[np.ndarray | None, float]:
                thr = p.dark_threshold if p.dark_threshold is not None else \
                    N.auto_dark_threshold(img, roi, p.dark_ratio)
                loop = N.nostril_contour(img, an[alpp], thr, p.closing_px,
                                         p.nostril_search_frac * ref,
                                         p.nostril_min_area_px, roi)
                return loop, thr

            loop2d, thr = self.cache.get("nostril", key, compute)
            self.res.evidence.setdefault(view, {})["nostril_threshold"] = thr
            reason = "the nostril is not visible (no dark region next to al'')"
            if loop2d is not None:
                ext = np.ptp(loop2d, axis=0).max()
                if ext > 1.5 * ref:
                    reason = (f"the dark region next to al'' is {ext:.0f} px wide, too large "
                              "for a nostril")
                    loop2d = None
            if loop2d is not None:
                cosang = np.abs(cam.rays(loop2d)[1] @ normal)
                if cosang.min() < 0.15:
                    reason = "the sill plane is seen almost edge-on from this photo"
                    loop2d = None
            self.timed("nostrils", t0)
        if loop2d is None:
            self.warn(curve, view, reason, "the sill is an ellipse in the sill plane")
            across = self.L3.get(md, self.L3.get(f"alp_{side}", point + [0.0, 0.0, 8.0]))
            P = sill_ellipse(point, across, normal)
            P = _resample_loop(P, p.curve_spacing_mm)
            self.res.flags[curve] = "fallback"
            if cam is not None:
                self.res.curves_2d[curve] = {view: cam.project(P)}
        else:
            loop2d = _smooth_loop(loop2d, p.path_smooth_px)
            P = lift_to_plane(loop2d, cam, point, normal)
            P = _resample_loop(P, p.curve_spacing_mm)
            k = int(np.argmin(np.linalg.norm(P - point, axis=1)))
            P = np.roll(P, -k, axis=0)
            self.res.flags[curve] = "estimated" if {md, alpp} & self.estimated else "image"
            self.res.curves_2d[curve] = {view: loop2d}
        self.res.curves[curve] = P
        self.res.anchors[curve] = [(alpp, 0)]

    def _sill_scale(self, an: Mapping[str, np.ndarray]) -> float:
        for a, b in (("alpp_l", "alpp_r"), ("al_l", "al_r"), ("alp_l", "alp_r")):
            if a in an and b in an:
                d = float(np.linalg.norm(an[a] - an[b]))
                return d if a.startswith("alpp") else 0.5 * d
        return 50.0


def extract_curves(case: Case, images: Mapping[str, np.ndarray] | None, sfm_result: StageOne,
                   params: CurveParams | None = None,
                   cache: StepCache | None = None) -> CurvesResult:
    """Stage 2: the boundary curves, their image evidence and the ad-landmarks.

    Args:
        case: the case (2D clicks; photos are read from it unless given in ``images``).
        images: view -> (H, W, 3) uint8 BGR photo, or None to read them from ``case``.
        sfm_result: stage-1 result: ``.landmarks`` id -> (3,) mm and ``.cameras``
            view -> :class:`~naseview.camera.Camera` (an SfmResult or a Reconstruction).
        params: tunables (default :class:`CurveParams`).
        cache: a :class:`StepCache` kept between calls so that a parameter change re-runs
            only the steps that depend on it; None = no reuse.
    Returns:
        :class:`CurvesResult` with all nine SPEC §5 curves (flagged where interpolated)
        and the ad-landmarks.
    """
    t_start = time.perf_counter()
    params = (params or CurveParams()).validated()
    run = _Run(case, images, sfm_result, params, cache if cache is not None else StepCache())
    run.mid_curve()
    for curve in EDGE_CURVES:
        run.edge_curve(curve)
    for curve in ("sill_l", "sill_r"):
        run.sill(curve)
    for curve in ("side_l", "side_r"):
        run.side_curve(curve)
    res = run.res
    res.curves = {k: res.curves[k] for k in CURVE_NAMES if k in res.curves}
    t0 = time.perf_counter()
    placed = {k: v for k, v in run.L3.items() if k not in run.estimated}
    res.ad_landmarks, res.ad_landmark_tags = ad_landmarks(placed, res.curves, res.anchors,
                                                          params.sub_landmarks)
    run.timed("sublandmarks", t0)
    res.seconds["total"] = time.perf_counter() - t_start
    return res
