"""Lifting 2D curve points to 3D (paper eq. 4-10).

A curve point seen in one photo lies on its line of sight L1 (camera centre through the
pixel, eq. 4-6). Its depth is taken from the line L2 through the two nearest landmarks
along the curve: the 3D point is a blend of the two closest points of L1 and L2 (eq. 7-9);
the paper takes their midpoint (eq. 10, ``weight = 0.5``).

Example
-------
>>> import numpy as np
>>> P = closest_points_between_lines(np.zeros(3), np.array([[1.0, 0, 0]]),
...                                  np.array([[0.0, 1, 0]]), np.array([[0.0, 0, 1]]))
>>> P[0].tolist(), P[1].tolist()
([[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera


def closest_points_between_lines(X1: ArrayLike, u: ArrayLike, X2: ArrayLike, v: ArrayLike,
                                 eps: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of the line pairs L1(t) = X1 + t u and L2(s) = X2 + s v (eq. 7-9).

    Args:
        X1: (3,) or (N, 3) points on L1.
        u: (N, 3) directions of L1 (any length, non-zero).
        X2: (3,) or (N, 3) points on L2.
        v: (N, 3) directions of L2 (non-zero).
        eps: relative threshold below which the lines count as parallel; then the foot
            of X1 on L2 and the foot of that point on L1 are returned.
    Returns:
        P1 (N, 3) on L1 and P2 (N, 3) on L2 minimising |P1 - P2| (eq. 8).
    """
    u = np.atleast_2d(np.asarray(u, dtype=np.float64))
    v = np.atleast_2d(np.asarray(v, dtype=np.float64))
    n = max(len(u), len(v))
    X1 = np.broadcast_to(np.asarray(X1, dtype=np.float64), (n, 3))
    X2 = np.broadcast_to(np.asarray(X2, dtype=np.float64), (n, 3))
    u = np.broadcast_to(u, (n, 3))
    v = np.broadcast_to(v, (n, 3))
    w0 = X1 - X2
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", u, v)
    c = np.einsum("ij,ij->i", v, v)
    d = np.einsum("ij,ij->i", u, w0)
    e = np.einsum("ij,ij->i", v, w0)
    den = a * c - b * b
    parallel = den <= eps * a * c
    safe = np.where(parallel, 1.0, den)
    # d(d^2)/dt = 0, d(d^2)/ds = 0  (eq. 9):  a t - b s = -d ;  b t - c s = -e
    t = np.where(parallel, 0.0, (b * e - c * d) / safe)
    s = np.where(parallel, 0.0, (a * e - b * d) / safe)
    if np.any(parallel):
        s_p = e / c
        foot = X2 + s_p[:, None] * v
        t_p = np.einsum("ij,ij->i", u, foot - X1) / a
        t = np.where(parallel, t_p, t)
        s = np.where(parallel, s_p, s)
    return X1 + t[:, None] * u, X2 + s[:, None] * v


def lift_to_lines(uv: ArrayLike, camera: Camera, A: ArrayLike, B: ArrayLike,
                  weight: float = 0.5, clamp: bool = True) -> np.ndarray:
    """3D points of pixels ``uv`` by the closest point of L1 (line of sight) and L2 = AB.

    Args:
        uv: (N, 2) pixels in the photo of ``camera``.
        camera: the view's camera (stage 1).
        A, B: (3,) or (N, 3) the two nearest landmarks along the curve (mm), A != B.
        weight: 0.5 = midpoint of the two closest points (paper eq. 10); 1 = the point on
            the line of sight (reprojects exactly onto ``uv``); 0 = the point on AB.
        clamp: keep the camera depth of the point on the line of sight within the depth
            range of A and B widened by |AB| (a line of sight nearly parallel to AB would
            otherwise send the point far away); both closest points move together.
    Returns:
        (N, 3) points in the world frame (mm).
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if len(uv) == 0:
        return np.zeros((0, 3))
    C, d = camera.rays(uv)
    A = np.broadcast_to(np.asarray(A, dtype=np.float64), (len(uv), 3))
    B = np.broadcast_to(np.asarray(B, dtype=np.float64), (len(uv), 3))
    P1, P2 = closest_points_between_lines(C, d, A, B - A)
    if clamp:
        # a line of sight nearly parallel to AB gives a wild depth: keep the point on its
        # line of sight within the depth range of A and B widened by |AB|
        z = camera.R[2]
        dA, dB = (A - C) @ z, (B - C) @ z
        m = np.linalg.norm(B - A, axis=1)
        lo, hi = np.minimum(dA, dB) - m, np.maximum(dA, dB) + m
        dz = d @ z
        t1 = np.clip(((P1 - C) @ z), lo, hi) / dz
        P1c = C + t1[:, None] * d
        P2 = P2 + (P1c - P1)
        P1 = P1c
    return weight * P1 + (1.0 - weight) * P2


def lift_to_plane(uv: ArrayLike, camera: Camera, point: ArrayLike,
                  normal: ArrayLike) -> np.ndarray:
    """Intersect the lines of sight of pixels ``uv`` with a plane (used for the sills).

    Args:
        uv: (N, 2) pixels; camera: their view's camera.
        point: (3,) a point of the plane (mm); normal: (3,) its normal.
    Returns:
        (N, 3) intersections (mm). Rays parallel to the plane give the foot of the plane
        point on the ray.
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if len(uv) == 0:
        return np.zeros((0, 3))
    C, d = camera.rays(uv)
    p = np.asarray(point, dtype=np.float64)
    nrm = np.asarray(normal, dtype=np.float64)
    nrm = nrm / np.linalg.norm(nrm)
    den = d @ nrm
    ok = np.abs(den) > 1e-9
    t = np.where(ok, ((p - C) @ nrm) / np.where(ok, den, 1.0), d @ (p - C))
    return C + t[:, None] * d
