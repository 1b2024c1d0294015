"""``naseview reconstruct --stages 1``: reconstruction.json from a case directory.

The cases are made by projecting known 3D landmarks through known cameras (no
rendering; ``tests/helpers.py``), so every number is checked against exact ground truth.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import table1_errors, write_projected_case

from naseview.case import read_case
from naseview.cli import main
from naseview.reconstruction import output_case_dir, read_reconstruction


def test_reconstruct_command_writes_reconstruction_json(tmp_path: Path, capsys):
    case_dir = write_projected_case(tmp_path / "case", seed=80)
    assert read_case(case_dir).views["front"].width == 1024
    rc = main(["reconstruct", str(case_dir), "-o", str(tmp_path / "out"), "--stages", "1"])
    out = capsys.readouterr().out
    assert rc == 0 and "stage landmarks: done in" in out
    rec = read_reconstruction(tmp_path / "out" / "reconstruction.json")
    truth = read_reconstruction(case_dir / "truth.json")
    assert np.array_equal(rec.landmarks["g"], np.zeros(3))
    assert table1_errors(rec.landmarks, truth.landmarks).mean() < 0.5
    assert set(rec.cameras) == {"front", "left", "right", "bottom"}
    for key in ("landmark_uncertainty_mm", "residuals_px", "suspect_clicks", "warnings"):
        assert key in rec.extra
    assert set(rec.extra["landmark_uncertainty_mm"]) == set(rec.landmarks)
    # the output names its case folder relative to itself, bound to that case's case.json
    assert rec.extra["case_dir"] == "../case"
    assert output_case_dir(tmp_path / "out", rec) == case_dir.resolve()
    assert rec.measurements["n-prn"] == pytest.approx(
        np.linalg.norm(rec.landmarks["n"] - rec.landmarks["prn"]))
    rc = main(["reconstruct", str(case_dir), "-o", str(tmp_path / "o2"), "--stages", "2,3"])
    assert rc == 2 and "--stages" in capsys.readouterr().err
