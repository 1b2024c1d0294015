"""Vertex paths of the SPEC §5 curves on a face mesh (naseview.facemodel.meshcurves): on
the ICT model and on any mesh.

The ICT data is read from ../shared (never copied into the repository).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.facemodel import meshcurves, store
from naseview.geometry.mesh import mesh_edges
from naseview.landmarks import CURVE_LANDMARKS, CURVE_NAMES, HELPER_IDS


@pytest.fixture(scope="module")
def ict(ict_dir: Path):
    return store.load_ict_npz(ict_dir / "ict_face_light.npz")


def _edges(F: np.ndarray) -> set[tuple[int, int]]:
    return set(map(tuple, mesh_edges(F).tolist()))


def _assert_connected(path: np.ndarray, edges: set[tuple[int, int]], closed: bool) -> None:
    seq = np.concatenate([path, path[:1]]) if closed else path
    for a, b in zip(seq[:-1], seq[1:], strict=True):
        assert (min(a, b), max(a, b)) in edges, (a, b)


def test_curve_paths_connect_their_landmarks(ict) -> None:
    edges = _edges(ict.faces)
    lm = ict.landmark_vertices
    assert tuple(ict.curve_vertices) == CURVE_NAMES
    for name, path in ict.curve_vertices.items():
        assert path.dtype == np.int64 and len(path) >= 3, name
        if name.startswith("sill"):
            _assert_connected(path, edges, closed=True)
            assert len(set(path.tolist())) == len(path)
            assert path[0] == lm["alpp_" + name[-1]]
            assert set(path.tolist()) <= set(ict.nostril_vertices.tolist())
            side = np.sign(ict.mean[path, 0])
            assert (side == (1 if name.endswith("_l") else -1)).all()
            continue
        _assert_connected(path, edges, closed=False)
        ids = [lm[i] for i in CURVE_LANDMARKS[name] if i not in HELPER_IDS]
        assert path[0] == ids[0] and path[-1] == ids[-1]
        pos = [int(np.nonzero(path == i)[0][0]) for i in ids]
        assert pos == sorted(pos), name
    assert np.all(ict.mean[ict.curve_vertices["mid"], 0] == 0.0)  # on the midline


def test_curve_paths_generic_mesh_and_boundary_loops() -> None:
    # a 21 x 21 grid bump in the SPEC axes (z up = anterior): curves exist on any mesh
    n = 21
    x, y = np.meshgrid(np.linspace(-20, 20, n), np.linspace(-20, 20, n))
    z = 20 * np.exp(-(x**2 + y**2) / 150)
    V = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])

    def vid(px: float, py: float) -> int:
        return int(np.argmin((V[:, 0] - px) ** 2 + (V[:, 1] - py) ** 2))

    lm = {"g": vid(0, 18), "n": vid(0, 12), "k": vid(0, 8), "r": vid(0, 4), "prn": vid(0, 0),
          "c": vid(0, -4), "sn": vid(0, -8)}
    for s, side in ((1, "l"), (-1, "r")):
        lm.update({f"mf_{side}": vid(6 * s, 14), f"int_{side}": vid(8 * s, 4),
                   f"al_{side}": vid(12 * s, -2), f"alp_{side}": vid(6 * s, -4),
                   f"alpp_{side}": vid(6 * s, -10), f"ac_{side}": vid(12 * s, -8),
                   f"md_{side}": vid(4 * s, -6)})
    nostril = np.array([vid(px, py) for px in (-8, -6, -4, 4, 6, 8) for py in (-12, -10, -8)])
    paths = meshcurves.curve_paths(V, F, lm, nostril)
    edges = _edges(F)
    for name, path in paths.items():
        _assert_connected(path, edges, closed=name.startswith("sill"))
    assert np.all(V[paths["mid"], 0] == 0.0)
    assert len(paths["sill_l"]) == 8 and (V[paths["sill_l"], 0] > 0).all()
    loops = meshcurves.region_boundary_loops(F, idx[2:6, 2:6].ravel())
    assert len(loops) == 1 and len(loops[0]) == 12
