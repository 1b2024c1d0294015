"""Batched axis-angle rotations with their left Jacobian: the rotation unknowns of eq. 1.

Paper §3.2, eq. 1: each photo's rotation is ``exp([r]x) R0``, with ``r`` an axis-angle
increment on the rig prior ``R0``. :func:`naseview.camera.rodrigues` is the same map for one
vector; the bundle adjustment needs it for all photos at once *and* its derivative, the
left Jacobian ``J_l(r)`` with ``exp(r + d) ~ exp(J_l(r) d) exp(r)``, which share the
coefficients computed here (Barfoot, *State Estimation for Robotics*, §7.1.3).

Example
-------
>>> import numpy as np
>>> from naseview.camera import rodrigues
>>> r = np.array([[0.1, -0.2, 0.3]])
>>> R, J = rodrigues_and_left_jacobian(r)
>>> R.shape, J.shape, bool(np.allclose(R[0], rodrigues(r[0])))
((1, 3, 3), (1, 3, 3), True)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices ``[v]x``."""
    k = np.zeros(v.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2] = -v[..., 2], v[..., 1]
    k[..., 1, 0], k[..., 1, 2] = v[..., 2], -v[..., 0]
    k[..., 2, 0], k[..., 2, 1] = -v[..., 1], v[..., 0]
    return k


def _coefficients(th: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(V,) angles -> sin(t)/t, (1-cos t)/t^2, (t-sin t)/t^3, with series near 0."""
    small = th < 1e-4
    ts = np.where(small, 1.0, th)
    t2 = th * th
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(ts)) / ts**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (ts - np.sin(ts)) / ts**3)
    return a, b, c


def rodrigues_and_left_jacobian(rvec: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) axis-angle (radians) -> (V, 3, 3) rotations and (V, 3, 3) left Jacobians.

    ``R = I + a K + b K^2`` (Rodrigues) and ``J_l = I + b K + c K^2`` with ``K = [r]x``
    and the coefficients ``a, b, c`` of the angle (series below 1e-4 rad).
    """
    r = np.asarray(rvec, dtype=np.float64).reshape(-1, 3)
    a, b, c = _coefficients(np.sqrt((r * r).sum(1)))
    k = skew(r)
    kk = k @ k
    R = np.eye(3) + a[:, None, None] * k + b[:, None, None] * kk
    J = np.eye(3) + b[:, None, None] * k + c[:, None, None] * kk
    return R, J
