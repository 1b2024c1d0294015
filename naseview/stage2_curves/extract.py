"""Stage 2 (paper section 3.3): the six boundary curves and the ad-landmarks, in order.

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
(warning; not an ad-landmark; :mod:`~naseview.stage2_curves.estimate`).

:func:`extract_curves` is that sequence: stand-ins, mid-curve
(:mod:`~naseview.stage2_curves.curve_mid`), edge curves
(:mod:`~naseview.stage2_curves.curve_edges`), sills
(:mod:`~naseview.stage2_curves.curve_sills`), side-curves
(:mod:`~naseview.stage2_curves.curve_side`), then the ad-landmarks
(:mod:`~naseview.stage2_curves.sublandmarks`).

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
>>> from naseview.stage1_landmarks import bundle_adjust
>>> case = read_case("case_dir")                              # doctest: +SKIP
>>> res = extract_curves(case, None, bundle_adjust(case))     # doctest: +SKIP
>>> res.ad_landmarks.shape, res.flags["mid"]                  # doctest: +SKIP
((76, 3), 'image')
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Protocol

import numpy as np

from naseview.camera import Camera
from naseview.case import Case
from naseview.landmarks import CURVE_NAMES
from naseview.stage2_curves.cache import StepCache
from naseview.stage2_curves.curve_edges import EDGE_CURVES, edge_curve
from naseview.stage2_curves.curve_mid import mid_curve
from naseview.stage2_curves.curve_side import side_curve
from naseview.stage2_curves.curve_sills import sill
from naseview.stage2_curves.estimate import stand_in_landmarks
from naseview.stage2_curves.params import CurveParams
from naseview.stage2_curves.result import CurvesResult
from naseview.stage2_curves.run import CurveRun
from naseview.stage2_curves.sublandmarks import ad_landmarks


class StageOne(Protocol):
    """What stage 2 needs from stage 1 (an SfmResult or a Reconstruction)."""

    @property
    def landmarks(self) -> Mapping[str, np.ndarray]: ...

    @property
    def cameras(self) -> Mapping[str, Camera]: ...


def _start(case: Case, images: Mapping[str, np.ndarray] | None, stage1: StageOne,
           params: CurveParams, cache: StepCache) -> CurveRun:
    """The run's inputs: stage 1's landmarks with stand-ins for the ones it could not
    place (their warnings come first)."""
    L3, estimated, warnings = stand_in_landmarks(case, stage1.landmarks, stage1.cameras)
    run = CurveRun(case, images, L3, estimated, stage1.cameras, params, cache)
    run.res.warnings.extend(warnings)
    return run


def _make_curves(run: CurveRun) -> None:
    """All nine SPEC §5 curves, each from its photo (or interpolated), in SPEC order."""
    mid_curve(run)
    for curve in EDGE_CURVES:
        edge_curve(run, curve)
    for curve in ("sill_l", "sill_r"):
        sill(run, curve)
    for curve in ("side_l", "side_r"):
        side_curve(run, curve)
    run.res.curves = {k: run.res.curves[k] for k in CURVE_NAMES if k in run.res.curves}


def _sample_ad_landmarks(run: CurveRun) -> None:
    """The 21 landmarks (stand-ins excluded) and the sub-landmarks on the curves."""
    t0 = time.perf_counter()
    res = run.res
    placed = {k: v for k, v in run.L3.items() if k not in run.estimated}
    res.ad_landmarks, res.ad_landmark_tags = ad_landmarks(placed, res.curves, res.anchors,
                                                          run.params.sub_landmarks)
    run.timed("sublandmarks", t0)


def extract_curves(case: Case, images: Mapping[str, np.ndarray] | None, sfm_result: StageOne,
                   params: CurveParams | None = None,
                   cache: StepCache | None = None) -> CurvesResult:
    """Stage 2: the boundary curves, their image evidence and the ad-landmarks.

    Args:
        case: the case (2D clicks; photos are read from it unless given in ``images``).
        images: view -> (H, W, 3) uint8 BGR photo, or None to read them from ``case``.
        sfm_result: stage-1 result: ``.landmarks`` id -> (3,) mm and ``.cameras``
            view -> :class:`~naseview.camera.Camera` (an SfmResult or a Reconstruction).
        params: tunables (default :class:`CurveParams`; checked when it was made).
        cache: a :class:`StepCache` kept between calls so that a parameter change re-runs
            only the steps that depend on it; None = no reuse.
    Returns:
        :class:`CurvesResult` with all nine SPEC §5 curves (flagged where interpolated)
        and the ad-landmarks.
    """
    t_start = time.perf_counter()
    run = _start(case, images, sfm_result, params if params is not None else CurveParams(),
                 cache if cache is not None else StepCache())
    _make_curves(run)
    _sample_ad_landmarks(run)
    run.res.seconds["total"] = time.perf_counter() - t_start
    return run.res
