"""The app's solver: landmark drags -> deformed nose, curves, ad-landmarks, measurements.

A pure consumer of stage 3 (paper §3.4): :class:`NoseEditSolver` builds one
:class:`naseview.stage3_mesh.NoseDeformer` on the *reconstructed* face (the baseline), with
the editable landmarks' vertices as handles, and re-solves it for every drag. The
deformation is the paper's ARAP (eq. 19-20) + cotangent smoothing (eq. 21); the smoothing
acts on the displacement (``smooth_displacement=True``) so an unedited nose stays exactly
the reconstruction.

Surgical manoeuvres (:mod:`naseview.editing.manoeuvres`: hump reduction, tip rotation...)
are displacement fields defined on the baseline; a solve adds their sum to the ARAP result,
moves the landmarks by the same field (so the spheres stay on the surface) and checks the
result for folded triangles. A change of manoeuvre amounts alone reuses the last ARAP
solve (no re-solve: the fields are cheap).

Curves and ad-landmarks follow the surface: each of their points is attached to the
baseline mesh (triangle, barycentric coordinates, offset from the surface) and carried
along by the deformed triangle. Measurements are
:func:`naseview.measurements.clinical_measurements` of the moved landmarks and curves.

Example
-------
    solver = NoseEditSolver(baseline)
    out = solver({**baseline.landmarks, "prn": p + [0, 1.0, 0]})
    out.V.shape, out.measurements["nasal_length"]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import igl
import numpy as np
from scipy.spatial import cKDTree

from naseview.editing.baseline import Baseline, Landmarks, Solved, copy_landmarks, landmarks_equal
from naseview.editing.manoeuvres import ManoeuvrePlan, folded_triangles
from naseview.editing.manoeuvres.plan import HUMP_MARGIN_MM
from naseview.landmarks import LANDMARK_IDS
from naseview.measurements import clinical_measurements
from naseview.stage3_mesh import NoseDeformer, RefineParams, deform_region

FIXED_LANDMARKS: tuple[str, ...] = ("g", "mf_l", "mf_r")
"""Bony reference points outside the nose: shown, never dragged."""


@dataclass(frozen=True)
class SurfaceAttachment:
    """Points glued to a triangle mesh.

    Attributes:
        face_ids: (P,) triangle of each point.
        bary: (P, 3) barycentric coordinates of the closest surface point.
        offset: (P, 3) point minus its closest surface point (mm), kept as is.
    """

    face_ids: np.ndarray
    bary: np.ndarray
    offset: np.ndarray


def attach_points(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> SurfaceAttachment:
    """Attach points (P, 3) to the closest points of the mesh (V (N, 3), F (M, 3)), mm."""
    P = np.ascontiguousarray(np.asarray(P, dtype=np.float64).reshape(-1, 3))
    if len(P) == 0:
        return SurfaceAttachment(np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    _, fid, C = igl.point_mesh_squared_distance(P, V, F)
    fid = np.asarray(fid, dtype=np.int64).ravel()
    C = np.asarray(C, dtype=np.float64).reshape(-1, 3)
    A, B, Cc = (np.ascontiguousarray(V[F[fid, k]]) for k in range(3))
    bary = np.asarray(igl.barycentric_coordinates(C, A, B, Cc), dtype=np.float64)
    return SurfaceAttachment(fid, bary, P - C)


def attached_positions(att: SurfaceAttachment, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(P, 3) positions of attached points on the mesh ``V`` (same topology ``F``)."""
    if len(att.face_ids) == 0:
        return np.zeros((0, 3))
    T = V[np.asarray(F)[att.face_ids]]                      # (P, 3, 3)
    return np.einsum("pk,pkd->pd", att.bary, T) + att.offset


def landmark_vertices(V: np.ndarray, landmarks: Mapping[str, np.ndarray],
                      candidates: np.ndarray | None = None,
                      tol_mm: float = 2.5) -> dict[str, int]:
    """The mesh vertex of each landmark: the nearest vertex among ``candidates`` (default
    all), kept only when closer than ``tol_mm`` (mm). Distinct landmarks may not share a
    vertex (the later one in SPEC order is dropped)."""
    ids = np.arange(len(V)) if candidates is None else np.asarray(candidates, np.int64)
    if len(ids) == 0:
        return {}
    tree = cKDTree(np.asarray(V)[ids])
    out: dict[str, int] = {}
    used: set[int] = set()
    order = [k for k in LANDMARK_IDS if k in landmarks] + \
        [k for k in landmarks if k not in LANDMARK_IDS]
    for k in order:
        d, j = tree.query(np.asarray(landmarks[k], dtype=np.float64).reshape(3))
        v = int(ids[int(j)])
        if d <= tol_mm and v not in used:
            out[k] = v
            used.add(v)
    return out


