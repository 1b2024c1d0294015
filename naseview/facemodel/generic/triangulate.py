"""The generic face's triangles: Delaunay in the meshing plane, then surface flips (step 2).

The half lattice (:mod:`~naseview.facemodel.generic.lattice`) is triangulated in the plane;
edge flips then make it Delaunay on the surface (3D angles), so that steep sides get no
long thin triangles; the half is finally mirrored across the midline.

Example
-------
>>> import numpy as np
>>> P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
>>> signed_area(P, np.array([[0, 1, 2]])).tolist()
[1.0]
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from naseview.geometry.polygon import points_in_polygon


def delaunay_half(P: np.ndarray, n_boundary: int) -> np.ndarray:
    """(F, 3) triangles of half-plane points P (N, 2), counter-clockwise in (a, b).

    ``P[:n_boundary]`` is the outline (top to bottom); triangles outside the region it
    bounds with the midline (slight concavities of the outline) are dropped.
    """
    tri = Delaunay(P, qhull_options="Qbb Qc Qz Q12").simplices.astype(np.int64)
    outline = P[:n_boundary]
    poly = np.concatenate([outline, outline[-2:0:-1] * np.array([-1.0, 1.0])])
    cen = P[tri].mean(axis=1)
    tri = tri[points_in_polygon(cen, poly) | (np.abs(cen[:, 0]) < 1e-9)]
    area = signed_area(P, tri)
    tri = tri[np.abs(area) > 1e-9]
    area = area[np.abs(area) > 1e-9]
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    return tri


def signed_area(P: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(M,) twice the signed area of triangles ``tri`` (M, 3) of plane points ``P`` (N, 2);
    > 0 counter-clockwise."""
    A = P[tri]
    return (A[:, 1, 0] - A[:, 0, 0]) * (A[:, 2, 1] - A[:, 0, 1]) \
        - (A[:, 2, 0] - A[:, 0, 0]) * (A[:, 1, 1] - A[:, 0, 1])


def _interior_edges(F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interior edges of a consistently oriented triangle mesh.

    Returns (E, 2) edges (i, j) as they run in the first triangle, and the two
    triangles (E,) t1 (containing i -> j) and t2 (containing j -> i).
    """
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    ft = np.tile(np.arange(len(F)), 3)
    key = np.minimum(he[:, 0], he[:, 1]) * (F.max() + 1) + np.maximum(he[:, 0], he[:, 1])
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    h1, h2 = order[pair], order[pair + 1]
    return he[h1], ft[h1], ft[h2]


def flip_to_delaunay_3d(P2: np.ndarray, X: np.ndarray, F: np.ndarray,
                         max_rounds: int = 60) -> np.ndarray:
    """Flip edges until the triangulation is Delaunay on the surface (3D angles).

    A lattice triangulated in the plane gives long thin triangles where the surface is
    steep; flipping to the 3D-Delaunay diagonals removes the shading streaks. Only flips
    that keep both triangles counter-clockwise in the plane (``P2``) are made, so the mesh
    stays an embedding over the plane.

    Args:
        P2: (N, 2) plane points; X: (N, 3) surface points; F: (M, 3) triangles (CCW in P2).
    Returns:
        (M, 3) triangles.
    """
    F = F.copy()
    for _ in range(max_rounds):
        E, t1, t2 = _interior_edges(F)
        i, j = E[:, 0], E[:, 1]
        # opposite vertices: k in t1, l in t2
        k = F[t1].sum(axis=1) - i - j
        l_ = F[t2].sum(axis=1) - i - j

        def cot(at: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
            u, v = X[p] - X[at], X[q] - X[at]
            return np.einsum("ij,ij->i", u, v) / np.maximum(
                np.linalg.norm(np.cross(u, v), axis=1), 1e-12)

        bad = cot(k, i, j) + cot(l_, i, j) < -1e-9
        if not bad.any():
            break
        # new triangles (i, l, k) and (l, j, k) must be counter-clockwise in the plane
        n1 = np.stack([i, l_, k], axis=1)
        n2 = np.stack([l_, j, k], axis=1)
        ok = bad & (signed_area(P2, n1) > 1e-9) & (signed_area(P2, n2) > 1e-9)
        cand = np.flatnonzero(ok)
        if cand.size == 0:
            break
        # flip an independent set: every triangle in at most one flip this round
        viol = (cot(k, i, j) + cot(l_, i, j))[cand]
        cand = cand[np.argsort(viol, kind="stable")]
        used = np.zeros(len(F), dtype=bool)
        chosen: list[int] = []
        for e in cand:
            if not used[t1[e]] and not used[t2[e]]:
                used[t1[e]] = used[t2[e]] = True
                chosen.append(int(e))
        take = np.asarray(chosen, dtype=np.int64)
        F[t1[take]] = n1[take]
        F[t2[take]] = n2[take]
    return F


def mirror_half(P2: np.ndarray, X: np.ndarray, F: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mirror a half mesh (a >= 0) across the midline a = 0.

    Returns plane points (N', 2), surface points (N', 3) (the half, then mirrored copies
    of the a > 0 points) and triangles (2M, 3), counter-clockwise seen from outside.
    """
    on_mid = np.abs(P2[:, 0]) < 1e-9
    side = np.flatnonzero(~on_mid)
    mirror_idx = np.arange(len(P2))
    mirror_idx[side] = len(P2) + np.arange(len(side))
    flip = np.array([-1.0, 1.0, 1.0])
    F_m = mirror_idx[F][:, [0, 2, 1]]
    return (np.concatenate([P2, P2[side] * flip[:2]]), np.concatenate([X, X[side] * flip]),
            np.concatenate([F, F_m]))
