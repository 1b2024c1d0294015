"""Stage 3 (paper §3.4): the refined face from the landmarks and ad-landmarks.

:func:`refine` runs the section's steps on a :class:`~naseview.reconstruction.Reconstruction`,
each in its own module:

1. :func:`~naseview.stage3_mesh.fit.fit_face_model` - the base face
   ``v_base, f_base = 3DMM(I)`` (eq. 18): similarity and identity coefficients of the
   morphable model fitted to the landmarks (and sub-landmarks);
2. :func:`~naseview.stage3_mesh.correspondences.correspondences` - each ad-landmark to a
   vertex of the base mesh (the handles);
3. :func:`~naseview.stage3_mesh.warp.smooth_warp` (naseview's addition) - the base bent
   smoothly towards the ad-landmarks; handles it cannot reconcile with their neighbours
   are released from the hard constraints (the ablation,
   :data:`naseview.testbed.surface.ABLATION_ROWS`, shows why);
4. :class:`~naseview.stage3_mesh.deform.NoseDeformer` - ARAP (eq. 19-20) on the nose region
   with a pinned margin ring and the handles as hard constraints, then cotangent
   smoothing (eq. 21). It stays in the result, ready for the app's re-solves.

Everything is in the SPEC frame (mm, origin g, +x subject's left, +y up, +z anterior).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> model = load_face_model("ict")                                   # doctest: +SKIP
>>> res = refine(model, reconstruction)                              # doctest: +SKIP
>>> V = res.deformer.solve(res.handles.targets + [0, 0, 1.0])        # doctest: +SKIP
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from naseview.facemodel import FaceModel
from naseview.geometry.region import grow_by_distance
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh.correspondences import Correspondences, correspondences
from naseview.stage3_mesh.curve_fractions import AdLandmarkTag
from naseview.stage3_mesh.deform import DeformReport, NoseDeformer, deform_region
from naseview.stage3_mesh.fit import BaseFit, fit_face_model
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.result import RefineResult
from naseview.stage3_mesh.warp import smooth_warp

_SubLandmarks = tuple[np.ndarray | None, Sequence[AdLandmarkTag] | None]
"""Stage 2's (M, 3) ad-landmarks and their M tags (both None when there are none)."""


def _sublandmarks(reconstruction: Reconstruction) -> _SubLandmarks:
    """The reconstruction's ad-landmarks and tags; (None, None) when it has none."""
    ad = reconstruction.ad_landmarks
    tags: Sequence[AdLandmarkTag] | None = reconstruction.ad_landmark_tags
    if ad is not None and len(np.asarray(ad).reshape(-1, 3)) == 0:
        return None, None
    return ad, tags


def _warped_base(model: FaceModel, fit: BaseFit, landmarks: dict[str, np.ndarray],
                 sub: _SubLandmarks, params: RefineParams
                 ) -> tuple[np.ndarray, Correspondences, list[str]]:
    """The handles on the fitted face, then (``params.use_warp``) the face bent smoothly
    towards them and the handles found again on it: (base (V, 3), handles, warnings)."""
    ad, tags = sub
    handles, warnings = correspondences(model, fit.vertices, landmarks, ad, tags, params)
    base = fit.vertices
    if params.use_warp and len(handles.vertex_ids):
        sig = np.where(handles.is_landmark, params.fit_sigma_mm, params.fit_sub_sigma_mm)
        around = grow_by_distance(base, model.faces, handles.vertex_ids, params.warp_radius_mm)
        base = smooth_warp(base, model.faces, handles.vertex_ids, handles.targets,
                           1.0 / np.maximum(sig, 1e-6) ** 2, params.warp_bending_mm2, around)
        handles, _ = correspondences(model, base, landmarks, ad, tags, params)
    return base, handles, warnings


