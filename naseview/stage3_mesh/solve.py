"""Stage 3: base face from the morphable model, ARAP deformation and cotangent smoothing.

The paper's section 3.4 (eq. 18-21), each step its own function:

1. :func:`fit_face_model` - the base face ``v_base, f_base = 3DMM(I)`` (eq. 18): a
   similarity transform (Umeyama) and identity coefficients with a Gaussian prior fitted to
   the 3D landmarks (and, when present, the sub-landmarks on the boundary curves).
2. :func:`correspondences` - each ad-landmark to a vertex of the base mesh: the 21 landmarks
   to ``model.landmark_vertices``, each sub-landmark to the vertex of the matching mesh
   curve (``model.curve_vertices``) at the same arc-length fraction.
3. :func:`smooth_warp` (naseview's addition) - the base bent smoothly towards the
   ad-landmarks (soft constraints, bi-Laplacian energy); ad-landmarks it cannot reconcile
   with their neighbours are not made hard constraints. Without it, a base face that is
   not close already (the generic model) crumples under ARAP; see the ablation
   (:data:`ABLATION_ROWS`, ``benchmarks/bench_stage3.py``).
4. :class:`NoseDeformer` - ARAP (eq. 19-20, libigl) on the nose region with a fixed margin
   ring, the ad-landmarks as hard constraints, then explicit cotangent Laplacian smoothing
   (eq. 21) with the same constraints. Precomputation is kept while only the handle
   positions change, so the app re-solves in a few tens of milliseconds.
5. :func:`refine` - all of the above for a :class:`~naseview.reconstruction.Reconstruction`.

:func:`surface_error` and :func:`ablation` measure the result against a ground-truth mesh
(SPEC §6 "Surface").

Everything is in the SPEC frame (mm, origin g, +x subject's left, +y up, +z anterior).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> model = load_face_model("ict")                                   # doctest: +SKIP
>>> res = refine(model, reconstruction)                              # doctest: +SKIP
>>> V = res.deformer.solve(res.handles.targets + [0, 0, 1.0])        # doctest: +SKIP
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.linalg import blas

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.geometry.mesh import face_normals, umeyama
from naseview.landmarks import CURVE_LANDMARKS, LANDMARK_IDS

# ---------------------------------------------------------------------------------------
# Parameters and results
# ---------------------------------------------------------------------------------------


@dataclass
class RefineParams:
    """Every tunable of stage 3. Defaults follow the paper where it gives a value.

    Base fit (:func:`fit_face_model`):
        n_modes: identity modes used (``None``: all the model has).
        fit_sigma_mm: expected landmark error (mm, SD); the prior weight on the
            coefficients is ``fit_sigma_mm**2`` (MAP with coefficients ~ N(0, 1)).
        fit_sub_sigma_mm: the same for sub-landmarks (their position along the curve is
            less certain than a landmark's).
        fit_iterations: alternations of similarity and coefficients.
        fit_scale: let the similarity scale (else rigid; stage 1 is already in mm).
        coeff_limit_sd: coefficients beyond this many SD are clamped, with a warning.
        fit_warn_mm: a landmark further than this (and than 3x the median) from the fitted
            face gives a "check this click" warning; an RMS misfit above half of it, a
            "the model fits poorly" warning.

    Correspondences and region (:func:`correspondences`, :func:`deform_region`):
        use_sublandmarks: use stage 2's sub-landmarks as handles (and in the fit).
        sub_landmark_curves: the curves whose sub-landmarks are used (``None``: all nine,
            the paper's 55). Default: the mid- and ala-curves only. Stage 2's other curves
            are approximations by construction (side-curve: a circle through int and mf;
            sill: a planar outline; bottom and C: silhouettes lifted between landmarks)
            whose sub-landmarks lie 0.6-1.7 mm (mean; up to 6 mm) off the true surface on
            synthetic cases, and used as hard constraints they made the ICT nose worse
            (mean surface error 0.30 mm with mid+ala, 0.44 with bottom and C added, 0.76
            with all; ``benchmarks/bench_stage3.py --synth``).
        handle_landmarks: the landmark ids used as handles (default: all 21).
        min_handle_spacing_mm: a sub-landmark whose vertex lies closer than this to an
            earlier handle (landmarks first) is not used as a handle.
        handle_clearance_mm: the deformed region is the model's nose region grown so that
            every handle lies at least this far (along mesh edges) from the fixed ring.
        margin_mm: width of the ring of vertices around the region pinned to the base, so
            the seam to the unchanged face is continuous (at least one edge ring).

    Smooth warp of the base (naseview's addition; :func:`smooth_warp`):
        use_warp: bend the fitted face towards the ad-landmarks before ARAP, with soft
            constraints (weights 1 / fit_sigma_mm^2 for landmarks, 1 / fit_sub_sigma_mm^2 for
            sub-landmarks) and a bi-Laplacian smoothness term. It carries the large,
            smooth part of the correction that a low-dimensional model (the generic face)
            cannot; ARAP then only closes the small remainder.
        warp_bending_mm2: weight of the bending term (mm^2): larger is smoother/stiffer.
        warp_radius_mm: the warp acts within this distance (along edges) of the handles.
        release_mm: a handle still further than this from its target after the warp
            contradicts its neighbours on this face model (e.g. a landmark convention the
            model does not share); it is not made a hard ARAP constraint (warning), which
            would crumple the mesh around it. ``inf`` keeps every handle (the paper).

    ARAP (paper: Open3D ARAP, 50 iterations):
        use_arap: run ARAP (``False``: only the base fit, for the ablation).
        arap_iterations: maximum ARAP iterations (paper 50).
        arap_tol_mm: stop early when one iteration moves no vertex more than this (mm).
        arap_anderson: Anderson acceleration memory of the local-global iterations
            (Peng et al., SIGGRAPH 2018; 0: plain iterations as libigl and the paper).
        arap_warn_mm: still moving more than this per iteration at the end -> warning.
        max_handle_displacement_mm: a handle asked to move further than this from its base
            position is pulled back to this distance, with a warning (a wrong click must
            not crumple the nose).

    Smoothing (paper: cotangent Laplacian smoothing, 10 iterations, step 0.1, tol 1e-5):
        use_smoothing: run the smoothing.
        smooth_iterations, smooth_step, smooth_tol: ``v <- v + step * D^-1 L v`` on the free
            vertices (D the diagonal of the cotangent Laplacian L, so the step is unitless
            and the iteration is stable), handles and ring fixed; stops when no vertex moves
            more than ``smooth_tol`` mm.
        smooth_displacement: smooth the displacement from the base (default) instead of
            the positions as the paper does: smoothing positions also flattens the base's
            own shape (tip, alar creases) and measurably raises the surface error (see
            ``benchmarks/bench_stage3.py``); smoothing the displacement only evens out
            what ARAP changed and leaves an unedited nose exactly as it was.
    """

    n_modes: int | None = None
    fit_sigma_mm: float = 1.0
    fit_sub_sigma_mm: float = 2.0
    fit_iterations: int = 6
    fit_scale: bool = True
    coeff_limit_sd: float = 3.5
    fit_warn_mm: float = 5.0
    use_sublandmarks: bool = True
    sub_landmark_curves: tuple[str, ...] | None = ("mid", "ala_l", "ala_r")
    handle_landmarks: tuple[str, ...] = LANDMARK_IDS
    min_handle_spacing_mm: float = 2.0
    handle_clearance_mm: float = 6.0
    margin_mm: float = 3.0
    use_warp: bool = True
    warp_bending_mm2: float = 0.5
    warp_radius_mm: float = 25.0
    release_mm: float = 1.0
    use_arap: bool = True
    arap_iterations: int = 50
    arap_tol_mm: float = 1e-3
    arap_anderson: int = 5
    arap_warn_mm: float = 1e-2
    max_handle_displacement_mm: float = 10.0
    use_smoothing: bool = True
    smooth_iterations: int = 10
    smooth_step: float = 0.1
    smooth_tol: float = 1e-5
    smooth_displacement: bool = True


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
class Correspondences:
    """Handles: ad-landmark -> base-mesh vertex.

    Attributes:
        vertex_ids: (H,) int64 distinct vertex ids of the base mesh.
        targets: (H, 3) where those vertices must go, mm.
        names: H labels: a landmark id, or the sub-landmark's tag id (``"mid.03"``; else
            ``"<curve>@<fraction>"``).
        is_landmark: (H,) bool.
    """

    vertex_ids: np.ndarray
    targets: np.ndarray
    names: list[str]
    is_landmark: np.ndarray


@dataclass
class DeformReport:
    """One :meth:`NoseDeformer.solve_report` call.

    Attributes:
        V: (V, 3) deformed full face, mm.
        arap_iterations: iterations run.
        arap_last_change_mm: max vertex motion in the last ARAP iteration.
        smooth_iterations: smoothing iterations run.
        folded_faces: (k,) ids (into the full F) of region triangles whose normal flipped
            against the base.
        clamped_handles: indices (into the handle list) pulled back by the displacement cap.
        seconds: {"arap": s, "smooth": s}.
        warnings: one line each.
    """

    V: np.ndarray
    arap_iterations: int
    arap_last_change_mm: float
    smooth_iterations: int
    folded_faces: np.ndarray
    clamped_handles: np.ndarray
    seconds: dict[str, float]
    warnings: list[str]


@dataclass
class RefineResult:
    """Stage 3 output.

    Attributes:
        V: (V, 3) refined face, mm, SPEC frame.
        F: (F, 3) int64 triangles (the model's).
        nose_vertex_ids: (N,) the model's nose region (what ``nose.ply`` holds).
        nose_faces: (M, 3) triangles of ``F`` with all corners in the nose region.
        region_vertex_ids: (R,) vertices ARAP may move (nose region grown around handles);
            the rest of ``V`` equals ``base_V``.
        base_V: (V, 3) the base face ARAP starts from: the morphable-model fit
            (``fit.vertices``) after the smooth warp.
        coefficients: (K,) identity coefficients of the fit.
        fit: the :class:`BaseFit`.
        handles: the :class:`Correspondences` used as hard constraints (vertex ids,
            targets, names).
        released: names of the ad-landmarks left out of the hard constraints
            (``params.release_mm``).
        deformer: the :class:`NoseDeformer`, ready for re-solves with moved handles.
        report: the :class:`DeformReport` of the solve (``None`` without ARAP).
        warnings: one line each (fit, correspondences, deformation).
        seconds: {"fit", "warp", "correspondences", "precompute", "arap", "smooth"} -> s.
        model_name: the face model's name (``"ict"``, ``"generic"``...).
        credit: the face model's attribution line (show it with the mesh).
        model: the :class:`~naseview.facemodel.FaceModel` used.
    """

    V: np.ndarray
    F: np.ndarray
    nose_vertex_ids: np.ndarray
    nose_faces: np.ndarray
    region_vertex_ids: np.ndarray
    base_V: np.ndarray
    coefficients: np.ndarray
    fit: BaseFit
    handles: Correspondences
    released: list[str]
    deformer: NoseDeformer | None
    report: DeformReport | None
    warnings: list[str]
    seconds: dict[str, float]
    model_name: str = ""
    credit: str = ""
    model: FaceModel | None = None


# ---------------------------------------------------------------------------------------
# Small geometry helpers
# ---------------------------------------------------------------------------------------


def vertex_adjacency(F: np.ndarray, n_vertices: int, V: np.ndarray | None = None
                     ) -> sp.csr_matrix:
    """Symmetric vertex adjacency (n, n); entries are edge lengths when ``V`` is given."""
    F = np.asarray(F, np.int64)
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
    count = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n_vertices, n_vertices))
    if V is None:
        count.data[:] = 1.0
        return count
    w = np.maximum(np.linalg.norm(V[i] - V[j], axis=1), 1e-9)
    A = sp.csr_matrix((w, (i, j)), shape=(n_vertices, n_vertices))
    A.data /= count.data  # same sparsity pattern and order: duplicates summed in both
    return A


def grow_by_distance(V: np.ndarray, F: np.ndarray, seeds: np.ndarray, radius_mm: float,
                     adjacency: sp.csr_matrix | None = None) -> np.ndarray:
    """Vertices within ``radius_mm`` of ``seeds`` along mesh edges (seeds included), sorted.

    At least the one-ring of the seeds is returned when ``radius_mm`` > 0.
    """
    from scipy.sparse.csgraph import dijkstra

    seeds = np.unique(np.asarray(seeds, np.int64))
    if radius_mm <= 0 or len(seeds) == 0:
        return seeds
    A = adjacency if adjacency is not None else vertex_adjacency(F, len(V), V)
    # one super-source: distances from the seed set
    d = dijkstra(A, directed=False, indices=seeds, limit=radius_mm, min_only=True)
    grown = np.flatnonzero(np.isfinite(d))
    ring1 = A[seeds].indices
    return np.unique(np.concatenate([grown, ring1, seeds]))


def submesh(V: np.ndarray, F: np.ndarray, vertex_ids: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles of ``F`` with all corners in ``vertex_ids``, reindexed.

    Returns:
        ``(V_sub, F_sub, ids)``: vertices used by those triangles, their triangles, and the
        original ids of the ``V_sub`` rows.
    """
    keep = np.zeros(len(V), bool)
    keep[np.asarray(vertex_ids, np.int64)] = True
    Fk = np.asarray(F, np.int64)[keep[F].all(1)]
    ids = np.unique(Fk)
    loc = np.full(len(V), -1, np.int64)
    loc[ids] = np.arange(len(ids))
    return V[ids], loc[Fk], ids


# ---------------------------------------------------------------------------------------
# Curve correspondences
# ---------------------------------------------------------------------------------------

def curve_path_segment(path: np.ndarray, model: FaceModel, curve: str,
                       segment: tuple[str, str] | None, reverse: bool = False) -> np.ndarray:
    """The part of a mesh curve that a fraction is measured along, in increasing order.

    Args:
        path: (L,) vertex ids of ``model.curve_vertices[curve]``.
        model: the face model (its ``landmark_vertices``).
        curve: SPEC §5 curve name; ``sill_*`` are closed loops.
        segment: ``(a, b)`` landmark ids: the part of the path from a's vertex to b's;
            ``(a, a)`` on a closed curve: the whole loop starting and ending at a's vertex;
            ``None`` (or landmarks not on the path): the whole curve, oriented in the SPEC
            order of its landmarks (:data:`~naseview.landmarks.CURVE_LANDMARKS`); a loop
            then starts at its landmark (al'').
        reverse: run a closed loop the other way round.
    Returns:
        (L',) vertex ids; a loop ends with its first vertex repeated.
    """
    path = np.asarray(path, np.int64)
    closed = curve.startswith("sill")
    lv = model.landmark_vertices

    def where(lm: str) -> int | None:
        hit = np.flatnonzero(path == lv.get(lm, -1))
        return int(hit[0]) if len(hit) else None

    if closed:
        start = None
        if segment is not None:
            start = where(segment[0])
        if start is None:
            for lm in CURVE_LANDMARKS.get(curve, ()):
                start = where(lm)
                if start is not None:
                    break
        loop = np.roll(path, -(start or 0))
        if reverse:
            loop = np.r_[loop[:1], loop[1:][::-1]]
        return np.r_[loop, loop[:1]]
    if segment is not None and segment[0] != segment[1]:
        a, b = where(segment[0]), where(segment[1])
        if a is not None and b is not None:
            return path[a:b + 1] if a <= b else path[b:a + 1][::-1]
    order = [i for i in (where(lm) for lm in CURVE_LANDMARKS.get(curve, ())) if i is not None]
    if len(order) >= 2 and order[0] > order[-1]:
        return path[::-1]
    return path


def arclength_point(P: np.ndarray, t: float) -> tuple[int, int, float]:
    """Where fraction ``t`` of the arc length of the polyline ``P`` (L, 3) falls.

    Returns:
        ``(i, j, a)``: the point is ``(1 - a) * P[i] + a * P[j]`` with ``j = i + 1``
        (``i == j`` for a single point).
    """
    if len(P) == 1:
        return 0, 0, 0.0
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    s = float(np.clip(t, 0.0, 1.0)) * cum[-1]
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(P) - 2))
    a = 0.0 if seg[i] <= 0 else float(np.clip((s - cum[i]) / seg[i], 0.0, 1.0))
    return i, i + 1, a


@dataclass
class _SubRow:
    """A sub-landmark's place on its mesh curve: fraction ``frac`` along
    :func:`curve_path_segment` ``(curve, segment, reverse)``."""

    name: str
    curve: str
    frac: float
    segment: tuple[str, str] | None
    target: np.ndarray
    reverse: bool = False


def _sub_rows(model: FaceModel, ad_landmarks: np.ndarray | None,
              tags: Sequence[Mapping[str, Any]] | None,
              curves: Sequence[str] | None = None) -> tuple[list[_SubRow], list[str]]:
    """Stage 2's sub-landmarks as rows (the 21 landmarks among the ad-landmarks skipped).

    Tags (:mod:`naseview.stage2_curves.sublandmarks`): ``{"id", "curve", "t", "between", "s"}``
    with ``t`` the fraction along the whole curve, ``between`` the segment's two landmarks
    and ``s`` the fraction inside it. The segment form is used when present. Only curves
    in ``curves`` are used (``None``: all).
    """
    rows: list[_SubRow] = []
    warnings: list[str] = []
    if ad_landmarks is None or tags is None:
        return rows, warnings
    ad = np.asarray(ad_landmarks, np.float64).reshape(-1, 3)
    if len(tags) != len(ad):
        warnings.append(f"reconstruction: {len(ad)} ad_landmarks but {len(tags)} "
                        "ad_landmark_tags; sub-landmarks not used")
        return rows, warnings
    missing: set[str] = set()
    for p, tag in zip(ad, tags, strict=True):
        if not isinstance(tag, Mapping) or not np.isfinite(p).all():
            continue
        if tag.get("id") in LANDMARK_IDS:
            continue  # one of the 21: taken from reconstruction.landmarks
        curve = tag.get("curve")
        if curves is not None and curve not in curves:
            continue
        seg = tag.get("between")
        segment = (str(seg[0]), str(seg[1])) if (
            isinstance(seg, (list, tuple)) and len(seg) == 2 and seg[0] and seg[1]) else None
        frac = tag.get("s") if segment is not None and tag.get("s") is not None else tag.get("t")
        if curve is None or frac is None:
            continue
        if curve not in model.curve_vertices or len(model.curve_vertices[curve]) < 2:
            missing.add(str(curve))
            continue
        name = str(tag.get("id") or f"{curve}@{float(frac):.3f}")
        rows.append(_SubRow(name, str(curve), float(frac), segment, p))
    if missing:
        warnings.append(f"face model '{model.name}' has no mesh curve {sorted(missing)}; "
                        "their sub-landmarks are not used")
    return rows, warnings


def _sub_positions(model: FaceModel, V: np.ndarray, rows: Sequence[_SubRow]
                   ) -> list[tuple[int, int, float]]:
    """For each row, ``(i, j, a)``: its point on mesh ``V`` is (1-a) V[i] + a V[j]."""
    out: list[tuple[int, int, float]] = [(0, 0, 0.0)] * len(rows)
    groups: dict[tuple[Any, ...], list[int]] = {}
    for k, r in enumerate(rows):
        groups.setdefault((r.curve, r.segment, r.reverse), []).append(k)
    for (curve, segment, reverse), ks in groups.items():
        path = curve_path_segment(model.curve_vertices[curve], model, curve, segment, reverse)
        if len(path) == 1:
            for k in ks:
                out[k] = (int(path[0]), int(path[0]), 0.0)
            continue
        seg = np.linalg.norm(np.diff(V[path], axis=0), axis=1)
        cum = np.r_[0.0, np.cumsum(seg)]
        s = np.clip([rows[k].frac for k in ks], 0.0, 1.0) * cum[-1]
        i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(seg[i] > 0, (s - cum[i]) / seg[i], 0.0)
        a = np.clip(a, 0.0, 1.0)
        for k, ii, aa in zip(ks, i, a, strict=True):
            out[k] = (int(path[ii]), int(path[ii + 1]), float(aa))
    return out


def _orient_loops(model: FaceModel, V: np.ndarray, rows: Sequence[_SubRow]) -> None:
    """Choose, per closed curve, the direction round the mesh loop that puts the
    sub-landmarks nearest their targets (``V`` in the targets' frame). In place."""
    for curve in sorted({r.curve for r in rows if r.curve.startswith("sill")}):
        group = [r for r in rows if r.curve == curve]
        cost = []
        for rev in (False, True):
            for r in group:
                r.reverse = rev
            pts = [(1 - a) * V[i] + a * V[j] for i, j, a in _sub_positions(model, V, group)]
            cost.append(sum(float(np.sum((q - r.target) ** 2))
                            for q, r in zip(pts, group, strict=True)))
        for r in group:
            r.reverse = cost[1] < cost[0]


def correspondences(model: FaceModel, V_base: np.ndarray,
                    landmarks: Mapping[str, np.ndarray],
                    ad_landmarks: np.ndarray | None = None,
                    ad_landmark_tags: Sequence[Mapping[str, Any]] | None = None,
                    params: RefineParams | None = None) -> tuple[Correspondences, list[str]]:
    """Each ad-landmark to a vertex of the base mesh (the ARAP handles).

    The 21 landmarks go to ``model.landmark_vertices``. A sub-landmark (stage 2 tag
    ``{"curve", "t", "between": [a, b], "s"}``) goes to the vertex of
    ``model.curve_vertices[curve]`` nearest to the same arc-length fraction ``s`` of the
    path between a's and b's vertices on ``V_base`` (without ``between``: fraction ``t`` of
    the whole curve). Its target is the sub-landmark plus the vertex's offset from the
    exact curve point at that fraction, so the vertex moves as that point does (no slip
    along the curve). Several ad-landmarks on one vertex: a landmark wins, sub-landmarks
    are averaged.

    Args:
        model: the face model (its annotations).
        V_base: (V, 3) fitted base face, mm.
        landmarks: id -> (3,) the 21 landmarks (any subset).
        ad_landmarks, ad_landmark_tags: stage 2's (M, 3) ad-landmarks and their M tags.
        params: :class:`RefineParams` (``handle_landmarks``, ``use_sublandmarks``).
    Returns:
        ``(Correspondences, warnings)``.
    """
    params = params or RefineParams()
    ids: list[int] = []
    targets: list[np.ndarray] = []
    names: list[str] = []
    is_lm: list[bool] = []
    taken: dict[int, int] = {}
    for lm in params.handle_landmarks:
        p = landmarks.get(lm)
        v = model.landmark_vertices.get(lm)
        if p is None or v is None or not np.isfinite(np.asarray(p, float)).all():
            continue
        if int(v) in taken:
            continue
        taken[int(v)] = len(ids)
        ids.append(int(v))
        targets.append(np.asarray(p, np.float64).reshape(3))
        names.append(lm)
        is_lm.append(True)
    warnings: list[str] = []
    if params.use_sublandmarks:
        rows, warnings = _sub_rows(model, ad_landmarks, ad_landmark_tags,
                                   params.sub_landmark_curves)
        _orient_loops(model, V_base, rows)
        sums: dict[int, list[Any]] = {}
        for r, (i, j, a) in zip(rows, _sub_positions(model, V_base, rows), strict=True):
            v = i if a < 0.5 else j
            if v in taken and is_lm[taken[v]]:
                continue
            if v not in sums:
                sums[v] = [np.zeros(3), 0, r.name]
            # the vertex moves as the curve point at the fraction does (no tangential slip)
            on_curve = (1 - a) * V_base[i] + a * V_base[j]
            sums[v][0] = sums[v][0] + r.target + (V_base[v] - on_curve)
            sums[v][1] += 1
        for v, (s, k, name) in sums.items():
            # sub-landmarks right beside another handle only add conflicting noise (and can
            # fold the triangles between the two): keep the first, a landmark first of all
            near = np.linalg.norm(V_base[ids] - V_base[v], axis=1) if ids else np.zeros(0)
            if len(near) and near.min() < params.min_handle_spacing_mm:
                continue
            ids.append(v)
            targets.append(s / k)
            names.append(name)
            is_lm.append(False)
    return (Correspondences(np.asarray(ids, np.int64),
                            np.asarray(targets, np.float64).reshape(-1, 3), names,
                            np.asarray(is_lm, bool)), warnings)


# ---------------------------------------------------------------------------------------
# Base fit
# ---------------------------------------------------------------------------------------


def fit_face_model(model: FaceModel, landmarks: Mapping[str, np.ndarray],
                   params: RefineParams | None = None,
                   ad_landmarks: np.ndarray | None = None,
                   ad_landmark_tags: Sequence[Mapping[str, Any]] | None = None) -> BaseFit:
    """Fit the morphable model to 3D landmarks: the base face of eq. 18.

    Minimises, alternating a few times between the two unknowns,

        sum_i |s R (mean_i + B_i w) + t - y_i|^2 / sigma_i^2 + |w|^2

    over the similarity (s, R, t) (Umeyama) and the identity coefficients w (regularised
    linear least squares; the prior ``|w|^2`` is the Gaussian N(0, I) of the model). The
    rows are the landmark vertices and, when sub-landmarks are given (and
    ``params.use_sublandmarks``), the points of the mesh curves at the same arc-length
    fraction (interpolated between two path vertices, re-measured every alternation).
    Coefficients beyond ``params.coeff_limit_sd`` are clamped with a warning.

    Args:
        model: the face model.
        landmarks: id -> (3,) in the SPEC frame, mm; at least 4 of the model's landmarks.
        params: :class:`RefineParams` (``n_modes``, ``fit_sigma_mm``, ...).
        ad_landmarks, ad_landmark_tags: optional stage 2 sub-landmarks (see
            :func:`correspondences`).
    Returns:
        :class:`BaseFit` with the fitted face in the SPEC frame.
    Raises:
        NaseviewError: fewer than 4 usable landmarks.
    """
    params = params or RefineParams()
    K = model.n_modes if params.n_modes is None else max(0, min(params.n_modes, model.n_modes))
    lm_ids = [k for k in LANDMARK_IDS if k in landmarks and k in model.landmark_vertices
              and np.isfinite(np.asarray(landmarks[k], float)).all()]
    if len(lm_ids) < 4:
        raise NaseviewError(
            f"stage 3: only {len(lm_ids)} landmarks ({', '.join(lm_ids) or 'none'}) to fit the "
            "face model; mark at least 4 (e.g. g, n, prn, al_l, al_r) in two or more views")
    Y_lm = np.array([np.asarray(landmarks[k], np.float64).reshape(3) for k in lm_ids])
    v_lm = np.array([model.landmark_vertices[k] for k in lm_ids], np.int64)
    rows, _ = (_sub_rows(model, ad_landmarks, ad_landmark_tags, params.sub_landmark_curves)
               if params.use_sublandmarks else ([], []))
    Y = np.concatenate([Y_lm, np.array([r.target for r in rows]).reshape(-1, 3)])
    sig = np.r_[np.full(len(lm_ids), params.fit_sigma_mm),
                np.full(len(rows), params.fit_sub_sigma_mm)]
    wts = 1.0 / np.maximum(sig, 1e-6) ** 2
    basis = model.basis[:K]
    mean = model.mean
    w = np.zeros(K)
    s, R, t = 1.0, np.eye(3), np.zeros(3)
    # the vertices the sub-landmark rows may use: every curve path
    sub_paths = sorted({r.curve for r in rows})
    path_ids = (np.unique(np.concatenate([model.curve_vertices[c] for c in sub_paths]))
                if sub_paths else np.zeros(0, np.int64))
    need = np.unique(np.concatenate([v_lm, path_ids]))
    Vcur = np.zeros_like(mean)
    for it in range(max(1, params.fit_iterations) + (1 if rows else 0)):
        # current model-frame shape at the needed vertices
        Vcur[need] = mean[need] + np.tensordot(w, basis[:, need], axes=1) if K else mean[need]
        if it == 1 and rows:
            # the similarity of the landmarks-only first pass decides the loops' direction
            Vs = Vcur.copy()
            Vs[need] = s * Vcur[need] @ R.T + t
            _orient_loops(model, Vs, rows)
        interp = _sub_positions(model, Vcur, rows) if it > 0 else []
        n_sub = len(interp)
        Ii = np.r_[v_lm, np.array([q[0] for q in interp], np.int64)]
        Jj = np.r_[v_lm, np.array([q[1] for q in interp], np.int64)]
        Aa = np.r_[np.zeros(len(v_lm)), np.array([q[2] for q in interp])]
        Yi, wi = Y[:len(v_lm) + n_sub], wts[:len(v_lm) + n_sub]
        X = (1 - Aa)[:, None] * Vcur[Ii] + Aa[:, None] * Vcur[Jj]
        s, R, t = umeyama(X, Yi, params.fit_scale, wi)
        if K == 0:
            continue
        # targets in the model frame; solve the prior-regularised linear least squares
        Ym = ((Yi - t) @ R) / s
        Bi = (1 - Aa)[None, :, None] * basis[:, Ii] + Aa[None, :, None] * basis[:, Jj]
        A = Bi.reshape(K, -1).T                                      # (3n, K)
        r = (Ym - ((1 - Aa)[:, None] * mean[Ii] + Aa[:, None] * mean[Jj])).ravel()
        ww = np.repeat(wi * s * s, 3)                                 # sigma in model units
        # normal equations without threaded BLAS (slow for these sizes on a busy machine)
        H = np.einsum("ik,il->kl", A, A * ww[:, None]) + np.eye(K)
        w = scipy.linalg.solve(H, np.einsum("ik,i->k", A, ww * r), assume_a="pos")
    warnings: list[str] = []
    if K and np.abs(w).max() > params.coeff_limit_sd:
        bad = np.flatnonzero(np.abs(w) > params.coeff_limit_sd)
        names = [model.mode_names[i] if i < len(model.mode_names) else f"mode {i}"
                 for i in bad[:3]]
        warnings.append(
            f"stage 3: the landmarks ask the face model for {len(bad)} coefficient(s) beyond "
            f"{params.coeff_limit_sd:g} SD ({', '.join(names)}); clamped - check the clicks "
            "and the calliper distance (scale_mm)")
        w = np.clip(w, -params.coeff_limit_sd, params.coeff_limit_sd)
    Vm = model.mean.copy()
    if K:
        Vm += blas.dgemv(1.0, basis.reshape(K, -1).T, w).reshape(-1, 3)  # no copy: F-order
    V = s * Vm @ R.T + t
    residuals = {k: float(np.linalg.norm(V[v] - y)) for k, v, y in zip(lm_ids, v_lm, Y_lm,
                                                                        strict=True)}
    res = np.array(list(residuals.values()))
    rms = float(np.sqrt(np.mean(res ** 2)))
    if rms > 0.5 * params.fit_warn_mm:
        warnings.append(
            f"stage 3: the '{model.name}' face model fits these landmarks only to {rms:.1f} mm "
            "RMS; the warp and ARAP carry the rest"
            + ("" if model.name == "ict" else
               " (a closer base: install the ICT model with `naseview model fetch`)"))
    # a click far off while the others fit: that landmark, not the model, is suspect
    far = [k for k, d in residuals.items()
           if d > max(params.fit_warn_mm, 3.0 * float(np.median(res)))]
    if far:
        warnings.append(
            "stage 3: landmark(s) " + ", ".join(f"{k} ({residuals[k]:.1f} mm)" for k in far)
            + " far from the face model fit while the others fit; check these clicks")
    if params.fit_scale and abs(math.log(s)) > math.log(1.25):
        warnings.append(f"stage 3: the face model had to be scaled by {s:.2f} to fit the "
                        "landmarks; check the calliper distance (scale_mm)")
    return BaseFit(V, w, float(s), R, t, residuals, warnings)


# ---------------------------------------------------------------------------------------
# ARAP + smoothing on the nose region
# ---------------------------------------------------------------------------------------


class NoseDeformer:
    """ARAP deformation + cotangent Laplacian smoothing of a region with hard handles.

    Built once per (mesh, region, handle set); :meth:`solve` only takes new handle
    positions, reusing the ARAP factorisation and the smoothing operator, and starts ARAP
    from the previous solution (warm start), so an interactive drag re-solves fast.

    The submesh is the region plus a ring of ``params.margin_mm`` (at least one edge ring)
    around it, pinned to ``V_base``: vertices outside the region never move and the seam
    stays continuous.

    Args:
        V_base: (V, 3) base face, mm (the rest shape of ARAP).
        F: (F, 3) int triangles.
        region_vertex_ids: (R,) vertices that may move (handles are added if missing).
        handle_vertex_ids: (H,) distinct vertex ids constrained by :meth:`solve`.
        params: :class:`RefineParams` (ARAP and smoothing fields).
    """

    def __init__(self, V_base: np.ndarray, F: np.ndarray, region_vertex_ids: np.ndarray,
                 handle_vertex_ids: np.ndarray, params: RefineParams | None = None) -> None:
        import igl

        self.params = params or RefineParams()
        self.V_base = np.ascontiguousarray(V_base, np.float64)
        self.F = np.ascontiguousarray(F, np.int64)
        n = len(self.V_base)
        self.handle_vertex_ids = np.asarray(handle_vertex_ids, np.int64).ravel()
        if len(np.unique(self.handle_vertex_ids)) != len(self.handle_vertex_ids):
            raise ValueError("handle_vertex_ids must be distinct")
        region = np.unique(np.r_[np.asarray(region_vertex_ids, np.int64).ravel(),
                                 self.handle_vertex_ids])
        adj = vertex_adjacency(self.F, n, self.V_base)
        ring = np.setdiff1d(grow_by_distance(self.V_base, self.F, region, self.params.margin_mm,
                                             adj), region)
        self.region_vertex_ids = region
        self.ring_vertex_ids = ring
        _, Fs, ids = submesh(self.V_base, self.F, np.r_[region, ring])
        self.sub_ids = ids
        loc = np.full(n, -1, np.int64)
        loc[ids] = np.arange(len(ids))
        in_region = np.zeros(n, bool)
        in_region[region] = True
        self.sub_F = Fs
        self.face_ids = np.flatnonzero(in_region[self.F].any(1))   # triangles that can move
        # region vertices not in any submesh triangle cannot move (isolated): pin them
        free_region = region[loc[region] >= 0]
        self._h_loc = loc[self.handle_vertex_ids]
        if (self._h_loc < 0).any():
            raise ValueError("a handle vertex belongs to no triangle of the region")
        pinned = np.setdiff1d(ids, free_region)                    # ring (+ stray) vertices
        self._pin_loc = loc[pinned]
        self._pin_pos = self.V_base[pinned]
        self._b = np.r_[self._h_loc, self._pin_loc].astype(np.int32)
        self._V_sub = np.ascontiguousarray(self.V_base[ids])
        self.data = igl.ARAPData()
        self.data.max_iter = 1
        igl.arap_precomputation(self._V_sub, Fs, 3, self._b, self.data)
        # smoothing operator on the free vertices: D^-1 L with clamped cotangent weights
        L = igl.cotmatrix(self._V_sub, Fs).tocsr()
        L.setdiag(0.0)
        L.data = np.maximum(L.data, 0.0)
        L.eliminate_zeros()
        deg = np.asarray(L.sum(axis=1)).ravel()
        fixed = np.zeros(len(ids), bool)
        fixed[self._b] = True
        self._free = np.flatnonzero(~fixed & (deg > 0))
        Dinv = sp.diags(1.0 / np.maximum(deg, 1e-12))
        self._S = (Dinv @ L).tocsr()[self._free]                  # (free, sub) averaging
        self._U = self._V_sub.copy()                               # warm start
        self._base_normals = face_normals(self.V_base, self.F[self.face_ids])

    @property
    def n_handles(self) -> int:
        return len(self.handle_vertex_ids)

    def base_handle_positions(self) -> np.ndarray:
        """(H, 3) the handles' positions on the base mesh."""
        return self.V_base[self.handle_vertex_ids].copy()

    def reset(self) -> None:
        """Forget the warm start (the next solve starts from the base)."""
        self._U = self._V_sub.copy()

    def _arap(self, bc: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, int, float]:
        """ARAP local-global iterations from ``U``, Anderson-accelerated when
        ``params.arap_anderson`` > 0. Returns (U, iterations, last change mm)."""
        import igl

        p = self.params
        self.data.max_iter = 1
        m = max(0, int(p.arap_anderson))
        x = U.ravel().copy()
        dF: list[np.ndarray] = []
        dG: list[np.ndarray] = []
        f_prev = g_prev = None
        res_prev = float("inf")
        g = x
        change, it = float("inf"), 0
        for it in range(1, p.arap_iterations + 1):  # noqa: B007
            g = igl.arap_solve(bc, self.data, x.reshape(-1, 3)).ravel()
            f = g - x
            change = float(np.abs(f).max())
            if change <= p.arap_tol_mm:
                break
            if m and f_prev is not None and change < 4.0 * res_prev:
                dF.append(f - f_prev)
                dG.append(g - g_prev)
                if len(dF) > m:
                    dF.pop(0)
                    dG.pop(0)
                A = np.stack(dF, axis=1)
                AtA = A.T @ A
                gamma = np.linalg.solve(AtA + 1e-10 * np.trace(AtA) * np.eye(len(dF)) +
                                        1e-30 * np.eye(len(dF)), A.T @ f)
                x = g - np.stack(dG, axis=1) @ gamma
            else:  # plain step (and a restart of the acceleration after a bad one)
                dF.clear()
                dG.clear()
                x = g
            f_prev, g_prev, res_prev = f, g, change
        return g.reshape(-1, 3), it, change

    def _smooth(self, U: np.ndarray) -> tuple[np.ndarray, int]:
        p = self.params
        if not p.use_smoothing or p.smooth_iterations <= 0 or len(self._free) == 0:
            return U, 0
        base = self._V_sub if p.smooth_displacement else None
        X = U - base if base is not None else U.copy()
        it = 0
        for it in range(1, p.smooth_iterations + 1):  # noqa: B007
            delta = p.smooth_step * (self._S @ X - X[self._free])
            X[self._free] += delta
            if np.abs(delta).max() < p.smooth_tol:
                break
        return (X + base if base is not None else X), it

    def solve_report(self, handle_positions: np.ndarray, warm_start: bool = True
                     ) -> DeformReport:
        """Deform with the handles at ``handle_positions`` (H, 3), mm; full report.

        Handles further than ``params.max_handle_displacement_mm`` from their base position
        are pulled back to that distance (warning). ARAP starts from the previous solution
        when ``warm_start`` (else from the base), runs until converged or
        ``params.arap_iterations``; smoothing follows (handles and ring fixed). Triangles
        whose normal flipped against the base are reported.
        """
        p = self.params
        H = np.asarray(handle_positions, np.float64).reshape(-1, 3)
        if len(H) != self.n_handles:
            raise ValueError(f"expected {self.n_handles} handle positions, got {len(H)}")
        if not np.isfinite(H).all():
            raise NaseviewError("stage 3: a handle position is not a finite number")
        warnings: list[str] = []
        base_h = self.V_base[self.handle_vertex_ids]
        d = H - base_h
        dn = np.linalg.norm(d, axis=1)
        clamped = np.flatnonzero(dn > p.max_handle_displacement_mm)
        if len(clamped):
            H = H.copy()
            H[clamped] = base_h[clamped] + d[clamped] * (
                p.max_handle_displacement_mm / dn[clamped])[:, None]
            warnings.append(
                f"stage 3: {len(clamped)} handle(s) asked to move up to {dn.max():.1f} mm from "
                f"the base face; limited to {p.max_handle_displacement_mm:g} mm")
        bc = np.r_[H, self._pin_pos]
        t0 = time.perf_counter()
        U0 = self._U if warm_start else self._V_sub.copy()
        U0 = U0.copy()
        U0[self._h_loc] = H
        if p.use_arap and p.arap_iterations > 0:
            U, iters, change = self._arap(bc, U0)
        else:
            U, iters, change = U0, 0, 0.0
        self._U = U
        t1 = time.perf_counter()
        U_s, s_it = self._smooth(U)
        t2 = time.perf_counter()
        if iters and change > p.arap_warn_mm:
            warnings.append(f"stage 3: ARAP did not converge in {iters} iterations (last step "
                            f"{change:.3f} mm); the handles may be inconsistent")
        V = self.V_base.copy()
        V[self.sub_ids] = U_s
        Nn = face_normals(V, self.F[self.face_ids])
        dots = np.einsum("ij,ij->i", Nn, self._base_normals)
        folded = self.face_ids[dots <= 0]
        if len(folded):
            warnings.append(f"stage 3: {len(folded)} triangle(s) of the nose folded over; "
                            "move the handles less or check the landmarks")
        return DeformReport(V, iters, change, s_it, folded, clamped,
                            {"arap": t1 - t0, "smooth": t2 - t1}, warnings)

    def solve(self, handle_positions: np.ndarray, warm_start: bool = True) -> np.ndarray:
        """(V, 3) deformed face for handles at ``handle_positions`` (H, 3), mm."""
        return self.solve_report(handle_positions, warm_start).V


def smooth_warp(V: np.ndarray, F: np.ndarray, handle_ids: np.ndarray, targets: np.ndarray,
                weights: np.ndarray, bending_mm2: float, region_ids: np.ndarray) -> np.ndarray:
    """Bend a mesh smoothly towards targets: soft-constrained bi-Laplacian deformation.

    The displacement ``d`` (zero outside ``region_ids``) minimises

        sum_h weights_h |V_h + d_h - targets_h|^2 + bending_mm2 * d^T L^T M^-1 L d

    with L the cotangent Laplacian and M the Voronoi mass matrix of ``V`` (Botsch &
    Sorkine 2008, bi-Laplacian editing with soft handles): the smoothest displacement that
    brings the handles close to their targets. One sparse factorisation (SuperLU).

    Args:
        V: (n, 3) mesh, mm. F: (m, 3) triangles.
        handle_ids: (H,) vertex ids inside the region; targets: (H, 3) mm.
        weights: (H,) handle weights (1/mm^2).
        bending_mm2: bending weight (mm^2).
        region_ids: vertices free to move.
    Returns:
        (n, 3) warped vertices.
    """
    import igl
    from scipy.sparse.linalg import splu

    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    n = len(V)
    region = np.unique(np.asarray(region_ids, np.int64))
    h = np.asarray(handle_ids, np.int64)
    inside = np.isin(h, region)
    h, T, w = h[inside], np.asarray(targets, float)[inside], np.asarray(weights, float)[inside]
    if len(h) == 0 or len(region) == 0:
        return V.copy()
    L = igl.cotmatrix(V, F).tocsr()
    m = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    Lr = L[:, region]                                     # d is zero outside the region
    Q = (Lr.T @ sp.diags(1.0 / np.maximum(m, 1e-12)) @ Lr).tocsc()
    loc = np.full(n, -1, np.int64)
    loc[region] = np.arange(len(region))
    W = sp.csc_matrix((w, (loc[h], loc[h])), shape=(len(region), len(region)))
    A = (bending_mm2 * Q + W + 1e-8 * sp.eye(len(region))).tocsc()
    rhs = np.zeros((len(region), 3))
    np.add.at(rhs, loc[h], w[:, None] * (T - V[h]))
    d = splu(A, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True}).solve(rhs)
    out = V.copy()
    out[region] += d
    return out


