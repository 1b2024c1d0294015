"""Interpolation where the photos give no evidence: stage2_curves.fallback."""

from __future__ import annotations

import numpy as np

from naseview.stage2_curves.fallback import catmull_rom_segments


def test_catmull_rom_through_landmarks() -> None:
    P = np.array([[0.0, 0, 0], [10, 5, 0], [20, 0, 3], [30, 2, 1]])
    segs = catmull_rom_segments(P, 20)
    assert len(segs) == 3
    for i, s in enumerate(segs):
        np.testing.assert_allclose(s[[0, -1]], P[[i, i + 1]])
