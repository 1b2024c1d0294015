"""``naseview evaluate``: paper Tables 1-2 and landmark RMSE against synthetic truth."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers import BASE_NOSE, write_projected_case
from scipy.stats import t as student_t

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.landmarks import TABLE1_DISTANCES
from naseview.testbed.evaluate import (
    evaluate_cases,
    format_report,
    landmark_rmse_case,
    mean_ci95,
    read_truth_boundaries,
    table1_case,
    table2_case,
)

TABLE1_KEYS = [f"{a}-{b}" for a, b in TABLE1_DISTANCES]


@pytest.fixture(scope="module")
def tiny_set(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("evalset")
    return [write_projected_case(root / f"case-{i}", seed=300 + i, noise_px=1.5)
            for i in range(3)]


def _truth() -> dict[str, np.ndarray]:
    out = {}
    for k, p in BASE_NOSE.items():
        out[k] = np.array(p, float)
        if k.endswith("_l"):
            out[k[:-2] + "_r"] = np.array(p, float) * [-1, 1, 1]
    return out


def test_table1_and_table2_of_known_errors():
    truth = _truth()
    pred = {k: v.copy() for k, v in truth.items()}
    d_cn = np.linalg.norm(truth["c"] - truth["sn"])
    pred["sn"] = truth["c"] + (truth["sn"] - truth["c"]) * (d_cn + 0.5) / d_cn  # c-sn +0.5
    del pred["md_l"]  # a landmark the reconstruction could not place
    t1 = table1_case(pred, truth)
    errs = {k: v["error_mm"] for k, v in t1["distances"].items()}
    assert list(errs) == TABLE1_KEYS
    assert errs["c-sn"] == pytest.approx(0.5)
    assert math.isnan(errs["md_l-md_r"]) and t1["missing"] == 1
    assert t1["mean_error_mm"] == pytest.approx(0.5 / 10)
    assert t1["percent_error"] == pytest.approx(100 * 0.5 / d_cn / 10)
    t2 = table2_case(pred, truth)
    assert t2["distances"]["prn-sn"]["error_mm"] > 0
    assert t2["distances"]["n-prn"]["error_mm"] == pytest.approx(0.0)
    # a rigid motion of the prediction changes nothing
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    moved = {k: R @ v + [5, 6, 7] for k, v in truth.items()}
    r = landmark_rmse_case(moved, truth)
    assert r["rmse_mm"] < 1e-9 and r["n"] == 21
    assert table1_case(moved, truth)["mean_error_mm"] < 1e-9


def test_mean_ci95_uses_the_t_distribution():
    s = mean_ci95([1.0, 2.0, 3.0, float("nan")])
    h = student_t.ppf(0.975, 2) * 1.0 / math.sqrt(3)
    assert s["n"] == 3 and s["mean"] == pytest.approx(2.0)
    assert (s["ci_low"], s["ci_high"]) == pytest.approx((2 - h, 2 + h))
    assert math.isnan(mean_ci95([4.0])["ci_low"])


def test_evaluate_tiny_synthetic_set(tiny_set: list[Path]):
    lines: list[str] = []
    report = evaluate_cases(tiny_set, stages=(1,), progress=lines.append)
    assert len(lines) == 3 and report["failed"] == []
    summ = report["summary"]
    assert summ["converged"] == {"ok": 3, "failed": 0}
    t1 = summ["table1"]
    assert list(t1["distances"]) == TABLE1_KEYS
    for k in TABLE1_KEYS:
        s = t1["distances"][k]
        assert s["n"] == 3 and s["ci_low"] <= s["mean"] <= s["ci_high"]
    assert 0 < t1["mean_error_mm"] < 0.6
    assert 0 < t1["percent_error"]["mean"] < 3.0
    assert 0 < summ["table2"]["mean_error_mm"]["mean"] < 0.8
    assert 0 < summ["landmarks"]["rmse_mm"]["mean"] < 1.2
    assert summ["stage_seconds_median"]["landmarks"] > 0
    text = format_report(report)
    assert "Table 1" in text and "Table 2" in text and "%Error" in text
    for k in TABLE1_KEYS:
        assert k in text


def test_evaluate_command_json_and_failed_case(tiny_set: list[Path], tmp_path: Path, capsys):
    bad = write_projected_case(tmp_path / "bad", seed=400)
    case = json.loads((bad / "case.json").read_text())
    for v in case["views"].values():
        v["landmarks"].pop("g", None)  # no origin: this case must fail, not the command
    (bad / "case.json").write_text(json.dumps(case))
    rc = main(["evaluate", str(tiny_set[0]), str(bad), "--json", "--stages", "1"])
    assert rc == 1                                    # a script sees the failed case
    out = json.loads(capsys.readouterr().out)
    assert out["summary"]["converged"] == {"ok": 1, "failed": 1}
    assert "glabella" in out["failed"][0]["error"]
    assert set(out["cases"][0]) >= {"case", "table1", "table2", "landmarks", "stage_seconds"}
    assert out["summary"]["table1"]["distances"]["g-n"]["ci_low"] is None  # one case: no CI
    rc = main(["evaluate", str(tiny_set[1]), "--stages", "1"])
    text = capsys.readouterr().out
    assert rc == 0 and "Table 1: landmark distance error (mm)" in text


def test_a_case_with_a_bad_truth_file_fails_alone(tiny_set: list[Path], tmp_path: Path,
                                                  capsys):
    no_truth = write_projected_case(tmp_path / "no-truth", seed=401)
    (no_truth / "truth.json").unlink()
    no_prn = write_projected_case(tmp_path / "no-prn", seed=402)
    truth = json.loads((no_prn / "truth.json").read_text())
    del truth["landmarks"]["prn"]
    (no_prn / "truth.json").write_text(json.dumps(truth))
    bad_bounds = write_projected_case(tmp_path / "bad-bounds", seed=403)
    (bad_bounds / "truth_boundaries.json").write_text('{"mid": 5}')
    report = evaluate_cases([no_truth, tiny_set[0], no_prn, bad_bounds], stages=(1, 2))
    assert len(report["cases"]) == 1                     # the good case, after a bad one
    errors = {Path(f["dir"]).name: f["error"] for f in report["failed"]}
    assert set(errors) == {"no-truth", "no-prn", "bad-bounds"}
    assert "no-truth/truth.json: file not found" in errors["no-truth"]
    assert "no-prn/truth.json: key 'landmarks' lacks prn" in errors["no-prn"]
    assert "truth_boundaries.json: key 'mid'" in errors["bad-bounds"]
    assert all("\n" not in e for e in errors.values())
    assert main(["evaluate", str(no_truth), str(tiny_set[0]), "--stages", "1"]) == 1
    text = capsys.readouterr().out
    assert "1 failed" in text and "Table 1: landmark distance error (mm)" in text
    assert main(["evaluate", str(no_truth), "--stages", "1"]) == 2   # nothing evaluated
    capsys.readouterr()
    (bad_bounds / "truth_boundaries.json").unlink()          # figures left out: said so
    assert main(["evaluate", str(bad_bounds), "--stages", "1,2"]) == 0
    assert "note synthetic: no truth_boundaries.json: no boundary figures" in \
        capsys.readouterr().out


def test_the_nose_samples_are_the_same_whatever_ran_before() -> None:
    """The surface error's truth samples and the region errors' nostril interior (and so
    every figure compared across a run) do not depend on what ran earlier in the
    process: libigl's ambient occlusion, which picks the open nose surface and the
    cavities, draws from C's rand(), and other occlusion calls advance it."""
    from igl.embree import ambient_occlusion

    from naseview.facemodel import load_face_model
    from naseview.testbed.regions import region_samples
    from naseview.testbed.surface import nose_surface_samples

    m = load_face_model("generic")
    V = np.asarray(m.mean, np.float64)
    F = np.asarray(m.faces, np.int64)
    first = nose_surface_samples(V, F, m.landmark_positions(V), 3000)
    regions = region_samples(V, F, m.landmark_positions(V), 3000)[1]
    n = np.tile([0.0, 0.0, 1.0], (50, 1))
    ambient_occlusion(V, F, np.ascontiguousarray(V[:50] + n), n, 97)   # advances rand()
    again = nose_surface_samples(V, F, m.landmark_positions(V), 3000)
    np.testing.assert_array_equal(first, again)
    ambient_occlusion(V, F, np.ascontiguousarray(V[:50] + n), n, 97)
    np.testing.assert_array_equal(regions, region_samples(V, F, m.landmark_positions(V),
                                                          3000)[1])


@pytest.mark.parametrize("points", ['"garbage"', "[[1, 2], [3]]", "[[1, 2, 3]]", "[[1, NaN]]"])
def test_truth_boundary_points_that_are_not_xy_lists_are_refused(tmp_path: Path, points: str):
    path = tmp_path / "truth_boundaries.json"
    path.write_text('{"mid": {"left": ' + points.replace("NaN", '"x"') + "}}")
    with pytest.raises(NaseviewError, match="key mid.left: expected a list of"):
        read_truth_boundaries(path)
    path.write_text('{"mid": {"left": [[1, 2.5]], "right": []}}')
    assert read_truth_boundaries(path)["mid"]["left"].tolist() == [[1.0, 2.5]]
