"""Stage 1 initialisation: rig hypotheses reach cameras far from the rig prior.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

from helpers import kabsch_errors, make_case

from naseview.stage1_landmarks import bundle_adjust


def test_converges_when_rig_is_20_degrees_off_the_prior():
    for k, (dy, dp) in enumerate([(20, 20), (-20, 20), (20, -20), (-20, -20)]):
        offsets = {"front": (dy / 2, dp / 2), "left": (dy, dp), "right": (-dy, dp),
                   "bottom": (dy / 2, dp)}
        case, truth = make_case(30 + k, noise_px=1.5, offsets=offsets)
        res = bundle_adjust(case)
        assert res.reprojection_rmse_px < 2.5
        assert kabsch_errors(res.landmarks, truth).max() < 2.5