def deform_region(model: FaceModel, V_base: np.ndarray, handle_vertex_ids: np.ndarray,
                  params: RefineParams | None = None) -> np.ndarray:
    """The vertices stage 3 may move: the model's nose region plus every vertex within
    ``params.handle_clearance_mm`` (along edges) of a handle, sorted (R,)."""
    params = params or RefineParams()
    seeds = np.asarray(handle_vertex_ids, np.int64)
    grown = grow_by_distance(V_base, model.faces, seeds, params.handle_clearance_mm)
    return np.unique(np.r_[np.asarray(model.nose_vertices, np.int64), grown])


def refine(model: FaceModel, reconstruction: Any, params: RefineParams | None = None
           ) -> RefineResult:
    """Stage 3: base fit, correspondences, smooth warp, ARAP and smoothing of the nose.

    1. :func:`fit_face_model` (similarity + coefficients) - the paper's base face;
    2. :func:`correspondences` - ad-landmarks to base vertices;
    3. :func:`smooth_warp` - soft bi-Laplacian bend of the base towards them (naseview's
       addition, ``params.use_warp``); handles still further than ``params.release_mm``
       are dropped from the hard constraints, with a warning;
    4. :class:`NoseDeformer` - ARAP with the remaining handles as hard constraints, then
       cotangent smoothing (the paper).

    Uses ``reconstruction.landmarks`` and, when present and tagged,
    ``reconstruction.ad_landmarks`` / ``ad_landmark_tags`` (stage 2's sub-landmarks).

    Args:
        model: the face model (``load_face_model``).
        reconstruction: a :class:`~naseview.reconstruction.Reconstruction` (or anything
            with ``landmarks`` and optionally ``ad_landmarks``, ``ad_landmark_tags``).
        params: :class:`RefineParams`.
    Returns:
        :class:`RefineResult`.
    Raises:
        NaseviewError: too few landmarks to fit the model.
    """
    params = params or RefineParams()
    landmarks = dict(getattr(reconstruction, "landmarks", {}) or {})
    ad = getattr(reconstruction, "ad_landmarks", None)
    tags = getattr(reconstruction, "ad_landmark_tags", None)
    if ad is not None and len(np.asarray(ad).reshape(-1, 3)) == 0:
        ad, tags = None, None
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    fit = fit_face_model(model, landmarks, params, ad, tags)
    t1 = time.perf_counter()
    handles, cw = correspondences(model, fit.vertices, landmarks, ad, tags, params)
    base = fit.vertices
    warnings = list(fit.warnings) + cw
    if params.use_warp and len(handles.vertex_ids):
        sig = np.where(handles.is_landmark, params.fit_sigma_mm, params.fit_sub_sigma_mm)
        around = grow_by_distance(base, model.faces, handles.vertex_ids, params.warp_radius_mm)
        base = smooth_warp(base, model.faces, handles.vertex_ids, handles.targets,
                           1.0 / np.maximum(sig, 1e-6) ** 2, params.warp_bending_mm2, around)
        handles, _ = correspondences(model, base, landmarks, ad, tags, params)
    t2 = time.perf_counter()
    # handles the smooth base cannot reach contradict their neighbours: not hard constraints
    miss = np.linalg.norm(handles.targets - base[handles.vertex_ids], axis=1)
    keep = miss <= params.release_mm
    released = [n for n, k in zip(handles.names, keep, strict=True) if not k]
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
    if released:
        handles = Correspondences(handles.vertex_ids[keep], handles.targets[keep],
                                  [n for n, k in zip(handles.names, keep, strict=True) if k],
                                  handles.is_landmark[keep])
    region = deform_region(model, base, handles.vertex_ids, params)
    t3 = time.perf_counter()
    seconds.update(fit=t1 - t0, warp=t2 - t1, correspondences=t3 - t2)
    deformer: NoseDeformer | None = None
    report: DeformReport | None = None
    V = base.copy()
    if (params.use_arap or params.use_smoothing) and len(handles.vertex_ids):
        deformer = NoseDeformer(base, model.faces, region, handles.vertex_ids, params)
        t4 = time.perf_counter()
        report = deformer.solve_report(handles.targets, warm_start=False)
        V = report.V
        warnings += report.warnings
        seconds.update(precompute=t4 - t3, **report.seconds)
        region = deformer.region_vertex_ids
    nose = np.asarray(model.nose_vertices, np.int64)
    in_nose = np.zeros(len(V), bool)
    in_nose[nose] = True
    F = np.asarray(model.faces, np.int64)
    return RefineResult(V=V, F=F, nose_vertex_ids=nose, nose_faces=F[in_nose[F].all(1)],
                        region_vertex_ids=region, base_V=base,
                        coefficients=fit.coefficients, fit=fit, handles=handles,
                        released=released,
                        deformer=deformer, report=report, warnings=warnings, seconds=seconds,
                        model_name=model.name, credit=model.credit, model=model)