def _release(model: FaceModel, base: np.ndarray, handles: Correspondences,
             params: RefineParams) -> tuple[Correspondences, list[str], list[str]]:
    """Handles the smooth base still misses by more than ``params.release_mm`` contradict
    their neighbours: not hard constraints. Returns (kept handles, released names,
    warnings)."""
    miss = np.linalg.norm(handles.targets - base[handles.vertex_ids], axis=1)
    keep = miss <= params.release_mm
    released = [n for n, k in zip(handles.names, keep, strict=True) if not k]
    warnings: list[str] = []
    bad_lm = [f"{n} ({d:.1f} mm)" for n, d, k, lm in
              zip(handles.names, miss, keep, handles.is_landmark, strict=True) if lm and not k]
    if bad_lm:
        warnings.append(
            f"stage 3: landmark(s) {', '.join(bad_lm)} disagree with a smooth deformation of "
            f"the '{model.name}' face and are not hard constraints; check those clicks (or "
            "the face model does not suit this nose)")
    n_sub = int((~handles.is_landmark).sum())
    n_bad_sub = int((~keep & ~handles.is_landmark).sum())
    if n_sub and n_bad_sub > n_sub / 3:
        warnings.append(
            f"stage 3: {n_bad_sub} of {n_sub} sub-landmarks disagree with a smooth deformation "
            f"of the '{model.name}' face by more than {params.release_mm:g} mm; the face "
            "model does not suit this nose well (or the boundary curves are off)")
    return (handles.subset(keep) if released else handles), released, warnings


def _deform(model: FaceModel, base: np.ndarray, region: np.ndarray, handles: Correspondences,
            params: RefineParams, seconds: dict[str, float]
            ) -> tuple[np.ndarray, np.ndarray, NoseDeformer | None, DeformReport | None]:
    """ARAP and smoothing (when enabled and there are handles): (V, region, deformer,
    report); ``seconds`` gets the precompute and solve times."""
    if not ((params.use_arap or params.use_smoothing) and len(handles.vertex_ids)):
        return base.copy(), region, None, None
    t = time.perf_counter()
    deformer = NoseDeformer(base, model.faces, region, handles.vertex_ids, params)
    seconds["precompute"] = time.perf_counter() - t
    report = deformer.solve_report(handles.targets, warm_start=False)
    seconds.update(report.seconds)
    return report.V, deformer.region_vertex_ids, deformer, report


def refine(model: FaceModel, reconstruction: Reconstruction,
           params: RefineParams | None = None) -> RefineResult:
    """Stage 3: base fit, correspondences, smooth warp, ARAP and smoothing of the nose.

    1. :func:`~naseview.stage3_mesh.fit.fit_face_model` (similarity + coefficients) - the
       paper's base face;
    2. :func:`~naseview.stage3_mesh.correspondences.correspondences` - ad-landmarks to base
       vertices;
    3. :func:`~naseview.stage3_mesh.warp.smooth_warp` - soft bi-Laplacian bend of the base
       towards them (naseview's addition, ``params.use_warp``); handles still further than
       ``params.release_mm`` are dropped from the hard constraints, with a warning;
    4. :class:`~naseview.stage3_mesh.deform.NoseDeformer` - ARAP with the remaining handles
       as hard constraints, then cotangent smoothing (the paper).

    Uses ``reconstruction.landmarks`` and, when present and tagged,
    ``reconstruction.ad_landmarks`` / ``ad_landmark_tags`` (stage 2's sub-landmarks).

    Args:
        model: the face model (``load_face_model``).
        reconstruction: the stage 1 (and 2) :class:`~naseview.reconstruction.Reconstruction`.
        params: :class:`RefineParams`.
    Returns:
        :class:`RefineResult`.
    Raises:
        NaseviewError: too few landmarks to fit the model.
    """
    params = params or RefineParams()
    landmarks = dict(reconstruction.landmarks or {})
    sub = _sublandmarks(reconstruction)
    t0 = time.perf_counter()
    fit = fit_face_model(model, landmarks, params, *sub)
    t1 = time.perf_counter()
    base, handles, cw = _warped_base(model, fit, landmarks, sub, params)
    t2 = time.perf_counter()
    handles, released, rw = _release(model, base, handles, params)
    region = deform_region(base, model.faces, model.nose_vertices, handles.vertex_ids,
                           params.handle_clearance_mm)
    seconds = {"fit": t1 - t0, "warp": t2 - t1, "correspondences": time.perf_counter() - t2}
    V, region, deformer, report = _deform(model, base, region, handles, params, seconds)
    nose = np.asarray(model.nose_vertices, np.int64)
    in_nose = np.zeros(len(V), bool)
    in_nose[nose] = True
    F = np.asarray(model.faces, np.int64)
    return RefineResult(V=V, F=F, nose_vertex_ids=nose, nose_faces=F[in_nose[F].all(1)],
                        region_vertex_ids=region, base_V=base,
                        coefficients=fit.coefficients, fit=fit, handles=handles,
                        released=released, deformer=deformer, report=report,
                        warnings=list(fit.warnings) + cw + rw
                        + (report.warnings if report is not None else []),
                        seconds=seconds, model_name=model.name, credit=model.credit,
                        model=model)
