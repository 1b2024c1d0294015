"""Stage 3, ARAP + cotangent smoothing (paper eq. 19-21): :class:`NoseDeformer`.

Uses the ICT Face Model Light from ../shared (tests/conftest.py): its mean face with a
region around the nose tip and 40 handles.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from naseview.geometry.mesh import face_normals
from naseview.stage3_mesh import NoseDeformer, RefineParams

TIP = 4841  # ICT nose tip vertex (largest z)


@pytest.fixture(scope="module")
def ict_raw(ict_dir):
    d = np.load(ict_dir / "ict_face_light.npz")
    V = d["mean"].astype(np.float64)
    F = d["faces"].astype(np.int64)
    return V, F


@pytest.fixture(scope="module")
def nose_setup(ict_raw):
    """Region: vertices within 30 mm of the tip; 40 handles spread over its inner part."""
    V, F = ict_raw
    r = np.linalg.norm(V - V[TIP], axis=1)
    region = np.flatnonzero(r < 30)
    inner = np.flatnonzero(r < 22)
    rng = np.random.default_rng(3)
    handles = np.unique(np.r_[TIP, rng.choice(inner, 39, replace=False)])
    return V, F, region, handles


def _deformer(nose_setup, **kw) -> NoseDeformer:
    V, F, region, handles = nose_setup
    return NoseDeformer(V, F, region, handles, RefineParams(**kw))


def test_handles_reached_exactly_and_outside_unchanged(nose_setup) -> None:
    V, F, region, handles = nose_setup
    dfm = _deformer(nose_setup)
    rng = np.random.default_rng(1)
    H = V[handles] + rng.normal(0, 1.0, (len(handles), 3))
    rep = dfm.solve_report(H)
    assert np.allclose(rep.V[handles], H, atol=1e-9)
    outside = np.setdiff1d(np.arange(len(V)), dfm.region_vertex_ids)
    assert np.array_equal(rep.V[outside], V[outside])
    moved = np.linalg.norm(rep.V - V, axis=1)
    assert moved[np.setdiff1d(region, handles)].max() > 0.1      # the region does follow
    assert len(rep.folded_faces) == 0 and not rep.warnings
    # the seam: triangles with corners inside and outside the region keep their shape
    inside = np.isin(F, dfm.region_vertex_ids)
    E = F[inside.any(1) & ~inside.all(1)]
    l0 = np.linalg.norm(V[E] - V[np.roll(E, 1, axis=1)], axis=2)
    l1 = np.linalg.norm(rep.V[E] - rep.V[np.roll(E, 1, axis=1)], axis=2)
    assert len(E) and np.abs(l1 - l0).max() < 0.5


def test_identity_when_handles_at_base(nose_setup) -> None:
    V, F, region, handles = nose_setup
    for disp in (True, False):
        dfm = _deformer(nose_setup, smooth_displacement=disp)
        out = dfm.solve(V[handles])
        if disp:
            assert np.abs(out - V).max() < 2e-3        # libigl fits rotations in float32
        else:  # the paper's smoothing of positions shrinks the base a little
            assert 1e-4 < np.abs(out - V).max() < 1.0


def test_incremental_solve_equals_fresh_solve(nose_setup) -> None:
    V, F, region, handles = nose_setup
    rng = np.random.default_rng(2)
    H1 = V[handles] + rng.normal(0, 0.8, (len(handles), 3))
    H2 = H1.copy()
    H2[handles == TIP] += [0.0, 1.0, 2.0]                      # drag the tip
    dfm = _deformer(nose_setup)
    dfm.solve(H1)
    warm = dfm.solve_report(H2)                                 # warm start from H1
    fresh = _deformer(nose_setup).solve_report(H2, warm_start=False)
    assert np.abs(warm.V - fresh.V).max() < 0.01
    assert warm.arap_iterations <= fresh.arap_iterations < RefineParams().arap_iterations
    assert not warm.warnings and not fresh.warnings
    # plain (unaccelerated) ARAP converges to the same deformation
    plain = _deformer(nose_setup, arap_anderson=0, arap_iterations=300).solve(H2)
    assert np.abs(plain - fresh.V).max() < 0.01


def test_no_foldover_for_moderate_moves_and_clamp_for_wild_ones(nose_setup) -> None:
    V, F, region, handles = nose_setup
    dfm = _deformer(nose_setup)
    tip = int(np.flatnonzero(handles == TIP)[0])
    H = V[handles].copy()
    H[tip] += [0.0, -2.0, 4.0]                                   # tip 4.5 mm out and down
    rep = dfm.solve_report(H)
    assert len(rep.folded_faces) == 0
    assert np.allclose(rep.V[handles], H)
    H[tip] = V[TIP] + [0.0, 0.0, 60.0]                           # a wild click
    rep = dfm.solve_report(H)
    assert list(rep.clamped_handles) == [tip]
    assert np.linalg.norm(rep.V[TIP] - V[TIP]) == pytest.approx(
        dfm.params.max_handle_displacement_mm)
    assert any("limited" in w for w in rep.warnings)


def test_foldover_is_detected(nose_setup) -> None:
    V, F, region, handles = nose_setup
    dfm = _deformer(nose_setup, max_handle_displacement_mm=100.0)
    H = V[handles].copy()
    H[handles == TIP] = V[TIP] - [0.0, 0.0, 45.0]                # tip pushed through the face
    rep = dfm.solve_report(H)
    assert len(rep.folded_faces) > 0
    assert any("folded" in w for w in rep.warnings)
    # stage 3's handles are the landmarks, not something a user moved (issue 27 item 4):
    # a fresh reconstruction must not ask to "move the handles less"
    assert not any("handles" in w for w in rep.warnings if "folded" in w)
    assert any("landmark" in w for w in rep.warnings if "folded" in w)
    n0 = face_normals(V, F[rep.folded_faces])
    n1 = face_normals(rep.V, F[rep.folded_faces])
    assert (np.einsum("ij,ij->i", n0, n1) <= 0).all()


def test_params_per_solve_equal_a_deformer_built_with_them(nose_setup) -> None:
    V, F, region, handles = nose_setup
    H = V[handles] + np.random.default_rng(4).normal(0, 0.8, (len(handles), 3))
    few = dataclasses.replace(RefineParams(), arap_iterations=3, smooth_displacement=False)
    shared = _deformer(nose_setup)
    a = shared.solve_report(H, warm_start=False, params=few)
    b = _deformer(nose_setup, arap_iterations=3, smooth_displacement=False).solve_report(
        H, warm_start=False)
    assert a.arap_iterations == b.arap_iterations == 3
    assert np.array_equal(a.V, b.V)
    assert shared.params == RefineParams()          # the deformer's own params are untouched
