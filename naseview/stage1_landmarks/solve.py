"""Stage 1: 3D landmarks and cameras by bundle adjustment (paper section 3.2, eq. 1).

:func:`bundle_adjust` runs the steps of stage 1, each in its own module:

1. :mod:`.validate`: one-line errors for clicks eq. 1 cannot use.
2. :mod:`.initial`: a four-view rig prior, the template fit per photo, DLT triangulation
   and resection rounds give initial cameras; several rig hypotheses are tried when the
   first one does not reach a small reprojection error, and the lowest robust cost wins.
3. :mod:`.problem`: the robust least-squares solve of eq. 1 with its analytic Jacobian.
4. :mod:`.suspects`: clicks that leave-one-out triangulation pins on one photo are left
   out of a second solve.
5. :mod:`.frame`: the result in the SPEC §4 frame (origin ``g``, +x the subject's left,
   +y up, +z anterior, millimetres from ``case.scale_mm``); :mod:`.uncertainty`: the 3D
   covariance of each landmark; :mod:`.single_view`: landmarks clicked in one photo only,
   on their viewing rays.

Example
-------
>>> from naseview.case import read_case
>>> res = bundle_adjust(read_case("assets/demo-case"))      # doctest: +SKIP
>>> res.landmarks["prn"], res.uncertainty_mm["prn"]         # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import functools
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import OptimizeResult

from naseview.camera import Camera
from naseview.case import Case
from naseview.errors import NaseviewError
from naseview.landmarks import ALL_VIEWS, LANDMARK_IDS
from naseview.stage1_landmarks import problem
from naseview.stage1_landmarks.frame import (
    Gauge,
    anatomical_frame,
    scale_from,
    similarity_camera,
)
from naseview.stage1_landmarks.initial import hypotheses, initial_cameras
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.plausibility import (
    resolution_warnings,
    symmetry_warnings,
    view_warnings,
)
from naseview.stage1_landmarks.result import SfmResult, SuspectClick
from naseview.stage1_landmarks.single_view import place_single
from naseview.stage1_landmarks.suspects import (
    Attribution,
    Click,
    attribute_suspects,
    moved_landmarks,
    moved_message,
    report_clicks,
    robust_stats,
    without_observations,
)
from naseview.stage1_landmarks.uncertainty import (
    click_sigma,
    landmark_blocks,
    landmark_covariance,
    standard_uncertainty,
)
from naseview.stage1_landmarks.validate import (
    MirroredError,
    check_fit,
    check_glabella,
    check_inputs,
    check_not_mirrored,
    check_scale,
    check_shared_clicks,
    gauge_error,
    no_rig_error,
    swapped_profiles_error,
)

try:
    import threadpoolctl
except ImportError:  # optional (pip install threadpoolctl); only speed depends on it
    threadpoolctl = None

__all__ = ["SfmParams", "SfmResult", "SuspectClick", "anatomical_frame", "bundle_adjust"]

_HOW = {"symmetry": "by left/right symmetry", "midline": "on the midsagittal plane",
        "template": "at the depth of a generic nose (weak prior)"}
"""How a one-photo landmark was placed (:func:`.single_view.place_single`), for messages."""


def bundle_adjust(case: Case, params: SfmParams | None = None) -> SfmResult:
    """Stage 1: 3D landmarks and cameras of a case by bundle adjustment.

    Args:
        case: a validated case (SPEC §3): clicks in px, at least one ``scale_mm`` distance.
        params: tunables (defaults: :class:`SfmParams`).
    Returns:
        :class:`SfmResult` in the SPEC §4 frame (mm, origin g).
    Raises:
        NaseviewError: a photo with fewer than ``min_clicks_per_photo`` clicks or collinear
            clicks, g not clicked in two photos, no usable scale distance, left/right
            labels swapped, or the adjustment did not converge (names the worst photo).
    """
    params = params or SfmParams()
    # trial steps far off (rejected by the solver) may overflow: not worth a warning
    with _single_thread_blas(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        try:
            return _bundle_adjust(case, params)
        except MirroredError as e:
            if "left" not in case.views or "right" not in case.views:
                raise
            mirrored = e
        # The left and right photos in each other's slot also give a mirrored nose: the
        # rig prior put them on the wrong sides. If they fit on swapped sides, say so.
        try:
            _bundle_adjust(case, replace(params, rig_yaw_deg=-params.rig_yaw_deg))
        except NaseviewError:
            raise mirrored from None
        raise swapped_profiles_error(case)


@functools.lru_cache(maxsize=1)
def _blas_controller() -> threadpoolctl.ThreadpoolController | None:
    return None if threadpoolctl is None else threadpoolctl.ThreadpoolController()


def _single_thread_blas() -> contextlib.AbstractContextManager[object]:
    """Context limiting BLAS to one thread: the matrices here are ~100 x 100, where thread
    hand-offs cost more than they save (and far more on a busy machine)."""
    ctl = _blas_controller()
    return contextlib.nullcontext() if ctl is None else ctl.limit(limits=1, user_api="blas")


@dataclass(frozen=True)
class _Clicks:
    """Which photos show which landmark.

    Attributes:
        views: the photos of the case, in SPEC order.
        seen_in: landmark id -> the photos that show it.
        point_ids: ids clicked in 2+ photos (adjusted); single: ids clicked in one.
    """

    views: list[str]
    seen_in: dict[str, list[str]]
    point_ids: list[str]
    single: list[str]

    @staticmethod
    def of(case: Case) -> _Clicks:
        views = [v for v in ALL_VIEWS if v in case.views]  # 4-6 photos, or a subset
        seen_in = {lid: [v for v in views if lid in case.views[v].landmarks]
                   for lid in LANDMARK_IDS}
        return _Clicks(views, seen_in,
                       [lid for lid in LANDMARK_IDS if len(seen_in[lid]) >= 2],
                       [lid for lid in LANDMARK_IDS if len(seen_in[lid]) == 1])


@dataclass(frozen=True)
class _Fit:
    """A solved bundle adjustment: the problem, the ``least_squares`` result, and the rig
    hypothesis it started from (e.g. ``"yaw 90, bottom 50"``)."""

    prob: problem.Problem
    sol: OptimizeResult
    hypothesis: str


@dataclass(frozen=True)
class _Scene:
    """Landmarks (id -> (3,)), their covariances (id -> (3, 3)) and the cameras (view ->
    camera), all in one frame."""

    landmarks: dict[str, np.ndarray]
    covariance: dict[str, np.ndarray]
    cameras: dict[str, Camera]


def _bundle_adjust(case: Case, params: SfmParams) -> SfmResult:
    """Checks, the best rig hypothesis, a second solve without suspect clicks, result."""
    check_inputs(case, params)
    clicks = _Clicks.of(case)
    check_shared_clicks(case, clicks.views, clicks.point_ids)
    base = problem.build_problem(case, clicks.views, clicks.point_ids, params)
    fit, att = _without_suspects(_best_hypothesis(case, base, params), params,
                                 _gauge(case, clicks.point_ids))
    return _finish(case, params, fit, clicks, att)


def _best_hypothesis(case: Case, base: problem.Problem, params: SfmParams) -> _Fit:
    """Solve from each rig hypothesis in turn until one reaches ``accept_rmse_px``; the
    lowest robust cost wins."""
    best: _Fit | None = None
    for yaw, elev in hypotheses(params):
        cams0, X0 = initial_cameras(case, base.views, base.point_ids, yaw, elev, params)
        prob = replace(base, R0=np.stack([c.R for c in cams0]))
        x0 = problem.pack(prob, cams0, X0)
        if x0 is None:
            continue
        sol = problem.solve(prob, x0, params)
        _, rmse = robust_stats(problem.click_residuals(prob, sol), params)
        if best is None or sol.cost < best.sol.cost:
            best = _Fit(prob, sol, f"yaw {yaw:g}, bottom {elev:g}")
        if rmse <= params.accept_rmse_px:
            break
    if best is None:
        raise no_rig_error(case)
    return best


def _without_suspects(fit: _Fit, params: SfmParams, gauge: Gauge
                      ) -> tuple[_Fit, Attribution | None]:
    """With ``params.drop_suspects``, the solve without the clicks that leave-one-click-out
    re-solves show wrong (:func:`.suspects.attribute_suspects`), and that attribution."""
    if not params.drop_suspects:
        return fit, None
    att = attribute_suspects(fit.prob, fit.sol, params, gauge)
    return _Fit(att.prob, att.sol, fit.hypothesis), att


def _finish(case: Case, params: SfmParams, fit: _Fit, clicks: _Clicks,
            att: Attribution | None) -> SfmResult:
    """Checks, gauge, uncertainty, residuals and one-photo landmarks of a solved problem."""
    prob, sol = fit.prob, fit.sol
    dropped, unsure = _attributed_clicks(att)
    res_norm = problem.click_residuals(prob, sol)
    suspect, inlier_rmse = robust_stats(res_norm, params)
    check_fit(case, prob, res_norm, inlier_rmse, suspect, params)
    gauge = _gauge(case, prob.point_ids)
    sigma = click_sigma(prob, sol, params)
    scene = _provisional_scene(prob, sol, gauge, sigma)
    residuals, suspects = report_clicks(case, prob, res_norm, suspect, clicks.seen_in,
                                        dropped, scene.cameras, scene.landmarks, unsure)
    warnings = [sc.message() for sc in suspects]
    if not sol.success:
        warnings.append(f"bundle adjustment stopped after {sol.nfev} evaluations without "
                        "full convergence; the result may be slightly off")
    placed, left_out = place_single(case, params, clicks.single, clicks.seen_in,
                                    scene.landmarks, scene.covariance, scene.cameras, sigma)
    if not len(gauge.scale_mm):  # the scale needs a one-photo landmark
        scene = _scaled_to_mm(case, scene)
        warnings.append("the scale distance uses a landmark clicked in one photo only; "
                        "click both ends in two photos each for an exact scale")
    check_glabella(case, scene.landmarks, clicks.seen_in)
    if "g" not in prob.point_ids:
        scene = _origin_at_glabella(scene, prob.point_ids)
    check_not_mirrored(case, scene.landmarks)
    shown = {v: [k for k in case.views[v].landmarks if k in scene.landmarks]
             for v in scene.cameras}
    low_res, low_views, blurred = resolution_warnings(scene.cameras, scene.landmarks, shown,
                                                      params)
    warnings[:0] = view_warnings(scene.cameras, params, blurred)  # explains the rest: first
    warnings += low_res + _focal_warnings({v: c for v, c in scene.cameras.items()
                                           if v not in blurred}, params)
    uncertainty = {k: standard_uncertainty(c) for k, c in scene.covariance.items()}
    _add_one_photo_residuals(case, scene, placed, clicks.seen_in, residuals)
    warnings += _one_photo_warnings(placed, left_out, clicks.seen_in, uncertainty)
    warnings += _uncertainty_warnings(prob.point_ids, clicks.seen_in, uncertainty, params,
                                      low_views)
    warnings += _moved_warnings(att, gauge, (prob, sol), dropped, unsure, uncertainty)
    warnings += symmetry_warnings({k: scene.landmarks[k] for k in prob.point_ids},
                                  scene.covariance, clicks.seen_in, params)
    landmarks = _in_landmark_order(scene.landmarks)
    return SfmResult(
        landmarks=landmarks, cameras=scene.cameras, residuals_px=residuals,
        uncertainty_mm={k: uncertainty[k] for k in landmarks},
        covariance_mm2={k: scene.covariance[k] for k in landmarks},
        reprojection_rmse_px=float(np.sqrt(np.mean(res_norm**2))),
        suspect_clicks=suspects, warnings=warnings,
        one_photo=dict(placed), left_out=tuple(left_out),
        sigma_px=sigma, hypothesis=fit.hypothesis, converged=bool(sol.success),
        n_evaluations=int(sol.nfev))


def _attributed_clicks(att: Attribution | None
                       ) -> tuple[list[Click], list[tuple[str, tuple[str, ...]]]]:
    """The clicks left out, and (landmark, photos) of the disagreements none of whose
    clicks could be shown wrong."""
    if att is None or att.before is None:
        return [], []
    before = att.before[0]
    _, dropped = without_observations(before, att.dropped)
    unsure = [(before.point_ids[before.obs_point[g[0]]],
               tuple(before.views[before.obs_view[k]] for k in g)) for g in att.ambiguous]
    return dropped, unsure


def _moved_warnings(att: Attribution | None, gauge: Gauge,
                    final: tuple[problem.Problem, OptimizeResult], dropped: list[Click],
                    unsure: list[tuple[str, tuple[str, ...]]],
                    uncertainty: dict[str, float]) -> list[str]:
    """The landmarks that leaving out a click, or not knowing which of disagreeing clicks
    is right, moves by more than their uncertainty, with the distances."""
    if att is None or att.before is None:
        return []
    out = []
    lost = frozenset(lid for _, lid in dropped) | frozenset(lid for lid, _ in unsure)
    if dropped:
        moved = moved_message(moved_landmarks(gauge, final, [att.before], lost), uncertainty)
        if moved:
            what = ", ".join(f"{lid!r} in photo {v!r}" for v, lid in dropped)
            out.append(f"leaving out the click(s) {what} moved landmark(s) {moved}; their "
                       "positions now rest on the other photos")
    for (lid, views), alts in zip(unsure, att.alternatives, strict=True):
        moved = moved_message(moved_landmarks(gauge, final, alts, lost), uncertainty)
        if moved:
            out.append(f"landmark {lid!r}: depending on which of the clicks in photos "
                       f"{', '.join(repr(v) for v in views)} is wrong, landmark(s) {moved} "
                       "move; check those clicks")
    return out


def _gauge(case: Case, point_ids: list[str]) -> Gauge:
    """The gauge of the adjusted landmarks, or a one-line error naming what is missing."""
    try:
        return Gauge.build(point_ids, case.scale_mm)
    except ValueError as e:
        raise gauge_error(case, e) from None


def _provisional_scene(prob: problem.Problem, sol: OptimizeResult, gauge: Gauge,
                       sigma: float) -> _Scene:
    """The solution in the provisional frame: SPEC axes, origin g (n while g is not yet
    placed), mm when a scale distance joins two adjusted landmarks (else
    bundle-adjustment units for now), with the landmark covariances."""
    cams_ba = problem.cameras_from_x(prob, sol.x)
    X_ba = problem.points_from_x(prob, sol.x)
    o, Rgs = gauge.frames(X_ba[None])
    s = float(gauge.scales(X_ba[None])[0])
    X = gauge.apply(X_ba[None])[0]
    cov = landmark_covariance(sol.jac, prob, X_ba, sigma, gauge)
    return _Scene({lid: X[j] for j, lid in enumerate(prob.point_ids)},
                  landmark_blocks(cov, prob.point_ids),
                  {v: similarity_camera(c, o[0], Rgs[0], s)
                   for v, c in zip(prob.views, cams_ba, strict=True)})


def _scaled_to_mm(case: Case, scene: _Scene) -> _Scene:
    """The scene in millimetres from the scale distances among all placed landmarks."""
    s2 = scale_from(case.scale_mm, scene.landmarks)
    if s2 is None:
        check_scale(case, set(scene.landmarks))
    assert s2 is not None
    return _Scene({k: s2 * p for k, p in scene.landmarks.items()},
                  {k: s2**2 * c for k, c in scene.covariance.items()},
                  {v: similarity_camera(c, np.zeros(3), np.eye(3), s2)
                   for v, c in scene.cameras.items()})


def _origin_at_glabella(scene: _Scene, point_ids: list[str]) -> _Scene:
    """The final frame when g was placed from one photo: origin g, axes from the adjusted
    landmarks (a no-op when g was adjusted)."""
    frame_pts = {k: scene.landmarks[k] for k in point_ids} | {"g": scene.landmarks["g"]}
    og, Rf = anatomical_frame(frame_pts)
    return _Scene({k: Rf @ (p - og) for k, p in scene.landmarks.items()},
                  {k: Rf @ c @ Rf.T for k, c in scene.covariance.items()},
                  {v: similarity_camera(c, og, Rf, 1.0) for v, c in scene.cameras.items()})


def _focal_warnings(cameras: dict[str, Camera], params: SfmParams) -> list[str]:
    """A warning for the first photo whose focal length is implausible for its size."""
    for v, cam in cameras.items():
        side = max(cam.width, cam.height)
        if not 0.25 * side < cam.focal_px < params.max_focal_factor * side:
            return [f"photo {v!r} fits an implausible focal length ({cam.focal_px:.0f} px "
                    f"for a {side} px photo); check that every photo is in its slot and that "
                    "_l/_r are the subject's left/right, or give the focal length in "
                    "case.json"]
    return []


def _add_one_photo_residuals(case: Case, scene: _Scene, placed: dict[str, str],
                             seen_in: dict[str, list[str]],
                             residuals: dict[str, dict[str, float]]) -> None:
    """Residual (px) of each placed one-photo landmark in its photo (in place)."""
    for lid in placed:
        v = seen_in[lid][0]
        r = scene.cameras[v].project(scene.landmarks[lid])[0] - case.views[v].landmarks[lid]
        residuals[v][lid] = float(np.linalg.norm(r))


def _one_photo_warnings(placed: dict[str, str], left_out: list[str],
                        seen_in: dict[str, list[str]], uncertainty: dict[str, float]
                        ) -> list[str]:
    """How each one-photo landmark was placed, or that it could not be."""
    out = [f"landmark {lid!r} is clicked in photo {seen_in[lid][0]!r} only; placed "
           f"{_HOW[method]} (+-{uncertainty[lid]:.1f} mm); click it in a second photo"
           for lid, method in placed.items()]
    out += [f"landmark {lid!r} is clicked in photo {seen_in[lid][0]!r} only and cannot be "
            "placed; click it in a second photo" for lid in left_out]
    return out


def _uncertainty_warnings(point_ids: list[str], seen_in: dict[str, list[str]],
                          uncertainty: dict[str, float], params: SfmParams,
                          low_res: frozenset[str]) -> list[str]:
    """The adjusted landmarks more uncertain than ``max_uncertainty_mm``: in one line
    blamed on the resolution when a photo that shows them is low-resolution
    (``low_res``), else each on the viewing directions."""
    poor = [lid for lid in point_ids if uncertainty[lid] > params.max_uncertainty_mm]
    by_res = [lid for lid in poor if set(seen_in[lid]) & low_res]
    out = [f"landmark {lid!r} is poorly determined (+-{uncertainty[lid]:.1f} mm): the "
           f"photos that show it ({', '.join(seen_in[lid])}) see it from similar "
           "directions; click it in a photo taken from another side"
           for lid in poor if lid not in by_res]
    if by_res:
        u = [uncertainty[lid] for lid in by_res]
        out.insert(0, f"landmark(s) {', '.join(repr(lid) for lid in by_res)} are poorly "
                      f"determined (+-{min(u):.1f} to {max(u):.1f} mm) because of the low "
                      "photo resolution; use higher-resolution photos")
    return out


def _in_landmark_order(landmarks: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The same dict in the order of :data:`naseview.landmarks.LANDMARK_IDS`."""
    order = {lid: i for i, lid in enumerate(LANDMARK_IDS)}
    return dict(sorted(landmarks.items(), key=lambda kv: order[kv[0]]))
