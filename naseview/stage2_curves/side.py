"""Side-curve int -> mf as a circular arc (paper eq. 15-17).

The side-curve has no distinct edge in the photos, so the paper approximates it in the
front view by the circle through ``int``, ``mf`` and a helper point ``tmp``. Between int
and mf the horizontal way is split w1 (next to int) + w2 (next to mf) and the vertical way
into a steep part next to int and a gradual part next to mf ("steep change in y-values
within segment w1 and gradual change in segment w2"), in the ratio h2 = 3 h1: ``tmp`` lies
halfway across and three quarters of the way up from int, i.e. eq. 15's offsets
``(x_mf - x_int) / 2`` and ``(y_mf - y_int) / 4`` taken from mf. (Taking them from int
instead bends the arc the other way, away from the nasofacial groove.)

Beyond the paper, ``bulge`` moves ``tmp`` towards the midline, perpendicular to the
int-mf chord, by that fraction of the chord length: when int and mf are nearly above each
other the paper's construction is almost a straight line, while the groove between the
nasal sidewall and the cheek is concave.

Example
-------
>>> import numpy as np
>>> c, r = circle_through_points([1.0, 0.0], [0.0, 1.0], [-1.0, 0.0])
>>> (np.round(c, 9) + 0.0).tolist(), round(r, 9)
([0.0, 0.0], 1.0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def circle_through_points(p1: ArrayLike, p2: ArrayLike,
                          p3: ArrayLike) -> tuple[np.ndarray, float]:
    """Circle x^2 + y^2 + d1 x + d2 y + d3 = 0 through three 2D points (eq. 16-17).

    Args:
        p1, p2, p3: (2,) points (px).
    Returns:
        centre (2,) and radius; radius ``inf`` (centre nan) when the points are collinear.
    """
    P = np.array([p1, p2, p3], dtype=np.float64).reshape(3, 2)
    A = np.column_stack([P, np.ones(3)])
    rhs = -(P ** 2).sum(axis=1)
    scale = max(float(np.ptp(P, axis=0).max()), 1e-12)
    if abs(np.linalg.det(np.column_stack([P / scale, np.ones(3)]))) < 1e-9:
        return np.full(2, np.nan), float("inf")
    d1, d2, d3 = np.linalg.solve(A, rhs)
    centre = np.array([-d1 / 2.0, -d2 / 2.0])
    radius = float(np.sqrt(max(centre @ centre - d3, 0.0)))
    return centre, radius


def side_tmp_point(int_xy: ArrayLike, mf_xy: ArrayLike, w_ratio: float = 1.0,
                   h_ratio: float = 3.0, bulge: float = 0.0,
                   toward: ArrayLike | None = None) -> np.ndarray:
    """The helper point ``tmp`` of eq. 15, (2,) px.

    Args:
        int_xy, mf_xy: (2,) ``int`` and ``mf`` in the front photo (px).
        w_ratio: w2 / w1, horizontal split (w1 next to int); paper 1.
        h_ratio: rise next to int over rise next to mf (the paper's h2 / h1); paper 3.
        bulge: shift of tmp perpendicular to the chord, as a fraction of the chord
            length, towards ``toward`` (0 = the paper's tmp).
        toward: (2,) a point on the medial side (e.g. the nasal dorsum), needed when
            ``bulge`` is not 0.
    """
    a = np.asarray(int_xy, dtype=np.float64)
    b = np.asarray(mf_xy, dtype=np.float64)
    fx = 1.0 / (1.0 + w_ratio)
    fy = h_ratio / (1.0 + h_ratio)
    tmp = a + np.array([fx, fy]) * (b - a)
    if bulge and toward is not None:
        ch = b - a
        L = float(np.linalg.norm(ch))
        if L > 0:
            nrm = np.array([-ch[1], ch[0]]) / L
            if nrm @ (np.asarray(toward, dtype=np.float64) - a) < 0:
                nrm = -nrm
            tmp = tmp + bulge * L * nrm
    return tmp


def arc_through(p_start: ArrayLike, p_via: ArrayLike, p_end: ArrayLike,
                n: int = 64) -> np.ndarray:
    """(n, 2) points on the circular arc from ``p_start`` through ``p_via`` to ``p_end``.

    Collinear points give the straight segment start -> end.
    """
    a = np.asarray(p_start, dtype=np.float64)
    m = np.asarray(p_via, dtype=np.float64)
    b = np.asarray(p_end, dtype=np.float64)
    centre, r = circle_through_points(a, m, b)
    s = np.linspace(0.0, 1.0, n)
    if not np.isfinite(r):
        return a + s[:, None] * (b - a)
    ang = [np.arctan2(*(p - centre)[::-1]) for p in (a, m, b)]
    t0, tm, t1 = ang
    two_pi = 2 * np.pi
    # sweep counter-clockwise from a to b; if the via point is not passed, go the other way
    ccw = (t1 - t0) % two_pi
    if (tm - t0) % two_pi <= ccw:
        theta = t0 + s * ccw
    else:
        theta = t0 - s * (two_pi - ccw)
    return centre + r * np.column_stack([np.cos(theta), np.sin(theta)])


def side_curve_2d(int_xy: ArrayLike, mf_xy: ArrayLike, w_ratio: float = 1.0,
                  h_ratio: float = 3.0, n: int = 64, bulge: float = 0.0,
                  toward: ArrayLike | None = None) -> np.ndarray:
    """(n, 2) side-curve in the front photo: arc int -> tmp -> mf (eq. 15-17), px.

    See :func:`side_tmp_point` for the arguments.
    """
    tmp = side_tmp_point(int_xy, mf_xy, w_ratio, h_ratio, bulge, toward)
    return arc_through(int_xy, tmp, mf_xy, n)
