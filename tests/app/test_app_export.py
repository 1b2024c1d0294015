"""The app's downloadable files: meshes, landmarks and measurements, read back."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import ict_baseline

from naseview.app.export import landmarks_csv, measurements_csv, measurements_json
from naseview.editing.baseline import Baseline
from naseview.measurements import clinical_measurements
from naseview.meshio import read_mesh
from naseview.texture.mesh_files import mesh_file


@pytest.fixture(scope="module")
def baseline() -> Baseline:
    return ict_baseline()


def test_exports_readable(baseline, tmp_path):
    for t in ("stl", "obj", "ply", "glb"):
        data = mesh_file(baseline.V, baseline.F, t, baseline.nose_ids)
        (tmp_path / f"n.{t}").write_bytes(data)
        V, F = read_mesh(tmp_path / f"n.{t}")
        assert 0 < len(F) < len(baseline.F)
        assert np.abs(V.min(0) - baseline.V[baseline.nose_ids].min(0)).max() < 1.0
    lms = dict(baseline.landmarks)
    lms["prn"] = lms["prn"] + [0, 0, 3.0]
    rows = landmarks_csv(lms, baseline.landmarks).decode().splitlines()
    assert len(rows) == 1 + len(lms)
    prn = next(r for r in rows if r.startswith("prn,"))
    assert prn.split(",")[-1] == "3.0000"
    sim = clinical_measurements(lms, None)
    js = json.loads(measurements_json(baseline.measurements, sim))
    m = js["measurements"]["nasal_length"]
    assert m["change"] == pytest.approx(m["simulated"] - m["original"])
    assert "nasal_length" in measurements_csv(baseline.measurements, sim).decode()


def test_glb_download_is_in_metres(baseline):
    import io

    import trimesh

    data = mesh_file(baseline.V, baseline.F, "glb")
    raw = trimesh.load(io.BytesIO(data), file_type="glb", force="mesh", process=False)
    width_m = float(raw.extents[0])
    assert 0.1 < width_m < 0.3                     # a face is 10-30 cm wide, not 140 m
    assert np.allclose(raw.extents, np.ptp(baseline.V, axis=0) / 1000.0, atol=1e-5)


def test_watertight_stl_for_printing(baseline, tmp_path):
    import trimesh

    for part in (None, baseline.nose_ids):
        data = mesh_file(baseline.V, baseline.F, "stl", part, watertight=True)
        (tmp_path / "p.stl").write_bytes(data)
        V, F = read_mesh(tmp_path / "p.stl")
        m = trimesh.Trimesh(V, F, process=False)
        assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    open_face = mesh_file(baseline.V, baseline.F, "stl")
    (tmp_path / "o.stl").write_bytes(open_face)
    assert not trimesh.Trimesh(*read_mesh(tmp_path / "o.stl"), process=False).is_watertight


def test_textured_exports(baseline):
    import io
    import zipfile

    import trimesh

    from naseview.texture.bake import FaceTexture
    from naseview.texture.mesh_files import textured_obj_zip
    from naseview.texture.uv import face_uv

    uv = face_uv(baseline.V, baseline.F)
    image = np.zeros((64, 64, 3), np.uint8)
    image[..., 0] = np.arange(64, dtype=np.uint8)[None, :] * 4
    tex = FaceTexture(uv, image, np.ones((64, 64), bool),
                      np.full((len(uv), 3), 180, np.uint8))
    glb = mesh_file(baseline.V, baseline.F, "glb", baseline.nose_ids, texture=tex)
    m = trimesh.load(io.BytesIO(glb), file_type="glb", force="mesh", process=False)
    assert len(m.visual.uv) == len(m.vertices) < len(uv)
    z = zipfile.ZipFile(io.BytesIO(textured_obj_zip(baseline.V, baseline.F, tex)))
    assert sorted(z.namelist()) == ["face.mtl", "face.obj", "face.png"]
    assert z.read("face.obj").decode().count("\nvt ") == len(uv)
    ply = mesh_file(baseline.V, baseline.F, "ply", texture=tex)
    assert b"red" in ply.split(b"end_header")[0]             # per-vertex colours
