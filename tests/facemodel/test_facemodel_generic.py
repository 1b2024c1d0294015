"""The built-in generic face model: a valid mesh, anatomical landmarks, interpretable modes."""

from __future__ import annotations

import igl
import numpy as np
import pytest
from scipy.spatial import cKDTree

from naseview.facemodel import load_face_model
from naseview.facemodel.generic import (
    CREDIT,
    FACE_MODES,
    MODE_SD_MM,
    NOSE_MODES,
    D,
    generic_face_model,
    generic_mesh,
    mode_measurements,
)
from naseview.geometry.mesh import vertex_adjacency
from naseview.landmarks import CURVE_LANDMARKS, CURVE_NAMES, HELPER_IDS, LANDMARK_IDS


@pytest.fixture(scope="module")
def fm():
    return generic_face_model()


def _face_normals(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    area = 0.5 * np.linalg.norm(n, axis=1)
    return n / np.maximum(2 * area, 1e-300)[:, None], area


def _edges(F: np.ndarray) -> np.ndarray:
    return np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])


def test_mesh_is_an_oriented_manifold_disk_without_degenerate_triangles(fm) -> None:
    V, F = fm.mean, fm.faces
    assert 8_000 <= len(V) <= 25_000 and np.isfinite(V).all()
    assert F.dtype == np.int64 and F.min() == 0 and F.max() == len(V) - 1
    # every directed edge once (consistent orientation), every edge in 1 or 2 triangles
    he = _edges(F)
    assert len(np.unique(he, axis=0)) == len(he)
    und, counts = np.unique(np.sort(he, axis=1), axis=0, return_counts=True)
    assert counts.max() == 2
    # a topological disk: Euler characteristic 1, one boundary loop, no isolated vertices
    assert len(V) - len(und) + len(F) == 1
    assert len(np.unique(F)) == len(V)
    b = und[counts == 1]
    assert len(np.unique(b)) == len(b)          # boundary vertices have degree 2 on it
    # no degenerate triangles: area and smallest angle bounded away from zero
    n, area = _face_normals(V, F)
    assert area.min() > 0.05
    ang = []
    for i in range(3):
        u = V[F[:, (i + 1) % 3]] - V[F[:, i]]
        w = V[F[:, (i + 2) % 3]] - V[F[:, i]]
        c = np.einsum("ij,ij->i", u, w) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        ang.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
    assert np.min(ang) > 5.0
    # normals point out of the face: every triangle away from the nostrils faces the
    # meshing direction (forwards, 25 degrees down); the nostril cups face downwards
    nostril = np.zeros(len(V), dtype=bool)
    nostril[fm.nostril_vertices] = True
    in_cup = nostril[F].all(axis=1)
    near_cup = nostril[F].any(axis=1)
    assert (n[~near_cup] @ D).min() > 0.0
    assert (n[in_cup] * area[in_cup, None]).sum(axis=0)[1] < 0.0
    at_tip = (F == fm.landmark_vertices["prn"]).any(axis=1)
    assert (n[at_tip][:, 2] > 0.9).all()
    # libigl's cotangent Laplacian (ARAP, smoothing) is finite on it
    L = igl.cotmatrix(np.ascontiguousarray(V), np.ascontiguousarray(F))
    assert np.isfinite(L.data).all()


def test_mesh_is_mirror_symmetric(fm) -> None:
    mesh = generic_mesh()
    V, m = fm.mean, mesh.mirror
    assert np.allclose(V[m], V * np.array([-1.0, 1.0, 1.0]))
    assert np.array_equal(m[m], np.arange(len(V)))


def test_adult_dimensions(fm) -> None:
    P = fm.landmark_positions()

    def d(a: str, b: str) -> float:
        return float(np.linalg.norm(P[a] - P[b]))

    V = fm.mean
    assert 45.0 <= d("n", "prn") <= 52.0
    assert 48.0 <= d("n", "sn") <= 56.0
    assert 32.0 <= d("al_l", "al_r") <= 36.0
    assert 26.0 <= P["prn"][2] - 0.5 * (P["ac_l"][2] + P["ac_r"][2]) <= 32.0
    assert 17.0 <= d("mf_l", "mf_r") <= 22.0
    assert 8.0 <= d("g", "n") <= 16.0
    assert 130.0 <= np.ptp(V[:, 0]) <= 150.0            # face width
    assert 170.0 <= np.ptp(V[:, 1]) <= 190.0            # forehead to chin


def test_landmarks_sit_on_the_right_anatomy(fm) -> None:
    lm = fm.landmark_vertices
    assert set(lm) == set(LANDMARK_IDS) and len(set(lm.values())) == len(LANDMARK_IDS)
    P = fm.landmark_positions()
    V = fm.mean
    nose = V[fm.nose_vertices]
    # prn: most anterior point of the nose; n behind g and prn; sn below prn
    assert P["prn"][2] >= nose[:, 2].max() - 1e-9
    assert P["n"][2] < P["g"][2] and P["n"][2] < P["prn"][2]
    assert P["sn"][1] < P["c"][1] < P["prn"][1] < P["r"][1] < P["k"][1] < P["n"][1]
    assert P["g"][1] > P["n"][1]
    for mid in ("g", "n", "k", "r", "prn", "c", "sn"):
        assert abs(P[mid][0]) < 1e-9
    # +x is the subject's left; mirrored pairs
    for base in ("mf", "int", "al", "alp", "alpp", "ac", "md"):
        left, right = P[f"{base}_l"], P[f"{base}_r"]
        assert left[0] > 0 > right[0]
        assert np.allclose(left, right * np.array([-1.0, 1.0, 1.0]))
    # al: the widest point of the nose, lateral to every other nasal landmark
    assert P["al_l"][0] >= 0.85 * nose[:, 0].max()
    for other in ("int_l", "alp_l", "alpp_l", "md_l", "mf_l"):
        assert P["al_l"][0] > P[other][0]
    # ac below al, in the crease behind the tip; md and c in front of the nostril sill
    assert P["ac_l"][1] < P["al_l"][1] and P["ac_l"][2] < P["alp_l"][2]
    assert P["alpp_l"][2] < P["md_l"][2] < P["c"][2]
    # int above the ala, mf at the nasal root beside n
    assert P["int_l"][1] > P["al_l"][1]
    assert abs(P["mf_l"][1] - P["n"][1]) < 2.0


