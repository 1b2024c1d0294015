"""Stage 1 suspect-click attribution (issue 13): the wrong click is found by what
explains the other clicks best (leave-one-click-out re-solves), not by its residual;
when the geometry cannot tell which click is wrong, both are named and kept; a landmark
moved by a left-out click is named with the distance.

Projected cases (``tests/helpers.py``): known landmarks and cameras, exact truth.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
from helpers import make_case

from naseview.case import Case
from naseview.stage1_landmarks import bundle_adjust


def _moved(case: Case, view: str, lid: str, d: tuple[float, float]) -> Case:
    v = case.views[view]
    views = dict(case.views)
    views[view] = replace(v, landmarks={**v.landmarks, lid: v.landmarks[lid] + np.array(d)})
    return replace(case, views=views)


def test_bad_bottom_click_is_blamed_not_the_good_profile_click():
    # before issue 13 the left photo's (good) al_l click was left out here
    case, _ = make_case(61, noise_px=1.0)
    res = bundle_adjust(_moved(case, "bottom", "al_l", (0.0, 20.0)))
    ignored = [(sc.view, sc.landmark) for sc in res.suspect_clicks if sc.ignored]
    assert ignored == [("bottom", "al_l")]
    moved = [w for w in res.warnings if w.startswith("leaving out")]
    assert len(moved) == 1 and "'al_l' in photo 'bottom'" in moved[0]
    m = re.search(r"moved landmark\(s\) '\w+' (\d+\.\d) mm", moved[0])
    assert m and float(m.group(1)) > 0.5


def test_undecidable_disagreement_names_both_photos_and_drops_neither():
    # md_r moved along the front/bottom epipolar direction: either click may be wrong
    # (before issue 13 the good bottom click was left out)
    case, _ = make_case(60, noise_px=1.0)
    res = bundle_adjust(_moved(case, "front", "md_r", (20.0, 0.0)))
    assert not [sc for sc in res.suspect_clicks if sc.ignored]
    sc = [s for s in res.suspect_clicks if s.landmark == "md_r"]
    assert len(sc) == 1 and {sc[0].view, *sc[0].other_views} == {"front", "bottom"}
    assert "none can be shown wrong" in sc[0].message()
