"""A ghost of the original nose: its contour lines, drawn over the simulated one.

A translucent copy of the original surface renders as blotchy patches in the browser
(transparent triangles are sorted per object, not per pixel). Contour lines read as a
ghost instead: the original nose ``V`` (n, 3) mm (SPEC frame, +y up), ``F`` (m, 3), cut
by the planes ``y = const`` (horizontal sections, every ``step_mm``) and ``x = const``
(sagittal sections), gives a light cage of the original shape through which the new
shape shows — where the nose was reduced the cage floats outside it, where it was
augmented the cage sinks in.

>>> import numpy as np
>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0.0]]); F = np.array([[0, 1, 2]])
>>> contour_segments(V, F, axis=1, step_mm=1.0).shape   # planes y = 0.5 and 1.5
(2, 2, 3)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def plane_sections(V: ArrayLike, F: ArrayLike, axis: int, levels: ArrayLike) -> np.ndarray:
    """(S, 2, 3) segments where the mesh crosses the planes ``X[axis] = level``.

    Args:
        V: (n, 3) vertices (mm); F: (m, 3) triangles.
        axis: 0 (x = const), 1 (y = const) or 2 (z = const).
        levels: (L,) plane positions (mm).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    out: list[np.ndarray] = []
    T = V[F]                                          # (m, 3, 3)
    h = T[:, :, axis]
    lo, hi = h.min(axis=1), h.max(axis=1)
    for lev in np.asarray(levels, dtype=np.float64):
        sel = (lo < lev) & (hi > lev)
        if not sel.any():
            continue
        t, d = T[sel], h[sel] - lev                   # (k, 3, 3), (k, 3)
        pts = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            cross = (d[:, a] > 0) != (d[:, b] > 0)
            w = d[:, a] / np.where(cross, d[:, a] - d[:, b], 1.0)
            p = t[:, a] + w[:, None] * (t[:, b] - t[:, a])
            pts.append((cross, p))
        # every crossed triangle has exactly two crossed edges
        cr = np.stack([c for c, _ in pts], axis=1)     # (k, 3)
        P = np.stack([p for _, p in pts], axis=1)      # (k, 3, 3)
        ok = cr.sum(axis=1) == 2
        first = np.argmax(cr, axis=1)
        last = 2 - np.argmax(cr[:, ::-1], axis=1)
        k = np.arange(len(cr))
        seg = np.stack([P[k, first], P[k, last]], axis=1)[ok]
        out.append(seg)
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


def contour_segments(V: ArrayLike, F: ArrayLike, axis: int = 1, step_mm: float = 2.5
                     ) -> np.ndarray:
    """(S, 2, 3) contour lines of the mesh every ``step_mm`` along ``axis`` (levels
    centred on the mesh's extent so a small mesh still gets one)."""
    V = np.asarray(V, dtype=np.float64)
    lo, hi = float(V[:, axis].min()), float(V[:, axis].max())
    n = max(1, int(np.floor((hi - lo) / step_mm)))
    mid = 0.5 * (lo + hi)
    levels = mid + step_mm * (np.arange(n) - (n - 1) / 2.0)
    return plane_sections(V, F, axis, levels)


def ghost_segments(V: ArrayLike, F: ArrayLike, step_mm: float = 2.5) -> np.ndarray:
    """(S, 2, 3) horizontal and sagittal contour lines of the original nose (mm)."""
    return np.concatenate([contour_segments(V, F, 1, step_mm),
                           contour_segments(V, F, 0, step_mm)])


__all__ = ["contour_segments", "ghost_segments", "plane_sections"]