# ---------------------------------------------------------------------------------------
# Surface accuracy against a ground-truth mesh (SPEC §6, "Surface")
# ---------------------------------------------------------------------------------------

NOSE_OUTLINE: tuple[str, ...] = ("mf_r", "mf_l", "int_l", "al_l", "ac_l", "sn", "ac_r",
                                 "al_r", "int_r")
"""Landmarks whose frontal (x, y) outline bounds the nose region of a ground-truth mesh."""


def _inside_polygon(P: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """(n,) bool: 2D points ``P`` (n, 2) inside the closed polygon ``poly`` (k, 2)."""
    x, y = P[:, 0][:, None], P[:, 1][:, None]
    x0, y0 = poly[:, 0][None], poly[:, 1][None]
    x1, y1 = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    cond = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return (cond & (x < xc)).sum(1) % 2 == 1


def nose_surface_samples(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                         n_samples: int = 20000, seed: int = 0,
                         max_occlusion: float = 0.6) -> np.ndarray:
    """Area-uniform random points of the external nose surface of a (ground-truth) face.

    The nose is the part of the surface whose frontal projection (x, y) lies inside the
    outline :data:`NOSE_OUTLINE` (mf_r, mf_l, int_l, al_l, ac_l, sn, ac_r, al_r, int_r);
    of it only the open surface counts: triangles whose ambient occlusion (libigl, embree,
    64 rays from the centroid) is at most ``max_occlusion``, which leaves out the nostril
    cavities (occlusion about 0.9) that no photo shows and no base face models alike.

    Args:
        V, F: (n, 3) mm / (m, 3) int, the mesh in the SPEC frame.
        landmarks: id -> (3,) on that mesh (all of :data:`NOSE_OUTLINE`).
        n_samples: number of points.
        seed: random seed (fixed: the same points every run).
        max_occlusion: largest ambient occlusion (0 open .. 1 enclosed) of a kept triangle.
    Returns:
        (n_samples, 3) points, mm.
    Raises:
        NaseviewError: an outline landmark is missing, or no triangle is inside it.
    """
    from igl.embree import ambient_occlusion

    missing = [k for k in NOSE_OUTLINE if k not in landmarks]
    if missing:
        raise NaseviewError(f"truth.json: key 'landmarks' lacks {', '.join(missing)}, needed "
                            "to outline the nose for the surface error")
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    poly = np.array([np.asarray(landmarks[k], float)[:2] for k in NOSE_OUTLINE])
    C = V[F].mean(1)
    N = face_normals(V, F)
    area = 0.5 * np.linalg.norm(N, axis=1)
    keep = np.flatnonzero(_inside_polygon(C[:, :2], poly) & (area > 0))
    if len(keep):
        Nu = np.ascontiguousarray(N[keep] / (2 * area[keep])[:, None])
        ao = ambient_occlusion(V, F, np.ascontiguousarray(C[keep] + 1e-3 * Nu), Nu, 64)
        keep = keep[ao <= max_occlusion]
    if not len(keep):
        raise NaseviewError("truth_face.ply: no open triangle inside the nose outline of the "
                            "truth landmarks; is the mesh in the SPEC frame?")
    rng = np.random.default_rng(seed)
    pick = keep[rng.choice(len(keep), n_samples, p=area[keep] / area[keep].sum())]
    r1, r2 = rng.random(n_samples), rng.random(n_samples)
    s = np.sqrt(r1)
    bary = np.c_[1 - s, s * (1 - r2), s * r2]
    return np.einsum("ij,ijk->ik", bary, V[F[pick]])


def surface_error(truth_V: np.ndarray, truth_F: np.ndarray,
                  truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray, F: np.ndarray,
                  landmarks: Mapping[str, np.ndarray], n_samples: int = 20000,
                  samples: np.ndarray | None = None) -> dict[str, float]:
    """Nose surface error (SPEC §6): truth nose samples to the reconstructed mesh.

    The reconstruction is first moved rigidly (Kabsch on the landmarks both have) onto the
    truth; then the distance from each ground-truth nose sample
    (:func:`nose_surface_samples`) to the nearest point of the reconstructed mesh
    (``igl.point_mesh_squared_distance``).

    Args:
        truth_V, truth_F: ground-truth face mesh (SPEC frame, mm).
        truth_landmarks: id -> (3,) true landmarks.
        V, F: reconstructed face mesh (mm).
        landmarks: id -> (3,) reconstructed landmarks (same frame as V).
        n_samples: ground-truth samples (when ``samples`` is not given).
        samples: optional precomputed (k, 3) truth samples.
    Returns:
        ``{"mean_mm", "p95_mm", "max_mm", "rigid_rmse_mm"}``.
    """
    import igl

    common = [k for k in LANDMARK_IDS if k in truth_landmarks and k in landmarks]
    if len(common) < 3:
        raise NaseviewError("surface error: fewer than 3 landmarks shared by the "
                            "reconstruction and truth.json")
    X = np.array([np.asarray(landmarks[k], float) for k in common])
    Y = np.array([np.asarray(truth_landmarks[k], float) for k in common])
    s, R, t = umeyama(X, Y, with_scale=False)
    rmse = float(np.sqrt(np.mean(np.sum((X @ R.T + t - Y) ** 2, axis=1))))
    Va = np.ascontiguousarray(np.asarray(V, float) @ R.T + t)
    P = samples if samples is not None else nose_surface_samples(
        truth_V, truth_F, truth_landmarks, n_samples)
    d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(P, dtype=np.float64), Va,
                                               np.ascontiguousarray(F, dtype=np.int64))
    d = np.sqrt(d2)
    return {"mean_mm": float(d.mean()), "p95_mm": float(np.percentile(d, 95)),
            "max_mm": float(d.max()), "rigid_rmse_mm": rmse}


