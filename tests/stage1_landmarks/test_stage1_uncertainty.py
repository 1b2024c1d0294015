"""Stage 1 uncertainty: the reported covariances match the actual 3D errors.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

import numpy as np
from helpers import gauge_truth, make_case

from naseview.stage1_landmarks import bundle_adjust


def test_uncertainty_matches_actual_errors():
    d2 = []
    for seed in range(8):
        case, truth = make_case(200 + seed, noise_px=1.5, focal=2400.0)
        res = bundle_adjust(case)
        assert res.uncertainty_mm["g"] == 0.0  # the origin
        T = gauge_truth(truth, list(res.landmarks))
        for k, X in res.landmarks.items():
            if k != "g":
                e = X - T[k]
                d2.append(float(e @ np.linalg.solve(res.covariance_mm2[k], e)))
    # squared Mahalanobis distances of 3D errors: mean 3 when the covariance is right
    assert 1.5 < np.mean(d2) < 6.0
    assert np.mean(np.array(d2) < 11.3) > 0.9  # chi2(3) 99 % quantile
