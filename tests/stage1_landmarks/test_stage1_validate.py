"""Stage 1 bad input: one-line errors naming case.json, the key and the fix.

Each case starts as clean projected clicks (``tests/helpers.py``) and is then broken in
one way.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import kabsch_errors, make_case

from naseview.case import Case
from naseview.errors import NaseviewError
from naseview.landmarks import mirror_id
from naseview.stage1_landmarks import bundle_adjust


def _one_line_error(case: Case, match: str) -> str:
    with pytest.raises(NaseviewError, match=match) as e:
        bundle_adjust(case)
    msg = str(e.value)
    assert "\n" not in msg and "case.json" in msg
    return msg


def test_too_few_clicks_in_a_photo():
    case, _ = make_case(70)
    lm = case.views["bottom"].landmarks
    for k in list(lm)[5:]:
        del lm[k]
    msg = _one_line_error(case, "only 5 landmark clicks in photo 'bottom'")
    assert "views.bottom.landmarks" in msg and "at least 6" in msg


def test_collinear_clicks():
    case, _ = make_case(71)
    lm = case.views["left"].landmarks
    for i, k in enumerate(lm):
        lm[k] = np.array([100.0 + 30 * i, 200.0 + 15 * i])
    _one_line_error(case, "photo 'left' lie on one line")


def test_missing_glabella_and_missing_scale_landmarks():
    case, _ = make_case(72)
    for v in case.views.values():
        v.landmarks.pop("g", None)
    _one_line_error(case, "glabella g")
    case, _ = make_case(73)
    for v in case.views.values():
        v.landmarks.pop("mf_l", None)
        v.landmarks.pop("mf_r", None)
    case.scale_mm = {("mf_l", "mf_r"): 20.0}
    msg = _one_line_error(case, "scale_mm")
    assert "mf_l" in msg


@pytest.mark.parametrize("distance", [0.0342, 3.42, 342.0])   # metres, cm, 0.1 mm units
def test_a_calliper_distance_in_the_wrong_unit_is_an_error(distance: float):
    case, _ = make_case(76)
    case.scale_mm = {("al_l", "al_r"): distance}
    msg = _one_line_error(case, "'scale_mm.al_l-al_r'")
    assert f"{distance:g} mm" in msg and "millimetres" in msg


@pytest.mark.parametrize(("pair", "distance"), [(("md_l", "md_r"), 3.91),  # a narrow tip
                                               (("k", "r"), 2.23), (("ac_l", "al_l"), 1.88),
                                               (("alpp_l", "c"), 24.97),
                                               (("al_l", "al_r"), 26.0),
                                               (("al_l", "al_r"), 48.0)])
def test_short_or_unusual_calliper_distances_of_real_shapes_are_accepted(pair, distance):
    """Distances measured on synthetic truths of both face models and on the james scan:
    short pairs vary by more than their own length between noses."""
    case, _ = make_case(77)
    case.scale_mm = {pair: distance}
    bundle_adjust(case)


def test_clicks_of_another_photo_fail_to_converge():
    case, _ = make_case(74)
    # the right photo's clicks replaced by a scrambled copy of the front photo's
    front = case.views["front"].landmarks
    rng = np.random.default_rng(0)
    ids = [k for k in case.views["right"].landmarks]
    pts = [front[k] for k in rng.permutation(list(front))[:len(ids)]]
    case.views["right"].landmarks = dict(zip(ids, pts, strict=True))
    _one_line_error(case, "did not converge")


def test_front_labels_from_the_viewers_side_are_detected():
    case, _ = make_case(75)
    front = case.views["front"]
    front.landmarks = {mirror_id(k): p for k, p in front.landmarks.items()}
    msg = _one_line_error(case, "in photo 'front' the _l landmarks lie on the image left")
    assert "views.front.landmarks" in msg
    # the same photo rotated by 180 degrees (phone upside down) is fine
    case, truth = make_case(75)
    front = case.views["front"]
    front.landmarks = {k: np.array([1023.0, 1023.0]) - p for k, p in front.landmarks.items()}
    assert kabsch_errors(bundle_adjust(case).landmarks, truth).max() < 2.0


def test_left_and_right_photos_in_each_others_slot_are_detected():
    case, _ = make_case(76)
    views = case.views
    views["left"], views["right"] = views["right"], views["left"]
    views["left"].name, views["right"].name = "left", "right"
    _one_line_error(case, "photos of 'left' and 'right' look swapped")
