"""The generic face's mean mesh, assembled (design steps 2 and 3).

Lattice points in the meshing plane (:mod:`~naseview.facemodel.generic.lattice`) cast onto
the surface (:mod:`~naseview.facemodel.generic.plane`), nostrils carved
(:mod:`~naseview.facemodel.generic.nostrils`), triangulated and flipped to surface Delaunay,
then mirrored (:mod:`~naseview.facemodel.generic.triangulate`). mm, the generic face's frame.

Example
-------
    mesh = generic_mesh()
    mesh.V.shape[1], mesh.F.shape[1]
    # -> (3, 3)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from naseview.facemodel.generic.lattice import half_points
from naseview.facemodel.generic.nostrils import carve_nostrils
from naseview.facemodel.generic.plane import ray_hits, ray_points
from naseview.facemodel.generic.triangulate import (
    delaunay_half,
    flip_to_delaunay_3d,
    mirror_half,
)


@dataclass(frozen=True)
class GenericMesh:
    """The mean face mesh and what the model annotations are computed from.

    Attributes:
        V: (N, 3) float64 vertices, mm.
        F: (M, 3) int64 triangles, counter-clockwise seen from outside.
        V_uncarved: (N, 3) vertices before the nostrils were carved.
        nostril_side: (N,) int64 +1 / -1 inside the left / right nostril, else 0.
        mirror: (N,) int64 index of each vertex's mirror image across x = 0.
    """

    V: np.ndarray
    F: np.ndarray
    V_uncarved: np.ndarray
    nostril_side: np.ndarray
    mirror: np.ndarray


@functools.lru_cache(maxsize=1)
def generic_mesh() -> GenericMesh:
    """Build the mean face mesh (deterministic; a fraction of a second; cached, read-only)."""
    half, n_outline = half_points()
    X0 = ray_points(half, ray_hits(half))
    X, which = carve_nostrils(X0)
    F = flip_to_delaunay_3d(half, X, delaunay_half(half, n_outline))
    _, V, F = mirror_half(half, X, F)
    _, V0, _ = mirror_half(half, X0, F[:0])
    side = np.abs(half[:, 0]) >= 1e-9
    n_half, n_side = len(half), int(side.sum())
    mirror = np.arange(n_half + n_side)
    mirror[np.flatnonzero(side)] = n_half + np.arange(n_side)
    mirror[n_half:] = np.flatnonzero(side)
    which = np.concatenate([which, -which[side]])
    which = _largest_patches(F, which)
    for arr in (V, F, V0, which, mirror):
        arr.flags.writeable = False
    return GenericMesh(V, F, V0, which, mirror)


def _largest_patches(F: np.ndarray, label: np.ndarray) -> np.ndarray:
    """Keep, for every non-zero label, only its largest edge-connected set of vertices."""
    out = np.zeros_like(label)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    for lab in np.unique(label[label != 0]):
        ids = np.flatnonzero(label == lab)
        pos = np.full(len(label), -1)
        pos[ids] = np.arange(len(ids))
        ee = e[(pos[e[:, 0]] >= 0) & (pos[e[:, 1]] >= 0)]
        A = coo_matrix((np.ones(len(ee)), (pos[ee[:, 0]], pos[ee[:, 1]])),
                       shape=(len(ids), len(ids)))
        _, comp = connected_components(A, directed=False)
        out[ids[comp == np.argmax(np.bincount(comp))]] = lab
    return out
