"""Left/right symmetry of the nose: the midsagittal plane and mirror images (paper §3.2).

A landmark clicked in one photo only is placed on its viewing ray by the symmetry of the
face (:mod:`.single_view`): a side landmark near the mirror image of its partner, a
midline landmark on the midsagittal plane fitted here.

Example
-------
>>> import numpy as np
>>> pts = {"g": np.zeros(3), "sn": np.array([0.0, -50.0, 0.0]),
...        "prn": np.array([0.0, -45.0, 15.0]),
...        "al_l": np.array([15.0, -45.0, -5.0]), "al_r": np.array([-15.0, -45.0, -5.0])}
>>> c, n = midsagittal_plane(pts)
>>> n.round(6).tolist(), mirror_points([[3.0, 1.0, 2.0]], c, n).round(6).tolist()
([1.0, 0.0, 0.0], [[-3.0, 1.0, 2.0]])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from naseview.landmarks import MIDLINE_IDS
from naseview.stage1_landmarks.frame import PAIR_BASES


def midsagittal_plane(points: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Plane fitted to the midline landmarks and the midpoints of left/right pairs.

    Args:
        points: id -> (3,) positions (3+ midline landmarks or pair midpoints).
    Returns:
        a point (3,) on the plane and its unit normal (3,), oriented towards the subject's
        left (along the ``_r`` -> ``_l`` pair vectors).
    """
    pts = [points[i] for i in MIDLINE_IDS if i in points]
    dirs = np.zeros(3)
    for base in PAIR_BASES:
        left, right = points.get(base + "_l"), points.get(base + "_r")
        if left is not None and right is not None:
            pts.append(0.5 * (left + right))
            dirs += left - right
    P = np.asarray(pts)
    c = P.mean(0)
    _, _, vt = np.linalg.svd(P - c)
    n = vt[-1]
    if np.linalg.norm(dirs) > 0 and n @ dirs < 0:
        n = -n
    return c, n


def mirror_points(X: ArrayLike, plane_point: ArrayLike, normal: ArrayLike) -> np.ndarray:
    """(N, 3) points mirrored across the plane through ``plane_point`` (3,) with unit
    ``normal`` (3,)."""
    X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normal, dtype=np.float64)
    d = (X - np.asarray(plane_point, dtype=np.float64)) @ n
    return X - 2.0 * d[:, None] * n
