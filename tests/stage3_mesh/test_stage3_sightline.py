"""Stage 3: one-photo landmarks on their line of sight, and accepted landmarks kept on the mesh."""

from __future__ import annotations

import igl
import numpy as np
import pytest

from naseview.facemodel import FaceModel, load_face_model
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh import RefineParams, refine
from naseview.stage3_mesh.sightline import SightLine, first_hit, place_one_photo_landmarks
from naseview.stage3_mesh.solve import landmark_tolerances


@pytest.fixture(scope="module")
def generic() -> FaceModel:
    return load_face_model("generic")


def _truth(model: FaceModel) -> dict[str, np.ndarray]:
    V = model.mean
    return {k: V[v] - V[model.landmark_vertices["g"]] for k, v in model.landmark_vertices.items()}


def _on_mesh_mm(V: np.ndarray, F: np.ndarray, P: np.ndarray) -> np.ndarray:
    d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(P, float),
                                               np.ascontiguousarray(V, float),
                                               np.ascontiguousarray(F, np.int64))
    return np.sqrt(d2)


def test_first_hit_is_the_nearest_surface() -> None:
    V = np.array([[-1., -1, 0], [1, -1, 0], [0, 1, 0], [-1, -1, -5], [1, -1, -5], [0, 1, -5]])
    F = np.array([[3, 4, 5], [0, 1, 2]])
    hit = first_hit(V, F, np.array([0.0, 0, 10]), np.array([0.0, 0, -1]))
    assert hit is not None and hit[1] == 1 and np.allclose(hit[0], 0)
    assert first_hit(V, F, np.array([5.0, 5, 10]), np.array([0.0, 0, -1])) is None


def test_one_photo_landmark_lands_on_the_face_where_its_ray_meets_it(generic) -> None:
    truth = _truth(generic)
    C = truth["mf_l"] + np.array([0.0, 0.0, 350.0])          # a front camera
    d = (truth["mf_l"] - C) / np.linalg.norm(truth["mf_l"] - C)
    lm = dict(truth)
    lm["mf_l"] = truth["mf_l"] + 6.0 * d                       # stage 1: 6 mm too deep
    placed = place_one_photo_landmarks(generic, Reconstruction(landmarks=lm),
                                       {"mf_l": SightLine("front", C, d)},
                                       RefineParams(sight_iterations=3))
    p = placed["mf_l"]
    assert np.linalg.norm(p.position - truth["mf_l"]) < 1.0    # was 6 mm off
    assert abs(float(np.cross(p.position - C, d) @ np.cross(p.position - C, d))) < 1e-9
    assert 0 < p.sd_along_mm < 5.0


def test_accepted_landmarks_stay_on_the_mesh_and_only_suspects_are_released(generic) -> None:
    truth = _truth(generic)
    lm = dict(truth)
    # a nose the model cannot reach: int_l and al_l pulled apart by 10 mm in depth
    lm["int_l"] = truth["int_l"] + np.array([0.0, 0.0, 5.0])
    lm["al_l"] = truth["al_l"] - np.array([0.0, 0.0, 5.0])
    res = refine(generic, Reconstruction(landmarks=lm))
    P = np.array([lm[k] for k in lm])
    assert _on_mesh_mm(res.V, res.F, P).max() <= 0.2
    assert not res.released
    sus = Reconstruction(landmarks=lm, extra={"suspect_clicks": [
        {"landmark": "al_l", "view": "front", "residual_px": 9.0, "ignored": False}]})
    res2 = refine(generic, sus)
    assert res2.released == ["al_l"]
    assert any("al_l" in w and "suspect" in w for w in res2.warnings)
    old = refine(generic, Reconstruction(landmarks=lm),
                 RefineParams(keep_landmarks=False, slide_landmarks=False))
    assert "al_l" in old.released                              # what stage 3 did before


