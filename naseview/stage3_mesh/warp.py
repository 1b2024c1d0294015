"""The smooth warp of the base face towards the ad-landmarks (naseview's addition to §3.4).

Between the morphable-model fit (eq. 18) and ARAP (eq. 19-20) naseview bends the fitted
face smoothly towards the ad-landmarks with soft constraints: the large, smooth part of the
correction that a low-dimensional model (the generic face) cannot make, so that ARAP only
closes the small remainder instead of crumpling the mesh. Bi-Laplacian editing with soft
handles (Botsch & Sorkine 2008), on the cotangent Laplacian and Voronoi mass of
:mod:`naseview.geometry.laplacian`. SPEC frame, mm.

Example
-------
    V2 = smooth_warp(V, F, handle_ids, targets, np.ones(len(handle_ids)), 0.5,
                     region_ids)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike
from scipy.sparse.linalg import splu

from naseview.geometry.laplacian import cotangent_laplacian, voronoi_mass


def smooth_warp(V: np.ndarray, F: np.ndarray, handle_ids: ArrayLike, targets: ArrayLike,
                weights: ArrayLike, bending_mm2: float, region_ids: ArrayLike) -> np.ndarray:
    """Bend a mesh smoothly towards targets: soft-constrained bi-Laplacian deformation.

    The displacement ``d`` (zero outside ``region_ids``) minimises

        sum_h weights_h |V_h + d_h - targets_h|^2 + bending_mm2 * d^T L^T M^-1 L d

    with L the cotangent Laplacian and M the Voronoi mass matrix of ``V``: the smoothest
    displacement that brings the handles close to their targets. One sparse factorisation
    (SuperLU).

    Args:
        V: (n, 3) mesh, mm. F: (m, 3) triangles.
        handle_ids: (H,) vertex ids; those outside the region are ignored.
        targets: (H, 3) mm.
        weights: (H,) handle weights (1/mm^2).
        bending_mm2: bending weight (mm^2).
        region_ids: vertices free to move.
    Returns:
        (n, 3) warped vertices.
    """
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    n = len(V)
    region = np.unique(np.asarray(region_ids, np.int64))
    h = np.asarray(handle_ids, np.int64)
    inside = np.isin(h, region)
    h, T, w = h[inside], np.asarray(targets, float)[inside], np.asarray(weights, float)[inside]
    if len(h) == 0 or len(region) == 0:
        return V.copy()
    L = cotangent_laplacian(V, F).tocsr()
    m = voronoi_mass(V, F)
    Lr = L[:, region]                                     # d is zero outside the region
    Q = (Lr.T @ sp.diags(1.0 / np.maximum(m, 1e-12)) @ Lr).tocsc()
    loc = np.full(n, -1, np.int64)
    loc[region] = np.arange(len(region))
    W = sp.csc_matrix((w, (loc[h], loc[h])), shape=(len(region), len(region)))
    A = (bending_mm2 * Q + W + 1e-8 * sp.eye(len(region))).tocsc()
    rhs = np.zeros((len(region), 3))
    np.add.at(rhs, loc[h], w[:, None] * (T - V[h]))
    d = splu(A, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True}).solve(rhs)
    out = V.copy()
    out[region] += d
    return out
