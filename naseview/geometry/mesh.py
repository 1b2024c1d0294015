"""Triangle-mesh basics: normals, edges and the vertex adjacency (one home each).

A mesh is ``V`` (n, 3) float vertices (mm) and ``F`` (m, 3) int triangles, counter-clockwise
seen from outside. The stages, the face models, the renderer and the app import these.

Example
-------
>>> import numpy as np
>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
>>> vertex_normals(V, F)[0].tolist()
[0.0, 0.0, 1.0]
>>> mesh_edges(F).tolist()
[[0, 1], [0, 2], [1, 2]]
>>> vertex_adjacency(3, F, V).toarray().round(3).tolist()[0]
[0.0, 1.0, 1.0]
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

__all__ = ["boundary_edges", "face_normals", "mesh_edges", "vertex_adjacency",
           "vertex_normals"]


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


def mesh_edges(F: ArrayLike) -> np.ndarray:
    """(E, 2) int64 unique undirected edges ``(i, j)``, ``i < j``, of triangles ``F`` (m, 3).

    Sorted by ``(i, j)``.
    """
    F = np.asarray(F, dtype=np.int64)
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    n = int(F.max()) + 1 if F.size else 1
    key = np.unique(e[:, 0] * n + e[:, 1])
    return np.stack([key // n, key % n], axis=1)


def boundary_edges(F: ArrayLike) -> np.ndarray:
    """(B, 2) directed edges (as they run in ``F`` (m, 3)) that belong to one triangle only."""
    F = np.asarray(F, dtype=np.int64)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    s = np.sort(e, axis=1)
    n = int(F.max()) + 1 if F.size else 1
    _, inv, counts = np.unique(s[:, 0] * n + s[:, 1], return_inverse=True, return_counts=True)
    return e[counts[inv.ravel()] == 1]


def vertex_adjacency(n_vertices: int, F: ArrayLike, V: ArrayLike | None = None
                     ) -> sp.csr_matrix:
    """(n, n) symmetric CSR adjacency of the mesh edges, sorted indices.

    Args:
        n_vertices: n, the number of vertices (isolated ones get empty rows).
        F: (m, 3) int triangles.
        V: optional (n, 3) vertices (mm): the entries are then the edge lengths (mm,
            at least 1e-9 so that no edge is an explicit zero), else 1.0.
    """
    E = mesh_edges(F)
    if V is None:
        w = np.ones(len(E))
    else:
        P = np.asarray(V, dtype=np.float64)
        w = np.maximum(np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1), 1e-9)
    A = sp.coo_matrix((w, (E[:, 0], E[:, 1])), shape=(n_vertices, n_vertices))
    return (A + A.T).tocsr()
