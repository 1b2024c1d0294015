"""The points of the generic face's mesh in its meshing plane (design step 2).

A graded, mirror-symmetric lattice (about 1 mm edges on the nose, 2 mm on eyes, lips and
around the nose, 3.5 mm elsewhere) over an egg-shaped face outline, in the plane of
:mod:`~naseview.facemodel.generic.plane`; only the subject's left half (a >= 0) is laid out
here, the right is its mirror image.

Example
-------
    P, n_outline = half_points()
    P.shape[1], bool((P[:, 0] >= 0).all())
    # -> (2, True)
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial import ConvexHull, cKDTree

from naseview.facemodel.generic.face import face_height
from naseview.facemodel.generic.plane import to_plane
from naseview.geometry.polygon import points_in_polygon

LATTICE_MM: tuple[tuple[float, float], ...] = ((0.7, 0.62), (1.4, 1.24), (2.8, 2.48))
"""Column spacing along x and row spacing along ``e2`` of the three nested lattices in the
meshing plane: nose; eyes, lips and the nose's surroundings; elsewhere. The plane
foreshortens the dorsum and the nose underside about twice and the sidewalls are steep in
x, so 3D edges on the nose come out near 1 mm."""

OUTLINE_XY: tuple[tuple[float, float], ...] = (
    (0.0, 60.0), (20.0, 59.0), (36.0, 54.0), (50.0, 43.0), (60.0, 26.0), (66.0, 6.0),
    (70.0, -25.0), (68.0, -55.0), (60.0, -80.0), (47.0, -100.0), (28.0, -114.0),
    (0.0, -122.0))
"""Outline of the face mask (x, y) in mm, subject's left half, top to chin."""


def _outline_plane(step: float) -> np.ndarray:
    """(B, 2) mask outline in the meshing plane, a >= 0, top to bottom, ~``step`` apart."""
    pts = np.asarray(OUTLINE_XY)
    cy = -30.0
    phi = np.arctan2(pts[:, 1] - cy, pts[:, 0])
    r = np.hypot(pts[:, 0], pts[:, 1] - cy)
    # mirror to a closed loop so the spline crosses the midline at right angles
    phi_all = np.r_[phi, np.pi - phi[-2:0:-1]]
    r_all = np.r_[r, r[-2:0:-1]]
    phi_all = np.unwrap(np.r_[phi_all, phi_all[0]])
    order = np.argsort(-phi_all[:-1])
    ph = -phi_all[:-1][order]
    rr = r_all[order]
    ph = np.r_[ph, ph[0] + 2 * np.pi]
    rr = np.r_[rr, rr[0]]
    spl = CubicSpline(ph, rr, bc_type="periodic")
    t = np.linspace(-np.pi / 2, np.pi / 2, 2001)       # -phi from top (-pi/2) to bottom
    x = spl(t) * np.cos(-t)
    y = cy + spl(t) * np.sin(-t)
    x[[0, -1]] = 0.0
    P3 = np.stack([x, y, face_height(x, y)], axis=1)
    dense = to_plane(P3)
    # keep the convex hull of the outline (the chin projects slightly concave), so the
    # planar Delaunay triangulation fills exactly the region it bounds
    full = np.concatenate([dense, dense * np.array([-1.0, 1.0])])
    hull = full[ConvexHull(full).vertices]
    hull = hull[hull[:, 0] >= 0.0]
    order = np.argsort(-np.arctan2(hull[:, 1] - hull[:, 1].mean(), hull[:, 0]))
    dense = hull[order]
    dense = np.concatenate([[[0.0, full[:, 1].max()]], dense, [[0.0, full[:, 1].min()]]])
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    n = max(int(np.ceil(arc[-1] / step)), 2)
    si = np.linspace(0.0, arc[-1], n + 1)
    out = np.stack([np.interp(si, arc, dense[:, 0]), np.interp(si, arc, dense[:, 1])], axis=1)
    out[[0, -1], 0] = 0.0
    return out


def _level(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Desired lattice level (0 fine, 1 medium, 2 coarse) at plane points."""
    upper_c = to_plane(np.array([0.0, -15.0, 8.0]))
    lower_c = to_plane(np.array([0.0, -42.0, 12.0]))
    qn = np.minimum((a / 15.0) ** 2 + ((b - upper_c[1]) / 20.0) ** 2,
                    (a / 25.0) ** 2 + ((b - lower_c[1]) / 14.0) ** 2)
    eye_c = to_plane(np.array([31.0, -8.0, -11.0]))
    qe = ((np.abs(a) - eye_c[0]) / 19.0) ** 2 + ((b - eye_c[1]) / 12.0) ** 2
    lip_c = to_plane(np.array([0.0, -71.0, 13.0]))
    ql = (a / 32.0) ** 2 + ((b - lip_c[1]) / 13.0) ** 2
    lev = np.full(a.shape, 2, dtype=np.int64)
    lev[(qn < 1.9) | (qe < 1.0) | (ql < 1.0)] = 1
    lev[qn < 1.0] = 0
    return lev


def half_points() -> tuple[np.ndarray, int]:
    """Plane points with a >= 0: the mask outline first, then lattice points.

    Returns (N, 2) points and the number of outline points.
    """
    boundary = _outline_plane(LATTICE_MM[2][0])
    dense = _outline_plane(0.2)
    poly = np.concatenate([dense, dense[-2:0:-1] * np.array([-1.0, 1.0])])
    tree = cKDTree(dense)
    lo, hi = dense.min(axis=0), dense.max(axis=0)
    pts = []
    for lev, (sa, sb) in enumerate(LATTICE_MM):
        k = np.arange(0, int(hi[0] / sa) + 2)
        j = np.arange(int(np.floor(lo[1] / sb)) - 2, int(np.ceil(hi[1] / sb)) + 3)
        K, J = np.meshgrid(k, j, indexing="ij")
        a = (K * sa).ravel()
        b = ((J + 0.5 * (K % 2)) * sb).ravel()
        lv = _level(a, b)
        keep = (lv == lev) if lev < 2 else (lv >= 2)
        cand = np.stack([a[keep], b[keep]], axis=1)
        cand = cand[points_in_polygon(cand, poly)]
        dist, _ = tree.query(cand)
        pts.append(cand[dist > 0.6 * sa])
    interior = np.concatenate(pts)
    interior = interior[np.lexsort((interior[:, 1], interior[:, 0]))]
    return np.concatenate([boundary, interior]), len(boundary)
