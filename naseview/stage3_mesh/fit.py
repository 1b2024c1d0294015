"""The base face of stage 3: the morphable model fitted to the landmarks (paper eq. 18).

``v_base, f_base = 3DMM(I)``: naseview fits the model's similarity (Umeyama) and identity
coefficients (with their Gaussian prior) to the 3D landmarks of stage 1 and, when present,
the sub-landmarks of stage 2 on the boundary curves, in the SPEC frame (mm); then, with a
face model rich enough to follow them (``RefineParams.uses_profile_band``), to the profile
photos' silhouettes from the glabella to the upper lip as well (issue 23: the base face
fitted to the evidence, not to 21 vertices alone; :func:`_fit_silhouettes`).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> model = load_face_model("generic")                                  # doctest: +SKIP
>>> fit = fit_face_model(model, model.landmark_positions())            # doctest: +SKIP
>>> fit.vertices.shape == model.mean.shape                              # doctest: +SKIP
True
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.linalg import blas

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.geometry.alignment import umeyama
from naseview.landmarks import LANDMARK_IDS
from naseview.stage3_mesh.curve_fractions import (
    AdLandmarkTag,
    SubRow,
    orient_loops,
    sub_positions,
    sub_rows,
)
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.profile_band import matched_region
from naseview.stage3_mesh.silhouette import (
    Silhouette,
    contour_targets,
    edge_faces,
    same_matches,
)


@dataclass
class BaseFit:
    """A face-model fit in the SPEC frame.

    Attributes:
        vertices: (V, 3) fitted face, mm, SPEC frame: ``scale * R @ x + t``.
        coefficients: (K,) identity coefficients (model units: SD).
        scale, R, t: the similarity, model frame -> SPEC frame (R (3, 3), t (3,)).
        residuals_mm: landmark id -> distance from its target to its fitted vertex.
        warnings: one line each.
    """

    vertices: np.ndarray
    coefficients: np.ndarray
    scale: float
    R: np.ndarray
    t: np.ndarray
    residuals_mm: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


@dataclass
class _Similarity:
    """``x -> s R x + t``: model frame -> SPEC frame (R (3, 3), t (3,) mm)."""

    s: float
    R: np.ndarray
    t: np.ndarray


@dataclass
class _FitRows:
    """The least-squares rows of the fit: the landmarks first, then the sub-landmarks.

    Attributes:
        lm_ids: the landmark ids used (SPEC order); v_lm: (n,) their model vertices.
        Y: (n + r, 3) targets, mm; weights: (n + r,) 1 / sigma^2.
        rows: the r sub-landmark rows (:class:`SubRow`).
        need: vertex ids the rows may use (the landmark vertices and every curve path).
    """

    lm_ids: list[str]
    v_lm: np.ndarray
    Y: np.ndarray
    weights: np.ndarray
    rows: list[SubRow]
    need: np.ndarray


def _usable_landmarks(model: FaceModel, landmarks: Mapping[str, np.ndarray]) -> list[str]:
    """The landmark ids (SPEC order) given, finite and on the model; at least 4."""
    lm_ids = [k for k in LANDMARK_IDS if k in landmarks and k in model.landmark_vertices
              and np.isfinite(np.asarray(landmarks[k], float)).all()]
    if len(lm_ids) < 4:
        raise NaseviewError(
            f"stage 3: only {len(lm_ids)} landmarks ({', '.join(lm_ids) or 'none'}) to fit the "
            "face model; mark at least 4 (e.g. g, n, prn, al_l, al_r) in two or more views")
    return lm_ids


def _fit_rows(model: FaceModel, landmarks: Mapping[str, np.ndarray], params: RefineParams,
              ad_landmarks: np.ndarray | None, tags: Sequence[AdLandmarkTag] | None
              ) -> _FitRows:
    """Targets and weights of the landmark and sub-landmark rows."""
    lm_ids = _usable_landmarks(model, landmarks)
    Y_lm = np.array([np.asarray(landmarks[k], np.float64).reshape(3) for k in lm_ids])
    v_lm = np.array([model.landmark_vertices[k] for k in lm_ids], np.int64)
    rows = (sub_rows(model, ad_landmarks, tags, params.sub_landmark_curves)[0]
            if params.use_sublandmarks else [])
    Y = np.concatenate([Y_lm, np.array([r.target for r in rows]).reshape(-1, 3)])
    sig = np.r_[np.full(len(lm_ids), params.fit_sigma_mm),
                np.full(len(rows), params.fit_sub_sigma_mm)]
    curves = sorted({r.curve for r in rows})
    path_ids = (np.unique(np.concatenate([model.curve_vertices[c] for c in curves]))
                if curves else np.zeros(0, np.int64))
    return _FitRows(lm_ids, v_lm, Y, 1.0 / np.maximum(sig, 1e-6) ** 2, rows,
                    np.unique(np.concatenate([v_lm, path_ids])))


def _row_points(fr: _FitRows, interp: list[tuple[int, int, float]]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(I, J, A)``: row k is the point (1 - A_k) V[I_k] + A_k V[J_k] of the model mesh
    (a landmark row: its vertex, A = 0)."""
    Ii = np.r_[fr.v_lm, np.array([q[0] for q in interp], np.int64)]
    Jj = np.r_[fr.v_lm, np.array([q[1] for q in interp], np.int64)]
    Aa = np.r_[np.zeros(len(fr.v_lm)), np.array([q[2] for q in interp])]
    return Ii, Jj, Aa


