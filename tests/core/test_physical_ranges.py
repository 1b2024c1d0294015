"""issue 26 item 9: every number read from case.json, reconstruction.json and session files
is bounded by its physical range (naseview.params), in one place: a finite but absurd
value (1e300 mm, a focal length of 1e-300 px) is a one-line error naming the file and the
key, never "internal error", never accepted with numpy overflow warnings."""

from __future__ import annotations

import copy
import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import write_projected_case

from naseview.camera import look_at
from naseview.case import read_case
from naseview.cli import main
from naseview.editing.baseline import Baseline
from naseview.editing.session import SESSION_FORMAT, load_session
from naseview.errors import NaseviewError
from naseview.reconstruction import Reconstruction

# -- case.json: views.*.camera.focal_px ---------------------------------------------------


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory) -> Path:
    return write_projected_case(tmp_path_factory.mktemp("ranges") / "case", seed=82)


def _with_camera(case_dir: Path, tmp_path: Path, camera_text: str) -> Path:
    """A copy of ``case_dir`` with views.front.camera set to
    ``camera_text`` (raw JSON, so 1e309 stays a literal)."""
    out = tmp_path / "c"
    out.mkdir()
    obj = json.loads((case_dir / "case.json").read_text())
    for v in obj["views"].values():
        shutil.copyfile(case_dir / v["image"], out / v["image"])
    obj["views"]["front"]["camera"] = "@CAMERA@"
    (out / "case.json").write_text(json.dumps(obj).replace('"@CAMERA@"', camera_text))
    return out


@pytest.mark.parametrize("focal", ["1e300", "1e309", "1e-300", "0", "-5", "0.001"])
def test_absurd_focal_length_is_a_key_error(case_dir, tmp_path, focal) -> None:
    case = _with_camera(case_dir, tmp_path, f'{{"focal_px": {focal}}}')
    with pytest.raises(NaseviewError) as e:
        read_case(case)
    msg = str(e.value)
    assert "\n" not in msg and "case.json: key 'views.front.camera.focal_px'" in msg, msg
    assert "is outside [" in msg


def test_absurd_focal_length_in_K_is_a_key_error(case_dir, tmp_path) -> None:
    case = _with_camera(case_dir, tmp_path, '{"K": [[1e300, 0, 500], [0, 1e300, 500], '
                                            '[0, 0, 1]]}')
    with pytest.raises(NaseviewError, match=r"key 'views\.front\.camera\.K': focal length"):
        read_case(case)


def test_plausible_focal_length_is_accepted(case_dir, tmp_path) -> None:
    case = _with_camera(case_dir, tmp_path, '{"focal_px": 2400}')
    assert read_case(case).views["front"].camera == {"focal_px": 2400.0}


def test_reconstruct_with_focal_1e309_exits_2_with_one_line(case_dir, tmp_path, capsys):
    case = _with_camera(case_dir, tmp_path, '{"focal_px": 1e309}')
    rc = main(["reconstruct", str(case), "-o", str(tmp_path / "out"), "--stages", "1"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "\n" not in err and "views.front.camera.focal_px" in err, err
    assert "internal error" not in err


# -- session files: vertices, landmarks, measurements, cameras ----------------------------


def _session() -> dict:
    rng = np.random.default_rng(3)
    V = rng.normal(0, 30, (12, 3))
    F = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6], [6, 7, 8]])
    lms = {"prn": V[0].copy(), "n": V[1].copy()}
    cam = look_at([0, 0, 400.0], [0, 0, 0], [0, 1, 0], 1000.0, 800, 600)
    rec = Reconstruction(landmarks=lms, cameras={"front": cam})
    b = Baseline(V=V, F=F, nose_ids=np.arange(4), landmarks=lms,
                 measurements={"nasal_length": 45.0}, reconstruction=rec)
    return {"format": SESSION_FORMAT, "baseline": b.to_json(), "edit": {}}


def _load(tmp_path: Path, obj: dict):
    p = tmp_path / "s.json"
    p.write_text(json.dumps(obj))
    with warnings.catch_warnings():
        warnings.simplefilter("error")           # no numpy overflow on the way
        return load_session(p)


def test_a_plausible_session_loads(tmp_path) -> None:
    assert _load(tmp_path, _session()).baseline.V.shape == (12, 3)


def _set(obj: dict, keys: str, value) -> dict:
    out = copy.deepcopy(obj)
    *path, last = keys.split("/")
    node = out
    for k in path:
        node = node[int(k)] if isinstance(node, list) else node[k]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return out


@pytest.mark.parametrize(("keys", "value", "named"), [
    ("baseline/mesh/vertices/3/1", 1e308, "baseline.mesh.vertices"),
    ("baseline/landmarks/prn/0", 1e300, "baseline.landmarks.prn"),
    ("baseline/reconstruction/landmarks/n/2", -5e3, "landmarks.n"),
    ("baseline/measurements/nasal_length", 1e300, "baseline.measurements.nasal_length"),
    ("baseline/reconstruction/cameras/front/t/2", 1e300, "cameras.front.t"),
    ("baseline/reconstruction/cameras/front/K/0/0", 1e-300, "cameras.front.K"),
    ("baseline/reconstruction/cameras/front/width", 10**12, "cameras.front.width"),
    ("baseline/reconstruction/reprojection_rmse_px", 1e300, "reprojection_rmse_px"),
])
def test_absurd_numbers_in_a_session_are_key_errors(tmp_path, keys, value, named) -> None:
    obj = _set(_session(), keys, value)
    with pytest.raises(NaseviewError) as e:
        _load(tmp_path, obj)
    msg = str(e.value)
    assert "\n" not in msg and str(tmp_path / "s.json") in msg and named in msg, msg


def test_absurd_edited_landmark_is_a_key_error(tmp_path) -> None:
    obj = _session()
    obj["edit"] = {"landmarks": {"prn": [0.0, 1e300, 0.0], "n": [0.0, 0.0, 0.0]}}
    with pytest.raises(NaseviewError, match=r"key 'edit\.landmarks\.prn': coordinate 1e\+300 "
                                            r"is outside \[-1000, 1000\]"):
        _load(tmp_path, obj)
