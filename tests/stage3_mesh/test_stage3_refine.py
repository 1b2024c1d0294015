"""Stage 3 (paper §3.4): the morphable-model fit (eq. 18) and refine() end to end, with the
ablation rows.

Uses the ICT Face Model Light from ../shared (tests/conftest.py). Accuracy bounds are
measured against the exact random identity the landmarks were taken from.
"""

from __future__ import annotations

import dataclasses

import igl
import numpy as np
import pytest

from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.landmarks import CURVE_LANDMARKS
from naseview.reconstruction import Reconstruction
from naseview.stage2_curves.params import DEFAULT_SUB_LANDMARKS
from naseview.stage2_curves.sublandmarks import ad_landmarks
from naseview.stage3_mesh import RefineParams, fit_face_model, refine
from naseview.testbed.surface import ABLATION_ROWS, nose_surface_samples, surface_error


@pytest.fixture(scope="module")
def ict_model():
    return load_face_model("ict")


def _identity(model, seed: int):
    rng = np.random.default_rng(seed)
    w = rng.normal(size=model.n_modes)
    V = model.shape(w)
    return w, V - V[model.landmark_vertices["g"]]               # SPEC frame: origin at g


def test_fit_recovers_a_random_identity_from_its_landmarks(ict_model) -> None:
    m = ict_model
    nose = m.nose_vertices
    errs, errs_mean = [], []
    for seed in range(3):
        w, Vt = _identity(m, seed)
        lm = m.landmark_positions(Vt)
        fit = fit_face_model(m, lm, RefineParams(fit_sigma_mm=0.5))
        assert fit.scale == pytest.approx(1.0, abs=0.05)
        errs.append(np.linalg.norm(fit.vertices[nose] - Vt[nose], axis=1).mean())
        errs_mean.append(np.linalg.norm(m.mean[nose] - m.mean[m.landmark_vertices["g"]]
                                        - Vt[nose], axis=1).mean())
        # the first (largest) modes are recovered
        assert np.corrcoef(fit.coefficients[:5], w[:5])[0, 1] > 0.8
        assert max(fit.residuals_mm.values()) < 2.0 and not fit.warnings
    assert np.mean(errs) < 1.0                                   # mm, vertex to vertex
    assert np.mean(errs) < 0.5 * np.mean(errs_mean)


def test_fit_needs_landmarks_and_warns_outside_the_model(ict_model) -> None:
    m = ict_model
    _, Vt = _identity(m, 5)
    lm = m.landmark_positions(Vt)
    with pytest.raises(NaseviewError, match="landmarks"):
        fit_face_model(m, {k: lm[k] for k in ("g", "n", "prn")})
    wild = dict(lm)
    wild["prn"] = lm["prn"] + [0, 0, 40.0]                       # a nose 4 cm too long
    fit = fit_face_model(m, wild)
    assert any("SD" in w or "far from" in w for w in fit.warnings)
    assert np.abs(fit.coefficients).max() <= RefineParams().coeff_limit_sd + 1e-9


def _true_ad_landmarks(m, Vt, lm):
    """Sub-landmarks sampled on the truth's own mesh curves, tagged like stage 2."""
    curves, anchors = {}, {}
    for name, path in m.curve_vertices.items():
        curves[name] = Vt[path]
        anchors[name] = [(k, int(np.flatnonzero(path == m.landmark_vertices[k])[0]))
                         for k in CURVE_LANDMARKS[name]
                         if k in m.landmark_vertices and (path == m.landmark_vertices[k]).any()]
    return ad_landmarks(lm, curves, anchors, DEFAULT_SUB_LANDMARKS)


def _surface(m, Vt, V) -> float:
    d, _, _ = igl.point_mesh_squared_distance(Vt[m.nose_vertices], V, m.faces)
    return float(np.sqrt(d).mean())


def test_refine_reaches_noisy_landmarks_without_damage(ict_model) -> None:
    m = ict_model
    _, Vt = _identity(m, 11)
    rng = np.random.default_rng(11)
    lm = {k: p + rng.normal(0, 0.3, 3) for k, p in m.landmark_positions(Vt).items()}
    res = refine(m, Reconstruction(landmarks=lm))
    for k, v in m.landmark_vertices.items():
        assert np.allclose(res.V[v], lm[k], atol=1e-9)
    assert _surface(m, Vt, res.V) < 0.8
    assert len(res.nose_faces) and np.isin(res.nose_faces, res.nose_vertex_ids).all()
    assert not res.warnings and res.report is not None
    outside = np.setdiff1d(np.arange(m.n_vertices), res.region_vertex_ids)
    assert np.array_equal(res.V[outside], res.base_V[outside])


