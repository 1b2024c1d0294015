"""Arc length along a polyline and resampling it evenly (one home for every stage).

A polyline is an (N, D) array of points joined in order (D = 2 for pixels, 3 for mm).
Two ways to resample it, with different meanings:

- :func:`resample_by_count`: exactly ``n`` points, equally spaced in arc length (stage 2:
  image paths, curve segments between two landmarks);
- :func:`resample_by_spacing`: a point every ``step`` along the curve or a little closer,
  ends included, optionally around a closed loop (the synthetic ground truth, SPEC §7:
  every 0.5 mm).

Both interpolate linearly in arc length, so every output point lies on the polyline.

Example
-------
>>> import numpy as np
>>> P = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
>>> cumulative_length(P).tolist(), polyline_length(P)
([0.0, 3.0, 4.0], 4.0)
>>> resample_by_count(P, 3).tolist()
[[0.0, 0.0], [2.0, 0.0], [3.0, 1.0]]
>>> len(resample_by_spacing(P, 1.5)), len(resample_by_spacing(P, 1.5, closed=True))
(4, 5)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike


def cumulative_length(P: ArrayLike) -> np.ndarray:
    """(N,) arc length from the first point of an (N, D) polyline (units of P)."""
    P = np.asarray(P, dtype=np.float64)
    if len(P) < 2:
        return np.zeros(len(P))
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


def polyline_length(P: ArrayLike) -> float:
    """Length of an (N, D) polyline (units of P); 0 for fewer than two points."""
    P = np.asarray(P, dtype=np.float64)
    return float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum()) if len(P) > 1 else 0.0


def _interpolate(P: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(len(t), D) points at arc lengths ``t`` of the (N, D) polyline ``P`` with
    cumulative lengths ``s`` (N,)."""
    return np.stack([np.interp(t, s, P[:, j]) for j in range(P.shape[1])], axis=1)


def resample_by_count(P: ArrayLike, n: int) -> np.ndarray:
    """(n, D) points equally spaced in arc length along an (N, D) polyline, ends included.

    A single point, or a polyline of zero length, gives ``n`` copies of its first point.
    """
    P = np.asarray(P, dtype=np.float64)
    if len(P) == 1:
        return np.repeat(P, n, axis=0)
    s = cumulative_length(P)
    if s[-1] <= 0:
        return np.repeat(P[:1], n, axis=0)
    return _interpolate(P, s, np.linspace(0.0, s[-1], n))


def resample_by_spacing(P: ArrayLike, step: float, closed: bool = False) -> np.ndarray:
    """(M, D) points along an (N, D) polyline, equally spaced at most ``step`` apart.

    The curve (of length L) is cut into ``max(ceil(L / step), 1)`` equal pieces. Open:
    M = pieces + 1, both ends included. ``closed``: the loop returns from the last point
    to the first; M = pieces, starting at the first point, which is not repeated. Fewer
    than two points (after closing) are returned as a copy.
    """
    P = np.asarray(P, dtype=np.float64)
    if closed:
        P = np.vstack([P, P[:1]])
    if len(P) < 2:
        return P.copy()
    s = cumulative_length(P)
    n = max(int(math.ceil(s[-1] / step)), 1)
    t = np.linspace(0.0, s[-1], n + 1)
    if closed:
        t = t[:-1]
    return _interpolate(P, s, t)
