"""Stage 1 least-squares problem (eq. 1): the analytic Jacobian and its sparsity.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

import numpy as np
from helpers import make_case
from scipy.optimize._numdiff import approx_derivative

from naseview.landmarks import LANDMARK_IDS
from naseview.stage1_landmarks import bundle_adjust, problem


def test_analytic_jacobian_matches_finite_differences():
    case, _ = make_case(3)
    case.views["bottom"].camera = {"focal_px": 2500.0}  # a photo with known intrinsics
    seen = {k: [v for v in case.views if k in case.views[v].landmarks] for k in LANDMARK_IDS}
    ids = [k for k in LANDMARK_IDS if len(seen[k]) >= 2]
    captured = {}

    def spy(prob, x0, params):
        captured["prob"], captured["x0"] = prob, x0
        return orig(prob, x0, params)

    orig = problem.solve
    problem.solve = spy
    try:
        bundle_adjust(case)
    finally:
        problem.solve = orig
    prob, x0 = captured["prob"], captured["x0"] + 0.01  # away from zero rotations
    assert prob.n_points == len(ids)
    Ja = problem.jacobian_dense(x0, prob, problem.jacobian_structure(prob))
    Jn = approx_derivative(lambda x: problem.residuals(x, prob), x0, method="3-point")
    assert np.abs(Ja - Jn).max() < 1e-5 * np.abs(Jn).max()
    assert problem.jacobian_sparsity(prob).toarray()[np.abs(Jn) > 1e-9].all()
