"""Arc length and the two resamplings of a polyline: geometry.polyline."""

from __future__ import annotations

import numpy as np

from naseview.geometry.polyline import (
    cumulative_length,
    polyline_length,
    resample_by_count,
    resample_by_spacing,
)


def _arc() -> np.ndarray:
    t = np.linspace(0.0, np.pi, 200)
    return np.column_stack([10 * np.cos(t), 10 * np.sin(t), np.zeros_like(t)])


def test_lengths_of_a_half_circle() -> None:
    P = _arc()
    s = cumulative_length(P)
    assert s[0] == 0.0 and np.all(np.diff(s) > 0)
    assert abs(s[-1] - polyline_length(P)) < 1e-9
    assert abs(polyline_length(P) - 10 * np.pi) < 1e-3
    assert polyline_length(P[:1]) == 0.0 and cumulative_length(P[:1]).tolist() == [0.0]


def test_by_count_gives_n_equal_steps_with_both_ends() -> None:
    P = _arc()
    Q = resample_by_count(P, 17)
    assert Q.shape == (17, 3)
    np.testing.assert_allclose(Q[[0, -1]], P[[0, -1]])
    steps = np.diff(cumulative_length(Q))
    assert np.ptp(steps) < 1e-3 * steps.mean()
    assert np.all(resample_by_count(P[:1], 4) == P[0])


def test_by_spacing_open_and_closed() -> None:
    P = _arc()
    Q = resample_by_spacing(P, 0.5)
    assert len(Q) == int(np.ceil(polyline_length(P) / 0.5)) + 1
    np.testing.assert_allclose(Q[[0, -1]], P[[0, -1]])
    assert np.diff(cumulative_length(Q)).max() <= 0.5
    square = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    L = resample_by_spacing(square, 1.0, closed=True)
    assert len(L) == 16 and L[0].tolist() == [0.0, 0.0]
    assert not np.allclose(L[-1], L[0])            # the first point is not repeated
