"""Stage 3 (paper §3.4): the refined face from the landmarks and ad-landmarks.

:func:`refine` runs the section's steps on a :class:`~naseview.reconstruction.Reconstruction`,
each in its own module:

1. :func:`~naseview.stage3_mesh.fit.fit_face_model` - the base face
   ``v_base, f_base = 3DMM(I)`` (eq. 18): similarity and identity coefficients of the
   morphable model fitted to the landmarks (and sub-landmarks) and, with a model rich
   enough to follow them, to the profile photos' silhouettes over the profile band
   (glabella to upper lip, :mod:`~naseview.stage3_mesh.profile_band`; issue 23);
2. :func:`~naseview.stage3_mesh.correspondences.correspondences` - each ad-landmark to a
   vertex of the base mesh (the handles);
3. :func:`~naseview.stage3_mesh.warp.smooth_warp` (naseview's addition) - the base bent
   smoothly towards the ad-landmarks; handles it cannot reconcile with their neighbours
   are released from the hard constraints (the ablation,
   :data:`naseview.testbed.surface.ABLATION_ROWS`, shows why); then
   :func:`~naseview.stage3_mesh.band_warp.band_warp` (issue 23) - the face around the
   profile band outside the nose (upper lip, glabella) bent smoothly onto the profile
   photos' silhouettes, so the nasolabial angle reads the patient's lip, not the model's;
4. :class:`~naseview.stage3_mesh.deform.NoseDeformer` - ARAP (eq. 19-20) on the nose region
   with a pinned margin ring and the handles as hard constraints, then cotangent
   smoothing (eq. 21). It stays in the result, ready for the app's re-solves;
5. :mod:`~naseview.stage3_mesh.silhouette` (naseview's addition, issue 11) - the nose's
   occluding contour (and the profile band's) in the profile photos matched to their
   silhouettes and added as hard handles, up to ``params.silhouette_rounds`` times,
   until a round matches the handles of the round before (the dense form of the
   mid-curve, whose sub-landmarks then shape the fit and warp only, unless the face
   model is too coarse to follow them: ``params.keeps_mid_handles``).

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
from collections.abc import Mapping, Sequence

import igl
import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from naseview.facemodel import FaceModel
from naseview.geometry.mesh import vertex_adjacency
from naseview.geometry.region import grow_by_distance
from naseview.geometry.unfold import unfold
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh.band_warp import band_warp
from naseview.stage3_mesh.correspondences import Correspondences, correspondences
from naseview.stage3_mesh.curve_fractions import AdLandmarkTag
from naseview.stage3_mesh.deform import DeformReport, NoseDeformer, deform_region
from naseview.stage3_mesh.fit import BaseFit, fit_face_model
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.profile_band import matched_region
from naseview.stage3_mesh.result import RefineResult
from naseview.stage3_mesh.silhouette import (
    Silhouette,
    contour_targets,
    edge_faces,
    same_matches,
)
from naseview.stage3_mesh.warp import smooth_warp

UNFOLD_ROUNDS = 8
"""Rounds of :func:`~naseview.geometry.unfold.unfold` on the warped base (each one ring
wider)."""

_SubLandmarks = tuple[np.ndarray | None, Sequence[AdLandmarkTag] | None]
"""Stage 2's (M, 3) ad-landmarks and their M tags (both None when there are none)."""


def sublandmarks(reconstruction: Reconstruction) -> _SubLandmarks:
    """The reconstruction's ad-landmarks and tags; (None, None) when it has none."""
    ad = reconstruction.ad_landmarks
    tags: Sequence[AdLandmarkTag] | None = reconstruction.ad_landmark_tags
    if ad is not None and len(np.asarray(ad).reshape(-1, 3)) == 0:
        return None, None
    return ad, tags


def warped_base(model: FaceModel, fit: BaseFit, landmarks: dict[str, np.ndarray],
                 sub: _SubLandmarks, params: RefineParams
                 ) -> tuple[np.ndarray, Correspondences, list[str]]:
    """The handles on the fitted face, then (``params.use_warp``) the face bent smoothly
    towards them and the handles found again on it: (base (V, 3), handles, warnings).
    Triangles the warp turned over against the fit are smoothed out
    (``params.unfold_rings``): ARAP keeps the rest shape's folds, a flap out of the
    nostril on the generic face (issue 27)."""
    ad, tags = sub
    handles, warnings = correspondences(model, fit.vertices, landmarks, ad, tags, params)
    base = fit.vertices
    if params.use_warp and len(handles.vertex_ids):
        sig = np.where(handles.is_landmark, params.fit_sigma_mm, params.fit_sub_sigma_mm)
        around = grow_by_distance(base, model.faces, handles.vertex_ids, params.warp_radius_mm)
        base = smooth_warp(base, model.faces, handles.vertex_ids, handles.targets,
                           1.0 / np.maximum(sig, 1e-6) ** 2, params.warp_bending_mm2, around)
        if params.unfold_rings:
            base = unfold(base, model.faces, fit.vertices, rings=params.unfold_rings,
                          max_rounds=UNFOLD_ROUNDS)[0]
        handles, _ = correspondences(model, base, landmarks, ad, tags, params)
    return base, handles, warnings


