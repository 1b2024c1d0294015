"""Linear (DLT) triangulation of points seen by several pinhole cameras.

Paper §3.2: the initial 3D landmarks of the bundle adjustment (eq. 1), and the
leave-one-out test of suspect clicks, triangulate with the direct linear transform
(Hartley & Zisserman, *Multiple View Geometry*, §12.2): per camera that sees a point, the
two rows ``x * P[2] - P[0]`` and ``y * P[2] - P[1]`` of the normalised projection
``P = [R | t]``; the point is the right singular vector of the smallest singular value.

Example
-------
>>> import numpy as np
>>> from naseview.camera import look_at
>>> cams = [look_at([x, 0.0, 400.0], [0, 0, 0], [0, 1, 0], 1000.0, 640, 480)
...         for x in (-100.0, 100.0)]
>>> X = np.array([[1.0, 2.0, 3.0]])
>>> uv = np.stack([c.project(X) for c in cams], axis=1)     # (1, 2, 2)
>>> triangulate_dlt(cams, uv, np.ones((1, 2), bool)).round(6).tolist()
[[1.0, 2.0, 3.0]]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera


def triangulate_dlt(cameras: Sequence[Camera], uv: ArrayLike, seen: ArrayLike) -> np.ndarray:
    """Linear (DLT) triangulation of N points, each seen by two or more of V cameras.

    Args:
        cameras: the V cameras.
        uv: (N, V, 2) pixel observations (ignored where not ``seen``).
        seen: (N, V) bool, which camera sees which point (>= 2 per point).
    Returns:
        (N, 3) points in the cameras' world frame.
    """
    uv = np.asarray(uv, dtype=np.float64)
    seen = np.asarray(seen, dtype=bool)
    N, V = seen.shape
    A = np.zeros((N, 2 * V, 4))
    for i, cam in enumerate(cameras):
        h = np.concatenate([uv[:, i], np.ones((N, 1))], axis=1)
        xn = np.linalg.solve(cam.K, h.T).T  # normalised image coordinates
        P = np.hstack([cam.R, cam.t[:, None]])
        w = seen[:, i, None].astype(np.float64)
        A[:, 2 * i] = w * (xn[:, 0, None] * P[2] - xn[:, 2, None] * P[0])
        A[:, 2 * i + 1] = w * (xn[:, 1, None] * P[2] - xn[:, 2, None] * P[1])
    _, _, vt = np.linalg.svd(A)
    h = vt[:, -1]
    return h[:, :3] / h[:, 3:4]
