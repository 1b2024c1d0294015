"""ICT face model: OBJ import, .npz loading and errors, annotations, curve paths, CLI.

The ICT data is read from ../shared (never copied into the repository); installs go to a
temporary NASEVIEW_DATA_DIR.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model, meshcurves, store
from naseview.facemodel.ict import ICT_CREDIT, ICT_LANDMARK_VERTICES
from naseview.landmarks import CURVE_LANDMARKS, CURVE_NAMES, HELPER_IDS, LANDMARK_IDS

SEEDS = (0, 1, 2, 3, 4, 5)


@pytest.fixture(scope="module")
def ict(ict_dir: Path):
    return store.load_ict_npz(ict_dir / "ict_face_light.npz")


@pytest.fixture()
def data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty user data dir, with NASEVIEW_ICT_MODEL unset."""
    d = tmp_path / "data"
    monkeypatch.setenv("NASEVIEW_DATA_DIR", str(d))
    monkeypatch.delenv("NASEVIEW_ICT_MODEL", raising=False)
    return d


def _random_faces(fm):
    for seed in SEEDS:
        yield seed, fm.shape(np.random.default_rng(seed).standard_normal(fm.n_modes))


# ---------------------------------------------------------------------------- OBJ reader

def test_read_obj_polygons_corner_syntax_and_relative_ids(tmp_path: Path) -> None:
    obj = tmp_path / "m.obj"
    obj.write_text(
        "# comment\nmtllib x.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
        "v 2 0 0 0.5 0.5 0.5\n"
        "usemtl skin\nf 2//1 5//1 3//1\n"
        "f -4 -3 -1\n")  # relative: vertices 2, 3, 5
    m = store.read_obj(obj)
    assert m.vertices.shape == (5, 3)
    np.testing.assert_array_equal(m.vertices[4], [2, 0, 0])
    np.testing.assert_array_equal(m.sizes, [4, 3, 3])
    np.testing.assert_array_equal(m.indices, [0, 1, 2, 3, 1, 4, 2, 1, 2, 4])
    tri = store.triangulate_polygons(m.indices, m.sizes)
    np.testing.assert_array_equal(tri, [[0, 1, 2], [0, 2, 3], [1, 4, 2], [1, 2, 4]])
    assert store.read_obj(obj, faces=False).sizes.size == 0


def test_read_obj_errors_name_file_and_line(tmp_path: Path) -> None:
    obj = tmp_path / "bad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    with pytest.raises(NaseviewError, match=r"bad\.obj: line 4"):
        store.read_obj(obj)
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(NaseviewError, match=r"bad\.obj: .*3 vertices"):
        store.read_obj(obj)


# ---------------------------------------------------------------------------- import

def test_import_original_sample_equals_published_npz(ict_dir: Path, data_dir: Path,
                                                     tmp_path: Path) -> None:
    # the checkout layout: <repo>/FaceXModel/*.obj (symlinks, nothing is copied)
    checkout = tmp_path / "ICT-FaceKit"
    (checkout / "FaceXModel").mkdir(parents=True)
    for p in (ict_dir / "original-sample").glob("*.obj"):
        (checkout / "FaceXModel" / p.name).symlink_to(p)
    path = store.import_ict(checkout)
    assert path == data_dir / "models" / "ict_face_light.npz"
    got = np.load(path)
    ref = np.load(ict_dir / "ict_face_light.npz")
    np.testing.assert_array_equal(got["faces"], ref["faces"])
    assert got["mean"].dtype == np.float32 and got["basis"].shape == (2, 9409, 3)
    assert str(got["units"]) == "mm"
    # float32 rounding of cm -> mm values up to ~165 mm: within 2 units in the last place
    np.testing.assert_allclose(got["mean"], ref["mean"], rtol=2.0**-22, atol=1e-6)
    np.testing.assert_allclose(got["basis"], ref["basis"][:2], rtol=2.0**-22, atol=2e-6)
    fm = store.load_ict_npz(path)
    assert fm.n_modes == 2 and fm.mode_names == ("identity000", "identity001")


def test_import_ready_npz_is_validated_and_copied(ict_dir: Path, data_dir: Path,
                                                  tmp_path: Path) -> None:
    src = ict_dir / "ict_face_light.npz"
    path = store.import_ict(src)
    assert path.read_bytes() == src.read_bytes()
    assert store.find_ict_npz() == path
    bad = tmp_path / "bad.npz"
    np.savez(bad, mean=np.zeros((10, 3)))
    with pytest.raises(NaseviewError, match="bad.npz"):
        store.import_ict(bad)


def test_import_rejects_folder_without_ict_files(tmp_path: Path, data_dir: Path) -> None:
    with pytest.raises(NaseviewError, match="generic_neutral_mesh.obj"):
        store.import_ict(tmp_path)
    assert not (data_dir / "models").exists()


# ---------------------------------------------------------------------------- locating

