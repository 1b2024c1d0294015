"""Mesh export round trips and one-line mesh errors (naseview.meshio)."""

from __future__ import annotations

import numpy as np
import pytest

from naseview.errors import NaseviewError
from naseview.meshio import export_mesh, read_mesh


@pytest.mark.parametrize("ext", ["ply", "stl", "obj", "glb"])
def test_export_round_trip(tmp_path, ext: str) -> None:
    rng = np.random.default_rng(1)
    # a bumpy open grid: distinct vertices, consistent orientation
    gx, gy = np.meshgrid(np.arange(6.0), np.arange(5.0))
    V = np.c_[gx.ravel() * 2.5, gy.ravel() * 2.5, rng.normal(0, 1, gx.size)]
    idx = np.arange(gx.size).reshape(gx.shape)
    F = np.concatenate([
        np.c_[idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()],
        np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()]])
    colors = rng.integers(0, 255, (len(V), 3)).astype(np.uint8)
    path = export_mesh(tmp_path / f"m.{ext}", V, F, vertex_colors=colors)
    V2, F2 = read_mesh(path)
    assert len(F2) == len(F) and len(V2) == len(V)
    # same triangles (as point triples, order-insensitive for STL's merged vertices)
    tri = np.sort(V[F].reshape(len(F), -1), axis=0)
    tri2 = np.sort(V2[F2].reshape(len(F2), -1), axis=0)
    assert np.allclose(tri, tri2, atol=1e-5)
    if ext != "stl":
        assert np.allclose(V2, V, atol=1e-5) and (F2 == F).all()
    assert not list(tmp_path.glob(".*.tmp"))


def test_mesh_errors_are_one_line(tmp_path) -> None:
    V = np.eye(3)
    F = np.array([[0, 1, 2]])
    with pytest.raises(NaseviewError, match="unsupported mesh type"):
        export_mesh(tmp_path / "m.xyz", V, F)
    with pytest.raises(NaseviewError, match="outside"):
        export_mesh(tmp_path / "m.ply", V, np.array([[0, 1, 5]]))
    with pytest.raises(NaseviewError, match="not found"):
        read_mesh(tmp_path / "none.ply")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"this is not a mesh")
    with pytest.raises(NaseviewError) as e:
        read_mesh(bad)
    assert "\n" not in str(e.value)
