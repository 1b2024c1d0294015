"""The edit solver (stage 3's deformer re-run on the reconstruction) on the ICT mean face."""

from __future__ import annotations

import numpy as np


def test_edit_solver_follows_handles_and_keeps_unedited_nose(baseline, real_solver_factory):
    solver = real_solver_factory()
    assert {"prn", "al_l", "al_r", "c", "sn"} <= set(solver.editable)
    assert not {"g", "mf_l", "mf_r"} & set(solver.editable)
    rest = solver(baseline.landmarks)
    assert np.abs(rest.V - baseline.V).max() < 0.01           # no edit, no change
    lms = dict(baseline.landmarks)
    lms["prn"] = lms["prn"] + [0.0, 0.0, 2.0]
    out = solver(lms)
    mid = out.curves["mid"]
    i = int(np.argmin(np.linalg.norm(baseline.curves["mid"] - baseline.landmarks["prn"], axis=1)))
    assert np.linalg.norm(mid[i] - lms["prn"]) < 0.05         # the mid-curve follows prn
    assert out.measurements["nasal_length"] > baseline.measurements["nasal_length"] + 1.0
    outside = np.setdiff1d(np.arange(len(baseline.V)), solver.region_ids)
    assert np.abs(out.V[outside] - baseline.V[outside]).max() == 0.0
    far = np.linalg.norm(baseline.V - baseline.landmarks["prn"], axis=1) > 30
    assert np.abs(out.V[far] - baseline.V[far]).max() < 0.1   # the edit stays local