class NoseEditSolver:
    """Re-deforms the reconstructed nose when landmarks move (the app's :class:`Solver`).

    Args:
        baseline: the reconstruction being edited (its ``V`` is the ARAP rest shape).
        params: :class:`naseview.stage3_mesh.RefineParams` (ARAP / smoothing fields used; the
            smoothing is switched to the displacement).
        fixed: landmark ids never dragged (:data:`FIXED_LANDMARKS`).
        interactive_iterations: ARAP iterations per solve during a drag (the warm start
            carries convergence across the drag's solves; 6 stays within 0.05 mm of the
            converged surface on the ICT nose); a final solve uses
            ``params.arap_iterations``.
        tol_mm: a landmark farther than this from every nose vertex is not editable.
    """

    def __init__(self, baseline: Baseline, params: RefineParams | None = None,
                 fixed: Sequence[str] = FIXED_LANDMARKS, interactive_iterations: int = 6,
                 tol_mm: float = 2.5) -> None:
        self.params = replace(params or RefineParams(), smooth_displacement=True)
        self.baseline = baseline
        V, F = baseline.V, baseline.F
        lv = landmark_vertices(V, {k: v for k, v in baseline.landmarks.items()
                                   if k not in fixed}, baseline.nose_ids, tol_mm)
        self.editable: list[str] = [k for k in baseline.landmarks if k in lv]
        self.handle_ids = np.array([lv[k] for k in self.editable], dtype=np.int64)
        region = deform_region(V, F, baseline.nose_ids, self.handle_ids,
                               self.params.handle_clearance_mm)
        self.deformer = NoseDeformer(V, F, region, self.handle_ids, self.params)
        self.plan = ManoeuvrePlan(V, F, baseline.nose_ids, baseline.landmarks,
                                  baseline.curves)
        """The manoeuvres' displacement fields on the baseline (built once)."""
        self.region_ids = np.union1d(np.asarray(self.deformer.region_vertex_ids, np.int64),
                                     np.asarray(self.plan.region_ids, np.int64))
        """Vertices a solve may move: the ARAP region and every vertex a manoeuvre moves."""
        self._nose_faces = np.flatnonzero(np.isin(F, self.region_ids).any(axis=1))
        self._fast = replace(self.params, arap_iterations=max(1, int(interactive_iterations)),
                             arap_warn_mm=float("inf"))
        self._base_handles = V[self.handle_ids].copy()
        self._base_lms = {k: np.asarray(baseline.landmarks[k], np.float64)
                          for k in self.editable}
        self._attach_curves_and_ad_landmarks()
        self._last: tuple[Landmarks, bool, np.ndarray, tuple[str, ...]] | None = None

    def _attach_curves_and_ad_landmarks(self) -> None:
        """Glue the baseline's curve points and ad-landmarks to its mesh, curves first."""
        b = self.baseline
        names = [k for k, c in b.curves.items() if len(c)]
        pts = [np.asarray(b.curves[k], np.float64).reshape(-1, 3) for k in names]
        self._curve_names = names
        self._curve_splits = np.cumsum([len(c) for c in pts])[:-1]
        allp = np.concatenate(pts + [np.asarray(b.ad_landmarks).reshape(-1, 3)]) \
            if pts or len(b.ad_landmarks) else np.zeros((0, 3))
        self._n_curve = int(sum(len(c) for c in pts))
        self._att = attach_points(allp, b.V, b.F)

    def __call__(self, landmarks: Mapping[str, np.ndarray],
                 interactive: bool = False,
                 manoeuvres: Mapping[str, float] | None = None, **_: object) -> Solved:
        """Solve for landmark positions (id -> (3,) mm) and manoeuvre amounts (name -> mm
        / degrees); see :class:`Solved`.

        ``interactive``: a solve during a drag (few ARAP iterations, no convergence
        warning); else a full solve with ``params``.
        """
        V, warnings = self._arap(landmarks, interactive)
        F = self.baseline.F
        shown: Landmarks | None = None
        lms: Mapping[str, np.ndarray] = landmarks
        if manoeuvres:
            plan = self.plan
            V = V + plan.displacement(manoeuvres)
            off = plan.landmark_offsets(manoeuvres)
            shown = copy_landmarks(landmarks)
            for k, d in off.items():
                if k in shown:
                    shown[k] = shown[k] + d
            lms = shown
            hump = plan.hump_depth
            cut = float(manoeuvres.get("hump_reduction", 0.0))
            if hump is not None and cut > hump + HUMP_MARGIN_MM:
                warnings += (f"hump reduction {cut:.1f} mm is more than the measured hump "
                             f"({hump:.1f} mm): applied {hump + HUMP_MARGIN_MM:.1f} mm, "
                             "which leaves the dorsum straight (more would crease it into "
                             "a saddle)",)
            above = plan.hump_above_tip
            if cut > 0.0 and plan.supratip_hump and above is not None:
                warnings += (f"the measured hump lies in the supratip, {above:.0f} mm above "
                             "the tip, not on the bony dorsum: lowering it there sharpens "
                             "the tip; check the profile and the tip",)
            skipped = [m for m in manoeuvres if m not in plan.available]
            if skipped:
                warnings += (f"manoeuvre(s) {', '.join(skipped)} need landmarks this "
                             "reconstruction lacks; not applied",)
            folded = folded_triangles(self.baseline.V, V, F, self._nose_faces)
            if len(folded):
                warnings += (f"{len(folded)} triangle(s) of the nose folded over: the "
                             "manoeuvres and landmark moves together go too far; reduce one",)
        P = attached_positions(self._att, V, F)
        curves = dict(zip(self._curve_names,
                          np.split(P[:self._n_curve], self._curve_splits), strict=True)) \
            if self._curve_names else {}
        ad = P[self._n_curve:]
        meas = clinical_measurements(lms, curves or None, V, F)
        return Solved(V, curves, ad, meas, warnings, shown)

    def _arap(self, landmarks: Mapping[str, np.ndarray], interactive: bool
              ) -> tuple[np.ndarray, tuple[str, ...]]:
        """(N, 3) ARAP solve for the landmark handles and its warnings; the last final
        solve is reused while the landmarks stay the same (a manoeuvre change)."""
        last = self._last
        if last is not None and not interactive and not last[1] \
                and landmarks_equal(last[0], landmarks):
            return last[2], last[3]
        H = self._base_handles.copy()
        for i, k in enumerate(self.editable):
            H[i] += np.asarray(landmarks[k], np.float64) - self._base_lms[k]
        rep = self.deformer.solve_report(H, warm_start=True,
                                         params=self._fast if interactive else self.params)
        self._last = (copy_landmarks(landmarks), interactive, rep.V, tuple(rep.warnings))
        return rep.V, tuple(rep.warnings)