_PAPER = {"use_warp": False, "release_mm": float("inf"), "sub_landmark_curves": None,
          "smooth_displacement": False}

ABLATION_ROWS: dict[str, dict[str, Any]] = {
    "fit": {**_PAPER, "use_arap": False, "use_smoothing": False, "use_sublandmarks": False},
    "arap21": {**_PAPER, "use_smoothing": False, "use_sublandmarks": False},
    "arap76": {**_PAPER, "use_smoothing": False},
    "arap76+smooth": {**_PAPER},
    "fit+warp": {"use_arap": False, "use_smoothing": False},
    "naseview-all76": {"sub_landmark_curves": None},
    "naseview": {},
}
"""The issue-5 comparison, each a change of :class:`RefineParams`. The paper's steps:
morphable-model fit only (21 landmarks); + ARAP with the 21 landmarks; + ARAP with all 76
ad-landmarks; + cotangent smoothing of the positions. Then naseview's: the fit bent
smoothly towards the ad-landmarks (no ARAP); the default pipeline with all 76
ad-landmarks; and the default pipeline (warp, ARAP with the consistent handles of the
mid- and ala-curves, smoothing of the displacement)."""


def ablation(model: FaceModel, reconstruction: Any, truth_V: np.ndarray, truth_F: np.ndarray,
             truth_landmarks: Mapping[str, np.ndarray], params: RefineParams | None = None,
             samples: np.ndarray | None = None) -> dict[str, dict[str, float]]:
    """Surface error of each :data:`ABLATION_ROWS` variant of stage 3 on one case.

    Args:
        model: base face model.
        reconstruction: stage 1(-2) result (landmarks, ad-landmarks).
        truth_V, truth_F, truth_landmarks: ground truth (``truth_face.ply``, ``truth.json``).
        params: the other stage-3 parameters (default :class:`RefineParams`).
        samples: optional precomputed truth nose samples (:func:`nose_surface_samples`).
    Returns:
        row name -> :func:`surface_error` dict plus ``"seconds"``.
    """
    import dataclasses

    params = params or RefineParams()
    if samples is None:
        samples = nose_surface_samples(truth_V, truth_F, truth_landmarks)
    out: dict[str, dict[str, float]] = {}
    for row, kw in ABLATION_ROWS.items():
        t = time.perf_counter()
        res = refine(model, reconstruction, dataclasses.replace(params, **kw))
        e = surface_error(truth_V, truth_F, truth_landmarks, res.V, res.F,
                          reconstruction.landmarks, samples=samples)
        e["seconds"] = time.perf_counter() - t
        out[row] = e
    return out
