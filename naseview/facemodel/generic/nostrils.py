"""The generic face's nostrils: real concave openings carved into the nasal base (step 3).

Inside each nostril ellipse on the nasal base the vertices move up into the nose onto a
half-ellipsoid cup (arc-length uniform), a concave opening with a sharp rim; the nostril
region is the cups and a thin ring of base around them. mm, the generic face's frame.

Example
-------
>>> import numpy as np
>>> c, u, v, cup = nostril_frame(1.0)
>>> round(float(np.linalg.norm(cup)), 6)
1.0
"""

from __future__ import annotations

import numpy as np

from naseview.facemodel.generic.nose import underside_y

NOSTRIL_CENTER = np.array([6.0, 0.0, 16.3])
"""Centre of the left nostril ellipse (x, -, z), mm (y is the nasal base's there)."""

NOSTRIL_AXES = np.array([5.3, 3.0])
"""Semi-axes of the nostril ellipse (long, short), mm."""

NOSTRIL_YAW = np.deg2rad(26.0)
"""Angle of the long axis from +z towards the midline, rad."""

NOSTRIL_DEPTH_MM = 7.0
"""Depth of the cup above the rim, mm."""

RIM_RING = 1.12
"""Nostril region = cup plus the base within this elliptical radius (border loop)."""


def nostril_frame(side: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centre (x, z) (2,), long axis u (2,), short axis v (2,) in the (x, z) plane, and
    the cup direction (3,) of the nostril on side ``side`` (+1 left, -1 right).

    The long axis points forwards and towards the midline.
    """
    c = np.array([side * NOSTRIL_CENTER[0], NOSTRIL_CENTER[2]])
    u = np.array([-side * np.sin(NOSTRIL_YAW), np.cos(NOSTRIL_YAW)])
    v = np.array([u[1], -u[0]])
    cup = np.array([0.0, 0.94, -0.34])
    return c, u, v, cup / np.linalg.norm(cup)


def nostril_rho(X: np.ndarray, side: float) -> np.ndarray:
    """(N,) elliptical radius of points (N, 3) in the nostril footprint (1 on the rim)."""
    c, u, v, _ = nostril_frame(side)
    q = X[:, [0, 2]] - c
    return np.sqrt(((q @ u) / NOSTRIL_AXES[0]) ** 2 + ((q @ v) / NOSTRIL_AXES[1]) ** 2)


def _on_underside(X: np.ndarray) -> np.ndarray:
    """(N,) bool: the surface at X is the nasal base plane (not the lobule or the lip)."""
    dy = X[:, 1] - underside_y(X[:, 0], X[:, 2])
    return (dy > -2.0) & (dy < 6.0)


def carve_nostrils(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Move the vertices of the two nostril footprints into half-ellipsoid cups.

    A vertex at elliptical radius ``r`` < 1 moves out to radius ``sin(pi r / 2)`` and up
    into the nose by ``depth cos(pi r / 2)``, so the cup wall is sampled evenly and meets
    the nasal base at a sharp rim.

    Args:
        X: (N, 3) surface points before carving.
    Returns:
        carved points (N, 3), and (N,) int64 nostril side of each vertex (+1 left,
        -1 right, 0 none).
    """
    X = X.copy()
    which = np.zeros(len(X), dtype=np.int64)
    under = _on_underside(X)
    for side in (1.0, -1.0):
        c, u, v, cup = nostril_frame(side)
        rho = nostril_rho(X, side)
        sel = (rho <= 1.0) & under & (np.sign(X[:, 0]) == side)
        if not sel.any():
            continue
        r = rho[sel]
        q = X[sel][:, [0, 2]] - c
        scale = np.where(r > 1e-9, np.sin(0.5 * np.pi * r) / np.maximum(r, 1e-9), 1.0)
        depth = NOSTRIL_DEPTH_MM * np.cos(0.5 * np.pi * r)
        Y = X[sel]
        Y[:, [0, 2]] = c + q * scale[:, None]
        X[sel] = Y + depth[:, None] * cup
        which[sel] = int(side)
        # the ring just outside the rim (still on the nasal base) belongs to the nostril
        # region too, so the region's border is a smooth loop on the base, not the rim's
        # zig-zag of partly carved vertices
        dy = X[:, 1] - underside_y(X[:, 0], X[:, 2])
        ring = (rho > 1.0) & (rho <= RIM_RING) & (dy > -0.7) & (dy < 4.0) \
            & (np.sign(X[:, 0]) == side)
        which[ring] = int(side)
    return X, which
