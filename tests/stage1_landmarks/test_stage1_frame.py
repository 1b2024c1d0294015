"""Stage 1 frame: the SPEC §4 gauge (origin g, axes, millimetre scale) of the result.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import gauge_truth, make_case

from naseview.stage1_landmarks import anatomical_frame, bundle_adjust


def test_gauge_origin_axes_and_scale():
    case, truth = make_case(21, noise_px=1.0)
    res = bundle_adjust(case)
    L = res.landmarks
    assert np.array_equal(L["g"], np.zeros(3))
    for base in ("mf", "int", "al", "alp", "ac", "md"):
        assert L[base + "_l"][0] > 0 > L[base + "_r"][0]  # +x = subject's left
    assert L["prn"][2] > 0  # +z anterior
    assert L["sn"][1] < L["n"][1] < 0  # +y up, g on top
    assert np.linalg.norm(L["al_l"] - L["al_r"]) == pytest.approx(case.scale_mm[("al_l", "al_r")],
                                                                 abs=1e-9)
    # the result is in its own anatomical frame, and that frame is the truth's within 2 deg
    o_e, R_e = anatomical_frame(L)
    assert np.allclose(R_e, np.eye(3), atol=1e-9) and np.allclose(o_e, 0, atol=1e-9)
    T = gauge_truth(truth, list(L))
    P, Q = np.array([L[k] for k in L]), np.array([T[k] for k in L])
    u, _, vt = np.linalg.svd(P.T @ Q)
    R = (u @ vt).T
    assert np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))) < 2.0
    assert np.abs(P - Q).max() < 2.0
    # the cameras reproject the landmarks to the clicks (frame change kept them consistent)
    for v, cam in res.cameras.items():
        for lid, r in res.residuals_px[v].items():
            uv = cam.project(L[lid])[0]
            assert np.linalg.norm(uv - case.views[v].landmarks[lid]) == pytest.approx(r, abs=1e-6)
    # the front camera sits in front of the face (+z), the left one on the subject's left
    assert res.cameras["front"].center[2] > 100 and res.cameras["left"].center[0] > 100


def test_scale_is_least_squares_over_all_distances():
    case, truth = make_case(22, noise_px=1.0)
    d_ac = float(np.linalg.norm(truth["ac_l"] - truth["ac_r"]))
    case.scale_mm[("ac_l", "ac_r")] = d_ac * 1.02  # a slightly inconsistent second calliper
    res = bundle_adjust(case)
    L = res.landmarks
    d = np.array([np.linalg.norm(L[a] - L[b]) for a, b in case.scale_mm])
    D = np.array(list(case.scale_mm.values()))
    # at the least-squares scale s = 1, d(s d - D)/ds = 0
    assert abs(float(d @ (d - D))) < 1e-6 * float(d @ d)
    assert not np.allclose(d, D, atol=0.05)
