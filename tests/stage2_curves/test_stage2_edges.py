"""Scharr edges and least-cost paths (paper eq. 11-12): stage2_curves.edges."""

from __future__ import annotations

import cv2
import numpy as np

from naseview.stage2_curves.edges import edge_cost, edge_map, least_cost_path, smooth_polyline
from naseview.stage2_curves.metrics import point_to_polyline


def test_least_cost_path_follows_a_drawn_edge() -> None:
    img = np.full((300, 300), 120, np.uint8)
    cv2.ellipse(img, (150, 150), (100, 60), 0, 0, 360, 170, -1)   # faint skin-like edge
    rng = np.random.default_rng(2)
    img = np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)
    em = edge_map(img, (0, 0, 300, 300), blur_sigma=1.0)
    start, end = np.array([50.0, 150.0]), np.array([150.0, 90.0])  # two points of the edge
    path = least_cost_path(edge_cost(em.strength), start, end, corridor=40)
    assert path is not None
    np.testing.assert_allclose(path[0], start)
    np.testing.assert_allclose(path[-1], end)
    r = np.hypot((path[:, 0] - 150) / 100, (path[:, 1] - 150) / 60)
    d_px = np.abs(r - 1) * 60                               # radial offset, px (upper bound)
    assert np.median(d_px) < 1.5 and d_px.max() < 4
    # the straight chord would be far from the ellipse
    chord = start + np.linspace(0, 1, 50)[:, None] * (end - start)
    assert np.abs(np.hypot((chord[:, 0] - 150) / 100, (chord[:, 1] - 150) / 60) - 1).max() > 0.2


def test_smoothing_keeps_ends_and_straight_lines() -> None:
    P = np.column_stack([np.arange(30.0), 2.0 * np.arange(30.0)])
    S = smooth_polyline(P, 2.0)
    np.testing.assert_allclose(S[[0, -1]], P[[0, -1]])
    assert point_to_polyline(S, P).max() < 1e-9
