"""ARAP deformation and cotangent smoothing of the nose with hard handles (paper eq. 19-21).

The paper moves the base face's ad-landmark vertices onto the ad-landmarks by
as-rigid-as-possible deformation (eq. 19-20; Sorkine & Alexa 2007, libigl's local-global
solver here, Anderson-accelerated) and evens the result by cotangent Laplacian smoothing
(eq. 21). :class:`NoseDeformer` precomputes once per (mesh, region, handle set) and then
solves for any handle positions and parameters: stage 3 solves once, the app re-solves on
every drag. SPEC frame, mm.

Example
-------
    dfm = NoseDeformer(V, F, deform_region(V, F, nose_ids, handle_ids, 6.0),
                       handle_ids)
    report = dfm.solve_report(V[handle_ids] + [0, 0, 1.0])
    report.V.shape, report.arap_iterations
    # -> ((9409, 3), 7)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import igl
import numpy as np
import scipy.sparse as sp

from naseview.errors import NaseviewError
from naseview.geometry.laplacian import cotangent_weights
from naseview.geometry.mesh import face_normals, vertex_adjacency
from naseview.geometry.region import grow_by_distance, submesh
from naseview.stage3_mesh.params import RefineParams


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


def deform_region(V_base: np.ndarray, F: np.ndarray, nose_vertex_ids: np.ndarray,
                  handle_vertex_ids: np.ndarray, clearance_mm: float,
                  adjacency: sp.csr_matrix | None = None) -> np.ndarray:
    """(R,) sorted vertices that may move: the nose region plus every vertex within
    ``clearance_mm`` (along the edges of ``V_base`` (n, 3), ``F`` (m, 3)) of a handle.
    ``adjacency``: optional ``vertex_adjacency(n, F, V_base)`` (edge lengths), computed
    once for a base that several handle sets deform."""
    grown = grow_by_distance(V_base, F, np.asarray(handle_vertex_ids, np.int64), clearance_mm,
                             adjacency)
    return np.unique(np.r_[np.asarray(nose_vertex_ids, np.int64), grown])


def _anderson_step(g: np.ndarray, f: np.ndarray, dF: list[np.ndarray],
                   dG: list[np.ndarray]) -> np.ndarray:
    """The Anderson-mixed next iterate from the last differences of residuals ``dF`` and of
    iterates ``dG`` (Tikhonov-regularised least squares over the memory)."""
    A = np.stack(dF, axis=1)
    AtA = A.T @ A
    gamma = np.linalg.solve(AtA + 1e-10 * np.trace(AtA) * np.eye(len(dF)) +
                            1e-30 * np.eye(len(dF)), A.T @ f)
    return np.asarray(g - np.stack(dG, axis=1) @ gamma)


class NoseDeformer:
    """ARAP deformation + cotangent Laplacian smoothing of a region with hard handles.

    Built once per (mesh, region, handle set); :meth:`solve` only takes new handle
    positions (and optionally other parameters), reusing the ARAP factorisation and the
    smoothing operator, and starts ARAP from the previous solution (warm start), so an
    interactive drag re-solves fast.

    The submesh is the region plus a ring of ``params.margin_mm`` (at least one edge ring)
    around it, pinned to ``V_base``: vertices outside the region never move and the seam
    stays continuous.

    Args:
        V_base: (V, 3) base face, mm (the rest shape of ARAP).
        F: (F, 3) int triangles.
        region_vertex_ids: (R,) vertices that may move (handles are added if missing).
        handle_vertex_ids: (H,) distinct vertex ids constrained by :meth:`solve`.
        params: :class:`RefineParams`: ``margin_mm`` builds the ring; the ARAP and
            smoothing fields are the default of every solve.
        adjacency: optional ``vertex_adjacency(len(V_base), F, V_base)`` (edge
            lengths), when the caller builds several deformers of one base (stage 3's
            silhouette rounds).
    Raises:
        ValueError: repeated handle ids, or a handle in no triangle of the region.
    """

    def __init__(self, V_base: np.ndarray, F: np.ndarray, region_vertex_ids: np.ndarray,
                 handle_vertex_ids: np.ndarray, params: RefineParams | None = None,
                 adjacency: sp.csr_matrix | None = None) -> None:
        self.params = params or RefineParams()
        self.V_base = np.ascontiguousarray(V_base, np.float64)
        self.F = np.ascontiguousarray(F, np.int64)
        self.handle_vertex_ids = np.asarray(handle_vertex_ids, np.int64).ravel()
        if len(np.unique(self.handle_vertex_ids)) != len(self.handle_vertex_ids):
            raise ValueError("handle_vertex_ids must be distinct")
        self._build_submesh(region_vertex_ids, adjacency)
        self.data = igl.ARAPData()
        self.data.max_iter = 1
        igl.arap_precomputation(self._V_sub, self.sub_F, 3, self._b, self.data)
        self._build_smoothing()
        self._U = self._V_sub.copy()                               # warm start
        self._base_normals = face_normals(self.V_base, self.F[self.face_ids])

    def _build_submesh(self, region_vertex_ids: np.ndarray,
                       adjacency: sp.csr_matrix | None) -> None:
        """The region (+ handles), its pinned ring, the submesh and the constrained rows."""
        n = len(self.V_base)
        region = np.unique(np.r_[np.asarray(region_vertex_ids, np.int64).ravel(),
                                 self.handle_vertex_ids])
        adj = adjacency if adjacency is not None else vertex_adjacency(n, self.F, self.V_base)
        ring = np.setdiff1d(grow_by_distance(self.V_base, self.F, region, self.params.margin_mm,
                                             adj), region)
        self.region_vertex_ids = region
        self.ring_vertex_ids = ring
        _, self.sub_F, ids = submesh(self.V_base, self.F, np.r_[region, ring])
        self.sub_ids = ids
        loc = np.full(n, -1, np.int64)
        loc[ids] = np.arange(len(ids))
        in_region = np.zeros(n, bool)
        in_region[region] = True
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

    def _build_smoothing(self) -> None:
        """The smoothing operator on the free vertices: ``D^-1 L`` with clamped cotangent
        weights (eq. 21), rows of the free (unconstrained, connected) vertices only."""
        L = cotangent_weights(self._V_sub, self.sub_F)
        deg = np.asarray(L.sum(axis=1)).ravel()
        fixed = np.zeros(len(self.sub_ids), bool)
        fixed[self._b] = True
        self._free = np.flatnonzero(~fixed & (deg > 0))
        Dinv = sp.diags(1.0 / np.maximum(deg, 1e-12))
        self._S = (Dinv @ L).tocsr()[self._free]                  # (free, sub) averaging

    @property
    def n_handles(self) -> int:
        return len(self.handle_vertex_ids)

    def _arap(self, bc: np.ndarray, U: np.ndarray, p: RefineParams
              ) -> tuple[np.ndarray, int, float]:
        """ARAP local-global iterations from ``U``, Anderson-accelerated when
        ``p.arap_anderson`` > 0. Returns (U, iterations, last change mm)."""
        self.data.max_iter = 1
        m = p.arap_anderson
        x = U.ravel().copy()
        dF: list[np.ndarray] = []
        dG: list[np.ndarray] = []
        f_prev: np.ndarray | None = None
        g_prev: np.ndarray | None = None
        res_prev = float("inf")
        g = x
        change, it = float("inf"), 0
        for it in range(1, p.arap_iterations + 1):  # noqa: B007
            g = igl.arap_solve(bc, self.data, x.reshape(-1, 3)).ravel()
            f = g - x
            change = float(np.abs(f).max())
            if change <= p.arap_tol_mm:
                break
            if m and f_prev is not None and g_prev is not None and change < 4.0 * res_prev:
                dF.append(f - f_prev)
                dG.append(g - g_prev)
                if len(dF) > m:
                    dF.pop(0)
                    dG.pop(0)
                x = _anderson_step(g, f, dF, dG)
            else:  # plain step (and a restart of the acceleration after a bad one)
                dF.clear()
                dG.clear()
                x = g
            f_prev, g_prev, res_prev = f, g, change
        return g.reshape(-1, 3), it, change

    def _smooth(self, U: np.ndarray, p: RefineParams) -> tuple[np.ndarray, int]:
        """Explicit cotangent smoothing (eq. 21) of the positions or, with
        ``p.smooth_displacement``, of the displacement from the base; constrained rows fixed."""
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

    def _capped(self, H: np.ndarray, p: RefineParams
                ) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """Handles further than ``p.max_handle_displacement_mm`` from their base position
        pulled back to that distance: (H, clamped indices, warnings)."""
        base_h = self.V_base[self.handle_vertex_ids]
        d = H - base_h
        dn = np.linalg.norm(d, axis=1)
        clamped = np.flatnonzero(dn > p.max_handle_displacement_mm)
        if not len(clamped):
            return H, clamped, []
        H = H.copy()
        H[clamped] = base_h[clamped] + d[clamped] * (
            p.max_handle_displacement_mm / dn[clamped])[:, None]
        return H, clamped, [
            f"stage 3: {len(clamped)} handle(s) asked to move up to {dn.max():.1f} mm from "
            f"the base face; limited to {p.max_handle_displacement_mm:g} mm"]

    def _folds(self, V: np.ndarray) -> tuple[np.ndarray, list[str]]:
        """Region triangles of ``V`` whose normal flipped against the base, and a warning."""
        Nn = face_normals(V, self.F[self.face_ids])
        dots = np.einsum("ij,ij->i", Nn, self._base_normals)
        folded = self.face_ids[dots <= 0]
        if not len(folded):
            return folded, []
        return folded, [f"stage 3: {len(folded)} triangle(s) of the nose folded over "
                        "where the landmarks pull the surface; check the landmark clicks "
                        "there"]

    def solve_report(self, handle_positions: np.ndarray, warm_start: bool = True,
                     params: RefineParams | None = None) -> DeformReport:
        """Deform with the handles at ``handle_positions`` (H, 3), mm; full report.

        Handles further than ``params.max_handle_displacement_mm`` from their base position
        are pulled back to that distance (warning). ARAP starts from the previous solution
        when ``warm_start`` (else from the base), runs until converged or
        ``params.arap_iterations``; smoothing follows (handles and ring fixed). Triangles
        whose normal flipped against the base are reported.

        Args:
            handle_positions: (H, 3) targets of the handles, mm.
            warm_start: start ARAP from the previous solve.
            params: the ARAP and smoothing fields of this solve (default: the
                constructor's ``params``; ``margin_mm`` is fixed at construction).
        Raises:
            ValueError: not H positions. NaseviewError: a position is not finite.
        """
        p = params or self.params
        H = np.asarray(handle_positions, np.float64).reshape(-1, 3)
        if len(H) != self.n_handles:
            raise ValueError(f"expected {self.n_handles} handle positions, got {len(H)}")
        if not np.isfinite(H).all():
            raise NaseviewError("stage 3: a handle position is not a finite number")
        H, clamped, warnings = self._capped(H, p)
        bc = np.r_[H, self._pin_pos]
        t0 = time.perf_counter()
        U0 = (self._U if warm_start else self._V_sub).copy()
        U0[self._h_loc] = H
        if p.use_arap and p.arap_iterations > 0:
            U, iters, change = self._arap(bc, U0, p)
        else:
            U, iters, change = U0, 0, 0.0
        self._U = U
        t1 = time.perf_counter()
        U_s, s_it = self._smooth(U, p)
        t2 = time.perf_counter()
        if iters and change > p.arap_warn_mm:
            warnings.append(f"stage 3: ARAP did not converge in {iters} iterations (last step "
                            f"{change:.3f} mm); the handles may be inconsistent")
        V = self.V_base.copy()
        V[self.sub_ids] = U_s
        folded, fold_warnings = self._folds(V)
        return DeformReport(V, iters, change, s_it, folded, clamped,
                            {"arap": t1 - t0, "smooth": t2 - t1}, warnings + fold_warnings)

    def solve(self, handle_positions: np.ndarray, warm_start: bool = True,
              params: RefineParams | None = None) -> np.ndarray:
        """(V, 3) deformed face for handles at ``handle_positions`` (H, 3), mm (see
        :meth:`solve_report`)."""
        return self.solve_report(handle_positions, warm_start, params).V
