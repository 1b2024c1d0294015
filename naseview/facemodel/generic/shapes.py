"""Smooth building blocks of the generic face's height fields (step 1 of its design).

Smooth minimum and maximum (the polynomial blends that join the face's parts with a blend
radius in mm), a C1 step, a Gaussian bump and :class:`Profile`, a natural cubic spline
through (height, value) knots continued linearly. Everything is elementwise on arrays.

Example
-------
>>> import numpy as np
>>> float(smax(np.array(0.0), np.array(0.0), 2.0))
0.5
>>> Profile([(0.0, 0.0), (1.0, 2.0)])(np.array([2.0])).tolist()
[4.0]
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


def smin(a: np.ndarray, b: np.ndarray, k: float | np.ndarray) -> np.ndarray:
    """Polynomial smooth minimum (union of signed distances) with blend radius ``k`` mm."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - 0.25 * k * h * h


def smax(a: np.ndarray, b: np.ndarray, k: float | np.ndarray) -> np.ndarray:
    """Polynomial smooth maximum (intersection) with blend radius ``k`` mm."""
    return -smin(-a, -b, k)


def smoothstep(t: np.ndarray) -> np.ndarray:
    """C1 step: 0 for t <= 0, 1 for t >= 1."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def gauss(u: np.ndarray) -> np.ndarray:
    """Gaussian bump ``exp(-u^2)``: 1 at 0, 0.37 at 1."""
    return np.exp(-u * u)


class Profile:
    """Natural cubic spline through knots (t, value), continued linearly outside them."""

    def __init__(self, knots: list[tuple[float, float]]) -> None:
        k = np.asarray(knots, dtype=np.float64)
        k = k[np.argsort(k[:, 0])]
        self._spl = CubicSpline(k[:, 0], k[:, 1], bc_type="natural")
        self._lo, self._hi = float(k[0, 0]), float(k[-1, 0])
        self._d_lo = float(self._spl(self._lo, 1))
        self._d_hi = float(self._spl(self._hi, 1))

    def __call__(self, t: np.ndarray, nu: int = 0) -> np.ndarray:
        """The profile (``nu`` = 0) or its slope (``nu`` = 1) at ``t`` (any shape)."""
        t = np.asarray(t, dtype=np.float64)
        tc = np.clip(t, self._lo, self._hi)
        if nu == 1:
            return np.where(t < self._lo, self._d_lo,
                            np.where(t > self._hi, self._d_hi, self._spl(tc, 1)))
        v = self._spl(tc)
        return v + np.where(t < self._lo, (t - self._lo) * self._d_lo, 0.0) \
            + np.where(t > self._hi, (t - self._hi) * self._d_hi, 0.0)
