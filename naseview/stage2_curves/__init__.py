"""Stage 2 (paper section 3.3): the six boundary curves and the 76 ad-landmarks.

The stage (:func:`extract_curves`, :mod:`~naseview.stage2_curves.extract`) makes each
curve in the module named after it, from the geometric steps below:

- :mod:`~naseview.stage2_curves.curve_mid`: mid-curve from the side photos' silhouettes;
- :mod:`~naseview.stage2_curves.curve_edges`: bottom-, ala- and C-curves along edges;
- :mod:`~naseview.stage2_curves.curve_sills`: nasal sills from the dark nostrils;
- :mod:`~naseview.stage2_curves.curve_side`: side-curves as circular arcs;
- :mod:`~naseview.stage2_curves.estimate`: stand-ins for landmarks stage 1 could not place;
- :mod:`~naseview.stage2_curves.run`: one call's inputs, warnings and curve assembly;
- :mod:`~naseview.stage2_curves.result`: :class:`CurvesResult`, what the stage returns.

Geometric steps, one job each:

- :mod:`~naseview.stage2_curves.params`: :class:`CurveParams`, every tunable with its range;
- :mod:`~naseview.stage2_curves.mask`: background colour from the border, HSV mask (eq. 2-3);
- :mod:`~naseview.stage2_curves.edges`: Scharr edges (eq. 11), least-cost paths (eq. 12);
- :mod:`~naseview.stage2_curves.nostrils`: dark nostrils, closing, contour tracing (eq. 13-14);
- :mod:`~naseview.stage2_curves.side`: side-curve circle through int, tmp, mf (eq. 15-17);
- :mod:`~naseview.stage2_curves.lift`: 2D -> 3D by the closest point of two lines (eq. 4-10);
- :mod:`~naseview.stage2_curves.sublandmarks`: sub-landmarks and the ad-landmarks;
- :mod:`~naseview.stage2_curves.fallback`: interpolation where the photos give no evidence;
- :mod:`~naseview.stage2_curves.cache`: step cache for re-runs after a parameter change;
- :mod:`~naseview.stage2_curves.metrics`: paper Tables 4-5 (boundary MAE and Hausdorff).

Which photo gives which curve is :data:`naseview.landmarks.CURVE_VIEWS`.
"""

from naseview.stage2_curves.cache import StepCache
from naseview.stage2_curves.extract import StageOne, extract_curves
from naseview.stage2_curves.params import DEFAULT_SUB_LANDMARKS, CurveParams, CurveParamsError
from naseview.stage2_curves.result import CurvesResult, ViewEvidence

__all__ = ["DEFAULT_SUB_LANDMARKS", "CurveParams", "CurveParamsError", "CurvesResult",
           "StageOne", "StepCache", "ViewEvidence", "extract_curves"]
