"""Stage 2 (paper section 3.3): the six boundary curves and the 76 ad-landmarks.

Modules, one geometric job each:

- :mod:`~naseview.curves.params`: :class:`CurveParams`, every tunable with its default;
- :mod:`~naseview.curves.mask`: background colour from the border, HSV mask (eq. 2-3);
- :mod:`~naseview.curves.edges`: Scharr edges (eq. 11), least-cost paths (eq. 12);
- :mod:`~naseview.curves.nostrils`: dark nostrils, closing, contour tracing (eq. 13-14);
- :mod:`~naseview.curves.side`: side-curve circle through int, tmp, mf (eq. 15-17);
- :mod:`~naseview.curves.lift`: 2D -> 3D by the closest point of two lines (eq. 4-10);
- :mod:`~naseview.curves.sublandmarks`: sub-landmarks and the ad-landmarks;
- :mod:`~naseview.curves.fallback`: interpolation where the photos give no evidence;
- :mod:`~naseview.curves.cache`: step cache for re-runs after a parameter change;
- :mod:`~naseview.curves.metrics`: paper Tables 4-5 (boundary MAE and Hausdorff);
- :mod:`~naseview.curves.extract`: :func:`extract_curves`, the stage itself.
"""

from naseview.curves.cache import StepCache
from naseview.curves.extract import CURVE_VIEWS, CurvesResult, extract_curves
from naseview.curves.params import DEFAULT_SUB_LANDMARKS, CurveParams

__all__ = ["CURVE_VIEWS", "DEFAULT_SUB_LANDMARKS", "CurveParams", "CurvesResult",
           "StepCache", "extract_curves"]
