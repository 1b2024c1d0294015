"""Folded triangles: the check that a displacement did not turn the surface over.

A triangle ``(i, j, k)`` with rest normal ``N0 = (v_j - v_i) x (v_k - v_i)`` and deformed
normal ``N1`` is *folded* when ``N0 . N1 <= 0`` (it turned by 90 degrees or more: flipped
over) or when its area ``|N1| / 2`` fell below 10 % of its rest area (crushed).
"""

from __future__ import annotations

import numpy as np

MIN_AREA_RATIO = 0.1
"""A triangle crushed below this fraction of its rest area counts as folded."""


def folded_triangles(V_rest: np.ndarray, V: np.ndarray, F: np.ndarray,
                     face_ids: np.ndarray | None = None) -> np.ndarray:
    """(k,) sorted ids of triangles whose normal flipped (dot <= 0) or whose area shrank
    below 10 % of the rest area.

    Args:
        V_rest: (N, 3) rest vertices, mm. V: (N, 3) deformed vertices. F: (M, 3) int.
        face_ids: (m,) triangles to check (default: all).
    """
    F = np.asarray(F, np.int64)
    ids = np.arange(len(F)) if face_ids is None else np.asarray(face_ids, np.int64)
    T = F[ids]

    def normals(X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, np.float64)
        return np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])

    N0, N1 = normals(V_rest), normals(V)
    a0 = np.linalg.norm(N0, axis=1)
    a1 = np.linalg.norm(N1, axis=1)
    bad = (np.einsum("ij,ij->i", N0, N1) <= 0.0) | (a1 < MIN_AREA_RATIO * a0)
    bad &= a0 > 0.0          # a degenerate rest triangle has no orientation to lose
    return np.asarray(np.sort(ids[bad]), np.int64)
