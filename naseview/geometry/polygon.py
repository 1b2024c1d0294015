"""Which 2D points lie inside a closed polygon (exact crossing-number test).

Used where a planar outline bounds a region: the generic face's mask in its meshing plane.

Example
-------
>>> import numpy as np
>>> square = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])
>>> points_in_polygon(np.array([[1.0, 1], [3, 1], [1, -0.5]]), square).tolist()
[True, False, False]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def points_in_polygon(P: ArrayLike, poly: ArrayLike) -> np.ndarray:
    """(n,) bool: the 2D points ``P`` (n, 2) inside the closed polygon ``poly`` (k, 2).

    Even-odd rule: a horizontal ray from each point crosses the polygon's edges an odd
    number of times. The polygon closes from its last vertex back to the first (do not
    repeat it); it may be concave. Points exactly on an edge may go either way.
    """
    P = np.asarray(P, dtype=np.float64)
    poly = np.asarray(poly, dtype=np.float64)
    x, y = P[:, 0][:, None], P[:, 1][:, None]
    x0, y0 = poly[:, 0][None], poly[:, 1][None]
    x1, y1 = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    cond = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return np.asarray((cond & (x < xc)).sum(1) % 2 == 1)
