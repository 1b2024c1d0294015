"""Suspect clicks of stage 1 (paper §3.2): residuals of eq. 1 far above the rest.

A click is suspect when its reprojection residual exceeds
``max(suspect_min_px, suspect_factor * median residual)``. For a landmark clicked in 3+
photos, leave-one-out triangulation can pin the error on one photo: that click is left
out of a second solve and reported as ignored. For a landmark clicked in two photos the
two clicks disagree and either may be wrong: both photos are named.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import OptimizeResult

from naseview.camera import Camera
from naseview.case import Case
from naseview.geometry.triangulation import triangulate_dlt
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.problem import Problem, cameras_from_x, click_residuals
from naseview.stage1_landmarks.result import SuspectClick

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


def attribute_suspects(prob: Problem, sol: OptimizeResult, params: SfmParams) -> list[int]:
    """Observations to leave out: suspect clicks pinned on one photo by leave-one-out.

    For each landmark with a suspect click and 3+ photos, triangulate it (DLT, adjusted
    cameras) without each photo in turn; the photo whose removal makes all remaining
    clicks fit (below the suspect threshold) while its own click does not, is the culprit.
    At most one click per landmark, and never one that would leave its photo with fewer
    than 5 clicks.

    Returns:
        indices into the M observations of ``prob``.
    """
    res_norm = click_residuals(prob, sol)
    suspect, _ = robust_stats(res_norm, params)
    if not suspect.any():
        return []
    thr = suspect_threshold(res_norm, params)
    cams = cameras_from_x(prob, sol.x)
    per_view = np.bincount(prob.obs_view, minlength=prob.n_views)
    out = []
    for j in np.unique(prob.obs_point[suspect]):
        idx = np.flatnonzero(prob.obs_point == j)
        if len(idx) < 3:
            continue
        r_others, k, r_k = _leave_one_out(prob, cams, idx)
        if r_others <= thr < r_k and per_view[prob.obs_view[k]] > 5:
            out.append(k)
            per_view[prob.obs_view[k]] -= 1
    return out


def _leave_one_out(prob: Problem, cams: list[Camera], idx: np.ndarray
                   ) -> tuple[float, int, float]:
    """The observation of one landmark (``idx``: its observations) whose removal fits the
    others best: (largest residual px of the others, its index, its own residual px)."""
    best = (np.inf, -1, 0.0)
    for k in idx:
        others = idx[idx != k]
        X = triangulate_dlt([cams[prob.obs_view[o]] for o in others],
                            prob.obs_uv[others][None], np.ones((1, len(others)), bool))[0]
        r = [float(np.linalg.norm(cams[prob.obs_view[o]].project(X)[0] - prob.obs_uv[o]))
             for o in idx]
        r_others = max(r[i] for i, o in enumerate(idx) if o != k)
        if r_others < best[0]:
            best = (r_others, int(k), r[list(idx).index(k)])
    return best


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
                  cameras: dict[str, Camera], landmarks: dict[str, np.ndarray]
                  ) -> tuple[dict[str, dict[str, float]], list[SuspectClick]]:
    """Residual of every click and the suspect clicks, largest first.

    Args:
        res_norm, suspect: (M,) residuals (px) and suspect mask of the adjusted clicks.
        seen_in: id -> photos that show it.
        dropped: clicks left out of the final solve; their residuals are measured with
            ``cameras`` and ``landmarks`` (any one frame).
    Returns:
        view -> id -> residual (px), and the suspect clicks (one per disagreeing pair).
    """
    residuals: dict[str, dict[str, float]] = {v: {} for v in prob.views}
    suspects: list[SuspectClick] = []
    for k in range(len(res_norm)):
        v, lid = prob.views[prob.obs_view[k]], prob.point_ids[prob.obs_point[k]]
        residuals[v][lid] = float(res_norm[k])
        if suspect[k]:
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
