"""The side-curve circle through int, tmp, mf (paper eq. 15-17): stage2_curves.side."""

from __future__ import annotations

import numpy as np

from naseview.stage2_curves.metrics import point_to_polyline
from naseview.stage2_curves.side import arc_through, circle_through_points, side_tmp_point


def test_circle_through_three_points() -> None:
    rng = np.random.default_rng(1)
    for _ in range(10):
        c0, r0 = rng.normal(0, 50, 2), rng.uniform(5, 80)
        a = rng.uniform(0, 2 * np.pi, 3)
        P = c0 + r0 * np.column_stack([np.cos(a), np.sin(a)])
        c, r = circle_through_points(*P)
        np.testing.assert_allclose(c, c0, atol=1e-7)
        assert np.isclose(r, r0)
    assert circle_through_points([0, 0], [1, 1], [2, 2])[1] == np.inf


def test_side_arc_passes_through_int_tmp_mf() -> None:
    i, m = np.array([400.0, 600.0]), np.array([430.0, 380.0])
    tmp = side_tmp_point(i, m, 1.0, 3.0)
    np.testing.assert_allclose(tmp, [415.0, 435.0])         # w1 = w2, h2 = 3 h1 (eq. 15)
    # the arc is steep next to int and flat next to mf: it bows towards the midline
    chord_x_at_tmp = 400.0 + 30.0 * (600.0 - 435.0) / 220.0
    assert tmp[0] < chord_x_at_tmp
    bulged = side_tmp_point(i, m, 1.0, 3.0, bulge=0.1, toward=[300.0, 500.0])
    assert np.isclose(np.linalg.norm(bulged - tmp), 0.1 * np.hypot(30, 220))
    assert bulged[0] < tmp[0]
    arc = arc_through(i, tmp, m, 200)
    np.testing.assert_allclose(arc[0], i, atol=1e-9)
    np.testing.assert_allclose(arc[-1], m, atol=1e-9)
    assert point_to_polyline(tmp[None], arc)[0] < 0.05
    assert np.ptp(arc[:, 1]) <= 221                         # no detour round the circle
