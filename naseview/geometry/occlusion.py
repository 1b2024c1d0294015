"""Ambient occlusion of a mesh at points on its surface, the same on every call.

libigl's ambient occlusion (``igl.embree.ambient_occlusion``, embree rays over the
hemisphere of each normal) draws its ray directions from C's ``rand()``. Unseeded, its
result depended on whatever had called it before in the process; :func:`occlusion`
seeds ``rand()`` first, so a mesh's occlusion - and everything chosen from it (the open
nose surface of the surface error, the nostril interior of the region errors) - is the
same every time.

Example
-------
>>> import numpy as np
>>> V = np.array([[-1., -1, 0], [1, -1, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
>>> occlusion(V, F, np.array([[0., 0, 0]]), np.array([[0., 0, 1]])).tolist()
[0.0]
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np
from igl.embree import ambient_occlusion

OCCLUSION_SEED = 1
"""Seed of C's ``rand()`` before each occlusion (libigl's ray directions)."""


def occlusion(V: np.ndarray, F: np.ndarray, points: np.ndarray, normals: np.ndarray,
              n_rays: int = 64) -> np.ndarray:
    """(k,) ambient occlusion (0 open .. 1 enclosed) of the mesh (V (n, 3), F (m, 3)) at
    ``points`` (k, 3) on its surface with unit ``normals`` (k, 3), from ``n_rays`` rays
    each, cast from 1e-3 mm off the surface (so a point does not hit its own triangle)."""
    N = np.ascontiguousarray(normals, np.float64)
    P = np.ascontiguousarray(np.asarray(points, np.float64) + 1e-3 * N)
    _seed_c_rand(OCCLUSION_SEED)
    return np.asarray(ambient_occlusion(np.ascontiguousarray(V, np.float64),
                                        np.ascontiguousarray(F, np.int64), P, N, n_rays))


def _seed_c_rand(seed: int) -> None:
    """Seed C's ``rand()``; without a C library to call (not Linux or macOS), nothing."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None)
        libc.srand(ctypes.c_uint(seed))
    except (OSError, AttributeError):
        pass
