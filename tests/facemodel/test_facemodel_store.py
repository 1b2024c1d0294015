"""ICT face model files: OBJ import, locating the installed model, .npz loading and its
errors, the ``naseview model`` command (naseview.facemodel.store).

The ICT data is read from ../shared (never copied into the repository); installs go to a
temporary NASEVIEW_DATA_DIR.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.facemodel import store
from naseview.facemodel.ict import ICT_CREDIT
from naseview.meshio import read_obj, triangulate_polygons


@pytest.fixture(scope="module")
def ict(ict_dir: Path):
    return store.load_ict_npz(ict_dir / "ict_face_light.npz")


def test_read_obj_polygons_corner_syntax_and_relative_ids(tmp_path: Path) -> None:
    obj = tmp_path / "m.obj"
    obj.write_text(
        "# comment\nmtllib x.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
        "v 2 0 0 0.5 0.5 0.5\n"
        "usemtl skin\nf 2//1 5//1 3//1\n"
        "f -4 -3 -1\n")  # relative: vertices 2, 3, 5
    m = read_obj(obj)
    assert m.vertices.shape == (5, 3)
    np.testing.assert_array_equal(m.vertices[4], [2, 0, 0])
    np.testing.assert_array_equal(m.sizes, [4, 3, 3])
    np.testing.assert_array_equal(m.indices, [0, 1, 2, 3, 1, 4, 2, 1, 2, 4])
    tri = triangulate_polygons(m.indices, m.sizes)
    np.testing.assert_array_equal(tri, [[0, 1, 2], [0, 2, 3], [1, 4, 2], [1, 2, 4]])
    assert read_obj(obj, faces=False).sizes.size == 0


def test_read_obj_errors_name_file_and_line(tmp_path: Path) -> None:
    obj = tmp_path / "bad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    with pytest.raises(NaseviewError, match=r"bad\.obj: line 4"):
        read_obj(obj)
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(NaseviewError, match=r"bad\.obj: .*3 vertices"):
        read_obj(obj)


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
