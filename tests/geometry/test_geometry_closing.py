"""Closing open meshes (naseview.geometry.closing): caps and a printable solid."""

from __future__ import annotations

import numpy as np
import trimesh

from naseview.geometry.closing import boundary_loops, cap_holes, cap_values, close_solid


def _sheet_with_hole(n: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """A curved open sheet (mm) with a square hole in the middle (like an eye opening)."""
    g = np.linspace(-40.0, 40.0, n)
    gx, gy = np.meshgrid(g, g)
    V = np.c_[gx.ravel(), gy.ravel(), -0.01 * (gx.ravel() ** 2 + gy.ravel() ** 2)]
    idx = np.arange(n * n).reshape(n, n)
    quads = [(i, j) for i in range(n - 1) for j in range(n - 1)
             if not (3 <= i <= 4 and 3 <= j <= 4)]
    F = np.array([t for i, j in quads for t in (
        (idx[i, j], idx[i, j + 1], idx[i + 1, j + 1]),
        (idx[i, j], idx[i + 1, j + 1], idx[i + 1, j]))])
    return V, F


def _segments_cross(A: np.ndarray, B: np.ndarray, T: np.ndarray) -> int:
    """How many segments AB (k, 3) pass strictly through triangles T (t, 3, 3)."""
    hits = 0
    for a, b in zip(A, B, strict=True):
        d = b - a
        e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = a - T[:, 0]
        u = np.einsum("ij,ij->i", tv, p) * inv
        q = np.cross(tv, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        e = 1e-6
        hits += int(np.sum(ok & (u > e) & (v > e) & (u + v < 1 - e) & (t > e) & (t < 1 - e)))
    return hits


def test_close_solid_is_watertight_and_does_not_cut_the_face() -> None:
    V, F = _sheet_with_hole()
    assert not trimesh.Trimesh(V, F, process=False).is_watertight
    V2, F2 = close_solid(V, F, back_mm=5.0)
    m = trimesh.Trimesh(V2, F2, process=False)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    assert np.array_equal(V2[:len(V)], V) and np.array_equal(F2[:len(F)], F)
    assert V2[:, 2].min() == V[:, 2].min() - 5.0
    new = F2[len(F):]
    E = np.concatenate([new[:, [0, 1]], new[:, [1, 2]], new[:, [2, 0]]])
    assert _segments_cross(V2[E[:, 0]], V2[E[:, 1]], V[F]) == 0


def test_cap_holes_closes_inner_loops_only() -> None:
    V, F = _sheet_with_hole()
    assert len(boundary_loops(F)) == 2
    V2, F2 = cap_holes(V, F, recess=0.3)
    assert len(V2) == len(V) + 1 and len(boundary_loops(F2)) == 1
    centre = V2[-1]
    assert centre[2] < -0.5                      # recessed behind the sheet's centre (z 0)
    m = trimesh.Trimesh(V2, F2, process=False)
    assert m.is_winding_consistent
    uv = np.c_[V[:, 0], V[:, 1]]
    assert np.allclose(cap_values(uv, F, V)[-1], [0.0, 0.0])
