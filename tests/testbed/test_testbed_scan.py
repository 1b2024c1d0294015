"""``naseview synth --scan``: a case from any face scan with landmarks (SPEC §8), and its
one-line errors; ``evaluate`` by region with the error colour map."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from naseview.case import read_case
from naseview.cli import main
from naseview.facemodel import FaceModel, load_face_model
from naseview.imagefile import read_image
from naseview.landmarks import HELPER_IDS, LANDMARK_IDS
from naseview.meshio import export_mesh, read_mesh
from naseview.reconstruction import read_reconstruction
from naseview.testbed.regions import REGIONS, error_map_png, region_errors, region_samples
from naseview.testbed.synth.scan import read_scan

JAMES = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans" / "james"


@pytest.fixture(scope="module")
def generic() -> FaceModel:
    return load_face_model("generic")


@pytest.fixture(scope="module")
def scan_files(generic: FaceModel, tmp_path_factory: pytest.TempPathFactory
               ) -> tuple[Path, Path, dict]:
    """The generic face as a 'scan' (PLY, in a frame turned and shifted from SPEC) with
    its SPEC §8 landmark file."""
    d = tmp_path_factory.mktemp("scan")
    V = generic.mean - generic.mean[generic.landmark_vertices["g"]]
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    t = np.array([5.0, -2.0, 7.0])
    export_mesh(d / "face.ply", (V - t) @ R, generic.faces)     # X_obj = R^T (X - t)
    lm = {k: V[generic.landmark_vertices[k]].tolist() for k in LANDMARK_IDS}
    for h in HELPER_IDS:
        a = V[generic.landmark_vertices[f"alp_{h[-1]}"]]
        b = V[generic.landmark_vertices["prn"]]
        lm[h] = (0.5 * (a + b)).tolist()
    data = {"format": "naseview.scan-landmarks/1", "scan": "face.ply", "units": "mm",
            "transform_from_obj": {"R": R.tolist(), "t": t.tolist()}, "landmarks": lm}
    (d / "lm.json").write_text(json.dumps(data))
    return d / "face.ply", d / "lm.json", data


def test_synth_scan_writes_a_case_with_the_scan_as_truth(scan_files, tmp_path, generic) -> None:
    ply, lmf, data = scan_files
    out = tmp_path / "case"
    assert main(["synth", str(out), "--scan", str(ply), "--landmarks", str(lmf),
                 "--size", "256", "--seed", "4"]) == 0
    case = read_case(out)
    assert sum(len(v.landmarks) for v in case.views.values()) > 30
    truth = read_reconstruction(out / "truth.json")
    for k in LANDMARK_IDS:
        assert np.allclose(truth.landmarks[k], data["landmarks"][k], atol=1e-6)
    tV, _ = read_mesh(out / "truth_face.ply")
    assert np.allclose(tV, generic.mean - generic.mean[generic.landmark_vertices["g"]],
                       atol=1e-4)                             # back in the SPEC frame
    assert read_image(out / "front.jpg").shape[:2] == (256, 256)
    named = ply.parent / "Doe_Jane_1970-01-01.ply"          # a scan named after its person
    shutil.copy(ply, named)
    assert main(["synth", str(tmp_path / "named"), "--scan", str(named), "--landmarks",
                 str(lmf), "--size", "128", "--seed", "4"]) == 0
    text = (tmp_path / "named" / "case.json").read_text()
    assert "Doe" not in text and "1970" not in text
    assert read_case(tmp_path / "named").id == case.id     # the id follows the geometry
    assert main(["synth", str(out), "--scan", str(ply), "--landmarks", str(lmf),
                 "--size", "128"]) == 0                      # its own earlier case: redone
    patient = tmp_path / "patient"
    patient.mkdir()
    (patient / "case.json").write_text('{"a real": "case"}')
    for argv in (["--scan", str(ply), "--landmarks", str(lmf)], ["--model", "generic"]):
        assert main(["synth", str(patient), *argv, "--size", "128"]) == 2
    assert (patient / "case.json").read_text() == '{"a real": "case"}'
    assert sorted(p.name for p in patient.iterdir()) == ["case.json"]


def _fails(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


def test_synth_scan_bad_inputs_are_one_line_errors(scan_files, tmp_path, capsys) -> None:
    ply, lmf, data = scan_files
    out = str(tmp_path / "x")
    bad = dict(data, landmarks={k: v for k, v in data["landmarks"].items() if k != "mf_l"})
    (tmp_path / "a.json").write_text(json.dumps(bad))
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "a.json")])
    assert "a.json" in err and "'landmarks'" in err and "mf_l" in err
    R = np.array(data["transform_from_obj"]["R"]) * 2.0
    bad = dict(data, transform_from_obj={"R": R.tolist(), "t": [0, 0, 0]})
    (tmp_path / "b.json").write_text(json.dumps(bad))
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "b.json")])
    assert "transform_from_obj.R" in err and "rotation" in err
    bad = dict(data, transform_from_obj=None)                 # identity: wrong frame
    (tmp_path / "c.json").write_text(json.dumps(bad))
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "c.json")])
    assert "from the scan surface" in err and "transform_from_obj" in err
    err = _fails(capsys, ["synth", out, "--scan", str(ply)])
    assert "--landmarks" in err
    (tmp_path / "d.json").write_text("{not json")
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "d.json")])
    assert "d.json" in err
    assert not (tmp_path / "x").exists()                      # nothing half-written


@pytest.mark.parametrize(("flag", "value", "says"), [("--size", "100000", "64 to 4096 px"),
                                                    ("--size", "32", "64 to 4096 px"),
                                                    ("--seed", "-1", "integer >= 0")])
def test_synth_arguments_out_of_range_are_one_line_errors(scan_files, tmp_path, capsys,
                                                          flag, value, says) -> None:
    ply, lmf, _ = scan_files
    err = _fails(capsys, ["synth", str(tmp_path / "x"), "--scan", str(ply), "--landmarks",
                          str(lmf), flag, value])
    assert f"{flag} {value}" in err and says in err
    err = _fails(capsys, ["synth", str(tmp_path / "y"), "--model", "generic", flag, value])
    assert says in err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_synth_scan_refuses_landmarks_in_metres_and_a_mesh_without_area(
        scan_files, tmp_path, capsys) -> None:
    ply, lmf, data = scan_files
    out = str(tmp_path / "x")
    t = np.array(data["transform_from_obj"]["t"])
    metres = dict(data, landmarks={k: (np.array(v) / 1000).tolist()   # all near g: every
                                   for k, v in data["landmarks"].items()},   # one "on" it
                  transform_from_obj=dict(data["transform_from_obj"], t=(t / 1000).tolist()))
    (tmp_path / "m.json").write_text(json.dumps(metres))
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "m.json")])
    assert "m.json" in err and "al_l-al_r" in err and "millimetres" in err
    same = dict(data, landmarks=dict(data["landmarks"], al_r=data["landmarks"]["al_l"]))
    (tmp_path / "s.json").write_text(json.dumps(same))
    err = _fails(capsys, ["synth", out, "--scan", str(ply), "--landmarks",
                          str(tmp_path / "s.json")])
    assert "al_l-al_r is 0 mm" in err
    V, F = read_mesh(ply)
    export_mesh(tmp_path / "flat.ply", np.zeros_like(V) + V[0], F)   # every triangle a point
    err = _fails(capsys, ["synth", out, "--scan", str(tmp_path / "flat.ply"), "--landmarks",
                          str(lmf)])
    assert "flat.ply" in err and "non-zero area" in err
    assert not (tmp_path / "x").exists()


def test_james_scan_reads_with_its_texture() -> None:
    scan = read_scan(JAMES / "james.obj", JAMES / "landmarks.json")
    assert scan.texture is not None and scan.uv is not None
    assert scan.uv.shape == (len(scan.F), 3, 2)
    assert np.allclose(scan.landmarks["g"], 0)
    assert "LICENSE" in scan.source["credit"]


def test_region_errors_locate_a_tip_change_and_the_map_is_written(generic, tmp_path) -> None:
    V = generic.mean - generic.mean[generic.landmark_vertices["g"]]
    F = np.asarray(generic.faces)
    lm = {k: V[i] for k, i in generic.landmark_vertices.items()}
    samples = region_samples(V, F, lm, n_samples=6000)
    found = {REGIONS[i] for i in np.unique(samples[1])}
    assert {"dorsum", "tip lobule", "sidewalls", "alae", "columella/sill"} <= found
    same = region_errors(V, F, lm, V, F, lm, samples=samples)
    assert max(r["mean_mm"] for r in same.values()) < 1e-6
    W = V.copy()
    near_tip = np.linalg.norm(V - lm["prn"], axis=1) < 6.0
    W[near_tip, 2] += 1.5                                     # the tip made more prominent
    moved = region_errors(V, F, lm, W, F, lm, samples=samples)
    assert moved["tip lobule"]["mean_mm"] > 0.1
    assert moved["tip lobule"]["mean_mm"] > 5 * moved["dorsum"]["mean_mm"]
    png = error_map_png(tmp_path / "m.png", V, F, lm, W, F, lm, title="t")
    img = read_image(png)
    assert img.shape[1] > 3 * img.shape[0] / 1.2             # three views and a colour bar