def _release(model: FaceModel, base: np.ndarray, handles: Correspondences,
             params: RefineParams, suspects: frozenset[str] = frozenset()
             ) -> tuple[Correspondences, list[str], list[str]]:
    """Handles the smooth base still misses by more than ``params.release_mm`` contradict
    their neighbours: not hard constraints. With ``params.keep_landmarks`` a landmark is
    released only when its click is in ``suspects`` (stage 1 names it), whatever the miss.
    Returns (kept handles, released names, warnings)."""
    miss = np.linalg.norm(handles.targets - base[handles.vertex_ids], axis=1)
    keep = miss <= params.release_mm
    warnings: list[str] = []
    if params.keep_landmarks:
        lm = np.asarray(handles.is_landmark, bool)
        sus = np.array([n in suspects for n in handles.names], bool)
        keep = np.where(lm, ~sus, keep)
        gone = [n for n, s, m in zip(handles.names, sus, lm, strict=True) if s and m]
        if gone:
            warnings.append(
                f"stage 3: landmark(s) {', '.join(gone)} not held on the mesh: stage 1 names "
                "their click(s) as suspect; check those clicks")
    released = [n for n, k in zip(handles.names, keep, strict=True) if not k]
    bad_lm = [f"{n} ({d:.1f} mm)" for n, d, k, lm in
              zip(handles.names, miss, keep, handles.is_landmark, strict=True) if lm and not k]
    if bad_lm and not params.keep_landmarks:
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


def slide_far_landmarks(model: FaceModel, base: np.ndarray, handles: Correspondences,
                        params: RefineParams, suspects: frozenset[str] = frozenset()
                        ) -> tuple[Correspondences, list[str]]:
    """Landmark handles whose model vertex the smooth base still misses by more than
    ``params.release_mm`` moved to the base vertex nearest their target
    (``params.slide_landmarks``; stage-1 suspects are left to :func:`_release`).

    Such a miss is mostly along the skin: the model puts the landmark elsewhere on a nose
    it cannot reach (the ICT int sits 7-8 mm from a real face's), while the smooth base
    passes close to the click itself. Held at the model vertex, ARAP would drag the skin
    sideways by the whole miss and crumple it; held at the nearest vertex, it moves the
    skin only by the surface's own distance from the click, and the final mesh still
    passes through it. A vertex already holding another handle is not taken.

    Returns:
        (handles, names of the moved landmarks).
    """
    if not params.slide_landmarks or not len(handles.vertex_ids):
        return handles, []
    miss = np.linalg.norm(handles.targets - base[handles.vertex_ids], axis=1)
    far = [i for i, (n, lm) in enumerate(zip(handles.names, handles.is_landmark, strict=True))
           if lm and n not in suspects and miss[i] > params.release_mm]
    if not far:
        return handles, []
    skin = np.unique(np.asarray(model.faces, np.int64))
    tree = cKDTree(base[skin])
    ids = handles.vertex_ids.copy()
    taken = set(ids.tolist())
    moved: list[str] = []
    for i in far:
        j = int(skin[tree.query(handles.targets[i])[1]])
        if j in taken:
            continue
        taken.discard(int(ids[i]))
        taken.add(j)
        ids[i] = j
        moved.append(handles.names[i])
    return Correspondences(ids, handles.targets, handles.names, handles.is_landmark), moved


LANDMARK_TOLERANCE_MM = 0.2
"""An accepted landmark ends within max(this, its stated uncertainty) of the mesh
(issue 11)."""


def landmark_tolerances(reconstruction: Reconstruction) -> dict[str, float]:
    """Id -> how close (mm) the mesh must pass to each landmark: max(0.2 mm, its stated
    uncertainty ``extra.landmark_uncertainty_mm``; 0.2 mm where none is stated)."""
    unc = reconstruction.extra.get("landmark_uncertainty_mm") or {}
    out = {}
    for k in reconstruction.landmarks or {}:
        u = unc.get(k) if isinstance(unc, dict) else None
        ok = isinstance(u, (int, float)) and np.isfinite(u)
        out[k] = max(LANDMARK_TOLERANCE_MM, float(u) if ok else 0.0)  # type: ignore[arg-type]
    return out


