"""Lifting 2D curve points to 3D (paper eq. 4-10): stage2_curves.lift."""

from __future__ import annotations

import numpy as np

from naseview.camera import look_at
from naseview.stage2_curves.lift import closest_points_between_lines, lift_to_lines, lift_to_plane
from naseview.stage2_curves.nostrils import sill_plane


def test_lift_returns_exact_point_when_lines_intersect() -> None:
    rng = np.random.default_rng(0)
    cam = look_at([300.0, 20, 10], [0, 0, 0], [0, 1, 0], 2000.0, 1024, 1024)
    for _ in range(20):
        A, B = rng.normal(0, 20, 3), rng.normal(0, 20, 3)
        X = A + rng.uniform(0.1, 0.9) * (B - A)          # a point of line AB
        uv = cam.project(X[None])
        for w in (0.0, 0.5, 1.0):
            np.testing.assert_allclose(lift_to_lines(uv, cam, A, B, w)[0], X, atol=1e-6)


def test_closest_points_of_skew_and_parallel_lines() -> None:
    P1, P2 = closest_points_between_lines([0.0, 0, 0], [[1.0, 0, 0]], [[0.0, 2, 5]],
                                          [[0.0, 0, 1]])
    np.testing.assert_allclose(P1[0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(P2[0], [0, 2, 0], atol=1e-12)
    P1, P2 = closest_points_between_lines([0.0, 0, 0], [[1.0, 0, 0]], [[3.0, 1, 0]],
                                          [[2.0, 0, 0]])
    assert np.isclose(np.linalg.norm(P1[0] - P2[0]), 1.0)
    # eq. 10 midpoint lies halfway between the two lines
    cam = look_at([0.0, 0, 100], [0, 0, 0], [0, 1, 0], 500.0, 64, 64)
    X = lift_to_lines(cam.project(np.zeros((1, 3))), cam, [-10.0, 1, 0], [10.0, 1, 0])
    np.testing.assert_allclose(X[0], [0.0, 0.5, 0.0], atol=1e-9)


def test_lift_to_plane_hits_the_plane_on_the_line_of_sight() -> None:
    cam = look_at([0.0, -200, 50], [0, 0, 0], [0, 0, 1], 900.0, 256, 256)
    X = np.array([[3.0, 1.0, -2.0], [-4.0, 2.5, 1.0]])
    p, n = sill_plane([3.0, 1.0, -2.0], [5.0, 2.0, 4.0], [0.0, 1.0, 6.0])
    X[1] -= ((X[1] - p) @ n) * n                           # move the 2nd point into the plane
    np.testing.assert_allclose(lift_to_plane(cam.project(X), cam, p, n), X, atol=1e-8)
    assert abs(n[2]) < 1e-12 and n[1] > 0                   # parallel to Oxy, oriented +y
    assert abs(n @ np.array([5.0 - 0.0, 2.0 - 1.0, 4.0 - 6.0])) < 1e-12  # perpendicular to md-c
