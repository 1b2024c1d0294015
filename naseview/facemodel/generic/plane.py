"""The generic face's meshing plane and the rays that put its mesh on the surface (step 2).

The mesh is laid out in a plane whose normal ``d`` points forwards and 25 degrees down;
each vertex is where the ray along ``d`` through its plane point meets the surface (unique,
found by bisection), so the nose underside is sampled like the dorsum.

Example
-------
>>> import numpy as np
>>> to_plane(np.array([[1.0, 0.0, 0.0]])).tolist()
[[1.0, 0.0]]
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from naseview.facemodel.generic.nose import surface_height

TILT_DEG = 25.0
"""Angle between the meshing direction ``d`` and the +z axis (``d`` points down-forward)."""

_TILT = np.deg2rad(TILT_DEG)
E1 = np.array([1.0, 0.0, 0.0])
E2 = np.array([0.0, np.cos(_TILT), np.sin(_TILT)])
D = np.array([0.0, -np.sin(_TILT), np.cos(_TILT)])
"""The meshing frame: ``e1`` (x), ``e2`` (up and 25 degrees forward) span the plane,
``d`` (forwards and 25 degrees down) is its normal and the direction of the rays."""


def to_plane(P: np.ndarray) -> np.ndarray:
    """(..., 3) points -> (..., 2) meshing-plane coordinates (a, b)."""
    return np.stack([P[..., 0], P[..., 1] * E2[1] + P[..., 2] * E2[2]], axis=-1)


def ray_hits(ab: np.ndarray,
             height: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
             iterations: int = 34) -> np.ndarray:
    """(N,) ray parameter t where the ray ``a e1 + b e2 + t d`` meets ``z = height(x, y)``.

    Along the ray ``z - height`` increases monotonically wherever the surface faces the
    meshing direction (``dz/dy > -cot(tilt)``), so bisection finds the unique hit.
    """
    height = surface_height if height is None else height
    a, b = ab[:, 0], ab[:, 1]
    lo = np.full(len(ab), -170.0)
    hi = np.full(len(ab), 170.0)
    for _ in range(iterations):
        t = 0.5 * (lo + hi)
        y = b * E2[1] + t * D[1]
        z = b * E2[2] + t * D[2]
        above = z > height(a, y)
        hi = np.where(above, t, hi)
        lo = np.where(above, lo, t)
    return 0.5 * (lo + hi)


def ray_points(ab: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(..., 3) points ``a e1 + b e2 + t d`` of plane points ``ab`` (..., 2) at ray
    parameters ``t`` (...)."""
    return ab[..., 0:1] * E1 + ab[..., 1:2] * E2 + t[..., None] * D
