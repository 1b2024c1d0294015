"""The profile band of stage 3 (issue 23): the glabella and the upper lip follow the
profile photos, so the angles a surgeon reads off the profile read the patient.

End to end on a real face no face model has seen (lps-a of ../shared/data/scan-cases,
rendered from Lee Perry-Smith's scan by a renderer that is not naseview's; CC BY 3.0)."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from naseview.camera import look_at
from naseview.case import read_case
from naseview.facemodel import load_face_model
from naseview.measurements import clinical_measurements
from naseview.meshio import read_mesh
from naseview.pipeline import PipelineResult, photo_silhouettes, reconstruct, run_stage3
from naseview.stage3_mesh import RefineParams
from naseview.stage3_mesh.profile_band import profile_band, profile_box
from naseview.stage3_mesh.silhouette import Silhouette, contour_targets, edge_faces, nose_box
from naseview.stage3_mesh.solve import surface_distances

LPS_A = Path(__file__).resolve().parents[3] / "shared" / "data" / "scan-cases" / "lps-a"


@pytest.fixture(scope="module")
def lps_stages12() -> PipelineResult:
    assert (LPS_A / "case.json").is_file(), f"{LPS_A} not found: ../shared is needed"
    return reconstruct(read_case(LPS_A), None, stages=(1, 2))


def _lip_ids(V: np.ndarray, lm: dict[str, np.ndarray]) -> np.ndarray:
    """Vertices of the upper lip near the midline: 2 to 12 mm below sn."""
    sn = lm["sn"]
    return np.flatnonzero((np.abs(V[:, 0] - sn[0]) < 6) & (V[:, 1] < sn[1] - 2)
                          & (V[:, 1] > sn[1] - 12))


def _true_nasolabial() -> float:
    """The nasolabial angle of lps-a's true face (deg), by naseview's own measurement."""
    truth = json.loads((LPS_A / "truth.json").read_text())
    tl = {k: np.asarray(v, float) for k, v in truth["landmarks"].items()}
    TV, TF = read_mesh(LPS_A / "truth_face.ply")
    return float(clinical_measurements(tl, None, TV, TF)["nasolabial_angle"])


def _lip_figures(res: PipelineResult, sils: list[Silhouette], true_angle: float, detrend: bool
                 ) -> tuple[float, float]:
    """(median distance (mm) of the lip's outline from the photos' silhouettes, absolute
    nasolabial angle error (deg)) of a stage-3 result."""
    assert res.refined is not None
    V, F = res.refined.V, res.refined.F
    lm = res.reconstruction.landmarks
    lip = np.zeros(len(V), bool)
    lip[_lip_ids(V, lm)] = True
    ids, tg, _ = contour_targets(V, F, sils, lip, np.zeros((0, 3)), 1.0, 10.0,
                                 edge_faces(F), detrend)
    assert len(ids) >= 3, "the lip's outline is not seen in the profile photos"
    m = clinical_measurements(lm, res.reconstruction.curves, V, F)
    return (float(np.median(np.linalg.norm(tg - V[ids], axis=1))),
            abs(m["nasolabial_angle"] - true_angle))


def test_the_upper_lip_follows_the_profile_photos(lps_stages12: PipelineResult) -> None:
    """ICT base on lps-a: with the band (matched in the fit and the silhouette rounds, and
    bent onto the photos before ARAP), the upper lip's outline lies on the profile
    photos' silhouettes (the face model's own lip bulged 6-8 mm forward of them), the
    nasolabial angle comes closer to the true face's, and the mesh still passes
    through the landmarks."""
    case = read_case(LPS_A)
    model = load_face_model("ict")
    true_angle = _true_nasolabial()
    sils = photo_silhouettes(case, lps_stages12.reconstruction)
    lip_residual, angle_error = {}, {}
    for used in (False, True):
        res = copy.deepcopy(lps_stages12)
        run_stage3(res, case, model, RefineParams() if used else dataclasses.replace(
            RefineParams(), profile_band_used=False, band_warp_rounds=0))
        lip_residual[used], angle_error[used] = _lip_figures(res, sils, true_angle, True)
        assert res.refined is not None
        lm = res.reconstruction.landmarks
        d = surface_distances(res.refined.V, res.refined.F,
                              np.array([lm[k] for k in ("n", "prn", "sn")]))
        assert d.max() < 0.25
    assert lip_residual[True] < 0.5, lip_residual
    assert lip_residual[True] < 0.3 * lip_residual[False], lip_residual
    assert angle_error[True] < 0.5 * angle_error[False], angle_error


def test_the_generic_lip_is_bent_onto_the_profile_photos(lps_stages12: PipelineResult) -> None:
    """Generic base on lps-a (its 9 modes cannot follow the band in the fit): the band warp
    brings the upper lip's outline onto the profile photos' silhouettes (the model's lip
    bulged several mm forward of them), the nasolabial angle comes close to the true
    face's, and the nose itself is not moved by it."""
    case = read_case(LPS_A)
    model = load_face_model("generic")
    true_angle = _true_nasolabial()
    sils = photo_silhouettes(case, lps_stages12.reconstruction)
    lip_residual, angle_error, base = {}, {}, {}
    for rounds in (0, RefineParams().band_warp_rounds):
        res = copy.deepcopy(lps_stages12)
        run_stage3(res, case, model, dataclasses.replace(RefineParams(),
                                                         band_warp_rounds=rounds))
        lip_residual[rounds], angle_error[rounds] = _lip_figures(res, sils, true_angle,
                                                                 False)
        assert res.refined is not None
        base[rounds] = res.refined.base_V
    on = RefineParams().band_warp_rounds
    assert on > 0
    assert lip_residual[on] < 0.5 and lip_residual[on] < 0.2 * lip_residual[0], lip_residual
    assert angle_error[on] < 5.0 < angle_error[0], angle_error
    nose = np.asarray(model.nose_vertices, np.int64)
    np.testing.assert_array_equal(base[on][nose], base[0][nose])


