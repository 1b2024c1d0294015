"""Boundary MAE and Hausdorff in mm (paper Tables 4-5): stage2_curves.metrics."""

from __future__ import annotations

import numpy as np

from naseview.camera import look_at
from naseview.stage2_curves.metrics import boundary_errors, hausdorff_polylines


def test_boundary_errors_in_mm() -> None:
    cam = look_at([0.0, 0, 200], [0, 0, 0], [0, 1, 0], 1000.0, 512, 512)
    P3 = np.column_stack([np.linspace(-10, 10, 21), np.zeros(21), np.zeros(21)])
    T = cam.project(P3 + [0, 1.0, 0])                       # truth 1 mm above, 5 px/mm
    r = boundary_errors({"c": P3}, {"front": cam}, {"c": {"front": T}}, px_per_mm=5.0)
    assert np.isclose(r["families"]["c"]["mae_mm"], 1.0)
    assert np.isclose(r["families"]["c"]["hausdorff_mm"], 1.0)
    assert hausdorff_polylines(T, T[:5]) > 10