def test_regions_and_curves(fm) -> None:
    V, F = fm.mean, fm.faces
    nose = set(fm.nose_vertices.tolist())
    assert set(fm.nostril_vertices.tolist()) <= nose
    assert 0.1 * len(V) < len(nose) < 0.6 * len(V)
    assert all(v in nose for k, v in fm.landmark_vertices.items() if k != "g")
    assert fm.landmark_vertices["g"] not in nose
    # two nostrils, each a real concave opening: its deepest vertex well above its border
    A = vertex_adjacency(len(V), F)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        ids = fm.nostril_vertices[np.sign(V[fm.nostril_vertices, 0]) == sign]
        sill = fm.curve_vertices[f"sill_{side}"]
        assert len(sill) >= 12 and set(sill.tolist()) <= set(ids.tolist())
        assert V[ids, 1].max() - V[sill, 1].mean() > 4.0
    # every SPEC curve is an edge path through its landmarks
    assert set(fm.curve_vertices) == set(CURVE_NAMES)
    for name, path in fm.curve_vertices.items():
        assert len(path) >= 2
        closed = name.startswith("sill")
        nxt = np.roll(path, -1) if closed else path[1:]
        assert all(A[a, b] for a, b in zip(path[: len(nxt)], nxt, strict=True))
        if not closed:
            ids = [i for i in CURVE_LANDMARKS[name] if i not in HELPER_IDS]
            assert path[0] == fm.landmark_vertices[ids[0]]
            assert path[-1] == fm.landmark_vertices[ids[-1]]
            assert all(fm.landmark_vertices[i] in set(path.tolist()) for i in ids)


def test_each_mode_changes_its_own_measurement(fm) -> None:
    assert fm.mode_names == NOSE_MODES + FACE_MODES
    assert fm.basis.shape == (len(fm.mode_names), fm.n_vertices, 3)
    meas = mode_measurements(fm)
    names = fm.mode_names
    base = {m: meas[m](fm.mean) for m in names}
    effect = np.array([[meas[m](fm.shape(np.eye(fm.n_modes)[k])) - base[m] for m in names]
                       for k in range(fm.n_modes)])
    for k, name in enumerate(names):
        # one unit = one population SD of the mode's own measurement, in the right direction
        assert effect[k, k] == pytest.approx(MODE_SD_MM[name], rel=0.05)
        # and no other mode changes that measurement as much
        others = np.delete(np.abs(effect[:, k]), k)
        assert others.max() < effect[k, k]
    P0, P1 = fm.landmark_positions(), fm.landmark_positions(fm.shape([1.0]))
    assert np.linalg.norm(P1["prn"] - P1["n"]) > np.linalg.norm(P0["prn"] - P0["n"])
    w = np.zeros(fm.n_modes)
    w[names.index("alar_width")] = 1.0
    P1 = fm.landmark_positions(fm.shape(w))
    assert P1["al_l"][0] - P1["al_r"][0] > P0["al_l"][0] - P0["al_r"][0] + 2.0
    w[:] = 0.0
    w[names.index("projection")] = 1.0
    P1 = fm.landmark_positions(fm.shape(w))
    assert P1["prn"][2] - P1["ac_l"][2] > P0["prn"][2] - P0["ac_l"][2] + 2.0


def test_nose_modes_are_local_and_face_modes_leave_the_nose(fm) -> None:
    V = fm.mean
    dist, _ = cKDTree(V[fm.nose_vertices]).query(V)
    far = dist > 12.0
    assert far.sum() > 0.3 * len(V)
    for k, name in enumerate(fm.mode_names):
        disp = np.linalg.norm(fm.basis[k], axis=1)
        if name in NOSE_MODES:
            assert disp[far].max() < 1e-9, name
            assert disp.max() > 0.5, name
        else:
            assert disp[fm.landmark_vertices["prn"]] < 1e-6, name


def test_modes_keep_the_mesh_valid_within_two_sd(fm) -> None:
    n0, _ = _face_normals(fm.mean, fm.faces)
    for k in range(fm.n_modes):
        for a in (-2.0, 2.0):
            w = np.zeros(fm.n_modes)
            w[k] = a
            n, area = _face_normals(fm.shape(w), fm.faces)
            assert np.einsum("ij,ij->i", n, n0).min() > 0.0, (fm.mode_names[k], a)
            assert area.min() > 0.01


def test_deterministic_cached_read_only_and_loadable(fm) -> None:
    assert generic_face_model() is fm
    rebuilt = generic_mesh.__wrapped__()
    assert np.array_equal(rebuilt.V, fm.mean) and np.array_equal(rebuilt.F, fm.faces)
    with pytest.raises(ValueError):
        fm.mean[0, 0] = 1.0
    assert fm.name == "generic" and fm.credit == CREDIT
    assert load_face_model("generic") is fm
