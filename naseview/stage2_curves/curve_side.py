"""The side-curves int-mf as circular arcs in the front photo (paper eq. 15-17).

The arc through int, tmp and mf (:func:`~naseview.stage2_curves.side.side_curve_2d`;
``tmp`` moved towards the nasal dorsum by ``CurveParams.side_bulge``) is lifted to 3D on
the line int-mf (eq. 4-10). Flag ``"circle"``: a regression, not image evidence. Without
int or mf in the photo the curve is the straight segment between the 3D landmarks.
"""

from __future__ import annotations

import numpy as np

from naseview.landmarks import CURVE_LANDMARKS, CURVE_VIEWS
from naseview.stage2_curves.lift import lift_to_lines
from naseview.stage2_curves.run import CurveRun
from naseview.stage2_curves.side import side_curve_2d

_DORSUM: tuple[str, ...] = ("n", "k", "r", "prn")
"""Midline clicks whose mean tells the arc which side is medial."""


def side_curve(run: CurveRun, curve: str) -> None:
    """Make ``side_l`` or ``side_r``."""
    p = run.params
    view = CURVE_VIEWS[curve][0]
    cam = run.cams.get(view)
    a, b = CURVE_LANDMARKS[curve]
    an = run.anchors(view)
    if run.left_out(curve):
        return
    if cam is None or a not in an or b not in an:
        run.warn(curve, view, "int or mf is not available in this photo",
                 "the curve is interpolated through its landmarks")
        run.finish_open(curve, [(a, b, np.array([run.L3[a], run.L3[b]]))], {}, 0)
        return
    mids = [an[i] for i in _DORSUM if i in an]
    toward = np.mean(mids, axis=0) if mids else None
    uv = side_curve_2d(an[a], an[b], p.side_w_ratio, p.side_h_ratio, 64, p.side_bulge,
                       toward)
    P = lift_to_lines(uv, cam, run.L3[a], run.L3[b], p.lift_weight)
    run.finish_open(curve, [(a, b, P)], {view: uv}, 1, good_flag="circle")