def _coefficients(basis: np.ndarray, mean: np.ndarray, IJA: tuple[np.ndarray, ...],
                  Yi: np.ndarray, wi: np.ndarray, sim: _Similarity) -> np.ndarray:
    """(K,) MAP identity coefficients for the rows with the similarity fixed.

    The targets go to the model frame; the prior ``|w|^2`` regularises the weighted linear
    least squares (normal equations, sigma in model units).
    """
    Ii, Jj, Aa = IJA
    K = basis.shape[0]
    Ym = ((Yi - sim.t) @ sim.R) / sim.s
    Bi = (1 - Aa)[None, :, None] * basis[:, Ii] + Aa[None, :, None] * basis[:, Jj]
    A = Bi.reshape(K, -1).T                                      # (3n, K)
    r = (Ym - ((1 - Aa)[:, None] * mean[Ii] + Aa[:, None] * mean[Jj])).ravel()
    ww = np.repeat(wi * sim.s * sim.s, 3)                        # sigma in model units
    # normal equations without threaded BLAS (slow for these sizes on a busy machine)
    H = np.einsum("ik,il->kl", A, A * ww[:, None]) + np.eye(K)
    return np.asarray(scipy.linalg.solve(H, np.einsum("ik,i->k", A, ww * r), assume_a="pos"))


def _alternate(model: FaceModel, fr: _FitRows, params: RefineParams, K: int
               ) -> tuple[np.ndarray, _Similarity]:
    """Alternate similarity (Umeyama) and coefficients ``params.fit_iterations`` times.

    The first pass uses the landmarks only; its similarity decides the direction round
    the closed curves; then the sub-landmark rows are re-measured along the current shape
    every pass (one extra pass when there are sub-landmarks).
    """
    basis, mean = model.basis[:K], model.mean
    need, rows = fr.need, fr.rows
    w = np.zeros(K)
    sim = _Similarity(1.0, np.eye(3), np.zeros(3))
    Vcur = np.zeros_like(mean)
    for it in range(params.fit_iterations + (1 if rows else 0)):
        # current model-frame shape at the needed vertices
        Vcur[need] = mean[need] + np.tensordot(w, basis[:, need], axes=1) if K else mean[need]
        if it == 1 and rows:
            Vs = Vcur.copy()
            Vs[need] = sim.s * Vcur[need] @ sim.R.T + sim.t
            orient_loops(model, Vs, rows)
        interp = sub_positions(model, Vcur, rows) if it > 0 else []
        n = len(fr.v_lm) + len(interp)
        Ii, Jj, Aa = _row_points(fr, interp)
        Yi, wi = fr.Y[:n], fr.weights[:n]
        X = (1 - Aa)[:, None] * Vcur[Ii] + Aa[:, None] * Vcur[Jj]
        sim = _Similarity(*umeyama(X, Yi, params.fit_scale, wi))
        if K:
            w = _coefficients(basis, mean, (Ii, Jj, Aa), Yi, wi, sim)
    return w, sim


