"""The ICT face model as loaded: types, cache and credit, the frozen annotations (landmarks,
nose and nostril regions) on the mean and on random identities (naseview.facemodel.ict).

The ICT data is read from ../shared (never copied into the repository).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.facemodel import load_face_model, store
from naseview.facemodel.ict import ICT_CREDIT, ICT_LANDMARK_VERTICES
from naseview.geometry.mesh import vertex_normals
from naseview.landmarks import LANDMARK_IDS

SEEDS = (0, 1, 2, 3, 4, 5)


@pytest.fixture(scope="module")
def ict(ict_dir: Path):
    return store.load_ict_npz(ict_dir / "ict_face_light.npz")


def test_loaded_model_types_cache_and_credit(ict_dir: Path, ict) -> None:
    path = ict_dir / "ict_face_light.npz"
    assert store.load_ict_npz(str(path)) is ict  # cached per resolved path
    assert ict.name == "ict" and ict.credit == ICT_CREDIT
    assert ict.mean.dtype == np.float64 and ict.basis.dtype == np.float64
    assert ict.faces.dtype == np.int64 and ict.faces.shape == (18460, 3)
    assert ict.basis.shape == (100, 9409, 3) and len(ict.mode_names) == 100
    assert set(ict.landmark_vertices) == set(LANDMARK_IDS)
    assert not ict.mean.flags.writeable  # shared by the cache
    assert load_face_model("ict") is ict and load_face_model(str(path)) is ict
    # faces are counter-clockwise seen from outside: the normal at the tip points +z
    n = vertex_normals(ict.mean, ict.faces)
    assert n[ICT_LANDMARK_VERTICES["prn"], 2] > 0.9


def _check_anatomy(fm, V: np.ndarray, exact: bool) -> None:
    lm = {k: V[i] for k, i in fm.landmark_vertices.items()}
    nose = V[fm.nose_vertices]
    # prn is the most anterior nose point (ICT identities move the tip by < 1 mm)
    assert lm["prn"][2] >= nose[:, 2].max() - (0.0 if exact else 1.0)
    # +x is the subject's left; midline landmarks on x ~ 0
    mid = [k for k in LANDMARK_IDS if not k.endswith(("_l", "_r"))]
    assert max(abs(lm[k][0]) for k in mid) <= (1e-9 if exact else 2.0)
    for k in LANDMARK_IDS:
        if k.endswith("_l"):
            assert lm[k][0] > 2.0 and lm[k[:-2] + "_r"][0] < -2.0, k
    # al: the widest alar points, wider than the other alar landmarks
    assert lm["al_l"][0] >= nose[:, 0].max() - (0.0 if exact else 2.5)
    assert lm["al_r"][0] <= nose[:, 0].min() + (0.0 if exact else 2.5)
    for k in ("ac", "int", "alp", "md", "alpp"):
        assert lm["al_l"][0] > lm[f"{k}_l"][0] and lm["al_r"][0] < lm[f"{k}_r"][0], k
    # profile order from top to bottom, and the frontonasal angle behind the g-prn chord
    ys = [lm[k][1] for k in ("g", "n", "k", "r", "prn", "c", "sn")]
    assert all(a > b for a, b in zip(ys[:-1], ys[1:], strict=True)), ys
    assert lm["n"][2] < lm["prn"][2] - 10.0
    d = lm["prn"][1:] - lm["g"][1:]
    normal = np.array([d[1], -d[0]]) / np.linalg.norm(d)  # anterior side of the chord
    assert (lm["n"][1:] - lm["g"][1:]) @ normal < -2.0
    assert lm["sn"][2] < lm["c"][2] < lm["prn"][2]
    # alar base and crease behind the tip, int above al, mf above int
    assert lm["ac_l"][2] < lm["alp_l"][2] < lm["prn"][2]
    assert lm["int_l"][1] > lm["al_l"][1] and lm["mf_l"][1] > lm["int_l"][1]


def test_anatomy_on_mean_face(ict) -> None:
    _check_anatomy(ict, ict.mean, exact=True)
    V = ict.mean
    # n is behind g and prn; prn is the most anterior point of the whole face
    lmv = ict.landmark_vertices
    assert V[lmv["n"], 2] < V[lmv["g"], 2] and V[lmv["n"], 2] < V[lmv["prn"], 2]
    assert lmv["prn"] == int(np.argmax(V[:, 2])) == 4841
    # the mean is mirror-symmetric: _l and _r landmarks are mirror images
    for k in LANDMARK_IDS:
        if k.endswith("_l"):
            np.testing.assert_allclose(V[lmv[k]] * [-1, 1, 1], V[lmv[k[:-2] + "_r"]], atol=1e-3)


@pytest.mark.parametrize("seed", SEEDS)
def test_anatomy_on_random_identities(ict, seed: int) -> None:
    V = ict.shape(np.random.default_rng(seed).standard_normal(ict.n_modes))
    _check_anatomy(ict, V, exact=False)


def test_nostril_and_nose_regions(ict) -> None:
    nose, nos = set(ict.nose_vertices.tolist()), set(ict.nostril_vertices.tolist())
    assert nos <= nose
    V = ict.mean
    lmv = ICT_LANDMARK_VERTICES
    assert len(nos) > 100 and len(nose - nos) > 400
    # vertical extent: radix (n) to subnasale; lateral extent: the alae
    assert V[ict.nose_vertices, 1].max() >= V[lmv["n"], 1]
    assert V[ict.nose_vertices, 1].min() >= V[lmv["sn"], 1] - 1.0
    assert np.isclose(np.ptp(V[ict.nose_vertices, 0]), V[lmv["al_l"], 0] - V[lmv["al_r"], 0])
    # nostrils sit between the alae, below the tip, behind it, on both sides
    x = V[ict.nostril_vertices, 0]
    assert (x > 0).sum() == (x < 0).sum()
    assert np.abs(x).max() < V[ICT_LANDMARK_VERTICES["al_l"], 0]
    # the region spans radix (n) to subnasale and the alar creases
    for k in ("n", "sn", "ac_l", "ac_r", "al_l", "mf_l", "int_r"):
        assert ICT_LANDMARK_VERTICES[k] in nose
