"""Columella setback: the hanging columella moves up into the nostrils (mm, 0..4).

Frame of :mod:`.frame` (lateral ``e``, width ``W``). With ``c_sn = |sn - c|``, the
columella axis ``k = (sn - c) / c_sn``, the setback direction ``v``: +y made orthogonal to
``k`` and to ``e`` (perpendicular to the columella in the midsagittal plane, cephalic and
posterior, "up into the nostril"), ``t = (p - c) . k / c_sn`` (0 at c, 1 at sn) and
``x = (p - g) . e`` (the lateral offset from the midline plane)::

    U(p) = v * phi(|2 t - 1|) * fade(|x|, 0.08 W, 0.2 W) * fade(|(p - c) . v|, 0.1 c_sn, c_sn)
    phi(r) = 1 - smoothstep(r)     (1 mid-columella, 0 at c and at sn)

The last factor keeps the field to the columella near the c-sn line (its side walls
inside the nostrils fade over one columella length, slope 1.5 / (0.9 c_sn) per mm). The
weight is zero at the tip lobule (c) and at the lip (sn); the hanging part between moves
by the amount. The slope along the columella is at most
3 / c_sn per mm (a shear, perpendicular to the columella: it never folds it).
"""

from __future__ import annotations

import numpy as np

from naseview.editing.manoeuvres.frame import NasalFrame, fade, smoothstep, unit


def setback_direction(frame: NasalFrame) -> np.ndarray:
    """(3,) unit setback direction ``v`` (module docstring)."""
    c, sn = frame.landmarks["c"], frame.landmarks["sn"]
    k = unit(sn - c)
    y = np.array([0.0, 1.0, 0.0])
    v = y - (y @ k) * k - (y @ frame.e) * frame.e
    return unit(v) if np.linalg.norm(v) > 1e-6 else frame.a * -1.0


def columella_setback_field(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K, 3) displacement per mm of columella setback at points P (K, 3)."""
    c, sn = frame.landmarks["c"], frame.landmarks["sn"]
    c_sn = float(np.linalg.norm(sn - c))
    if c_sn < 1e-6:
        return np.zeros((len(P), 3))
    k = (sn - c) / c_sn
    v = setback_direction(frame)
    X = np.asarray(P, np.float64) - c
    t = X @ k / c_sn
    along = 1.0 - smoothstep(np.abs(2.0 * t - 1.0))
    W = frame.width
    w = along * fade(np.abs(frame.lateral(P)), 0.08 * W, 0.2 * W) \
        * fade(np.abs(X @ v), 0.1 * c_sn, c_sn)
    return np.asarray(w[:, None] * v[None, :])