def _fit_silhouettes(model: FaceModel, fr: _FitRows, params: RefineParams, K: int,
                     w: np.ndarray, sim: _Similarity, silhouettes: Sequence[Silhouette],
                     landmarks: Mapping[str, np.ndarray]) -> tuple[np.ndarray, _Similarity]:
    """The landmark fit carried on with the profile photos' silhouettes (issue 23).

    Each round (``params.fit_silhouette_rounds`` at most, until a round matches what
    the round before did) finds the fitted face's occluding contour on the nose and
    the profile band (:func:`~naseview.stage3_mesh.profile_band.matched_region`:
    glabella and upper lip near the midline) and matches it to each photo's silhouette
    (:func:`~naseview.stage3_mesh.silhouette.contour_targets`, each match at most
    ``params.silhouette_max_mm``, the camera's shift taken out); the matches join the
    landmark and sub-landmark rows as rows of weight ``1 / fit_silhouette_sigma_mm^2``
    and the similarity and coefficients are solved again. The correspondences slide:
    a contour vertex is whichever vertex lies on the contour now, not a fixed one.
    """
    F = np.asarray(model.faces, np.int64)
    ed = edge_faces(F)
    basis, mean = model.basis[:K], model.mean
    last: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(params.fit_silhouette_rounds):
        V = _fitted_face(model, w, sim)
        band = matched_region(model, V, landmarks, params)
        ids, tg, _ = contour_targets(V, F, silhouettes, band, np.zeros((0, 3)),
                                     params.silhouette_spacing_mm, params.silhouette_max_mm,
                                     ed, params.silhouette_detrend)
        if not len(ids) or same_matches(ids, tg, last):
            break
        last = (ids, tg)
        Vm = ((V - sim.t) @ sim.R) / sim.s                       # the model frame
        Ii, Jj, Aa = _row_points(fr, sub_positions(model, Vm, fr.rows) if fr.rows else [])
        n = len(Ii)
        Ii, Jj = np.r_[Ii, ids], np.r_[Jj, ids]
        Aa = np.r_[Aa, np.zeros(len(ids))]
        Y = np.r_[fr.Y[:n], tg]
        wt = np.r_[fr.weights[:n],
                   np.full(len(ids), 1.0 / params.fit_silhouette_sigma_mm ** 2)]
        X = (1 - Aa)[:, None] * Vm[Ii] + Aa[:, None] * Vm[Jj]
        sim = _Similarity(*umeyama(X, Y, params.fit_scale, wt))
        if K:
            w = _coefficients(basis, mean, (Ii, Jj, Aa), Y, wt, sim)
    return w, sim


def _clamp(model: FaceModel, w: np.ndarray, limit_sd: float) -> tuple[np.ndarray, list[str]]:
    """Coefficients beyond ``limit_sd`` clamped, with a warning naming the first modes."""
    if not len(w) or np.abs(w).max() <= limit_sd:
        return w, []
    bad = np.flatnonzero(np.abs(w) > limit_sd)
    names = [model.mode_names[i] if i < len(model.mode_names) else f"mode {i}"
             for i in bad[:3]]
    return np.clip(w, -limit_sd, limit_sd), [
        f"stage 3: the landmarks ask the face model for {len(bad)} coefficient(s) beyond "
        f"{limit_sd:g} SD ({', '.join(names)}); clamped - check the clicks "
        "and the calliper distance (scale_mm)"]


def _fitted_face(model: FaceModel, w: np.ndarray, sim: _Similarity) -> np.ndarray:
    """(V, 3) the model's face for coefficients ``w`` (K,), in the SPEC frame."""
    K = len(w)
    Vm = model.mean.copy()
    if K:
        Vm += blas.dgemv(1.0, model.basis[:K].reshape(K, -1).T, w).reshape(-1, 3)  # F-order
    return np.asarray(sim.s * Vm @ sim.R.T + sim.t)