def test_a_click_beside_the_model_landmark_is_on_the_mesh_without_dragging_the_skin(
        generic) -> None:
    """A real nose puts a landmark elsewhere on the skin than the model does (ICT's int
    sits 7-8 mm from a real face's): the mesh passes through the click, and the skin
    is not dragged sideways to bring the model's vertex there."""
    truth = _truth(generic)
    V0 = generic.mean - generic.mean[generic.landmark_vertices["g"]]
    vk = generic.landmark_vertices["r"]
    # the skin vertex ~8 mm down the dorsum from the model's rhinion, on the surface
    dist = np.linalg.norm(V0 - V0[vk], axis=1)
    ring = np.flatnonzero((dist > 7.5) & (dist < 8.5) & (V0[:, 1] < V0[vk, 1] - 3.0)
                          & (np.abs(V0[:, 0]) < 1.0))
    lm = dict(truth)
    lm["r"] = V0[ring[0]].copy()
    rec = Reconstruction(landmarks=lm, extra={"landmark_uncertainty_mm": {"r": 0.3}})
    new = refine(generic, rec)
    old = refine(generic, rec, RefineParams(slide_landmarks=False))
    tol = landmark_tolerances(rec)
    assert tol["r"] == 0.3 and tol["g"] == 0.2
    assert _on_mesh_mm(new.V, new.F, lm["r"][None])[0] <= tol["r"]
    assert not new.released
    # ARAP's own move of the smooth base: the whole remaining miss before, now only the
    # skin's distance from the click
    drag_new = np.linalg.norm(new.V - new.base_V, axis=1).max()
    drag_old = np.linalg.norm(old.V - old.base_V, axis=1).max()
    assert drag_old > 1.0                                       # what stage 3 did before
    assert drag_new < 0.5 * drag_old


def test_sight_line_placement_is_fused_only_where_it_lowers_the_uncertainty() -> None:
    from naseview.pipeline import _fused
    from naseview.stage1_landmarks.result import SfmResult
    from naseview.stage3_mesh.sightline import Placed

    C, d = np.zeros(3), np.array([0.0, 0.0, -1.0])
    line = {"mf_l": SightLine("front", C, d)}
    rec = Reconstruction(landmarks={"mf_l": np.array([0.0, 0.0, -100.0])})

    def sfm(sd: float) -> SfmResult:
        return SfmResult({}, {}, {}, {}, {"mf_l": np.eye(3) * sd ** 2}, 0.0)

    face = {"mf_l": Placed(np.array([0.0, 0.0, -104.0]), 2.0, "front")}
    assert _fused(face, line, rec, sfm(1.0)) == {}               # stage 1 is surer
    both = _fused(face, line, rec, sfm(3.0))["mf_l"]           # the face is surer
    assert -104.0 < both.position[2] < -102.0 and both.sd_along_mm < 2.0


def test_one_note_per_one_photo_landmark_saying_how_it_was_placed() -> None:
    """The surgeon reads one note per landmark clicked in one photo, and it says where the
    landmark finally is: stage 1's symmetry/template note gives way to the line-of-sight
    one when stage 3 places it there (no two notes contradicting each other)."""
    from pathlib import Path

    from naseview.case import read_case
    from naseview.pipeline import reconstruct

    case = read_case(Path(__file__).resolve().parents[2] / "assets" / "demo-case")
    res = reconstruct(case, load_face_model("generic"))
    how = res.reconstruction.extra["landmarks_one_photo"]
    assert how and "line of sight" in how.values()
    for k, method in how.items():
        notes = [w for w in res.warnings if f"'{k}'" in w and "clicked in photo" in w]
        assert len(notes) == 1
        assert ("line of sight" in notes[0]) == (method == "line of sight")
    assert res.reconstruction.extra["warnings"] == res.warnings
    # the ray each line-of-sight sd is along, unit, for the measurements' uncertainty
    rays = res.reconstruction.extra["landmark_sight_direction"]
    assert set(rays) == {k for k, m in how.items() if m == "line of sight"}
    for d in rays.values():
        assert abs(float(np.linalg.norm(d)) - 1.0) < 1e-4
