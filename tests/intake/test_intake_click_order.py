"""The guided click order of a new patient: along the curves, agreeing with the one table
of which landmarks each photo shows (naseview.landmarks.VIEW_LANDMARKS)."""

from __future__ import annotations

from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER, describe
from naseview.landmarks import ALL_IDS, CURVE_LANDMARKS, VIEW_LANDMARKS, VIEWS


def test_click_order_follows_the_curves():
    assert set(VIEW_ORDER) == set(VIEWS)
    assert {i for ids in CLICK_ORDER.values() for i in ids} == set(ALL_IDS)
    mid = CURVE_LANDMARKS["mid"]
    for v in ("front", "left", "right"):
        assert CLICK_ORDER[v][:len(mid)] == mid, v        # down the mid-curve first
    bottom = [i for i in CLICK_ORDER["bottom"] if i in CURVE_LANDMARKS["bottom"]]
    assert tuple(bottom) == CURVE_LANDMARKS["bottom"]    # the bottom curve end to end
    assert CLICK_ORDER["bottom"][:len(bottom)] == CURVE_LANDMARKS["bottom"]
    for side in ("l", "r"):                              # ala- then side-curve, in a row
        order = CLICK_ORDER["left" if side == "l" else "right"]
        seq = [f"ac_{side}", f"al_{side}", f"int_{side}", f"mf_{side}"]
        i = order.index(seq[0])
        assert list(order[i:i + 4]) == seq
    assert all(i.startswith("add") is False for v in ("front", "left", "right")
               for i in CLICK_ORDER[v])                  # helpers only in the bottom view
    for lid in ALL_IDS:
        text = describe(lid, "front")
        assert "\n" not in text and lid in text and len(text) < 160


def test_click_order_orders_exactly_the_landmarks_each_photo_shows():
    for v in VIEWS:
        assert sorted(CLICK_ORDER[v]) == sorted(VIEW_LANDMARKS[v]), v
        assert len(set(CLICK_ORDER[v])) == len(CLICK_ORDER[v]), v