def test_the_band_reaches_glabella_and_lip_and_stays_on_the_midline() -> None:
    lm = {"g": np.zeros(3), "n": np.array([0.0, -18, -3]), "prn": np.array([0.0, -60, 20]),
          "sn": np.array([0.0, -72, 7])}
    V = np.array([[0, 8, 0], [0, 12, 0], [0, -85, 6], [0, -89, 6], [11, -40, 5],
                  [13, -40, 5]], float)
    band = profile_band(V, lm, above_g_mm=10, below_sn_mm=15, half_width_mm=12)
    assert band.tolist() == [True, False, True, False, True, False]
    assert not profile_band(V, {"g": lm["g"]}, 10, 15, 12).any()   # no sn: no band


def test_the_photo_box_holds_the_band() -> None:
    """The profile photo's searched box covers the glabella above g and the lip below sn,
    and never less than the nose's own box."""
    cam = look_at([300.0, -40, 0], [0, -40, 0], [0, 1, 0], 2000.0, 800, 1200)
    lm = {"g": np.zeros(3), "n": np.array([0.0, -18, -3]), "k": np.array([0.0, -35, 6]),
          "prn": np.array([0.0, -60, 20]), "c": np.array([0.0, -66, 16]),
          "sn": np.array([0.0, -72, 7])}
    box = profile_box(cam, lm, above_g_mm=10, below_sn_mm=15)
    nose = nose_box(cam, lm)
    assert box is not None and nose is not None
    x0, y0, x1, y1 = box
    assert x0 <= nose[0] and y0 <= nose[1] and x1 >= nose[2] and y1 >= nose[3]
    for p in (lm["g"] + [0, 10, 0], lm["sn"] + [0, -15, 0]):
        u, v = cam.project(p[None])[0]
        assert x0 <= u <= x1 and y0 <= v <= y1
