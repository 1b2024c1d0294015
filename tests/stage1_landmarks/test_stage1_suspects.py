"""Stage 1 suspect clicks: named, left out when pinned on one photo, harmless.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

from helpers import kabsch_errors, make_case

from naseview.stage1_landmarks import bundle_adjust


def test_suspect_click_is_named_left_out_and_harmless():
    case, truth = make_case(60, noise_px=1.0)
    clean = kabsch_errors(bundle_adjust(case).landmarks, truth).max()
    case.views["left"].landmarks["al_l"] = case.views["left"].landmarks["al_l"] + [24.0, -12.0]
    res = bundle_adjust(case)
    top = res.suspect_clicks[0]
    assert (top.landmark, top.view, top.ignored) == ("al_l", "left", True)
    assert top.residual_px > 20
    assert "'al_l'" in res.warnings[0] and "'left'" in res.warnings[0]
    assert kabsch_errors(res.landmarks, truth).max() < clean + 0.5
    assert len(res.suspect_clicks) <= 2


def test_disagreeing_pair_of_clicks_names_both_photos():
    case, _ = make_case(61, noise_px=0.5)
    # mf_l is clicked in front and left only: an error there cannot be pinned on one photo
    case.views["left"].landmarks["mf_l"] = case.views["left"].landmarks["mf_l"] + [0.0, 25.0]
    res = bundle_adjust(case)
    sc = [s for s in res.suspect_clicks if s.landmark == "mf_l"]
    assert len(sc) == 1 and not sc[0].ignored
    assert {sc[0].view, *sc[0].other_views} == {"front", "left"}
    assert "check both" in sc[0].message()