def _misfit_warnings(model: FaceModel, residuals: dict[str, float], scale: float,
                     params: RefineParams, verified: Collection[str] = ()) -> list[str]:
    """A poor overall fit, single landmarks far off while the others fit, a large scale.

    A landmark far off whose position two or more photos agree on (``verified``) is the
    model's miss, not the click's: the message says so rather than sending the surgeon to
    a click the geometry has already checked (the ICT int sits 7-8 mm from a real
    face's)."""
    warnings: list[str] = []
    res = np.array(list(residuals.values()))
    rms = float(np.sqrt(np.mean(res ** 2)))
    if rms > 0.5 * params.fit_warn_mm:
        warnings.append(
            f"stage 3: the '{model.name}' face model fits these landmarks only to {rms:.1f} mm "
            "RMS; the warp and ARAP carry the rest"
            + ("" if model.name == "ict" else
               " (a closer base: install the ICT model with `naseview model fetch`)"))
    far = [k for k, d in residuals.items()
           if d > max(params.fit_warn_mm, 3.0 * float(np.median(res)))]
    shown = [k for k in far if k in verified]
    unsure = [k for k in far if k not in verified]
    if shown:
        warnings.append(
            "stage 3: landmark(s) " + ", ".join(f"{k} ({residuals[k]:.1f} mm)" for k in shown)
            + f" far from the '{model.name}' face model fit while the others fit; their photos "
            "agree on them, so the model does not reach this nose there (not a click error)")
    if unsure:  # a click far off while the others fit: that landmark, not the model
        warnings.append(
            "stage 3: landmark(s) " + ", ".join(f"{k} ({residuals[k]:.1f} mm)" for k in unsure)
            + " far from the face model fit while the others fit; check these clicks")
    if params.fit_scale and abs(math.log(scale)) > math.log(1.25):
        warnings.append(f"stage 3: the face model had to be scaled by {scale:.2f} to fit the "
                        "landmarks; check the calliper distance (scale_mm)")
    return warnings


def fit_face_model(model: FaceModel, landmarks: Mapping[str, np.ndarray],
                   params: RefineParams | None = None,
                   ad_landmarks: np.ndarray | None = None,
                   ad_landmark_tags: Sequence[AdLandmarkTag] | None = None,
                   verified: Collection[str] = (),
                   silhouettes: Sequence[Silhouette] = ()) -> BaseFit:
    """Fit the morphable model to 3D landmarks: the base face of eq. 18.

    Minimises, alternating a few times between the two unknowns,

        sum_i |s R (mean_i + B_i w) + t - y_i|^2 / sigma_i^2 + |w|^2

    over the similarity (s, R, t) (Umeyama) and the identity coefficients w (regularised
    linear least squares; the prior ``|w|^2`` is the Gaussian N(0, I) of the model). The
    rows are the landmark vertices and, when sub-landmarks are given (and
    ``params.use_sublandmarks``), the points of the mesh curves at the same arc-length
    fraction (interpolated between two path vertices, re-measured every alternation).
    Coefficients beyond ``params.coeff_limit_sd`` are clamped with a warning. With
    ``silhouettes`` (and ``params.uses_profile_band``) the sum gains, for a few rounds,
    the rows ``|s R (mean_j + B_j w) + t - b_j|^2 / sigma_s^2`` of the contour vertices j
    matched to the profile photos' silhouettes at b_j (:func:`_fit_silhouettes`).

    Args:
        model: the face model.
        landmarks: id -> (3,) in the SPEC frame, mm; at least 4 of the model's landmarks.
        params: :class:`RefineParams` (``n_modes``, ``fit_sigma_mm``, ...).
        ad_landmarks, ad_landmark_tags: optional stage 2 (M, 3) sub-landmarks and their M
            tags (see :func:`~naseview.stage3_mesh.correspondences.correspondences`).
        verified: ids whose position two or more photos agree on (only the wording of
            the misfit warning depends on it).
        silhouettes: the photos' silhouettes; the profile ones (``outline``) join the
            fit for ``params.fit_silhouette_rounds`` rounds (:func:`_fit_silhouettes`)
            when ``params.uses_profile_band`` (a model rich enough to follow them).
    Returns:
        :class:`BaseFit` with the fitted face in the SPEC frame.
    Raises:
        NaseviewError: fewer than 4 usable landmarks.
    """
    params = params or RefineParams()
    K = model.n_modes if params.n_modes is None else max(0, min(params.n_modes, model.n_modes))
    fr = _fit_rows(model, landmarks, params, ad_landmarks, ad_landmark_tags)
    w, sim = _alternate(model, fr, params, K)
    profiles = [s for s in silhouettes if s.outline]
    if profiles and params.fit_silhouette_rounds and params.uses_profile_band(model.n_modes):
        w, sim = _fit_silhouettes(model, fr, params, K, w, sim, profiles, landmarks)
    w, warnings = _clamp(model, w, params.coeff_limit_sd)
    V = _fitted_face(model, w, sim)
    residuals = {k: float(np.linalg.norm(V[v] - y))
                 for k, v, y in zip(fr.lm_ids, fr.v_lm, fr.Y[:len(fr.lm_ids)], strict=True)}
    warnings += _misfit_warnings(model, residuals, sim.s, params, verified)
    return BaseFit(V, w, float(sim.s), sim.R, sim.t, residuals, warnings)