def surface_distances(V: np.ndarray, F: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(k,) distance (mm) from each point of ``P`` (k, 3) to the mesh (V, F)."""
    if not len(P):
        return np.zeros(0)
    d2 = igl.point_mesh_squared_distance(np.ascontiguousarray(P, np.float64),
                                         np.ascontiguousarray(V, np.float64),
                                         np.ascontiguousarray(F, np.int64))[0]
    return np.sqrt(np.asarray(d2, float))


def _carried(handles: Correspondences, slid: list[str], V: np.ndarray, F: np.ndarray,
             tol: dict[str, float]) -> np.ndarray:
    """(H,) bool: the slid landmark handles the surface (V, F) already passes within
    their tolerance of (the smooth warp carries them; no hard ARAP handle needed)."""
    idx = [i for i, n in enumerate(handles.names) if n in slid and handles.is_landmark[i]]
    out = np.zeros(len(handles.names), bool)
    if idx:
        d = surface_distances(V, F, handles.targets[idx])
        out[idx] = d <= np.array([tol.get(handles.names[i], LANDMARK_TOLERANCE_MM)
                                  for i in idx])
    return out


def _suspect_landmarks(reconstruction: Reconstruction) -> frozenset[str]:
    """Landmark ids whose click stage 1 names as suspect (``extra.suspect_clicks``)."""
    sus = reconstruction.extra.get("suspect_clicks")
    return frozenset(str(s["landmark"]) for s in (sus if isinstance(sus, list) else [])
                     if isinstance(s, dict) and "landmark" in s)


def _verified_landmarks(reconstruction: Reconstruction) -> frozenset[str]:
    """Landmark ids whose position two or more photos agree on: with a stage-1 residual
    in two or more photos (``extra.residuals_px``), neither placed from one photo
    (``extra.landmarks_one_photo``) nor named suspect. Empty without that record (a
    reconstruction from elsewhere: nothing is taken as checked)."""
    res = reconstruction.extra.get("residuals_px")
    if not isinstance(res, dict):
        return frozenset()
    seen: dict[str, int] = {}
    for per_view in res.values():
        for k in per_view if isinstance(per_view, dict) else ():
            seen[str(k)] = seen.get(str(k), 0) + 1
    one = reconstruction.extra.get("landmarks_one_photo")
    placed = frozenset(str(k) for k in one) if isinstance(one, (dict, list)) else frozenset()
    return (frozenset(k for k, n in seen.items() if n >= 2 and k in reconstruction.landmarks)
            - placed - _suspect_landmarks(reconstruction))


def _deform(model: FaceModel, base: np.ndarray, region: np.ndarray, handles: Correspondences,
            params: RefineParams, seconds: dict[str, float],
            adjacency: sp.csr_matrix | None = None
            ) -> tuple[np.ndarray, np.ndarray, NoseDeformer | None, DeformReport | None]:
    """ARAP and smoothing (when enabled and there are handles): (V, region, deformer,
    report); ``seconds`` gets the precompute and solve times. ``adjacency``: the base's
    ``vertex_adjacency`` (edge lengths), when several handle sets deform it."""
    if not ((params.use_arap or params.use_smoothing) and len(handles.vertex_ids)):
        return base.copy(), region, None, None
    t = time.perf_counter()
    deformer = NoseDeformer(base, model.faces, region, handles.vertex_ids, params, adjacency)
    seconds["precompute"] = time.perf_counter() - t
    report = deformer.solve_report(handles.targets, warm_start=False)
    seconds.update(report.seconds)
    return report.V, deformer.region_vertex_ids, deformer, report


def _silhouette_rounds(model: FaceModel, base: np.ndarray, V: np.ndarray,
                       held: Correspondences, landmarks: Mapping[str, np.ndarray],
                       silhouettes: Sequence[Silhouette],
                       params: RefineParams, seconds: dict[str, float],
                       adjacency: sp.csr_matrix
                       ) -> tuple[np.ndarray, np.ndarray, NoseDeformer | None,
                                  DeformReport | None, Correspondences] | None:
    """``params.silhouette_rounds`` rounds: the nose's occluding contour in each photo of
    ``silhouettes`` matched to the photo's silhouette and added as hard handles, solved
    again from the base; the contour matched is the nose's and the profile band's
    (:func:`~naseview.stage3_mesh.profile_band.matched_region`: glabella to upper lip),
    so the deformed region grows over the band where a match holds it
    (:mod:`~naseview.stage3_mesh.silhouette`; ``adjacency`` the base's
    ``vertex_adjacency``). None when no contour vertex matched; else (V, region,
    deformer, report, handles)."""
    t = time.perf_counter()
    F = np.asarray(model.faces, np.int64)
    nose = np.asarray(model.nose_vertices, np.int64)
    movable = matched_region(model, base, landmarks, params)
    movable[held.vertex_ids] = False
    ed = edge_faces(F)
    out = None
    last: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(params.silhouette_rounds):
        ids, tg, names = contour_targets(V, F, silhouettes, movable, held.targets,
                                         params.silhouette_spacing_mm,
                                         params.silhouette_max_mm, ed,
                                         params.silhouette_detrend)
        if not len(ids) or same_matches(ids, tg, last):
            break                # the same handles again: this round would change nothing
        last = (ids, tg)
        allh = Correspondences(np.r_[held.vertex_ids, ids], np.r_[held.targets, tg],
                               list(held.names) + names,
                               np.r_[held.is_landmark, np.zeros(len(ids), bool)])
        region = deform_region(base, model.faces, nose, allh.vertex_ids,
                               params.handle_clearance_mm, adjacency)
        V, region, deformer, report = _deform(model, base, region, allh, params, seconds,
                                              adjacency)
        out = (V, region, deformer, report, allh)
    seconds["silhouette"] = time.perf_counter() - t
    return out


def refine(model: FaceModel, reconstruction: Reconstruction,
           params: RefineParams | None = None,
           silhouettes: Sequence[Silhouette] = ()) -> RefineResult:
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
        silhouettes: the photos' silhouettes for ``params.silhouette_rounds``
            (:func:`~naseview.stage3_mesh.silhouette.photo_silhouettes`).
    Returns:
        :class:`RefineResult`.
    Raises:
        NaseviewError: too few landmarks to fit the model.
    """
    params = params or RefineParams()
    landmarks = dict(reconstruction.landmarks or {})
    sub = sublandmarks(reconstruction)
    t0 = time.perf_counter()
    fit = fit_face_model(model, landmarks, params, *sub,
                         verified=_verified_landmarks(reconstruction), silhouettes=silhouettes)
    t1 = time.perf_counter()
    base, handles, cw = warped_base(model, fit, landmarks, sub, params)
    base = band_warp(model, base, landmarks, silhouettes, params)
    t2 = time.perf_counter()
    suspects = _suspect_landmarks(reconstruction)
    handles, slid = slide_far_landmarks(model, base, handles, params, suspects)
    handles, released, rw = _release(model, base, handles, params, suspects)
    F = np.asarray(model.faces, np.int64)
    tol = landmark_tolerances(reconstruction)
    carried = _carried(handles, slid, base, F, tol) if params.warp_carries_landmarks \
        else np.zeros(len(handles.names), bool)
    held = handles.subset(~carried) if carried.any() else handles
    if not params.keeps_mid_handles(model.n_modes) and silhouettes and params.silhouette_rounds:
        # the profile photos' silhouettes hold the profile instead (fit and warp keep them)
        held = held.subset(np.array([not (n.startswith("mid") and not lm) for n, lm in
                                     zip(held.names, held.is_landmark, strict=True)], bool))
    adj = vertex_adjacency(len(base), F, base)          # one base, several handle sets
    region = deform_region(base, model.faces, model.nose_vertices, held.vertex_ids,
                           params.handle_clearance_mm, adj)
    seconds = {"fit": t1 - t0, "warp": t2 - t1, "correspondences": time.perf_counter() - t2}
    V, region, deformer, report = _deform(model, base, region, held, params, seconds, adj)
    if carried.any():
        # ARAP moved the skin under a carried landmark beyond its tolerance: hold it too
        lost = carried & ~_carried(handles, slid, V, F, tol)
        if lost.any():
            held = handles.subset(~(carried & ~lost))
            region = deform_region(base, model.faces, model.nose_vertices, held.vertex_ids,
                                   params.handle_clearance_mm, adj)
            V, region, deformer, report = _deform(model, base, region, held, params,
                                                  seconds, adj)
    if params.silhouette_rounds and silhouettes and deformer is not None:
        sil = _silhouette_rounds(model, base, V, held, landmarks, silhouettes, params,
                                 seconds, adj)
        if sil is not None:
            V, region, deformer, report, held = sil
    handles = held
    nose = np.asarray(model.nose_vertices, np.int64)
    in_nose = np.zeros(len(V), bool)
    in_nose[nose] = True
    return RefineResult(V=V, F=F, nose_vertex_ids=nose, nose_faces=F[in_nose[F].all(1)],
                        region_vertex_ids=region, base_V=base,
                        coefficients=fit.coefficients, fit=fit, handles=handles,
                        released=released, deformer=deformer, report=report,
                        warnings=list(fit.warnings) + cw + rw
                        + (report.warnings if report is not None else []),
                        seconds=seconds, model_name=model.name, credit=model.credit,
                        model=model)
