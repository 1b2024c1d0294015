"""Interpolations used when the photos give no evidence for a curve.

An open curve falls back to a centripetal Catmull-Rom spline through its 3D landmarks; a
nasal sill (one landmark only) falls back to an ellipse in the sill plane.

Example
-------
>>> import numpy as np
>>> P = np.array([[0.0, 0, 0], [1, 1, 0], [2, 0, 0]])
>>> segs = catmull_rom_segments(P, 5)
>>> len(segs), segs[0][0].tolist(), segs[1][-1].tolist()
(2, [0.0, 0.0, 0.0], [2.0, 0.0, 0.0])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def catmull_rom_segments(P: ArrayLike, n: int, alpha: float = 0.5) -> list[np.ndarray]:
    """Centripetal Catmull-Rom spline through (K, D) points, one (n, D) array per segment.

    The ends are extended by reflection. Each segment runs from P[i] to P[i + 1] inclusive.
    """
    P = np.asarray(P, dtype=np.float64)
    if len(P) < 2:
        return []
    ext = np.vstack([2 * P[0] - P[1], P, 2 * P[-1] - P[-2]])
    out = []
    for i in range(len(P) - 1):
        p0, p1, p2, p3 = ext[i:i + 4]
        t0 = 0.0
        t1 = t0 + np.maximum(np.linalg.norm(p1 - p0), 1e-9) ** alpha
        t2 = t1 + np.maximum(np.linalg.norm(p2 - p1), 1e-9) ** alpha
        t3 = t2 + np.maximum(np.linalg.norm(p3 - p2), 1e-9) ** alpha
        t = np.linspace(t1, t2, n)[:, None]
        a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1
        a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
        a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
        b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2
        b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
        c = (t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2
        c[0], c[-1] = p1, p2
        out.append(c)
    return out


def sill_ellipse(alpp: ArrayLike, toward: ArrayLike, normal: ArrayLike,
                 aspect: float = 0.6, n: int = 48) -> np.ndarray:
    """(n, 3) ellipse in the sill plane through al'' with its far end at ``toward``.

    Args:
        alpp: (3,) al'' (mm), a point of the loop.
        toward: (3,) a point across the nostril (projected into the plane); the long axis
            runs from al'' to it.
        normal: (3,) unit normal of the sill plane.
        aspect: short axis / long axis.
    Returns:
        the loop, starting at al'', first point not repeated.
    """
    a = np.asarray(alpp, dtype=np.float64)
    nrm = np.asarray(normal, dtype=np.float64)
    nrm = nrm / np.linalg.norm(nrm)
    b = np.asarray(toward, dtype=np.float64)
    b = b - ((b - a) @ nrm) * nrm
    axis = b - a
    L = float(np.linalg.norm(axis))
    if L < 1e-9:
        return np.repeat(a[None], n, axis=0)
    e1 = axis / L
    e2 = np.cross(nrm, e1)
    c = 0.5 * (a + b)
    th = np.linspace(np.pi, 3 * np.pi, n, endpoint=False)
    return c + 0.5 * L * np.cos(th)[:, None] * e1 + 0.5 * L * aspect * np.sin(th)[:, None] * e2
