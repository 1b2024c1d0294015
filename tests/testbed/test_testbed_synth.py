"""Synthetic cases (testbed.synth): clicks against the truth, visibility, files, photos, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from naseview.case import read_case
from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel, load_face_model
from naseview.fileio import read_json
from naseview.imagefile import read_image
from naseview.landmarks import CURVE_VIEWS, HELPER_IDS, LANDMARK_IDS, VIEW_LANDMARKS, VIEWS
from naseview.meshio import read_mesh
from naseview.reconstruction import read_reconstruction
from naseview.render import rasterize, visible_points
from naseview.testbed.synth import (
    build_scene,
    random_streams,
    sample_identity,
    sample_rig,
    synthesize_case,
)
from naseview.testbed.synth.clicks import CONTOUR_RADIUS_PX, VISIBILITY_TOL_MM
from naseview.testbed.synth.eyes import GENERIC_EYES_MM

SIZE = 512
SEED = 3


@pytest.fixture(scope="module")
def model() -> FaceModel:
    return load_face_model("ict")


@pytest.fixture(scope="module")
def noisy_case(model: FaceModel, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("synth") / "noisy"
    synthesize_case(out, model, seed=SEED, noise_px=1.5, size=SIZE, image_noise=2.0)
    return out


@pytest.fixture(scope="module")
def exact_case(model: FaceModel, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("synth") / "exact"
    synthesize_case(out, model, seed=SEED, noise_px=0.0, size=SIZE, image_noise=0.0)
    return out


def test_case_and_truth_files(noisy_case: Path, model: FaceModel) -> None:
    case = read_case(noisy_case)
    assert set(case.views) == set(VIEWS)
    for v in case.views.values():
        assert (v.width, v.height) == (SIZE, SIZE)
        assert set(v.landmarks) <= set(VIEW_LANDMARKS[v.name])
    assert set(case.scale_mm) == {("al_l", "al_r")}
    truth = read_reconstruction(noisy_case / "truth.json")
    assert set(truth.landmarks) == set(LANDMARK_IDS)
    assert np.allclose(truth.landmarks["g"], 0.0)
    assert set(truth.cameras) == set(VIEWS)
    assert set(truth.curves) == set(model.curve_vertices)
    al = np.linalg.norm(truth.landmarks["al_l"] - truth.landmarks["al_r"])
    assert case.scale_mm[("al_l", "al_r")] == pytest.approx(al, abs=1e-3)
    assert truth.measurements["n-prn"] == pytest.approx(
        np.linalg.norm(truth.landmarks["n"] - truth.landmarks["prn"]), abs=1e-6)
    # anatomy in the SPEC frame: nose tip anterior and below g, subject's left at +x
    assert truth.landmarks["prn"][2] > 10 and truth.landmarks["prn"][1] < -30
    assert truth.landmarks["al_l"][0] > 0 > truth.landmarks["al_r"][0]
    bounds = read_json(noisy_case / "truth_boundaries.json")
    for name, views in CURVE_VIEWS.items():
        assert set(bounds[name]) == set(views), name
        for pts in bounds[name].values():
            P = np.asarray(pts)
            assert len(P) >= 5 and P.shape[1] == 2, name
            assert np.all((P >= -0.5) & (P <= SIZE - 0.5))
    V, F = read_mesh(noisy_case / "truth_face.ply")
    assert V.shape == (model.n_vertices, 3) and len(F) == len(model.faces)
    assert np.allclose(V[model.landmark_vertices["prn"]], truth.landmarks["prn"], atol=1e-4)


def test_noise_free_clicks_are_exact_projections(exact_case: Path) -> None:
    case = read_case(exact_case)
    truth = read_reconstruction(exact_case / "truth.json")
    n = 0
    for name, v in case.views.items():
        cam = truth.cameras[name]
        for lid, uv in v.landmarks.items():
            if lid in HELPER_IDS:
                continue
            err = np.linalg.norm(cam.project(truth.landmarks[lid][None])[0] - uv)
            assert err < 0.01, (name, lid, err)
            n += 1
    assert n >= 40


def test_click_noise_matches_noise_px(noisy_case: Path, exact_case: Path) -> None:
    noisy, exact = read_case(noisy_case), read_case(exact_case)
    # identity, rig and photos do not depend on the click noise
    t1 = read_json(noisy_case / "truth.json")
    t2 = read_json(exact_case / "truth.json")
    assert t1["landmarks"] == t2["landmarks"] and t1["cameras"] == t2["cameras"]
    errs = [np.linalg.norm(noisy.views[v].landmarks[k] - exact.views[v].landmarks[k])
            for v in VIEWS for k in noisy.views[v].landmarks if k in exact.views[v].landmarks]
    assert len(errs) >= 40
    # per-axis sigma 1.5 px: the error norm is Rayleigh, mean 1.5 sqrt(pi/2) = 1.88 px
    assert 1.3 < np.mean(errs) < 2.5
    assert max(errs) < 1.5 * 5


def test_visibility_policy(model: FaceModel, exact_case: Path) -> None:
    """Listed clicks are visible; policy landmarks left out are hidden (or off-image)."""
    case = read_case(exact_case)
    rs = random_streams(SEED)
    V, _ = sample_identity(model, rs["identity"])
    cams, _ = sample_rig(V, model, rs["rig"], SIZE)
    scene, _ = build_scene(model, V, rs["appearance"])
    radius = max(1, round(CONTOUR_RADIUS_PX * SIZE / 1024))
    hidden_seen = 0
    for view, cam in cams.items():
        depth = rasterize(scene.V, scene.F, cam, cull_backfaces=True).depth
        ids = [i for i in VIEW_LANDMARKS[view] if i in LANDMARK_IDS]
        P = np.array([V[model.landmark_vertices[i]] for i in ids])
        vis = visible_points(P, cam, depth, VISIBILITY_TOL_MM, radius)
        listed = case.views[view].landmarks
        for lid, ok in zip(ids, vis, strict=True):
            if lid in listed:
                assert ok, (view, lid)
            uv = cam.project(V[model.landmark_vertices[lid]][None])[0]
            if ok and np.all((uv > 10) & (uv < SIZE - 10)):
                assert lid in listed, (view, lid)
        # the far-side ala is behind the nose in a profile photo
        other = {"left": "al_r", "right": "al_l"}.get(view)
        if other is not None:
            X = V[model.landmark_vertices[other]][None]
            assert not visible_points(X, cam, depth, VISIBILITY_TOL_MM, radius)[0]
            hidden_seen += 1
    assert hidden_seen == 2
    assert not any(k.endswith("_r") for k in case.views["left"].landmarks)
    assert not any(k.endswith("_l") for k in case.views["right"].landmarks)
    assert {"add_l", "add_r"} <= set(case.views["bottom"].landmarks)


def test_photos_background_and_nostrils(noisy_case: Path, model: FaceModel) -> None:
    truth = read_json(noisy_case / "truth.json")
    bg = np.array(truth["synth"]["appearance"]["background_bgr"], dtype=float)
    # profile photos: the nose points to the image border in front of the face, which
    # must be uniform backdrop (the paper's mid-curve detection needs it)
    for view, col in (("left", 0), ("right", SIZE - 1)):
        edge = read_image(noisy_case / f"{view}.jpg")[:, col].astype(float)
        assert np.all(np.abs(edge.mean(axis=0) - bg) < 4), view
        assert edge.std(axis=0).max() < 6, view
    # nostrils much darker than the skin of the nose in the bottom photo
    rec = read_reconstruction(noisy_case / "truth.json")
    cam = rec.cameras["bottom"]
    V, F = read_mesh(noisy_case / "truth_face.ply")
    img = read_image(noisy_case / "bottom.jpg").astype(float).mean(axis=2)
    depth = rasterize(V, F, cam, cull_backfaces=True).depth

    def grey(ids: np.ndarray) -> float:
        P = V[ids]
        P = P[visible_points(P, cam, depth, 0.5)]
        uv = np.round(cam.project(P)).astype(int)
        return float(np.median(img[uv[:, 1], uv[:, 0]]))

    nostril = grey(np.asarray(model.nostril_vertices))
    skin = grey(np.setdiff1d(model.nose_vertices, model.nostril_vertices))
    assert nostril < 0.4 * skin


def test_generic_face_case(tmp_path: Path) -> None:
    """The built-in face (eyes modelled in the mesh, no holes) makes a valid case too."""
    model = load_face_model("generic")
    out = tmp_path / "generic"
    synthesize_case(out, model, seed=7, size=384)
    case = read_case(out)
    assert len(case.views["front"].landmarks) >= 15
    truth = read_reconstruction(out / "truth.json")
    cam = truth.cameras["front"]
    img = read_image(out / "front.jpg").astype(float).mean(axis=2)
    # painted eyes: the sclera beside the iris is brighter than the skin below the eye
    V, _ = read_mesh(out / "truth_face.ply")
    for cx, cy in GENERIC_EYES_MM:
        i = int(np.argmin(np.hypot(model.mean[:, 0] - cx, model.mean[:, 1] - cy)))
        sclera = cam.project(np.array([V[i] + [dx, 0.0, 0.0] for dx in (-9.0, 9.0)]))
        cheek = cam.project((V[i] + [0.0, -20.0, 0.0])[None])[0]
        eye = max(img[int(round(p[1])), int(round(p[0]))] for p in sclera)
        assert eye > img[int(round(cheek[1])), int(round(cheek[0]))] + 15, (cx, cy)


def test_same_seed_same_files(model: FaceModel, noisy_case: Path, tmp_path: Path) -> None:
    synthesize_case(tmp_path / "again", model, seed=SEED, noise_px=1.5, size=SIZE,
                    image_noise=2.0)
    for name in ("case.json", "truth.json", "truth_boundaries.json", "front.jpg",
                 "bottom.jpg"):
        assert (tmp_path / "again" / name).read_bytes() == (noisy_case / name).read_bytes()


def test_batch_command_and_sheet(tmp_path: Path) -> None:
    out = tmp_path / "batch"
    assert main(["synth", str(out), "--model", "ict", "--batch", "2", "--seed", "5",
                 "--size", "256", "--noise-px", "1"]) == 0
    ids = [read_case(out / f"case-{i:03d}").id for i in range(2)]
    assert ids == ["synth-ict-5", "synth-ict-6"]
    a = json.loads((out / "case-000" / "case.json").read_text())
    b = json.loads((out / "case-001" / "case.json").read_text())
    assert a["views"]["front"]["landmarks"] != b["views"]["front"]["landmarks"]
    sheet = tmp_path / "sheet.png"
    assert main(["sheet", str(out / "case-000"), "-o", str(sheet), "--reconstruction",
                 str(out / "case-000" / "truth.json")]) == 0
    img = read_image(sheet)
    assert img.shape[1] == 2 * 640 and img.shape[0] > 2 * 640
    assert main(["sheet", str(out / "case-000"), "-o", str(tmp_path / "s.jpg")]) == 2


def test_bad_arguments(model: FaceModel, tmp_path: Path) -> None:
    with pytest.raises(NaseviewError, match="size"):
        synthesize_case(tmp_path / "x", model, seed=0, size=32)
    with pytest.raises(NaseviewError, match="noise"):
        synthesize_case(tmp_path / "x", model, seed=0, noise_px=-1)