def test_find_ict_npz_env_then_user_data_dir(tmp_path: Path, data_dir: Path,
                                             monkeypatch: pytest.MonkeyPatch,
                                             ict_dir: Path) -> None:
    assert store.find_ict_npz() is None
    installed = data_dir / "models" / "ict_face_light.npz"
    installed.parent.mkdir(parents=True)
    installed.write_bytes(b"x")
    assert store.find_ict_npz() == installed
    monkeypatch.setenv("NASEVIEW_ICT_MODEL", str(ict_dir / "ict_face_light.npz"))
    assert store.find_ict_npz() == ict_dir / "ict_face_light.npz"
    monkeypatch.setenv("NASEVIEW_ICT_MODEL", str(tmp_path / "nope.npz"))
    with pytest.raises(NaseviewError, match="nope.npz.*NASEVIEW_ICT_MODEL"):
        store.find_ict_npz()


def test_user_data_dir_fallbacks(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("NASEVIEW_DATA_DIR", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert store.user_data_dir() == tmp_path / "xdg" / "naseview"
    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert store.user_data_dir() == tmp_path / "home" / ".local" / "share" / "naseview"


# ---------------------------------------------------------------------------- loading

def _one_line_error(fn, *args) -> str:
    with pytest.raises(NaseviewError) as e:
        fn(*args)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def test_load_errors_are_one_line_and_name_file_and_key(tmp_path: Path, ict,
                                                       ict_dir: Path) -> None:
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"this is not a zip archive")
    assert str(garbage) in _one_line_error(store.load_ict_npz, garbage)
    assert "missing.npz" in _one_line_error(store.load_ict_npz, tmp_path / "missing.npz")

    no_basis = tmp_path / "no_basis.npz"
    np.savez(no_basis, mean=ict.mean, faces=ict.faces)
    msg = _one_line_error(store.load_ict_npz, no_basis)
    assert "no_basis.npz" in msg and "'basis'" in msg

    wrong = tmp_path / "wrong_shape.npz"
    np.savez(wrong, mean=ict.mean[:100], faces=ict.faces, basis=ict.basis[:1])
    msg = _one_line_error(store.load_ict_npz, wrong)
    assert "wrong_shape.npz" in msg and "'mean'" in msg

    cm = tmp_path / "in_cm.npz"
    np.savez(cm, mean=ict.mean / 10, faces=ict.faces, basis=ict.basis[:1] / 10)
    msg = _one_line_error(store.load_ict_npz, cm)
    assert "in_cm.npz" in msg and "millimetres" in msg

    nan = tmp_path / "nan.npz"
    basis = np.array(ict.basis[:1])
    basis[0, 5, 1] = np.nan
    np.savez(nan, mean=ict.mean, faces=ict.faces, basis=basis)
    assert "'basis'" in _one_line_error(store.load_ict_npz, nan)

    truncated = tmp_path / "truncated.npz"
    src = np.load(ict_dir / "ict_face_light.npz")
    np.savez_compressed(truncated, mean=src["mean"], faces=src["faces"], basis=src["basis"][:3])
    truncated.write_bytes(truncated.read_bytes()[:200_000])
    assert "truncated.npz" in _one_line_error(store.load_ict_npz, truncated)


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
    n = meshcurves.vertex_normals(ict.mean, ict.faces)
    assert n[ICT_LANDMARK_VERTICES["prn"], 2] > 0.9


# ---------------------------------------------------------------------------- anatomy

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


# ---------------------------------------------------------------------------- curves

def _edges(F: np.ndarray) -> set[tuple[int, int]]:
    return set(map(tuple, meshcurves.mesh_edges(F).tolist()))


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


# ---------------------------------------------------------------------------- CLI

def test_cli_model_info_and_import(ict_dir: Path, data_dir: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["model", "info"]) == 0
    out = capsys.readouterr().out
    assert "ict: not installed" in out and "naseview model fetch" in out
    assert main(["model", "import-ict", str(ict_dir / "original-sample")]) == 0
    out = capsys.readouterr().out
    assert str(data_dir / "models" / "ict_face_light.npz") in out and ICT_CREDIT in out
    assert main(["model", "info"]) == 0
    out = capsys.readouterr().out
    assert "2 identity modes" in out and ICT_CREDIT in out
    assert main(["model", "import-ict", str(data_dir / "nothing-here")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("naseview: error: ") and "nothing-here" in err[0]


def test_cli_fetch_unreachable_url_gives_one_line_error(data_dir: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    assert main(["model", "fetch", "--url", "http://127.0.0.1:9/"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("naseview:")]
    assert len(err) == 1
    assert err[0].startswith(
        "naseview: error: could not download http://127.0.0.1:9/generic_neutral_mesh.obj: ")
    assert err[0].endswith("check the network or use `naseview model import-ict DIR`")
    assert not (data_dir / "models").exists()
