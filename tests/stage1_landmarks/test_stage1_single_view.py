"""Stage 1 one-photo landmarks: placed on their viewing rays, or left out.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from helpers import VISIBLE, gauge_truth, kabsch_errors, project_case, random_nose, rig_cameras

from naseview.stage1_landmarks import SfmParams, bundle_adjust


def test_landmark_in_one_photo_is_placed_by_symmetry_or_left_out():
    visible = {v: list(ids) for v, ids in VISIBLE.items()}
    visible["left"].remove("md_l")
    visible["bottom"].remove("md_l")  # md_l now only in the front photo
    errs = []
    for seed in range(4):
        rng = np.random.default_rng(40 + seed)
        truth = random_nose(rng)
        case = project_case(truth, rig_cameras(rng), rng, 1.5, Path("/x"), visible=visible)
        res = bundle_adjust(case)
        assert res.one_photo == {"md_l": "symmetry"}
        assert any("'md_l'" in w and "'front' only" in w for w in res.warnings)
        T = gauge_truth(truth, [k for k in res.landmarks if k != "md_l"])
        errs.append(np.linalg.norm(res.landmarks["md_l"] - T["md_l"]))
        assert res.residuals_px["front"]["md_l"] < 0.01  # on the click's viewing ray
    assert np.mean(errs) < 1.5
    res = bundle_adjust(case, SfmParams(symmetric_fill=False))
    assert res.left_out == ("md_l",) and "md_l" not in res.landmarks


def test_pair_in_one_photo_each_and_glabella_in_front_only():
    visible = {v: list(ids) for v, ids in VISIBLE.items()}
    for v in ("left", "right"):
        visible[v].remove("g")  # g only in the front photo (synth does this sometimes)
    visible["front"] = [i for i in visible["front"] if not i.startswith("alpp")]
    rng = np.random.default_rng(50)
    truth = random_nose(rng)
    case = project_case(truth, rig_cameras(rng), rng, 1.0, Path("/x"), visible=visible)
    res = bundle_adjust(case)
    assert res.one_photo["g"] in ("midline", "template")
    assert set(res.one_photo) == {"g", "alpp_l", "alpp_r"}
    assert np.array_equal(res.landmarks["g"], np.zeros(3))
    assert res.uncertainty_mm["alpp_l"] > res.uncertainty_mm["al_l"]
    errs = kabsch_errors(res.landmarks, truth)
    assert np.sqrt(np.mean(errs**2)) < 1.5
