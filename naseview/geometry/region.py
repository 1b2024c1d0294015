"""Vertex regions of a mesh: grow a set along the edges, cut out its triangles.

Stage 3 grows the nose region around the ARAP handles and pins a margin ring around it
(paper §3.4), the app does the same for the edited nose, and the pipeline writes the nose
as a submesh (``nose.ply``).

Example
-------
>>> import numpy as np
>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0]])
>>> F = np.array([[0, 1, 3], [1, 4, 3], [1, 2, 4]])
>>> grow_by_distance(V, F, np.array([0]), 1.2).tolist()
[0, 1, 3]
>>> Vs, Fs, ids = submesh(V, F, np.array([0, 1, 3, 4]))
>>> Fs.tolist(), ids.tolist()
([[0, 1, 2], [1, 3, 2]], [0, 1, 3, 4])
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse.csgraph import dijkstra

from naseview.geometry.mesh import vertex_adjacency


def grow_by_distance(V: np.ndarray, F: np.ndarray, seeds: ArrayLike, radius_mm: float,
                     adjacency: sp.csr_matrix | None = None) -> np.ndarray:
    """(k,) sorted vertex ids within ``radius_mm`` of ``seeds`` along mesh edges.

    The seeds are included, and at least their one-ring when ``radius_mm`` > 0.

    Args:
        V: (n, 3) vertices, mm. F: (m, 3) int triangles.
        seeds: (s,) vertex ids.
        radius_mm: largest path length along the edges, mm (<= 0: the seeds only).
        adjacency: optional precomputed ``vertex_adjacency(n, F, V)`` (edge lengths).
    """
    seeds = np.unique(np.asarray(seeds, np.int64))
    if radius_mm <= 0 or len(seeds) == 0:
        return seeds
    A = adjacency if adjacency is not None else vertex_adjacency(len(V), F, V)
    # one super-source: distances from the seed set
    d = dijkstra(A, directed=False, indices=seeds, limit=radius_mm, min_only=True)
    grown = np.flatnonzero(np.isfinite(d))
    ring1 = A[seeds].indices
    return np.unique(np.concatenate([grown, ring1, seeds]))


def submesh(V: np.ndarray, F: np.ndarray, vertex_ids: ArrayLike
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles of ``F`` with all corners in ``vertex_ids``, reindexed.

    Args:
        V: (n, 3) vertices. F: (m, 3) int triangles. vertex_ids: (k,) ids into V.
    Returns:
        ``(V_sub, F_sub, ids)``: (r, 3) vertices used by those triangles, their (t, 3)
        triangles indexing ``V_sub``, and the (r,) sorted original ids of the ``V_sub`` rows.
    """
    keep = np.zeros(len(V), bool)
    keep[np.asarray(vertex_ids, np.int64)] = True
    Fk = np.asarray(F, np.int64)[keep[F].all(1)]
    ids = np.unique(Fk)
    loc = np.full(len(V), -1, np.int64)
    loc[ids] = np.arange(len(ids))
    return V[ids], loc[Fk], ids
