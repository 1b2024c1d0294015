"""Sub-landmarks and the 76 ad-landmarks: stage2_curves.sublandmarks."""

from __future__ import annotations

import numpy as np

from naseview.landmarks import CURVE_NAMES, LANDMARK_IDS
from naseview.stage2_curves import CurveParams
from naseview.stage2_curves.metrics import point_to_polyline
from naseview.stage2_curves.sublandmarks import ad_landmarks, sample_curve


def test_sub_landmarks_split_by_segment_length() -> None:
    P = np.column_stack([np.linspace(0, 30, 61), np.zeros(61), np.zeros(61)])
    X, tags = sample_curve(P, [("a", 0), ("b", 20), ("c", 60)], 6, "mid")
    assert [t["between"] for t in tags].count(["a", "b"]) == 2      # 10 mm of 30 mm
    np.testing.assert_allclose([t["t"] for t in tags], X[:, 0] / 30.0)
    L = np.vstack([[0.0, 0, 0], [5, 0, 0], [5, 5, 0], [0, 5, 0]])
    X, tags = sample_curve(L, [("alpp_l", 2)], 3, "sill_l", closed=True)
    assert len(X) == 3 and tags[0]["between"] == ["alpp_l", "alpp_l"]
    assert point_to_polyline(X, L, closed=True).max() < 1e-12


def test_76_ad_landmarks_with_tags() -> None:
    rng = np.random.default_rng(5)
    lms = {k: rng.normal(0, 20, 3) for k in LANDMARK_IDS}
    curves, anchors = {}, {}
    for name in CURVE_NAMES:
        P = np.cumsum(rng.normal(0, 1, (40, 3)), axis=0)
        curves[name] = P
        anchors[name] = [("alpp_" + name[-1], 0)] if name.startswith("sill") else \
            [("x", 0), ("y", 17), ("z", 39)]
    X, tags = ad_landmarks(lms, curves, anchors, CurveParams().sub_landmarks)
    assert X.shape == (76, 3) and len(tags) == 76
    assert [t["id"] for t in tags[:21]] == list(LANDMARK_IDS)
    assert all({"id", "curve", "t", "between", "s"} <= set(t) for t in tags)
    assert len({t["id"] for t in tags}) == 76
    assert all(0 < t["t"] < 1 for t in tags[21:])
