"""The test bed tells the truth (issue 23): the SPEC §6 nose region works on a whole-head
truth mesh, and the clinical measurement errors are reconstruction minus truth."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import igl
import numpy as np
import pytest

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel, load_face_model
from naseview.geometry.mesh import face_normals
from naseview.landmarks import LANDMARK_IDS
from naseview.measurements import midline_plane
from naseview.meshio import read_mesh
from naseview.reconstruction import read_reconstruction
from naseview.testbed.clinical import HEADLINE, measurement_errors, summarize_errors
from naseview.testbed.evaluate import evaluate_cases, format_report
from naseview.testbed.regions import region_samples
from naseview.testbed.surface import nose_region, nose_surface_samples, region_box

LPS_A = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scan-cases" / "lps-a"


def _quad(x0: float, x1: float, y0: float, y1: float, z: float, facing: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """Two triangles of the rectangle [x0, x1] x [y0, y1] at depth z, normal (0, 0, facing)."""
    V = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]]) if facing > 0 else np.array([[0, 2, 1], [0, 3, 2]])
    return V, F


def test_nose_region_is_a_box_of_forward_facing_triangles() -> None:
    """A front sheet is the nose; the back of the 'head' behind it and a backward-facing
    flap in front of the alar creases are not, though all lie inside the frontal outline."""
    lm = {"n": np.array([0.0, -18, -3]), "sn": np.array([0.0, -70, 15]),
          "al_l": np.array([16.0, -62, 2]), "al_r": np.array([-16.0, -62, 2]),
          "ac_l": np.array([15.0, -66, -1]), "ac_r": np.array([-15.0, -66, -2])}
    parts = [_quad(-10, 10, -60, -30, 5.0, +1),          # the nose: in the box, facing +z
             _quad(-10, 10, -60, -30, -150.0, -1),       # the back of the head
             _quad(-3, 3, -50, -45, 12.0, -1),           # a flap facing backwards
             _quad(-10, 10, -90, -80, 5.0, +1)]          # the chin: below sn - 3
    V = np.concatenate([p[0] for p in parts])
    F = np.concatenate([p[1] + 4 * i for i, p in enumerate(parts)])
    reg = nose_region(V, F, lm)
    assert sorted(reg.triangles.tolist()) == [0, 1]
    lo, hi = region_box(lm)
    np.testing.assert_allclose(lo, [-19.0, -73.0, -5.0])
    assert hi[:2].tolist() == [19.0, -15.0] and hi[2] == np.inf
    P = nose_surface_samples(V, F, lm, 500)
    assert np.allclose(P[:, 2], 5.0)
    with pytest.raises(NaseviewError, match="truth.json: key 'landmarks' lacks ac_r"):
        nose_surface_samples(V, F, {k: v for k, v in lm.items() if k != "ac_r"})
    with pytest.raises(NaseviewError, match="truth_face.ply: no open"):
        nose_surface_samples(V, F[4:6], lm)


@pytest.fixture(scope="module")
def lps_truth() -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The whole-head truth of the lps cases (../shared)."""
    V, F = read_mesh(LPS_A / "truth_face.ply")
    return np.asarray(V, float), np.asarray(F, np.int64), read_reconstruction(
        LPS_A / "truth.json").landmarks


def test_whole_head_truth_gives_no_back_facing_samples(lps_truth) -> None:
    V, F, lm = lps_truth
    N = face_normals(V, F)
    Nu = N / np.maximum(np.linalg.norm(N, axis=1), 1e-12)[:, None]
    C = V[F].mean(1)
    lo, hi = region_box(lm)
    frontal = ((C[:, :2] >= lo[:2]) & (C[:, :2] <= hi[:2])).all(1)
    assert (frontal & (C[:, 2] < lo[2] - 50)).sum() > 50     # the back of the head is there
    in_box = frontal & (C[:, 2] >= lo[2])
    assert (in_box & (Nu[:, 2] <= -0.2)).sum() > 20          # and backward faces in the box
    P = nose_surface_samples(V, F, lm, 4000)
    _, tri, _ = igl.point_mesh_squared_distance(P, V, F)
    assert (Nu[tri, 2] > -0.2).all()
    reg = nose_region(V, F, lm)                                # centroids in the box,
    edge = np.linalg.norm(V[F[reg.triangles]] - C[reg.triangles][:, None], axis=2).max()
    assert ((P >= lo - edge) & (P <= hi + edge)).all()         # points within a triangle
    assert np.ptp(P[:, 1]) > 45                                # radix down to the sills
    assert P[:, 1].max() > lm["n"][1]                           # up to nasion and past it
    Q, lab = region_samples(V, F, lm, 3000)
    _, tri, _ = igl.point_mesh_squared_distance(Q, V, F)
    assert (Nu[tri, 2] > -0.2).all() and len(np.unique(lab)) >= 5


