"""Every tunable of stage 1 (paper §3.2, the bundle adjustment of eq. 1), checked once.

:class:`SfmParams` is a frozen dataclass: an unknown name fails at construction, a value
outside its range fails in ``__post_init__`` with a one-line
:class:`~naseview.errors.NaseviewError` naming the field and the allowed range; change a
value with :func:`dataclasses.replace`.

Example
-------
>>> from dataclasses import replace
>>> replace(SfmParams(), loss_scale_px=2.0).loss_scale_px
2.0
>>> SfmParams(loss_scale_px=0.0)  # doctest: +ELLIPSIS
Traceback (most recent call last):
    ...
naseview.errors.NaseviewError: SfmParams.loss_scale_px: 0.0 is outside (0, 100]; ...
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from naseview.params import Range, check_choice, check_flag, check_number

LOSSES: tuple[str, ...] = ("linear", "huber", "soft_l1", "cauchy", "arctan")
"""Robust losses of :func:`scipy.optimize.least_squares` that stage 1 accepts."""

TR_SOLVERS: tuple[str, ...] = ("exact", "lsmr")
"""Trust-region solvers of :func:`scipy.optimize.least_squares` that stage 1 accepts."""


def _closed(low: float, high: float, meaning: str,
            integer: bool = False) -> tuple[Range, str]:
    return Range(low, high, integer=integer), meaning


def _positive(high: float, meaning: str) -> tuple[Range, str]:
    return Range(0.0, high, low_open=True), meaning


_RANGES: dict[str, tuple[Range, str]] = {
    "loss_scale_px": _positive(100.0, "residual (px) where the robust loss flattens"),
    "max_iterations": _closed(1, 100_000, "residual evaluations of one solve", integer=True),
    "rig_yaw_deg": _closed(-180.0, 180.0, "prior yaw (deg) of the profile cameras"),
    "bottom_elevation_deg": _closed(-90.0, 90.0, "prior elevation (deg) of the bottom camera"),
    "hypothesis_step_deg": _closed(0.0, 90.0, "offset (deg) of the other rig hypotheses"),
    "accept_rmse_px": _closed(0.0, 1000.0, "inlier RMSE (px) that ends the hypotheses"),
    "resection_rounds": _closed(0, 100, "rounds of resection and triangulation",
                                integer=True),
    "focal_guess": _positive(100.0, "initial focal length / larger image side"),
    "focal_coupling": _closed(0.0, 10.0, "sd of log(f_photo / f_mean); 0 disables it"),
    "focal_prior_sd": _closed(0.0, 100.0, "sd of log(f / guess); 0 disables it"),
    "max_focal_factor": (Range(0.25, 1000.0, low_open=True),
                         "largest plausible focal length / larger image side"),
    "tolerance": (Range(0.0, 1.0, low_open=True, high_open=True),
                  "xtol, ftol and gtol of least_squares"),
    "min_clicks_per_photo": _closed(1, 21, "landmark clicks needed per photo", integer=True),
    "min_spread_ratio": _closed(0.0, 1.0, "ratio of the 2D singular values of the clicks"),
    "max_rmse_px": _positive(1000.0, "inlier RMSE (px) above which the fit fails"),
    "max_suspect_fraction": _closed(0.0, 1.0, "fraction of suspect clicks allowed"),
    "suspect_min_px": _closed(0.0, 1000.0, "smallest residual (px) of a suspect click"),
    "suspect_factor": _closed(1.0, 100.0, "suspect residual / median residual"),
    "min_sigma_px": _closed(0.0, 100.0, "floor of the click noise (px)"),
    "outlier_alpha": (Range(0.0, 0.5, low_open=True),
                      "false-alarm probability of the click chi-square tests"),
    "min_px_per_mm": _closed(0.0, 1000.0, "photo resolution (px per mm at the nose) "
                                          "below which a warning is given"),
    "max_uncertainty_mm": _positive(1000.0, "3D uncertainty (mm) that gets a warning"),
    "max_asymmetry_mm": _positive(100.0, "distance (mm) off the midline or from the mirror "
                                         "image, beyond 1 sd, that gets a warning"),
    "max_view_angle_deg": _closed(0.0, 180.0, "angle (deg) from its view's direction above "
                                              "which a camera closer to another is swapped"),
    "max_roll_deg": _closed(0.0, 180.0, "roll (deg) of a photo above which it is "
                                        "reported rotated"),
    "symmetry_sd_mm": _positive(100.0, "sd (mm) of the symmetry and midline constraints"),
    "template_sd_mm": _positive(1000.0, "sd (mm) of the template depth prior"),
    "max_single_view_sd_mm": _positive(1000.0, "largest depth sd (mm) of a one-photo "
                                               "landmark"),
}

_CHOICES: dict[str, tuple[str, ...]] = {"loss": LOSSES, "tr_solver": TR_SOLVERS}

_FLAGS: tuple[str, ...] = ("presolve_lm", "drop_suspects", "symmetric_fill")


@dataclass(frozen=True)
class SfmParams:
    """Every tunable of stage 1, with its default.

    Attributes:
        loss: robust loss of :func:`scipy.optimize.least_squares` (``"linear"``,
            ``"huber"``, ``"soft_l1"``, ``"cauchy"``, ``"arctan"``), applied per pixel
            coordinate.
        loss_scale_px: residual (px) where the robust loss starts to flatten.
        max_iterations: cap on residual evaluations of one least-squares solve.
        rig_yaw_deg: prior yaw of the left / right cameras from the front (degrees).
        bottom_elevation_deg: prior elevation of the bottom camera below the front one.
        hypothesis_step_deg: offset of the alternative rig hypotheses (degrees).
        accept_rmse_px: stop trying rig hypotheses once the inlier RMSE is below this.
        resection_rounds: rounds of per-photo resection (PnP) and re-triangulation that
            refine the initial cameras before the bundle adjustment.
        focal_guess: initial focal length as a multiple of the larger image side, for
            photos without known intrinsics.
        focal_coupling: soft prior tying the per-photo focal lengths together: the
            standard deviation of log(f_photo / f_mean) (0.1: photos within ~10 % of each
            other, as with one phone; ~0.02 means "same camera, same zoom"; give the focal
            lengths in case.json when photos were taken at different zooms). Without it a
            photo with few, shallow landmarks (the bottom one) can drift towards an
            infinite focal length, because focal length and distance are nearly
            interchangeable there. 0 disables it.
        focal_prior_sd: very weak prior on the mean focal length of the photos without
            known intrinsics: sd of log(f / (focal_guess x larger image side)) (3: a factor
            20 is one sd). It only keeps all photos from drifting together to an infinite
            focal length (orthographic), where a depth-reversed nose fits as well; when the
            clicks barely constrain the focal length it still pulls it a few percent
            towards the guess. 0 disables it.
        max_focal_factor: a focal length above this multiple of the larger image side
            (nearly orthographic: depth may be reversed) or below a quarter of it gets a
            warning.
        tr_solver: trust-region solver of ``least_squares``: ``"exact"`` (dense SVD, the
            fastest for ~21 landmarks x 4 photos) or ``"lsmr"`` (sparse Jacobian).
        presolve_lm: start the robust trf solve from a Levenberg-Marquardt solution with
            the squared loss (faster; same minimum).
        tolerance: ``xtol``, ``ftol`` and ``gtol`` of ``least_squares``. 1e-10: the
            focal length and the camera distance trade off along a flat valley, and at
            1e-6 the solve stopped anywhere in it (cameras 1 px / 1 mm apart, landmarks
            2 um) with last-bit noise of numpy's sums, which depend on what ran before;
            stage 3's discrete choices made that meshes 0.2 mm apart for one case run
            twice in one process (james-a, generic base). At 1e-10 they are 0.007 px /
            2e-5 mm apart and the meshes the same; stage 1 29 -> 34 ms median
            (bench_stage1), the same Table 1.
        min_clicks_per_photo: fewer landmark clicks in a photo is an error.
        min_spread_ratio: a photo whose clicks are thinner than this fraction of their
            length (ratio of the 2D singular values) is "collinear" and an error.
        max_rmse_px: inlier reprojection RMSE above this after all hypotheses means the
            adjustment failed (error).
        max_suspect_fraction: more suspect clicks than this fraction also means failure.
        suspect_min_px, suspect_factor: a click is suspect when its residual exceeds
            ``max(suspect_min_px, suspect_factor * median residual)``.
        min_sigma_px: floor of the click noise (px) used for the 3D uncertainty.
        outlier_alpha: false-alarm probability of the chi-square tests on the clicks
            (leave-one-click-out attribution of suspect clicks, midline offsets).
        min_px_per_mm: a photo with fewer pixels per mm at the nose (focal length /
            median depth of its landmarks) gets a warning. Measured by the resolution
            sweep of ``benchmarks/bench_clicks.py`` (generic cases, seeds 1-4, 1.5 px
            click noise; lowest photo's px/mm -> Table 1 mean error): 8.3 -> 0.192 mm
            (1024 px), 6.2 -> 0.248 (768), 5.2 -> 0.282 (640), 4.1 -> 0.351 (512), 2.1 ->
            0.571 (256), 1.6 -> 0.674 (200), 1.0 -> 1.301 mm (120 px); the error passes
            1.5x its 1024-px value at about 5 px per mm.
        max_uncertainty_mm: a landmark with a larger 3D uncertainty gets a warning.
        max_asymmetry_mm: a midline landmark farther than this from the midsagittal plane,
            or a left/right pair whose mirror images are farther apart, beyond their
            uncertainty (1 sd), gets a warning worded as a finding to confirm (a sideways
            front-photo click, or a deviated nose).
        max_view_angle_deg: a camera whose viewing direction is farther than this from its
            view's (front along -z, left along -x, right along +x, bottom from below at
            ``bottom_elevation_deg``) and closer to another view's gets a swap warning.
        max_roll_deg: a photo whose subject's up is rolled by more than this from the
            image's up gets a rotation (EXIF orientation) warning.
        drop_suspects: re-solve once without suspect clicks that leave-one-out
            triangulation pins on one photo (landmarks clicked in 3+ photos); they are
            reported as ignored.
        symmetric_fill: place a landmark clicked in one photo only on its viewing ray
            (:func:`naseview.stage1_landmarks.single_view.place_single`: symmetry,
            midline plane, template depth); else it is left out.
        symmetry_sd_mm: how far (sd, mm) a landmark may be from the mirror image of its
            partner, or a midline landmark from the midsagittal plane.
        template_sd_mm: sd (mm) of the weak depth prior from the generic nose template.
        max_single_view_sd_mm: a one-photo landmark whose depth is more uncertain than
            this is left out.

    Raises:
        NaseviewError: a field outside its range (the message names the field and the
            range), a string that is not one of its choices, a flag that is not a bool.
    """

    loss: str = "huber"
    loss_scale_px: float = 3.0
    max_iterations: int = 200
    rig_yaw_deg: float = 90.0
    bottom_elevation_deg: float = 50.0
    hypothesis_step_deg: float = 20.0
    accept_rmse_px: float = 4.0
    resection_rounds: int = 3
    focal_guess: float = 2.0
    focal_coupling: float = 0.1
    focal_prior_sd: float = 3.0
    max_focal_factor: float = 8.0
    tr_solver: str = "exact"
    presolve_lm: bool = True
    tolerance: float = 1e-10
    min_clicks_per_photo: int = 6
    min_spread_ratio: float = 0.03
    max_rmse_px: float = 8.0
    max_suspect_fraction: float = 0.25
    suspect_min_px: float = 3.0
    suspect_factor: float = 4.0
    min_sigma_px: float = 0.5
    outlier_alpha: float = 0.01
    min_px_per_mm: float = 5.0
    max_uncertainty_mm: float = 3.0
    max_asymmetry_mm: float = 1.0
    max_view_angle_deg: float = 30.0
    max_roll_deg: float = 45.0
    drop_suspects: bool = True
    symmetric_fill: bool = True
    symmetry_sd_mm: float = 1.0
    template_sd_mm: float = 4.0
    max_single_view_sd_mm: float = 5.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in _RANGES:
                check_number("SfmParams", f.name, value, *_RANGES[f.name])
            elif f.name in _CHOICES:
                check_choice("SfmParams", f.name, value, _CHOICES[f.name])
            elif f.name in _FLAGS:
                check_flag("SfmParams", f.name, value)
            else:  # a new field must be given a check
                raise AssertionError(f"SfmParams.{f.name} has no check")
