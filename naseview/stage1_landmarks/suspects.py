"""Suspect clicks of stage 1 (paper §3.2): residuals of eq. 1 far above the rest.

A click is suspect when its reprojection residual exceeds
``max(suspect_min_px, suspect_factor * median residual)``. For a landmark clicked in 3+
photos, leave-one-out triangulation can pin the error on one photo: that click is left
out of a second solve and reported as ignored. For a landmark clicked in two photos the
two clicks disagree and either may be wrong: both photos are named.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.stats
from scipy.optimize import OptimizeResult

from naseview.camera import Camera
from naseview.case import Case
from naseview.geometry.alignment import umeyama
from naseview.landmarks import MIDLINE_IDS, partner
from naseview.stage1_landmarks.frame import Gauge
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.problem import Problem, click_residuals, points_from_x, solve
from naseview.stage1_landmarks.result import SuspectClick
from naseview.stage1_landmarks.symmetry import midsagittal_plane, mirror_points
from naseview.stage1_landmarks.uncertainty import GAUGE_SD_MM

Click = tuple[str, str]
"""(view, landmark id) of one click."""


def suspect_threshold(res_norm: np.ndarray, params: SfmParams) -> float:
    """Residual (px) above which a click of residual norms ``res_norm`` (M,) is suspect."""
    med = float(np.median(res_norm)) if res_norm.size else 0.0
    return max(params.suspect_min_px, params.suspect_factor * med)


def robust_stats(res_norm: np.ndarray, params: SfmParams) -> tuple[np.ndarray, float]:
    """(M,) bool suspect mask and inlier RMSE (px) of per-click residual norms (M,) px."""
    suspect = res_norm > suspect_threshold(res_norm, params)
    inl = res_norm[~suspect]
    rmse = float(np.sqrt(np.mean(inl**2))) if inl.size else float("inf")
    return suspect, rmse


@dataclass(frozen=True)
class Attribution:
    """What leave-one-click-out re-solves decided about the suspect clicks.

    Attributes:
        dropped: indices (into the observations of the problem given) of the clicks shown
            wrong, in the order they were found.
        ambiguous: per landmark whose clicks disagree with none shown wrong: the indices
            of the clicks that could each be the wrong one (all kept, down-weighted by the
            robust loss).
        prob, sol: the problem without ``dropped`` and its solution.
        alternatives: per ambiguous landmark (same order), the solutions without each of
            its candidate clicks: (problem, solution) pairs.
        before: (problem, solution) with every click (what ``dropped`` changed).
    """

    dropped: list[int]
    ambiguous: list[tuple[int, ...]]
    prob: Problem
    sol: OptimizeResult
    alternatives: list[list[tuple[Problem, OptimizeResult]]] = field(default_factory=list)
    before: tuple[Problem, OptimizeResult] | None = None


def _sigma2(prob: Problem, sol: OptimizeResult, params: SfmParams) -> float:
    """Click noise variance (px^2) of a solution: 2 cost / dof, floored."""
    dof = 2 * prob.n_obs + prob.n_prior - len(sol.x) + 7
    s2 = 2.0 * float(sol.cost) / dof if dof > 0 else 0.0
    return max(s2, params.min_sigma_px ** 2)


def _symmetry_chi2(gauge: Gauge, prob: Problem, sol: OptimizeResult, j: int,
                   params: SfmParams) -> float:
    """Chi-square of landmark ``j`` against the symmetry of the face (sd
    ``symmetry_sd_mm``): a midline landmark's distance from the midsagittal plane of the
    left/right pairs (1 dof), a side landmark's distance from the mirror image of its
    partner (3 dof, both uncertain). 0 without millimetres or a partner."""
    if not len(gauge.scale_mm):
        return 0.0
    X = gauge.apply(points_from_x(prob, sol.x)[None])[0]
    pts = {lid: X[i] for i, lid in enumerate(prob.point_ids)}
    lid = prob.point_ids[j]
    sd2 = params.symmetry_sd_mm ** 2
    pairs = {k: v for k, v in pts.items() if k.endswith(("_l", "_r"))}
    if lid in MIDLINE_IDS:
        if len(pairs) < 6:
            return 0.0
        c, n = midsagittal_plane(pairs)
        return float(((pts[lid] - c) @ n) ** 2 / sd2)
    other = partner(lid)
    if other is None or other not in pts:
        return 0.0
    c, n = midsagittal_plane({k: v for k, v in pts.items() if k not in (lid, other)})
    m = mirror_points(pts[other][None], c, n)[0]
    return float(np.sum((pts[lid] - m) ** 2) / (2 * sd2))


def attribute_suspects(prob: Problem, sol: OptimizeResult, params: SfmParams,
                       gauge: Gauge) -> Attribution:
    """Which suspect clicks are wrong, decided by what explains all the other clicks best.

    For each landmark with a suspect click and 3+ photos, the whole bundle adjustment
    (every landmark and camera) is solved again without each of its clicks in turn. With
    the click noise ``s^2`` of the best re-solve (cost / degrees of freedom), two
    chi-square tests (2 degrees of freedom per click) decide:

    - significance: removing the best click lowers ``2 cost / s^2`` by more than the
      ``1 - outlier_alpha / M`` quantile (Bonferroni over the M clicks);
    To ``2 cost / s^2`` of each re-solve is added the chi-square of the landmark against
    the symmetry of the face (:func:`_symmetry_chi2`), so a removal that explains the
    clicks only by putting the landmark off the midline or far from its mirror partner
    loses.

    - attribution: the second-best removal leaves that score higher than the best
      by more than the ``1 - outlier_alpha`` quantile; otherwise the clicks that come
      within it could each be the wrong one, and all are kept (down-weighted by the
      robust loss) and reported as disagreeing.

    The most significant landmark is settled first and the suspects are measured again
    on its re-solve, so a wrong click does not make its neighbours look wrong. Never a
    click that would leave its photo with 5 clicks or fewer. Runs only when a click is
    suspect (clean cases pay nothing).
    """
    res_norm = click_residuals(prob, sol)
    suspect, _ = robust_stats(res_norm, params)
    out = Attribution([], [], prob, sol, before=(prob, sol))
    if not suspect.any():
        return out
    orig = np.arange(prob.n_obs)  # current observation -> original index
    per_view = np.bincount(prob.obs_view, minlength=prob.n_views)
    done: set[int] = set()
    dropped: list[int] = []
    ambiguous: list[tuple[int, ...]] = []
    alternatives: list[list[tuple[Problem, OptimizeResult]]] = []
    q_sig = float(scipy.stats.chi2.isf(params.outlier_alpha / prob.n_obs, 2))
    q_gap = float(scipy.stats.chi2.isf(params.outlier_alpha, 2))
    cur_prob, cur_sol = prob, sol
    while True:
        suspect, _ = robust_stats(click_residuals(cur_prob, cur_sol), params)
        cands = [j for j in np.unique(cur_prob.obs_point[suspect]) if j not in done
                 and np.count_nonzero(cur_prob.obs_point == j) >= 3]
        best = None
        for j in cands:
            idx = np.flatnonzero(cur_prob.obs_point == j)
            fits = []
            for k in idx:
                pk, _ = without_observations(cur_prob, [int(k)])
                fits.append((int(k), pk, solve(pk, cur_sol.x, params)))
            s2 = min(_sigma2(f[1], f[2], params) for f in fits)
            score = {f[0]: 2.0 * f[2].cost / s2 + _symmetry_chi2(gauge, f[1], f[2], int(j),
                                                                 params) for f in fits}
            fits.sort(key=lambda f: score[f[0]])
            gain = 2.0 * cur_sol.cost / s2 + _symmetry_chi2(gauge, cur_prob, cur_sol, int(j),
                                                           params) - score[fits[0][0]]
            if best is None or gain > best[0]:
                best = (gain, int(j), fits, score)
        if best is None or best[0] <= q_sig:
            break
        _, jb, fits, score_of = best
        done.add(jb)
        close = [f for f in fits if score_of[f[0]] - score_of[fits[0][0]] <= q_gap]
        kb = fits[0][0]
        if len(close) == 1 and per_view[cur_prob.obs_view[kb]] > 5:
            dropped.append(int(orig[kb]))
            per_view[cur_prob.obs_view[kb]] -= 1
            orig = np.delete(orig, kb)
            cur_prob, cur_sol = fits[0][1], fits[0][2]
        else:
            ambiguous.append(tuple(int(orig[f[0]]) for f in close))
            alternatives.append([(f[1], f[2]) for f in close])
    return Attribution(dropped, ambiguous, cur_prob, cur_sol, alternatives, (prob, sol))


def without_observations(prob: Problem, culprits: list[int]) -> tuple[Problem, list[Click]]:
    """The problem without the observations ``culprits``, and those clicks."""
    keep = np.ones(prob.n_obs, dtype=bool)
    keep[culprits] = False
    dropped = [(prob.views[prob.obs_view[k]], prob.point_ids[prob.obs_point[k]])
               for k in culprits]
    return replace(prob, obs_view=prob.obs_view[keep], obs_point=prob.obs_point[keep],
                   obs_uv=prob.obs_uv[keep]), dropped


def report_clicks(case: Case, prob: Problem, res_norm: np.ndarray, suspect: np.ndarray,
                  seen_in: dict[str, list[str]], dropped: list[Click],
                  cameras: dict[str, Camera], landmarks: dict[str, np.ndarray],
                  ambiguous: list[tuple[str, tuple[str, ...]]] = ()  # type: ignore[assignment]
                  ) -> tuple[dict[str, dict[str, float]], list[SuspectClick]]:
    """Residual of every click and the suspect clicks, largest first.

    Args:
        res_norm, suspect: (M,) residuals (px) and suspect mask of the adjusted clicks.
        seen_in: id -> photos that show it.
        dropped: clicks left out of the final solve; their residuals are measured with
            ``cameras`` and ``landmarks`` (any one frame).
        ambiguous: (landmark, photos) whose clicks disagree with none shown wrong (all
            kept): one suspect naming all those photos.
    Returns:
        view -> id -> residual (px), and the suspect clicks (one per disagreeing pair).
    """
    residuals: dict[str, dict[str, float]] = {v: {} for v in prob.views}
    suspects: list[SuspectClick] = []
    unsure = dict(ambiguous)
    for lid, views in ambiguous:
        r = max(float(res_norm[k]) for k in range(len(res_norm))
                if prob.point_ids[prob.obs_point[k]] == lid
                and prob.views[prob.obs_view[k]] in views)
        suspects.append(SuspectClick(lid, views[0], r, other_views=views[1:]))
    for k in range(len(res_norm)):
        v, lid = prob.views[prob.obs_view[k]], prob.point_ids[prob.obs_point[k]]
        residuals[v][lid] = float(res_norm[k])
        if suspect[k] and lid not in unsure:
            others = tuple(u for u in seen_in[lid] if u != v)
            pair = others if len(seen_in[lid]) == 2 else ()
            if pair and any(sc.landmark == lid for sc in suspects):
                continue  # the same disagreement, already reported from the other photo
            suspects.append(SuspectClick(lid, v, float(res_norm[k]), other_views=pair))
    for v, lid in dropped:
        r = float(np.linalg.norm(cameras[v].project(landmarks[lid])[0]
                                 - case.views[v].landmarks[lid]))
        residuals[v][lid] = r
        suspects.append(SuspectClick(lid, v, r, ignored=True))
    suspects.sort(key=lambda sc: -sc.residual_px)
    return residuals, suspects


def moved_landmarks(gauge: Gauge, final: tuple[Problem, OptimizeResult],
                    others: list[tuple[Problem, OptimizeResult]],
                    lost_click: frozenset[str] = frozenset()) -> dict[str, float]:
    """id -> largest distance (mm) between the adjusted landmarks of ``final`` and those
    of each of ``others`` (same points), in the SPEC frame after the rigid alignment on
    the landmarks that did not lose a click (``lost_click``; all of them when fewer than
    three remain), so a moved origin ``g`` or axis landmark does not move the rest.

    Empty when the gauge has no scale distance (no millimetres yet) or nothing to compare.
    """
    if not others or not len(gauge.scale_mm):
        return {}
    prob, sol = final
    X = gauge.apply(points_from_x(prob, sol.x)[None])[0]
    anchor = np.array([lid not in lost_click for lid in prob.point_ids])
    if anchor.sum() < 3:
        anchor[:] = True
    worst = np.zeros(len(X))
    for p, s in others:
        Y = gauge.apply(points_from_x(p, s.x)[None])[0]
        _, R, t = umeyama(Y[anchor], X[anchor], with_scale=False)
        worst = np.maximum(worst, np.linalg.norm(Y @ R.T + t - X, axis=1))
    return {lid: float(worst[j]) for j, lid in enumerate(prob.point_ids)}


def moved_message(moved: dict[str, float], uncertainty: dict[str, float]) -> str:
    """``'n' 2.6 mm (+-0.4), 'g' 1.2 mm``: the landmarks that moved more than their
    uncertainty, largest first ('' when none).

    A landmark fixed by the gauge (uncertainty 0: the origin) is compared with the median
    uncertainty of the others, the precision it has relative to them, and printed without
    one."""
    measured = [u for u in uncertainty.values() if u >= GAUGE_SD_MM]
    typical = float(np.median(measured)) if measured else 0.0

    def limit(lid: str) -> float:
        u = uncertainty.get(lid, 0.0)
        return u if u >= GAUGE_SD_MM else typical

    big = sorted(((d, lid) for lid, d in moved.items() if d > limit(lid)), reverse=True)
    return ", ".join(f"{lid!r} {d:.1f} mm" + (f" (+-{uncertainty[lid]:.1f})"
                                              if uncertainty.get(lid, 0.0) >= GAUGE_SD_MM
                                              else "")
                     for d, lid in big)