def test_a_wild_click_is_flagged_and_does_not_crumple_the_nose(ict_model) -> None:
    m = ict_model
    _, Vt = _identity(m, 5)
    lm = m.landmark_positions(Vt)
    lm["prn"] = lm["prn"] + [0.0, 0.0, 15.0]                    # tip clicked 15 mm out
    res = refine(m, Reconstruction(landmarks=lm))
    assert any("prn" in w and "check" in w for w in res.warnings)
    assert len(res.report.folded_faces) == 0
    # the other landmarks are still met and the upper dorsum stays where it was
    for k, v in m.landmark_vertices.items():
        assert k == "prn" or np.allclose(res.V[v], lm[k], atol=1e-9)
    upper = np.flatnonzero(np.linalg.norm(Vt - Vt[m.landmark_vertices["n"]], axis=1) < 12)
    d, _, _ = igl.point_mesh_squared_distance(Vt[upper], res.V, m.faces)
    assert np.sqrt(d).mean() < 0.8


def test_exact_ad_landmarks_make_arap_beat_the_fit(ict_model) -> None:
    m = ict_model
    gain_arap, gain_pipeline = [], []
    for seed in (21, 22):
        _, Vt = _identity(m, seed)
        lm = m.landmark_positions(Vt)
        ad, tags = _true_ad_landmarks(m, Vt, lm)
        assert len(ad) == 76
        rec = Reconstruction(landmarks=lm, ad_landmarks=ad, ad_landmark_tags=tags)
        errs = {row: _surface(m, Vt, refine(m, rec, dataclasses.replace(RefineParams(), **kw)).V)
                for row, kw in ABLATION_ROWS.items() if row in ("fit", "arap76", "naseview")}
        gain_arap.append(errs["fit"] - errs["arap76"])
        gain_pipeline.append(errs["fit"] - errs["naseview"])
    assert min(gain_arap) > 0.05 and min(gain_pipeline) > 0.05   # mm, every case improves


def test_generic_base_is_bent_not_crumpled(ict_model) -> None:
    """The built-in face is not the truth's model: the smooth warp carries the correction,
    and handles it cannot reconcile are released instead of folding the mesh."""
    g = load_face_model("generic")
    m = ict_model
    _, Vt = _identity(m, 31)
    rng = np.random.default_rng(31)
    lm = {k: p + rng.normal(0, 0.3, 3) for k, p in m.landmark_positions(Vt).items()}
    ad, tags = _true_ad_landmarks(m, Vt, lm)
    rec = Reconstruction(landmarks=lm, ad_landmarks=ad, ad_landmark_tags=tags)
    samples = nose_surface_samples(Vt, m.faces, m.landmark_positions(Vt), 4000)

    def err(res) -> float:
        return surface_error(Vt, m.faces, m.landmark_positions(Vt), res.V, res.F,
                             lm, samples=samples)["mean_mm"]

    fit = refine(g, rec, dataclasses.replace(RefineParams(), **ABLATION_ROWS["fit"]))
    res = refine(g, rec)
    assert len(res.report.folded_faces) == 0
    assert err(res) < 1.2 and err(res) < err(fit) - 0.2
    for v, t in zip(res.handles.vertex_ids, res.handles.targets, strict=True):
        assert np.allclose(res.V[v], t, atol=1e-9)           # kept handles are exact


def test_a_landmark_the_photos_agree_on_is_not_blamed_for_the_models_miss(ict_model) -> None:
    """A real nose the model cannot reach: the far landmark is the model's miss when two
    photos agree on it (stage 1's residuals), a click to check when one photo placed it."""
    m = ict_model
    _, Vt = _identity(m, 5)
    lm = m.landmark_positions(Vt)
    lm["prn"] = lm["prn"] + [0.0, 0.0, 15.0]
    both = {"front": dict.fromkeys(lm, 1.0), "left": dict.fromkeys(lm, 1.0)}
    checked = refine(m, Reconstruction(landmarks=lm, extra={"residuals_px": both}))
    far = [w for w in checked.warnings if "prn (" in w]
    assert far and all("not a click error" in w and "check" not in w for w in far)
    one = refine(m, Reconstruction(landmarks=lm, extra={
        "residuals_px": both, "landmarks_one_photo": {"prn": "template"}}))
    assert any("prn (" in w and "check these clicks" in w for w in one.warnings)
    # a hand-edited record of the wrong type is not read as checked (and does not crash)
    odd = refine(m, Reconstruction(landmarks=lm, extra={"residuals_px": [1, 2],
                                                        "suspect_clicks": 7}))
    assert any("prn (" in w and "check these clicks" in w for w in odd.warnings)
