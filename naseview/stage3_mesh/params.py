"""Every tunable of stage 3 (paper §3.4), frozen and validated once, where it is made.

Defaults follow the paper where it gives a value (ARAP: 50 iterations; cotangent smoothing:
10 iterations, step 0.1, tolerance 1e-5). A value outside its range fails at construction
with a one-line :class:`~naseview.errors.NaseviewError` naming the field and the range;
an unknown field name fails as for any dataclass. Change a value with
:func:`dataclasses.replace`.

Example
-------
>>> import dataclasses
>>> p = dataclasses.replace(RefineParams(), arap_iterations=20)
>>> p.arap_iterations, p.smooth_step
(20, 0.1)
>>> RefineParams(smooth_step=2.0)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
naseview.errors.NaseviewError: RefineParams.smooth_step: 2.0 is outside (0, 1]; ...
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from naseview.landmarks import CURVE_NAMES, LANDMARK_IDS
from naseview.params import Range, check_flag, check_names, check_number
from naseview.stage3_mesh.silhouette import OUTLINE_CURVES


def _R(low: float, high: float, closed_low: bool, integer: bool,  # noqa: N802
       what: str) -> tuple[Range, str]:
    """A range ``low < x <= high`` (``low <= x`` when ``closed_low``; ``high`` may be
    ``inf`` itself, meaning "no limit")."""
    return Range(low, high, low_open=not closed_low, high_open=False, integer=integer), what


_RANGES: dict[str, tuple[Range, str]] = {
    "n_modes": _R(0, 100_000, True, True, "identity modes used (None: all)"),
    "fit_sigma_mm": _R(0, 50, False, False, "the expected landmark error, mm"),
    "fit_sub_sigma_mm": _R(0, 50, False, False, "the expected sub-landmark error, mm"),
    "fit_iterations": _R(1, 100, True, True, "alternations of similarity and "
                                                 "coefficients"),
    "coeff_limit_sd": _R(0, 10, False, False, "the coefficient clamp, SD"),
    "fit_warn_mm": _R(0, 100, False, False, "the fit residual that warns, mm"),
    "min_handle_spacing_mm": _R(0, 20, True, False, "the least spacing of "
                                                        "sub-landmark handles, mm"),
    "handle_clearance_mm": _R(0, 50, True, False, "the region's clearance around "
                                                      "handles, mm"),
    "margin_mm": _R(0, 20, False, False, "the pinned ring around the region, mm"),
    "warp_bending_mm2": _R(0, 1000, False, False, "the warp's bending weight, mm^2"),
    "warp_radius_mm": _R(0, 200, True, False, "the warp's reach around handles, mm"),
    "unfold_rings": _R(0, 20, True, True, "edge rings of the first unfolding patch "
                                          "(0: no unfolding)"),
    "release_mm": _R(0, math.inf, False, False, "the handle miss that releases it, mm "
                                                    "(inf: none)"),
    "sight_iterations": _R(0, 20, True, True, "fit / line-of-sight placement rounds of "
                                              "one-photo landmarks (0: stage 1's)"),
    "arap_iterations": _R(0, 10_000, True, True, "the ARAP iterations"),
    "fit_silhouette_rounds": _R(0, 50, True, True, "rounds of the profile silhouettes in "
                                                   "the model fit (0: landmarks only)"),
    "fit_silhouette_sigma_mm": _R(0, 50, False, False, "the expected silhouette match "
                                                       "error in the fit, mm"),
    "band_warp_rounds": _R(0, 20, True, True, "rounds of the band warp onto the profile "
                                              "silhouettes (0: none)"),
    "band_warp_max_mm": _R(0, 50, False, False, "the largest band-warp match, mm"),
    "band_warp_half_width_mm": _R(0, 80, True, False, "the band warp's half-width, mm"),
    "profile_above_g_mm": _R(0, 60, True, False, "the profile band's reach above g, mm"),
    "profile_below_sn_mm": _R(0, 40, True, False, "the profile band's reach below sn, mm"),
    "profile_half_width_mm": _R(0, 60, True, False, "the profile band's half-width, mm"),
    "arap_tol_mm": _R(0, 1, True, False, "the ARAP stopping step, mm"),
    "arap_anderson": _R(0, 50, True, True, "the Anderson memory (0: plain ARAP)"),
    "arap_warn_mm": _R(0, math.inf, False, False, "the last ARAP step that warns, mm"),
    "max_handle_displacement_mm": _R(0, 1000, False, False, "the handle displacement "
                                                                "cap, mm"),
    "smooth_iterations": _R(0, 10_000, True, True, "the smoothing iterations"),
    "smooth_step": _R(0, 1, False, False, "the smoothing step (unitless)"),
    "smooth_tol": _R(0, 1, True, False, "the smoothing stopping step, mm"),
    "silhouette_rounds": _R(0, 10, True, True, "rounds of photo-silhouette handles "
                                               "(0: none)"),
    "silhouette_max_mm": _R(0, 20, False, False, "the largest silhouette match, mm"),
    "silhouette_spacing_mm": _R(0, 20, False, False, "the least spacing of silhouette "
                                                     "handles, mm"),
}
"""Numeric field -> allowed range and what it is (the error message's words)."""


@dataclass(frozen=True)
class RefineParams:
    """Every tunable of stage 3. Defaults follow the paper where it gives a value.

    Base fit (:func:`~naseview.stage3_mesh.fit.fit_face_model`, eq. 18):
        n_modes: identity modes used (``None``: all the model has).
        fit_sigma_mm: expected landmark error (mm, SD); the prior weight on the
            coefficients is ``fit_sigma_mm**2`` (MAP with coefficients ~ N(0, 1)).
        fit_sub_sigma_mm: the same for sub-landmarks (their position along the curve is
            less certain than a landmark's).
        fit_iterations: alternations of similarity and coefficients.
        fit_scale: let the similarity scale (else rigid; stage 1 is already in mm).
        coeff_limit_sd: coefficients beyond this many SD are clamped, with a warning.
        fit_warn_mm: a landmark further than this (and than 3x the median) from the fitted
            face gives a "check this click" warning; an RMS misfit above half of it, a
            "the model fits poorly" warning.

    Correspondences and region (:mod:`~naseview.stage3_mesh.correspondences`,
    :func:`~naseview.stage3_mesh.deform.deform_region`):
        use_sublandmarks: use stage 2's sub-landmarks as handles (and in the fit).
        sub_landmark_curves: the curves whose sub-landmarks are used (``None``: all nine,
            the paper's 55). Default: the mid- and ala-curves only. Stage 2's other curves
            are approximations by construction (side-curve: a circle through int and mf;
            sill: a planar outline; bottom and C: silhouettes lifted between landmarks)
            whose sub-landmarks lie 0.6-1.7 mm (mean; up to 6 mm) off the true surface on
            synthetic cases, and used as hard constraints they made the ICT nose worse
            (mean surface error 0.30 mm with mid+ala, 0.44 with bottom and C added, 0.76
            with all; ``benchmarks/bench_stage3.py --synth``).
        handle_landmarks: the landmark ids used as handles (default: all 21).
        min_handle_spacing_mm: a sub-landmark whose vertex lies closer than this to an
            earlier handle (landmarks first) is not used as a handle.
        handle_clearance_mm: the deformed region is the model's nose region grown so that
            every handle lies at least this far (along mesh edges) from the fixed ring.
        margin_mm: width of the ring of vertices around the region pinned to the base, so
            the seam to the unchanged face is continuous (at least one edge ring).

    Smooth warp of the base (naseview's addition; :mod:`~naseview.stage3_mesh.warp`):
        use_warp: bend the fitted face towards the ad-landmarks before ARAP, with soft
            constraints (weights 1 / fit_sigma_mm^2 for landmarks, 1 / fit_sub_sigma_mm^2 for
            sub-landmarks) and a bi-Laplacian smoothness term. It carries the large,
            smooth part of the correction that a low-dimensional model (the generic face)
            cannot; ARAP then only closes the small remainder.
        warp_bending_mm2: weight of the bending term (mm^2): larger is smoother/stiffer.
        warp_radius_mm: the warp acts within this distance (along edges) of the handles.
        unfold_rings: triangles the warp turned over against the fitted face (a flap out
            of a nostril, a slit along the alar groove; issue 27) are smoothed out before
            ARAP, whose rest shape the warped face is:
            :func:`~naseview.geometry.unfold.unfold` of the warp's displacement, from
            this many edge rings around them (0: left as they are).
        release_mm: a handle still further than this from its target after the warp
            contradicts its neighbours on this face model (e.g. a landmark convention the
            model does not share); it is not made a hard ARAP constraint (warning), which
            would crumple the mesh around it. ``inf`` keeps every handle (the paper).
            With ``keep_landmarks`` this applies to sub-landmarks only.
        keep_landmarks: a landmark handle is released only when stage 1 names its click
            as suspect (``extra.suspect_clicks``): the mesh passes through every accepted
            click; ``False``: landmarks are released by ``release_mm`` like sub-landmarks.
        slide_landmarks: a landmark whose model vertex the smooth base misses by more than
            ``release_mm`` (a nose the model cannot reach: the miss is along the skin) is
            held at the base vertex nearest to it instead
            (:func:`~naseview.stage3_mesh.solve.slide_far_landmarks`), so ARAP does not
            drag the skin sideways; the mesh still passes through the click.
        warp_carries_landmarks: a slid landmark that the smooth base already passes
            within max(0.2 mm, its stated uncertainty) of is not a hard ARAP handle (the
            warp carries it); it is held only if ARAP then moves the skin beyond that.
        sight_iterations: landmarks clicked in one photo are placed where their line of
            sight meets the fitted face, alternating fit and placement this many times
            (:mod:`~naseview.stage3_mesh.sightline`; 0: keep stage 1's symmetry/template
            placement). The placement is fused with stage 1's on the same ray by inverse
            variance, and only where the face states the smaller uncertainty
            (:func:`naseview.pipeline.run_stage3`). On (3) since bench_real's ablation:
            james-b 0.859 -> 0.797 mm, in-model 0.291 -> 0.277, james-a 0.653 -> 0.661,
            the rest unchanged; +0.25 s a case.

    ARAP (eq. 19-20; paper: Open3D ARAP, 50 iterations):
        use_arap: run ARAP (``False``: only the base fit, for the ablation).
        arap_iterations: maximum ARAP iterations (paper 50).
        arap_tol_mm: stop early when one iteration moves no vertex more than this (mm).
        arap_anderson: Anderson acceleration memory of the local-global iterations
            (Peng et al., SIGGRAPH 2018; 0: plain iterations as libigl and the paper).
        arap_warn_mm: still moving more than this per iteration at the end -> warning.
        max_handle_displacement_mm: a handle asked to move further than this from its base
            position is pulled back to this distance, with a warning (a wrong click must
            not crumple the nose).

    Smoothing (eq. 21; paper: cotangent Laplacian smoothing, 10 iterations, step 0.1,
    tol 1e-5):
        use_smoothing: run the smoothing.
        smooth_iterations, smooth_step, smooth_tol: ``v <- v + step * D^-1 L v`` on the free
            vertices (D the diagonal of the cotangent Laplacian L, so the step is unitless
            and the iteration is stable), handles and ring fixed; stops when no vertex moves
            more than ``smooth_tol`` mm.
        smooth_displacement: smooth the displacement from the base (default) instead of
            the positions as the paper does: smoothing positions also flattens the base's
            own shape (tip, alar creases) and measurably raises the surface error (see
            ``benchmarks/bench_stage3.py``); smoothing the displacement only evens out
            what ARAP changed and leaves an unedited nose exactly as it was.

    Photo silhouettes (issue 11; :mod:`~naseview.stage3_mesh.silhouette`):
        silhouette_rounds: after the ARAP solve, at most this many rounds of matching
            the nose's occluding contour in the profile photos to their silhouettes, each
            adding the matched contour vertices as hard handles and solving again (0:
            none); the rounds stop early at their fixed point (a round matching the
            handles of the round before). Each match is capped at ``silhouette_max_mm``,
            so a profile far from the photo needs several rounds to reach it. On since
            bench_real's ablation (2 rounds, ``mid_handles`` off): james-a 0.661 -> 0.637
            mm, james-b 0.797 -> 0.739 (p95 2.01 -> 1.68), cross-model (10 cases each way)
            0.689 -> 0.679 and 0.865 -> 0.851, in-model 0.277 -> 0.276. 6 rounds since
            the next ablation (row "2 silh. rounds" against the default, deterministic
            metric): james-b 0.739 -> 0.728 (ICT) and 0.775 -> 0.670 (generic),
            scan-3px generic 0.741 -> 0.731, scan-james generic 0.641 -> 0.635,
            cross-model 0.678 -> 0.675 and 0.845 -> 0.835; the ICT base on james-a,
            scan-james and scan-3px within +0.004; +0.1-0.7 s a case.
        silhouette_max_mm: a contour vertex further than this from the silhouette (at its
            depth, perpendicular to the line of sight) is not matched.
        silhouette_spacing_mm: least spacing of silhouette handles from each other and
            from the other handles.
        silhouette_detrend: take out of each photo's contour offsets the part a 2D rigid
            motion of the image explains (the camera's pose error).
        mid_handles: the mid-curve sub-landmarks are hard ARAP handles; ``False`` (with
            ``silhouette_rounds``): they shape the fit and the warp only, and the
            silhouette handles hold the profile. ``None`` (default): kept where the fit
            uses fewer identity modes than there are landmarks (21): such a model cannot
            even interpolate the landmarks, and its profile between them needs the
            curve's handles before the silhouettes (the built-in generic face, 9 modes);
            dropped with a richer model (ICT, 100). Chosen by bench_real's ablation
            (rows "silh. drop mid" / "silh. keep mid" against the default): on the
            generic base kept is better on james-b 0.699 -> 0.670 mm, scan-3px 0.741 ->
            0.731, ict->generic 0.851 -> 0.835, level on scan-james (0.636 -> 0.635),
            slightly worse on james-a (0.559 -> 0.562); on the ICT base kept is worse
            (james-a 0.638 -> 0.647, james-b 0.728 -> 0.756).
        outline_curves: pieces of stage 2's curves that trace the nose's outline over
            the face (``"bottom_l"``, ``"bottom_r"``, ``"bottom_tip"`` in the bottom
            photo, ``"ala_l"``, ``"ala_r"`` in the front photo;
            :data:`~naseview.stage3_mesh.silhouette.OUTLINE_CURVES`) matched in the same
            rounds as the profile silhouettes, where stage 2 found the curve in the photo
            (flag ``"image"``). Default: none, for speed: the alar outlines of both
            photos (``("bottom_l", "bottom_r", "ala_l", "ala_r")``) cost up to 0.7 s a
            case (2.0 -> 2.7 s on ICT->generic, past the 2 s target: a full-mesh depth
            raster per outline and round) for bench_real's gains (nose surface mean,
            without -> with): james-a 0.637 -> 0.633 (ICT),
            scan-james 0.591 -> 0.584 (ICT), 0.646 -> 0.639 (generic), ICT->generic
            0.851 -> 0.846, the rest within +-0.002; the tip piece ``"bottom_tip"`` made
            james-a worse (0.637 -> 0.658) and is left out.
        fit_silhouette_rounds: rounds in which the model fit (eq. 18) also matches the
            profile photos' silhouettes over the profile band (issue 23,
            :func:`~naseview.stage3_mesh.fit.fit_face_model`): the base face is fitted
            to the evidence, not to the 21 landmark vertices alone (0: landmarks only).
        fit_silhouette_sigma_mm: the expected error of one silhouette match in that fit
            (its rows weigh ``1 / sigma^2`` beside the landmarks' ``fit_sigma_mm``).
        band_warp_rounds, band_warp_max_mm: on a base whose fit does not match the band
            (:attr:`profile_band_used` off, the generic face), at most this many rounds
            of bending the band outside the nose onto the profile silhouettes before ARAP,
            each match at most this far (:mod:`~naseview.stage3_mesh.band_warp`; 0: none).
        profile_above_g_mm, profile_below_sn_mm, profile_half_width_mm: the profile
            band (:func:`~naseview.stage3_mesh.profile_band.profile_band`): the face near
            the midline from above g (the glabella, read by the nasofrontal angle) to
            below sn (the upper lip, read by the nasolabial angle) whose outline the
            profile photos show; matched in the fit and in the silhouette rounds, so
            the deformed region grows over it.
        profile_band_used: whether the band is matched (True), only the nose (False), or
            ``None``: automatic, with a face model that has at least as many modes as
            landmarks (ICT, not the generic face; the rule of :attr:`mid_handles`).
            bench_real (SPEC §6 nose surface mean, ICT base, without -> with the band):
            james-a 0.769 -> 0.735, james-b 1.000 -> 0.921, lps-a 0.983 -> 0.847, lps-b
            1.243 -> 1.224, synth --scan james 0.77 -> 0.72, lps 1.12 -> 1.00, in-model
            0.29 -> 0.29; nasolabial angle error -5.9/-15.3/-36.5/-37.6 ->
            +3.4/+3.5/-8.2/-12.6 deg. On the generic face (whose lip its 9 modes cannot
            bend, and whose band matches past ``silhouette_max_mm`` are left out) the
            band moved james-a 0.907 -> 1.020 and lps-a 1.045 -> 0.909 mm and the
            nasolabial error of lps-b from -34 to -91 deg: off there.

    Raises:
        NaseviewError: a value outside its range (the message names the field and range).
    """

    n_modes: int | None = None
    fit_sigma_mm: float = 1.0
    fit_sub_sigma_mm: float = 2.0
    fit_iterations: int = 6
    fit_scale: bool = True
    coeff_limit_sd: float = 3.5
    fit_warn_mm: float = 5.0
    use_sublandmarks: bool = True
    sub_landmark_curves: tuple[str, ...] | None = ("mid", "ala_l", "ala_r")
    handle_landmarks: tuple[str, ...] = LANDMARK_IDS
    min_handle_spacing_mm: float = 2.0
    handle_clearance_mm: float = 6.0
    margin_mm: float = 3.0
    use_warp: bool = True
    warp_bending_mm2: float = 0.5
    warp_radius_mm: float = 25.0
    unfold_rings: int = 1
    release_mm: float = 1.0
    keep_landmarks: bool = True
    slide_landmarks: bool = True
    warp_carries_landmarks: bool = False
    sight_iterations: int = 3
    use_arap: bool = True
    arap_iterations: int = 50
    arap_tol_mm: float = 1e-3
    arap_anderson: int = 5
    arap_warn_mm: float = 1e-2
    max_handle_displacement_mm: float = 10.0
    use_smoothing: bool = True
    smooth_iterations: int = 10
    smooth_step: float = 0.1
    smooth_tol: float = 1e-5
    smooth_displacement: bool = True
    silhouette_rounds: int = 6
    silhouette_max_mm: float = 3.0
    silhouette_spacing_mm: float = 1.0
    silhouette_detrend: bool = True
    mid_handles: bool | None = None
    outline_curves: tuple[str, ...] = ()
    fit_silhouette_rounds: int = 3
    fit_silhouette_sigma_mm: float = 1.0
    band_warp_rounds: int = 3
    band_warp_max_mm: float = 8.0
    band_warp_half_width_mm: float = 30.0
    profile_above_g_mm: float = 10.0
    profile_below_sn_mm: float = 15.0
    profile_half_width_mm: float = 12.0
    profile_band_used: bool | None = None

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in _RANGES:
                if not (f.name == "n_modes" and value is None):
                    check_number("RefineParams", f.name, value, *_RANGES[f.name])
            elif f.name == "sub_landmark_curves":
                if value is not None:
                    check_names("RefineParams", f.name, value, CURVE_NAMES)
            elif f.name == "outline_curves":
                check_names("RefineParams", f.name, value, tuple(OUTLINE_CURVES))
            elif f.name == "handle_landmarks":
                check_names("RefineParams", f.name, value, LANDMARK_IDS)
            elif f.name in ("mid_handles", "profile_band_used") and value is None:
                pass                                    # automatic, per face model
            else:
                check_flag("RefineParams", f.name, value)

    def keeps_mid_handles(self, model_modes: int) -> bool:
        """Whether the mid-curve sub-landmarks are hard handles with a face model of
        ``model_modes`` identity modes (:attr:`mid_handles`; ``None``: when the fit uses
        fewer modes than there are landmarks)."""
        if self.mid_handles is not None:
            return self.mid_handles
        used = model_modes if self.n_modes is None else min(self.n_modes, model_modes)
        return used < len(LANDMARK_IDS)

    def uses_profile_band(self, model_modes: int) -> bool:
        """Whether the fit and the silhouette rounds match the profile band beyond the
        nose (:attr:`profile_band_used`; ``None``: with a face model rich enough to
        follow the profile, the one that drops the mid-curve handles,
        :meth:`keeps_mid_handles`)."""
        if self.profile_band_used is not None:
            return self.profile_band_used
        return not self.keeps_mid_handles(model_modes)
