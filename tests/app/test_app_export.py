"""The app's downloadable files: meshes, landmarks and measurements, read back."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import ict_baseline

from naseview.app.export import landmarks_csv, measurements_csv, measurements_json, mesh_file
from naseview.editing.baseline import Baseline
from naseview.measurements import clinical_measurements
from naseview.meshio import read_mesh


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
