"""The least-squares problem of paper eq. 1: reprojection residuals, analytic Jacobian, solve.

From the 2D clicks of the landmarks in the photos, the 3D landmarks and a pinhole camera
per photo minimise the reprojection error (paper §3.2, eq. 1)

    sum_ij rho(|| uv_ij - project(K_i, R_i, t_i, X_j) ||^2)

with :func:`scipy.optimize.least_squares` (method ``trf``, robust loss ``rho``, analytic
Jacobian with a fixed sparsity pattern, ``x_scale="jac"``; the dense exact trust-region
solver is the fastest at this size, the sparse ``lsmr`` one is available). Unknowns: per
photo an axis-angle rotation increment on the rig prior, a translation and the focal
length (principal point at the image centre, unless the case gives the intrinsics), and
the 3D landmarks seen in at least two photos; two weak priors on the focal lengths keep
the problem away from the orthographic limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse
from scipy.optimize import OptimizeResult, least_squares

from naseview.camera import Camera, intrinsics
from naseview.case import Case
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.rotations import rodrigues_and_left_jacobian, skew

JacobianStructure = tuple[np.ndarray, np.ndarray]
"""(rows, cols) index arrays of the Jacobian entries (:func:`jacobian_structure`)."""


@dataclass
class Problem:
    """Observations and parameter layout of one bundle adjustment.

    Parameters: per view a rotation increment on ``R0`` (3), the translation ``t_x, t_y``
    (mm), ``log t_z`` and, when the focal length is unknown, ``log m`` with the
    magnification ``m = f / t_z`` (px per mm at the origin's depth); then the points
    (N x 3). With (m, t_z) instead of (f, t_z), the near-ambiguity between focal length and
    distance (weak perspective) lies along one parameter axis, where ``x_scale="jac"``
    lets the trust region take long steps.

    Attributes:
        views: the V photos, in parameter order.
        point_ids: the N landmarks adjusted (clicked in two photos or more).
        obs_view, obs_point: (M,) view and point index of each click.
        obs_uv: (M, 2) the clicks (px).
        K0: (V, 3, 3) intrinsics (focal overwritten where free).
        sizes: V (width, height) of the photos (px).
        free: (V,) bool, focal length estimated.
        focal_weight: weight of the focal coupling prior (px per unit log f).
        focal_abs_weight: weight of the prior on the mean log focal length.
        log_f0: (V,) centre of that prior (log px).
        R0: (V, 3, 3) rig-prior rotations the increments apply to.
        cam_cols: (V,) first column of each view's block (7 columns if free focal, else 6).
        n_cam_params: columns of all camera blocks.
        prior_A, prior_b: (n_prior, P) and (n_prior,): the focal priors ``A x - b``.
    """

    views: list[str]
    point_ids: list[str]
    obs_view: np.ndarray
    obs_point: np.ndarray
    obs_uv: np.ndarray
    K0: np.ndarray
    sizes: list[tuple[int, int]]
    free: np.ndarray
    focal_weight: float = 0.0
    focal_abs_weight: float = 0.0
    log_f0: np.ndarray = field(default_factory=lambda: np.zeros(0))
    R0: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    cam_cols: np.ndarray = field(init=False)
    n_cam_params: int = field(init=False)
    prior_A: np.ndarray = field(init=False)
    prior_b: np.ndarray = field(init=False)

    @property
    def n_views(self) -> int:
        return len(self.views)

    @property
    def n_points(self) -> int:
        return len(self.point_ids)

    @property
    def n_obs(self) -> int:
        return len(self.obs_view)

    @property
    def n_params(self) -> int:
        """P: camera blocks and 3 per point."""
        return self.n_cam_params + 3 * self.n_points

    @property
    def n_prior(self) -> int:
        """Rows of the focal priors (coupling of 2+ free focal lengths, mean focal)."""
        return len(self.prior_b)

    def __post_init__(self) -> None:
        sizes = np.where(self.free, 7, 6)
        self.cam_cols = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        self.n_cam_params = int(sizes.sum())
        self.prior_A, self.prior_b = self._focal_priors()

    def _focal_priors(self) -> tuple[np.ndarray, np.ndarray]:
        """Focal priors, linear in the parameters (log f = log m + log t_z): coupling rows
        w (log f_i - mean log f), and one row w_abs mean(log f - log f0)."""
        P = self.n_params
        fc = self.cam_cols[self.free]
        n = len(fc)
        L = np.zeros((n, P))  # row i: log f of free view i
        L[np.arange(n), fc + 5] = 1.0
        L[np.arange(n), fc + 6] = 1.0
        rows: list[np.ndarray] = []
        rhs: list[np.ndarray] = []
        if self.focal_weight > 0 and n >= 2:
            rows.append(self.focal_weight * (L - L.mean(0)))
            rhs.append(np.zeros(n))
        if self.focal_abs_weight > 0 and n >= 1:
            rows.append(self.focal_abs_weight * L.mean(0)[None])
            rhs.append(np.array([self.focal_abs_weight * float(np.mean(self.log_f0[self.free]))]))
        A = np.vstack(rows) if rows else np.zeros((0, P))
        return A, (np.concatenate(rhs) if rhs else np.zeros(0))


def build_problem(case: Case, views: list[str], point_ids: list[str], params: SfmParams
                  ) -> Problem:
    """The problem of the clicks of ``point_ids`` in ``views``, with identity ``R0``.

    Each rig hypothesis gives its own ``R0`` with ``dataclasses.replace(prob, R0=...)``.
    """
    obs_view, obs_point, obs_uv = _observations(case, views, point_ids)
    known_K = [case.views[v].known_K() for v in views]
    sizes = [(case.views[v].width, case.views[v].height) for v in views]
    K0 = np.stack([K if K is not None else intrinsics(1.0, *sz)
                   for K, sz in zip(known_K, sizes, strict=True)])
    return Problem(
        views=views, point_ids=point_ids, obs_view=obs_view, obs_point=obs_point,
        obs_uv=obs_uv,
        K0=K0, sizes=sizes, free=np.array([K is None for K in known_K]),
        focal_weight=1.0 / params.focal_coupling if params.focal_coupling > 0 else 0.0,
        focal_abs_weight=1.0 / params.focal_prior_sd if params.focal_prior_sd > 0 else 0.0,
        log_f0=np.log([params.focal_guess * max(sz) for sz in sizes]),
        R0=np.repeat(np.eye(3)[None], len(views), axis=0))


def _observations(case: Case, views: list[str], point_ids: list[str]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M,) view index, (M,) point index and (M, 2) px of every click of the points."""
    obs_view, obs_point, obs_uv = [], [], []
    for i, v in enumerate(views):
        for j, lid in enumerate(point_ids):
            if lid in case.views[v].landmarks:
                obs_view.append(i)
                obs_point.append(j)
                obs_uv.append(case.views[v].landmarks[lid])
    return np.array(obs_view), np.array(obs_point), np.array(obs_uv, dtype=np.float64)


def unpack(prob: Problem, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                  np.ndarray, np.ndarray]:
    """Parameters (P,) -> R (V,3,3), left Jacobians of the increments J_l (V,3,3),
    t (V,3), K (V,3,3), X (N,3)."""
    cc = prob.cam_cols
    cam = x[cc[:, None] + np.arange(6)]
    t = np.column_stack([cam[:, 3:5], np.exp(np.clip(cam[:, 5], -30.0, 30.0))])
    dR, J_l = rodrigues_and_left_jacobian(cam[:, :3])
    R = dR @ prob.R0
    K = prob.K0.copy()
    free = prob.free
    f = np.exp(np.clip(x[cc[free] + 6], -30.0, 30.0)) * t[free, 2]
    K[free, 0, 0] = f
    K[free, 1, 1] = f
    X = x[prob.n_cam_params:].reshape(-1, 3)
    return R, J_l, t, K, X


def project(prob: Problem, R: np.ndarray, t: np.ndarray, K: np.ndarray, X: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per observation: rotated points R X (M,3), homogeneous pixels K x_cam (M,3), uv (M,2)."""
    vi, pj = prob.obs_view, prob.obs_point
    RX = np.einsum("mij,mj->mi", R[vi], X[pj])
    p = np.einsum("mij,mj->mi", K[vi], RX + t[vi])
    return RX, p, p[:, :2] / p[:, 2:3]


def residuals(x: np.ndarray, prob: Problem) -> np.ndarray:
    """(2M + prior,) reprojection residuals (px), then the focal priors."""
    R, _, t, K, X = unpack(prob, x)
    r = (project(prob, R, t, K, X)[2] - prob.obs_uv).ravel()
    if prob.n_prior:
        r = np.concatenate([r, prob.prior_A @ x - prob.prior_b])
    return r


def click_residuals(prob: Problem, sol: OptimizeResult) -> np.ndarray:
    """(M,) reprojection residual norms (px) of the clicks at a solution."""
    return np.linalg.norm(sol.fun[:2 * prob.n_obs].reshape(-1, 2), axis=1)


def jacobian_structure(prob: Problem) -> JacobianStructure:
    """Row and column indices of the Jacobian entries, in the order of
    :func:`jacobian_values`.

    Each observation has 2 rows x 10 entries (rotation 3, t_x, t_y, log t_z, log m,
    point 3); the log-m entry of a photo with known intrinsics points at a dummy column P.
    """
    M = prob.n_obs
    P = prob.n_params
    cc = prob.cam_cols[prob.obs_view]
    cols = np.empty((M, 10), dtype=np.int64)
    cols[:, :6] = cc[:, None] + np.arange(6)
    cols[:, 6] = np.where(prob.free[prob.obs_view], cc + 6, P)
    cols[:, 7:] = prob.n_cam_params + 3 * prob.obs_point[:, None] + np.arange(3)
    rows = np.repeat(np.arange(2 * M), 10)
    flat = np.repeat(cols[:, None, :], 2, axis=1).ravel()
    pr, pc = np.nonzero(prob.prior_A)
    return np.concatenate([rows, 2 * M + pr]), np.concatenate([flat, pc])


def jacobian_values(x: np.ndarray, prob: Problem) -> np.ndarray:
    """Analytic Jacobian entries of :func:`residuals`, in :func:`jacobian_structure` order.

    With ``x_cam = exp(r) R0 X + t`` and ``p = K x_cam``, ``uv = p[:2] / p[2]``:
    d uv/d x_cam = (K[:2] - uv K[2]) / p[2]; d x_cam/d r = -[R X]x J_l(r);
    d x_cam/d t = I; d x_cam/d X = R; d t_z/d log t_z = t_z; d uv/d log f = uv - c, and
    log f = log m + log t_z for a free focal length.
    """
    R, J_l, t, K, X = unpack(prob, x)
    vi = prob.obs_view
    RX, p, uv = project(prob, R, t, K, X)
    Km = K[vi]
    duv_dxc = (Km[:, :2, :] - uv[:, :, None] * Km[:, 2:3, :]) / p[:, 2, None, None]
    dlogf = uv - Km[:, :2, 2]
    free = prob.free[vi][:, None]
    data = np.empty((len(vi), 2, 10))
    data[:, :, 0:3] = duv_dxc @ (-skew(RX) @ J_l[vi])
    data[:, :, 3:5] = duv_dxc[:, :, :2]
    data[:, :, 5] = duv_dxc[:, :, 2] * t[vi, 2, None] + np.where(free, dlogf, 0.0)
    data[:, :, 6] = dlogf
    data[:, :, 7:10] = duv_dxc @ R[vi]
    return np.concatenate([data.ravel(), prob.prior_A[np.nonzero(prob.prior_A)]])


def jacobian_dense(x: np.ndarray, prob: Problem, structure: JacobianStructure) -> np.ndarray:
    """(2M + prior, P) Jacobian of :func:`residuals` as a dense array."""
    rows, cols = structure
    P = len(x)
    J = np.zeros((2 * prob.n_obs + prob.n_prior, P + 1))
    J[rows, cols] = jacobian_values(x, prob)
    return J[:, :P]


def jacobian_sparse(x: np.ndarray, prob: Problem, structure: JacobianStructure
                    ) -> scipy.sparse.csr_matrix:
    """(2M + prior, P) Jacobian of :func:`residuals` as a CSR matrix."""
    rows, cols = structure
    P = len(x)
    J = scipy.sparse.csr_matrix((jacobian_values(x, prob), (rows, cols)),
                                shape=(2 * prob.n_obs + prob.n_prior, P + 1))
    return J[:, :P]


def jacobian_sparsity(prob: Problem) -> scipy.sparse.csr_matrix:
    """Boolean (rows, P) non-zero pattern of the bundle-adjustment Jacobian.

    Usable as ``least_squares(..., jac_sparsity=...)`` with finite differences (kept for
    checking the analytic Jacobian and for large problems).
    """
    rows, cols = jacobian_structure(prob)
    P = prob.n_params
    keep = cols < P
    return scipy.sparse.csr_matrix(
        (np.ones(int(keep.sum()), dtype=bool), (rows[keep], cols[keep])),
        shape=(2 * prob.n_obs + prob.n_prior, P))


def solve(prob: Problem, x0: np.ndarray, params: SfmParams) -> OptimizeResult:
    """scipy least_squares (trf, robust loss, x_scale='jac') with the analytic Jacobian.

    With ``params.presolve_lm``, MINPACK's Levenberg-Marquardt (squared loss, QR instead
    of the SVD of each trf step) first runs from ``x0``; the robust trf solve then starts
    from its answer and needs only a few steps. Same minimum, ~20 % less time.

    Args:
        x0: (P,) start (:func:`pack`).
    Returns:
        the ``least_squares`` result (``x`` (P,), ``fun``, ``jac``, ``cost``, ``nfev``, ...).
    """
    structure = jacobian_structure(prob)
    jac: Callable[[np.ndarray, Problem], np.ndarray | scipy.sparse.csr_matrix]
    if params.tr_solver == "exact":
        def jac(x: np.ndarray, p: Problem) -> np.ndarray:
            return jacobian_dense(x, p, structure)
    else:
        def jac(x: np.ndarray, p: Problem) -> scipy.sparse.csr_matrix:
            return jacobian_sparse(x, p, structure)
    if params.presolve_lm and len(x0) <= 2 * prob.n_obs + prob.n_prior:
        x0 = _lm_presolve(prob, x0, params, structure)
    return least_squares(
        residuals, x0, jac=jac, args=(prob,), method="trf", loss=params.loss,
        f_scale=params.loss_scale_px, x_scale="jac", max_nfev=params.max_iterations,
        tr_solver=params.tr_solver, xtol=params.tolerance, ftol=params.tolerance,
        gtol=params.tolerance)


def _lm_presolve(prob: Problem, x0: np.ndarray, params: SfmParams,
                 structure: JacobianStructure) -> np.ndarray:
    """Start of the robust solve: the Levenberg-Marquardt answer from ``x0`` when it is
    sound, else ``x0``.

    An LM answer drifting to a near-orthographic camera (mean focal length above 4x the
    guess) may be the depth-reversed nose, and one that does not halve the cost is no
    better a start; then the trust-region solve starts from the initial cameras.
    """
    pre = least_squares(
        residuals, x0, jac=lambda x, p: jacobian_dense(x, p, structure), args=(prob,),
        method="lm", x_scale="jac", max_nfev=params.max_iterations,
        xtol=params.tolerance, ftol=params.tolerance, gtol=params.tolerance)
    f_pre = np.exp(prob.prior_A[-1:] @ pre.x / max(prob.focal_abs_weight, 1e-300)) \
        if prob.focal_abs_weight > 0 and prob.free.any() else np.ones(1)
    f_0 = np.exp(float(np.mean(prob.log_f0[prob.free]))) if prob.free.any() else 1.0
    if (np.all(np.isfinite(pre.x)) and float(f_pre[0]) < 4.0 * f_0
            and pre.cost <= 0.5 * float(np.sum(residuals(x0, prob) ** 2))):
        return np.asarray(pre.x)
    return x0


def pack(prob: Problem, cams: Sequence[Camera], X: np.ndarray) -> np.ndarray | None:
    """(P,) parameter vector for cameras whose rotations equal ``prob.R0`` (zero
    increments) and (N, 3) points; ``None`` when a camera has the origin behind it."""
    x = np.zeros(prob.n_params)
    for i, c in zip(prob.cam_cols, cams, strict=True):
        if c.t[2] <= 0:
            return None
        x[i + 3:i + 5] = c.t[:2]
        x[i + 5] = math.log(c.t[2])
    for v in np.flatnonzero(prob.free):
        c = cams[int(v)]
        x[prob.cam_cols[v] + 6] = math.log(c.focal_px / c.t[2])
    x[prob.n_cam_params:] = X.ravel()
    return x


def cameras_from_x(prob: Problem, x: np.ndarray) -> list[Camera]:
    """The V cameras of parameters ``x`` (P,), in the bundle-adjustment frame."""
    R, _, t, K, _ = unpack(prob, x)
    return [Camera(K[i].copy(), R[i].copy(), t[i].copy(), *prob.sizes[i])
            for i in range(prob.n_views)]


def points_from_x(prob: Problem, x: np.ndarray) -> np.ndarray:
    """(N, 3) points of parameters ``x`` (P,), in the bundle-adjustment frame."""
    return x[prob.n_cam_params:].reshape(-1, 3)
