"""Every tunable of stage 2 (paper section 3.3) in one dataclass.

The app binds sliders to these fields; :func:`naseview.stage2_curves.extract.extract_curves`
caches each step on the fields it reads, so changing one field re-runs only the steps
that depend on it.

The dataclass is frozen and checks every field when it is made: a value outside its range
raises :class:`CurveParamsError` naming the field and the range, an unknown field name a
``TypeError``. Change a value with :func:`dataclasses.replace`.

Example
-------
>>> from dataclasses import replace
>>> p = CurveParams(closing_px=7)
>>> p.total_sub_landmarks()
55
>>> try:
...     replace(p, lift_weight=1.5)
... except CurveParamsError as e:
...     print(str(e).split(";")[0])
CurveParams.lift_weight: 1.5 is outside [0, 1]
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from numbers import Integral

from naseview.errors import NaseviewError
from naseview.landmarks import CURVE_NAMES
from naseview.params import Range, check_choice, check_number

DEFAULT_SUB_LANDMARKS: dict[str, int] = {
    "mid": 12, "bottom": 12, "ala_l": 5, "ala_r": 5, "c": 5,
    "sill_l": 5, "sill_r": 5, "side_l": 3, "side_r": 3,
}
"""Sub-landmarks per curve; 55 in all, so 21 + 55 = 76 ad-landmarks as in the paper."""


class CurveParamsError(NaseviewError, ValueError):
    """A :class:`CurveParams` field out of its range (one line: field, value, range).

    Also a :class:`ValueError`, which is what the checks raised before they moved into
    the constructor.
    """


_AT_LEAST_0 = Range(0.0)
_POSITIVE = Range(0.0, low_open=True)

_INT_FIELDS: frozenset[str] = frozenset({"border_px", "mask_clean_px", "roi_margin_px",
                                         "closing_px", "nostril_min_area_px"})
"""Fields that hold a whole number of pixels."""

_RANGES: dict[str, tuple[Range, str]] = {
    "border_px": (Range(1.0), "width (px) of the border that gives the background colour"),
    "hue_tol": (_AT_LEAST_0, "hue tolerance of the background box (OpenCV hue units)"),
    "sat_tol": (_AT_LEAST_0, "saturation tolerance of the background box"),
    "val_tol": (_AT_LEAST_0, "value tolerance of the background box"),
    "grey_sat": (Range(0.0, 255.0), "background saturation below which hue is not used"),
    "border_min_inlier": (Range(0.0, 1.0), "fraction of border pixels of background colour"),
    "mask_clean_px": (_AT_LEAST_0, "size (px) of the mask opening/closing, 0 = none"),
    "silhouette_tol": (_POSITIVE, "fraction of the g-sn length in the photo"),
    "edge_blur_sigma": (_AT_LEAST_0, "Gaussian blur (px) before Scharr, 0 = none"),
    "edge_ref_percentile": (Range(0.0, 100.0, low_open=True),
                            "percentile of the edge magnitude that counts as full strength"),
    "path_cost_exponent": (_POSITIVE, "exponent of (1 - E) in the path cost (eq. 12)"),
    "path_cost_floor": (_POSITIVE, "cost floor that keeps paths short on flat skin"),
    "corridor_px": (Range(1.0), "smallest half-width (px) of the path corridor"),
    "corridor_frac": (_AT_LEAST_0, "corridor half-width as a fraction of the segment"),
    "path_prior_weight": (_AT_LEAST_0, "0 is the paper's cost"),
    "path_min_contrast": (_AT_LEAST_0, "times the median edge strength of the nose region"),
    "path_smooth_px": (_AT_LEAST_0, "Gaussian smoothing (px) of the paths, 0 = none"),
    "roi_margin_px": (_AT_LEAST_0, "margin (px) around the landmarks of a view"),
    "dark_ratio": (Range(0.0, 1.0, low_open=True, high_open=True),
                   "dark = below this times the median value of the nose region"),
    "closing_px": (_AT_LEAST_0, "diameter (px) of the closing element of eq. 13, 0 = none"),
    "nostril_min_area_px": (Range(1.0), "smallest dark area (px^2) taken as a nostril"),
    "nostril_search_frac": (_POSITIVE, "fraction of the al''-al'' distance"),
    "side_w_ratio": (_POSITIVE, "w2 / w1 of eq. 15, the paper's 1"),
    "side_h_ratio": (_POSITIVE, "h2 / h1 of eq. 15, the paper's 3"),
    "side_bulge": (Range(-0.5, 0.5), "fraction of the int-mf distance, 0 is the paper's"),
    "lift_weight": (Range(0.0, 1.0),
                    "0.5 is the paper's midpoint of eq. 10, 1 the point on the line of sight"),
    "curve_spacing_mm": (_POSITIVE, "spacing (mm) of the output polylines"),
}
"""Allowed range and a reminder of the meaning of every numeric field."""

_DARK_THRESHOLD = Range(0.0, 255.0, low_open=True, high_open=True)
_MID_TRACES: tuple[str, ...] = ("contour", "rows")


def _fail(name: str, message: str) -> CurveParamsError:
    return CurveParamsError(f"CurveParams.{name}: {message}")


def _check_number(name: str, value: object, allowed: Range, hint: str) -> None:
    """One numeric field: an integer (pixel counts) or a real number inside ``allowed``."""
    if name in _INT_FIELDS:
        allowed = replace(allowed, integer=True)
    check_number("CurveParams", name, value, allowed, hint, error=CurveParamsError)


def _check_sub_landmarks(counts: object) -> None:
    """Known SPEC §5 curve names, each with a whole count >= 0."""
    if not isinstance(counts, dict):
        raise _fail("sub_landmarks", f"{counts!r} is not a dict curve name -> count")
    unknown = sorted(set(map(str, counts)) - set(CURVE_NAMES))
    if unknown:
        raise _fail("sub_landmarks", f"unknown curve {', '.join(unknown)}; the curves are "
                                     f"{', '.join(CURVE_NAMES)}")
    for name, k in counts.items():
        if isinstance(k, bool) or not isinstance(k, Integral) or k < 0:
            raise _fail("sub_landmarks", f"{name}: {k!r} is outside [0, inf); sub-landmarks "
                                         "on that curve")


@dataclass(frozen=True)
class CurveParams:
    """Parameters of the boundary-curve stage (paper section 3.3).

    Background mask (eq. 2-3), used for the mid-curve in the left and right photos:

    Attributes:
        border_px: width (px) of the image border whose dominant HSV colour is taken as
            the background colour.
        hue_tol: hue tolerance (OpenCV hue units, 0..180) of the background threshold
            T_thresh; ignored when the background is nearly grey (saturation below
            ``grey_sat``).
        sat_tol: saturation tolerance (0..255) of T_thresh.
        val_tol: value (brightness) tolerance (0..255) of T_thresh.
        grey_sat: background saturation (0..255) below which hue is not used.
        border_min_inlier: fraction of border pixels that must match the background colour;
            below it the photo's border is not a uniform background (warning, fallback).
            The subject often touches the border of a tight crop, hence well below 1.
        mask_clean_px: size (px) of the opening/closing that removes specks from the mask.
        mid_trace: ``"contour"`` follows the silhouette contour from g to sn (keeps the
            near-horizontal c-sn part); ``"rows"`` is eq. 3 literally (first foreground
            pixel per row, from the anterior side).
        silhouette_tol: largest median distance (as a fraction of the g-sn length in the
            photo) between the mid-curve landmarks and the silhouette before a view's
            profile is rejected.

    Edges and least-cost paths (eq. 11-12), for the bottom-, ala- and C-curves:

    Attributes:
        edge_blur_sigma: Gaussian blur (px) before the Scharr filter (0 = none).
        edge_ref_percentile: percentile of the Scharr magnitude (eq. 11) inside the nose
            region that counts as a full-strength edge (robust version of max(M)).
        path_cost_exponent: cost of stepping onto a pixel is ``floor + (1 - E)^exponent``
            times the step length, E the edge strength in 0..1 (eq. 12).
        path_cost_floor: see ``path_cost_exponent``; keeps paths short on flat skin.
        corridor_px: smallest half-width (px) of the search corridor around the straight
            segment between two consecutive landmarks.
        corridor_frac: corridor half-width as a fraction of the segment length (the larger
            of the two is used).
        path_prior_weight: beyond the paper: weight of a penalty ``(d / corridor)^2`` on
            the distance d (px) from the smooth curve through the landmarks, which keeps
            a path on the edge it should follow when a stronger edge runs nearby (0 = the
            paper's cost).
        path_min_contrast: a found path is trusted only if its mean edge strength is at
            least this many times the median strength of the photo's nose region;
            otherwise there is no edge to follow (warning, the segment is interpolated
            through its landmarks instead).
        path_smooth_px: Gaussian smoothing (px of arc length) of the pixel paths.
        roi_margin_px: margin (px) around the landmarks of a view in which edges are
            computed.

    Nostrils (eq. 13-14), for the nasal sills in the bottom photo:

    Attributes:
        dark_ratio: a pixel is dark when its value (HSV V) is below ``dark_ratio`` times
            the median value of the nose region (used when ``dark_threshold`` is None).
        dark_threshold: fixed value threshold (0..255); None = automatic from dark_ratio.
        closing_px: diameter (px) of the elliptical structuring element B of eq. 13.
        nostril_min_area_px: smallest dark area (px^2) accepted as a nostril.
        nostril_search_frac: a nostril must come within this fraction of the al''-al''
            distance of its al'' landmark.

    Side-curve (eq. 15-17), see :mod:`naseview.stage2_curves.side`:

    Attributes:
        side_w_ratio: w2 / w1 (paper: 1), horizontal split of int -> tmp -> mf.
        side_h_ratio: h2 / h1 (paper: 3), rise next to int over rise next to mf.
        side_bulge: beyond the paper: tmp moved towards the midline by this fraction of
            the int-mf distance (0 = the paper's circle). The default was calibrated on
            synthetic ICT cases (seeds 100-119, not the benchmark's).

    Lifting (eq. 4-10) and output:

    Attributes:
        lift_weight: position between the two closest points of eq. 8-9: 0.5 is the
            paper's midpoint (eq. 10); 1.0 (default) keeps the point on the line of sight,
            so the 3D curve reprojects exactly onto the image evidence and only the depth
            comes from the line through the two nearest landmarks.
        curve_spacing_mm: spacing of the output 3D polylines (mm).
        sub_landmarks: sub-landmarks per curve (SPEC curve name -> count).
    """

    border_px: int = 12
    hue_tol: float = 10.0
    sat_tol: float = 25.0
    val_tol: float = 60.0
    grey_sat: float = 40.0
    border_min_inlier: float = 0.4
    mask_clean_px: int = 3
    mid_trace: str = "contour"
    silhouette_tol: float = 0.06
    edge_blur_sigma: float = 1.0
    edge_ref_percentile: float = 98.0
    path_cost_exponent: float = 2.0
    path_cost_floor: float = 0.02
    corridor_px: float = 10.0
    corridor_frac: float = 0.35
    path_prior_weight: float = 1.0
    path_min_contrast: float = 2.0
    path_smooth_px: float = 2.0
    roi_margin_px: int = 40
    dark_ratio: float = 0.5
    dark_threshold: float | None = None
    closing_px: int = 5
    nostril_min_area_px: int = 30
    nostril_search_frac: float = 0.25
    side_w_ratio: float = 1.0
    side_h_ratio: float = 3.0
    side_bulge: float = 0.06
    lift_weight: float = 1.0
    curve_spacing_mm: float = 0.5
    sub_landmarks: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_SUB_LANDMARKS))

    def __post_init__(self) -> None:
        """Check every field (see the class docstring for the meanings)."""
        for f in fields(self):
            if f.name in _RANGES:
                allowed, hint = _RANGES[f.name]
                _check_number(f.name, getattr(self, f.name), allowed, hint)
        check_choice("CurveParams", "mid_trace", self.mid_trace, _MID_TRACES,
                     error=CurveParamsError)
        if self.dark_threshold is not None:
            _check_number("dark_threshold", self.dark_threshold, _DARK_THRESHOLD,
                          "fixed value threshold (0..255), None = automatic")
        _check_sub_landmarks(self.sub_landmarks)

    def total_sub_landmarks(self) -> int:
        """Sum of ``sub_landmarks`` (55 by default)."""
        return int(sum(self.sub_landmarks.values()))

    def subset(self, *names: str) -> dict[str, object]:
        """The named fields as a dict (used as cache keys of the steps reading them)."""
        return {n: (dict(v) if isinstance(v := getattr(self, n), dict) else v) for n in names}