@pytest.fixture(scope="module")
def generic_truth() -> tuple[FaceModel, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    m = load_face_model("generic")
    V = np.asarray(m.mean, float) - m.mean[m.landmark_vertices["g"]]
    return m, V, np.asarray(m.faces, np.int64), {k: V[i] for k, i in
                                                  m.landmark_vertices.items()}


def test_measurement_errors_are_zero_against_itself(generic_truth) -> None:
    _, V, F, lm = generic_truth
    e = measurement_errors(V, F, lm, V, F, lm)
    meas = e["measurements"]
    assert set(HEADLINE) <= set(meas)
    for name, v in meas.items():
        assert v["error"] == pytest.approx(0.0, abs=1e-9), name
    assert e["profile"]["truth"] == e["profile"]["pred"]
    assert e["profile"]["pred"]["source"] == "mesh"
    assert e["profile"]["pred"]["below_sn_mm"] > 8            # the nasolabial angle's lip
    assert 80 < meas["nasolabial_angle"]["truth"] < 140
    summ = summarize_errors([e, e])
    assert summ["tip_projection"] == {"mae": 0.0, "mean_error": 0.0, "n": 2, "missing": 0}


def test_measurement_errors_have_the_sign_of_the_change(generic_truth) -> None:
    """Tip 1 mm forward, eye rims 1 mm back (landmarks), upper lip sheared back (mesh):
    the reconstruction reads more projection, a higher radix, an opener nasolabial angle."""
    _, V, F, lm = generic_truth
    ant = midline_plane(lm).anterior
    pred = {k: v.copy() for k, v in lm.items()}
    pred["prn"] = lm["prn"] + ant
    pred["mf_l"], pred["mf_r"] = lm["mf_l"] - ant, lm["mf_r"] - ant
    W = V.copy()
    sn = lm["sn"]
    lip = (V[:, 1] < sn[1] - 0.5) & (np.abs(V[:, 0]) < 20) & (V[:, 2] > sn[2] - 20)
    W[lip, 2] -= 0.4 * (sn[1] - V[lip, 1])                     # further back lower down
    e = measurement_errors(V, F, lm, W, F, pred)["measurements"]
    assert e["tip_projection"]["error"] == pytest.approx(1.0, abs=1e-6)
    assert e["radix_height"]["error"] == pytest.approx(1.0, abs=1e-6)
    assert e["nasal_length"]["error"] > 0
    assert e["nasolabial_angle"]["error"] > 5
    assert e["nasolabial_angle"]["pred"] == pytest.approx(
        e["nasolabial_angle"]["truth"] + e["nasolabial_angle"]["error"])
    nose_only = (V[:, 1] > sn[1])                              # a mesh without the lip
    keep = nose_only[F].all(axis=1)
    e2 = measurement_errors(V, F, lm, V, F[keep], lm)
    assert math.isnan(e2["measurements"]["nasolabial_angle"]["error"])
    assert summarize_errors([e2])["nasolabial_angle"]["missing"] == 1


@pytest.fixture(scope="module")
def lps_report() -> dict[str, Any]:
    """``naseview evaluate`` of lps-a (whole-head truth) on the ICT base, no ablation."""
    return evaluate_cases([LPS_A], model="ict", stages=(1, 2, 3), ablate=False)


def test_evaluate_on_a_whole_head_case_is_sane(lps_report: dict[str, Any]) -> None:
    assert lps_report["failed"] == []
    case = lps_report["cases"][0]
    surf = case["surface"]["pipeline"]
    assert 0.1 < surf["mean_mm"] < 5.0 and surf["p95_mm"] < 10.0
    meas = case["measurements"]["measurements"]
    for name in HEADLINE:                                     # found on both sides
        assert math.isfinite(meas[name]["error"]), name
    assert 100 < meas["nasolabial_angle"]["truth"] < 140
    assert 115 < meas["nasofrontal_angle"]["truth"] < 150
    assert {p["source"] for p in case["measurements"]["profile"].values()} == {"mesh"}
    assert 3 < case["measurements"]["frame_tilt_deg"] < 8           # lps's +y vs sn -> g
    s1 = lps_report["summary"]["measurements"]["in_stage1_frame"]["tip_rotation"]
    assert s1["n"] == 1 and math.isfinite(s1["mae"])
    summ = lps_report["summary"]["measurements"]["errors"]
    assert summ["nasolabial_angle"]["mae"] == pytest.approx(
        abs(meas["nasolabial_angle"]["error"]))
    text = format_report(lps_report)
    assert "Clinical measurement error" in text and "nasolabial_angle *" in text
    assert "lps-a" in text


def test_the_frame_convention_is_told_apart_from_the_shape(generic_truth) -> None:
    """The same face, its truth kept in a frame whose +y is not stage 1's (sn -> g): the
    measurements that read the vertical differ by the tilt in the SPEC §6 figure and not
    at all with the truth turned into stage 1's frame; angles between profile lines and
    distances agree either way."""
    from naseview.stage1_landmarks import anatomical_frame

    _, V, F, lm = generic_truth
    o, R = anatomical_frame({k: v for k, v in lm.items() if k in LANDMARK_IDS})
    V1 = (V - o) @ R.T                                         # as a reconstruction's
    lm1 = {k: R @ (v - o) for k, v in lm.items()}
    e = measurement_errors(V, F, lm, V1, F, lm1)
    assert e["frame_tilt_deg"] > 1.0
    spec, s1 = e["measurements"], e["in_stage1_frame"]
    assert abs(spec["tip_rotation"]["error"]) > 1.0
    for name in ("tip_rotation", "radix_height", "tip_projection", "nasolabial_angle",
                 "nasal_length"):
        assert s1[name]["error"] == pytest.approx(0.0, abs=1e-6), name
    for name in ("nasolabial_angle", "nasal_length"):
        assert spec[name]["error"] == pytest.approx(0.0, abs=0.05), name
    assert summarize_errors([e], "in_stage1_frame")["tip_rotation"]["mae"] < 1e-6
