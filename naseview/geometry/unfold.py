"""Folds of a deformed mesh found against its rest shape and smoothed out.

A deformation ``V`` of a rest mesh ``ref`` (same triangles ``F``) *folds* a triangle when
its normal turns against the rest normal: the skin has creased back over itself (a flap
out of a nostril, a slit along the alar groove). :func:`folded_faces` finds them;
:func:`unfold` replaces the displacement ``V - ref`` over a patch around them by its
harmonic interpolation from the patch's rim (graph Laplacian), growing the patch ring by
ring until no triangle is folded. The rest shape is unfolded, and a harmonic displacement
of it changes slowly over the patch, so the patch is smooth again; vertices outside the
patch and the ``fixed`` ones never move.

Example
-------
>>> import numpy as np
>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0],
...               [0, 2, 0], [1, 2, 0], [2, 2, 0]], float)
>>> F = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3], [4, 5, 3], [2, 3, 6], [3, 7, 6],
...               [3, 5, 7], [5, 8, 7]])
>>> W = V.copy(); W[3] = [-0.5, -0.5, 0.0]          # the centre vertex pulled across
>>> len(folded_faces(W, F, V)) > 0, len(folded_faces(unfold(W, F, V)[0], F, V))
(True, 0)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse.linalg import spsolve

from naseview.geometry.mesh import face_normals, vertex_adjacency

__all__ = ["folded_faces", "unfold"]


def folded_faces(V: ArrayLike, F: ArrayLike, ref: ArrayLike,
                 faces: ArrayLike | None = None) -> np.ndarray:
    """Ids of the triangles of ``F`` whose normal in ``V`` points against (or across,
    a collapsed triangle) their normal in ``ref``; only among ``faces`` when given.
    Triangles degenerate in ``ref`` are never counted."""
    F = np.asarray(F, np.int64)
    ids = np.arange(len(F)) if faces is None else np.asarray(faces, np.int64)
    n0 = face_normals(ref, F[ids])
    n1 = face_normals(V, F[ids])
    a0 = np.linalg.norm(n0, axis=1)
    ok = a0 > 1e-9 * max(float(a0.max(initial=0.0)), 1e-30)
    dots = np.einsum("ij,ij->i", n0, n1)
    return ids[ok & (dots <= 0.0)]


def unfold(V: ArrayLike, F: ArrayLike, ref: ArrayLike, fixed: ArrayLike | None = None,
           movable: ArrayLike | None = None, rings: int = 2, max_rounds: int = 8
           ) -> tuple[np.ndarray, int]:
    """``V`` with its folds against ``ref`` smoothed out (see the module doc).

    Args:
        V: (n, 3) deformed vertices; F: (m, 3) triangles; ref: (n, 3) rest vertices.
        fixed: (n,) bool or vertex ids that must not move (hard handles, a pinned ring).
        movable: (n,) bool or vertex ids that may move (default: all); only triangles
            with a movable vertex are checked.
        rings: edge rings the first patch reaches around the folded triangles; each
            further round reaches one ring more.
        max_rounds: rounds before giving up.
    Returns:
        (V', number of triangles still folded).
    """
    V = np.array(V, dtype=np.float64)
    F = np.asarray(F, np.int64)
    ref = np.asarray(ref, np.float64)
    n = len(V)

    def mask(x: ArrayLike | None, default: bool) -> np.ndarray:
        m = np.full(n, default)
        if x is not None:
            a = np.asarray(x)
            m = a.astype(bool) if a.dtype == bool and len(a) == n else np.zeros(n, bool)
            if a.dtype != bool:
                m[a.astype(np.int64)] = True
        return m

    free = mask(movable, True) & ~mask(fixed, False)
    faces = np.flatnonzero(free[F].any(1))
    folded = folded_faces(V, F, ref, faces)
    if not len(folded):
        return V, 0
    A = vertex_adjacency(n, F).astype(bool).astype(np.float64)
    L = (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr()
    for r in range(max_rounds):
        patch = np.zeros(n, bool)
        patch[F[folded].ravel()] = True
        for _ in range(rings + r):
            patch |= (A @ patch.astype(np.float64)) > 0
        patch &= free
        if not patch.any():
            break
        inside = np.flatnonzero(patch)
        rim = np.flatnonzero(~patch)
        D = V - ref
        rhs = -(L[inside][:, rim] @ D[rim])
        K = L[inside][:, inside] + 1e-9 * sp.identity(len(inside))   # a patch with no rim
        sol = spsolve(K.tocsc(), rhs)
        V[inside] = ref[inside] + np.asarray(sol).reshape(-1, 3)
        folded = folded_faces(V, F, ref, faces)
        if not len(folded):
            break
    return V, len(folded)
