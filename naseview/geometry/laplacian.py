"""The cotangent Laplacian and the Voronoi mass matrix of a triangle mesh (libigl).

``L`` (n, n) is the cotangent Laplacian, negative semi-definite: ``L_ij = (cot a_ij +
cot b_ij) / 2`` for an edge ij with opposite angles a_ij, b_ij, and ``L_ii = -sum_j L_ij``;
``M`` the diagonal Voronoi mass matrix (mm^2 per vertex), so ``M^-1 L`` approximates the
Laplace-Beltrami operator (Meyer et al. 2003). Used by stage 3's smooth warp (a
bi-Laplacian energy), its cotangent smoothing (paper eq. 21) and the mean curvature of the
mesh-curve costs.

Example
-------
>>> import numpy as np
>>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]); F = np.array([[0, 1, 2]])
>>> cotangent_laplacian(V, F).toarray().round(3).tolist()[0]
[-1.0, 0.5, 0.5]
>>> voronoi_mass(V, F).round(4).tolist()
[0.25, 0.125, 0.125]
>>> cotangent_weights(V, F).toarray().round(3).tolist()[1]
[0.5, 0.0, 0.0]
"""

from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike


def _mesh(V: ArrayLike, F: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Contiguous float64 (n, 3) and int64 (m, 3) copies for libigl."""
    return (np.ascontiguousarray(V, dtype=np.float64),
            np.ascontiguousarray(F, dtype=np.int64))


def cotangent_laplacian(V: ArrayLike, F: ArrayLike) -> sp.csc_matrix:
    """(n, n) cotangent Laplacian ``L`` (CSC, as libigl returns it), negative semi-definite.

    Args:
        V: (n, 3) vertices, mm. F: (m, 3) int triangles.
    """
    Vc, Fc = _mesh(V, F)
    return igl.cotmatrix(Vc, Fc)


def voronoi_mass(V: ArrayLike, F: ArrayLike) -> np.ndarray:
    """(n,) diagonal of the Voronoi mass matrix ``M``, mm^2 (0 for isolated vertices).

    Args:
        V: (n, 3) vertices, mm. F: (m, 3) int triangles.
    """
    Vc, Fc = _mesh(V, F)
    return np.asarray(igl.massmatrix(Vc, Fc, igl.MASSMATRIX_TYPE_VORONOI).diagonal())


def cotangent_weights(V: ArrayLike, F: ArrayLike) -> sp.csr_matrix:
    """(n, n) CSR edge weights: the off-diagonal of ``L`` clamped at 0, explicit zeros removed.

    Obtuse triangles give negative cotangent weights; clamped, every row is a convex
    averaging of the neighbours once divided by its sum (stage 3's smoothing, eq. 21).

    Args:
        V: (n, 3) vertices, mm. F: (m, 3) int triangles.
    """
    W = cotangent_laplacian(V, F).tocsr()
    W.setdiag(0.0)
    W.data = np.maximum(W.data, 0.0)
    W.eliminate_zeros()
    return W
