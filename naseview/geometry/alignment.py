"""Best similarity (or rigid) transform between two corresponding point sets (Umeyama).

Used by stage 1 (the similarity to the reference frame), stage 3 (the morphable-model fit,
paper eq. 18) and the test bed (rigid alignment before measuring errors). Umeyama, "Least-
squares estimation of transformation parameters between two point patterns", PAMI 1991.

Example
-------
>>> import numpy as np
>>> X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
>>> s, R, t = umeyama(X, 2 * X + [1, 2, 3])
>>> round(s, 6), np.allclose(R, np.eye(3)), t.round(6).tolist()
(2.0, True, [1.0, 2.0, 3.0])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


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
