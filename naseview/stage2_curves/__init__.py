"""Stage 2 (paper section 3.3): the six boundary curves and the 76 ad-landmarks.

Modules, one geometric job each:

- :mod:`~naseview.stage2_curves.params`: :class:`CurveParams`, every tunable with its default;
- :mod:`~naseview.stage2_curves.mask`: background colour from the border, HSV mask (eq. 2-3);
- :mod:`~naseview.stage2_curves.edges`: Scharr edges (eq. 11), least-cost paths (eq. 12);
- :mod:`~naseview.stage2_curves.nostrils`: dark nostrils, closing, contour tracing (eq. 13-14);
- :mod:`~naseview.stage2_curves.side`: side-curve circle through int, tmp, mf (eq. 15-17);
- :mod:`~naseview.stage2_curves.lift`: 2D -> 3D by the closest point of two lines (eq. 4-10);
- :mod:`~naseview.stage2_curves.sublandmarks`: sub-landmarks and the ad-landmarks;
- :mod:`~naseview.stage2_curves.fallback`: interpolation where the photos give no evidence;
- :mod:`~naseview.stage2_curves.cache`: step cache for re-runs after a parameter change;
- :mod:`~naseview.stage2_curves.metrics`: paper Tables 4-5 (boundary MAE and Hausdorff);
- :mod:`~naseview.stage2_curves.extract`: :func:`extract_curves`, the stage itself.
"""

from naseview.stage2_curves.cache import StepCache
from naseview.stage2_curves.extract import CURVE_VIEWS, CurvesResult, extract_curves
from naseview.stage2_curves.params import DEFAULT_SUB_LANDMARKS, CurveParams

__all__ = ["CURVE_VIEWS", "DEFAULT_SUB_LANDMARKS", "CurveParams", "CurvesResult",
           "StepCache", "extract_curves"]
