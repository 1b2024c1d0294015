"""Small mesh and point-set helpers shared by the pipeline, the renderer and the app.

Example
-------
>>> import numpy as np
>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
>>> vertex_normals(V, F)[0].tolist()
[0.0, 0.0, 1.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def face_normals(V: ArrayLike, F: ArrayLike) -> np.ndarray:
    """(F, 3) unnormalised triangle normals (length = twice the area, mm^2).

    Triangles are counter-clockwise seen from outside, so normals point outwards.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def vertex_normals(V: ArrayLike, F: ArrayLike) -> np.ndarray:
    """(V, 3) unit vertex normals: area-weighted sum of the incident face normals.

    A vertex with no incident triangle gets a zero normal.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fn = face_normals(V, F)
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    norm = np.linalg.norm(N, axis=1, keepdims=True)
    return N / np.where(norm > 0, norm, 1.0)


def umeyama(X: ArrayLike, Y: ArrayLike, with_scale: bool = True,
            weights: ArrayLike | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """Similarity (or rigid, Kabsch) transform minimising sum w_i |s R x_i + t - y_i|^2.

    Args:
        X, Y: (n, 3) corresponding points (mm), n >= 3 not collinear.
        with_scale: estimate ``s`` (else 1: the rigid Kabsch alignment).
        weights: optional (n,) non-negative weights.
    Returns:
        ``(s, R, t)`` with R (3, 3) a proper rotation, t (3,) mm.
    """
    X = np.asarray(X, np.float64)
    Y = np.asarray(Y, np.float64)
    w = np.ones(len(X)) if weights is None else np.asarray(weights, np.float64)
    w = w / w.sum()
    mx, my = w @ X, w @ Y
    Xc, Yc = X - mx, Y - my
    C = (Yc * w[:, None]).T @ Xc
    U, S, Vt = np.linalg.svd(C)
    D = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        D[2, 2] = -1.0
    R = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / (w @ (Xc ** 2).sum(1))) if with_scale else 1.0
    return s, R, my - s * R @ mx
