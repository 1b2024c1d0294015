"""Mesh basics, regions and the cotangent Laplacian (naseview.geometry)."""

from __future__ import annotations

import numpy as np

from naseview.geometry.laplacian import cotangent_laplacian, cotangent_weights, voronoi_mass
from naseview.geometry.mesh import boundary_edges, mesh_edges, vertex_adjacency
from naseview.geometry.region import grow_by_distance, submesh


def _grid(n: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """An n x n grid of 1 mm squares in z = 0, two CCW triangles per square."""
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    V = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), \
        idx[1:, :-1].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_adjacency_is_symmetric_with_edge_lengths() -> None:
    V, F = _grid()
    A, W = vertex_adjacency(len(V), F), vertex_adjacency(len(V), F, V)
    assert A.nnz == 2 * len(mesh_edges(F)) and (A != A.T).nnz == 0
    assert np.array_equal(A.indices, W.indices) and set(A.data) == {1.0}
    assert np.isclose(W[0, 1], 1.0) and np.isclose(W[0, 6], np.sqrt(2))
    assert len(boundary_edges(F)) == 4 * 4


def test_grow_and_submesh() -> None:
    V, F = _grid()
    grown = grow_by_distance(V, F, np.array([12]), 1.0)          # the centre and its ring
    assert grown.tolist() == [6, 7, 11, 12, 13, 17, 18]
    Vs, Fs, ids = submesh(V, F, grown)
    assert np.array_equal(Vs, V[ids]) and Fs.max() == len(ids) - 1 and len(Fs) == 6


def test_laplacian_of_a_plane_and_its_mass() -> None:
    V, F = _grid()
    L, m, W = cotangent_laplacian(V, F), voronoi_mass(V, F), cotangent_weights(V, F)
    inner = np.setdiff1d(np.arange(len(V)), np.unique(boundary_edges(F)))
    assert np.abs((L @ V)[inner]).max() < 1e-12                  # linear functions: 0
    assert np.isclose(m.sum(), 16.0)                               # the grid's area, mm^2
    assert W.diagonal().max() == 0 and W.data.min() > 0
