"""3D uncertainty of the stage-1 landmarks (paper §3.2): covariance of the eq. 1 solution.

The click noise ``sigma`` is estimated from the final cost and its degrees of freedom
(floored); the landmark covariance is ``sigma^2 (J^T J)^+`` of the free-gauge problem,
propagated through the gauge map to the SPEC frame (:class:`.frame.Gauge`).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse
from scipy.optimize import OptimizeResult

from naseview.stage1_landmarks.frame import Gauge
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.problem import Problem


def click_sigma(prob: Problem, sol: OptimizeResult, params: SfmParams) -> float:
    """Click noise (px): ``sqrt(2 cost / dof)`` with the 7 gauge directions given back,
    floored at ``params.min_sigma_px``."""
    dof = 2 * prob.n_obs + prob.n_prior - len(sol.x) + 7
    sigma_hat = math.sqrt(2.0 * sol.cost / dof) if dof > 0 else 0.0
    return max(sigma_hat, params.min_sigma_px)


def landmark_covariance(jac: np.ndarray | scipy.sparse.spmatrix, prob: Problem,
                        X_ba: np.ndarray, sigma: float, gauge: Gauge) -> np.ndarray:
    """(3N, 3N) covariance of the landmarks in the (provisional) SPEC frame.

    ``sigma^2 (J^T J)^+`` of the free-gauge problem, restricted to the points and
    propagated through the gauge map (origin, axes and scale taken from the landmarks).
    The gauge map is invariant to similarity transforms of its input, so its Jacobian
    annihilates the 7 gauge directions and the pseudo-inverse gives the exact result.

    Args:
        jac: (rows, P) Jacobian at the solution (dense or sparse).
        X_ba: (N, 3) points in the bundle-adjustment frame.
        sigma: click noise (px).
        gauge: the gauge (origin, axes, scale) definition.
    """
    J = jac if isinstance(jac, np.ndarray) else jac.toarray()
    Hp = np.linalg.pinv(J.T @ J, rcond=1e-12, hermitian=True)
    nc = prob.n_cam_params
    Cx = sigma**2 * Hp[nc:, nc:]
    n3 = X_ba.size
    h = 1e-6 * max(float(np.ptp(X_ba, axis=0).max()), 1e-9)
    batch = np.repeat(X_ba.ravel()[None], n3 + 1, axis=0)
    batch[1:] += h * np.eye(n3)
    Y = gauge.apply(batch.reshape(n3 + 1, -1, 3)).reshape(n3 + 1, n3)
    G = ((Y[1:] - Y[0]) / h).T  # (3N out, 3N in)
    return G @ Cx @ G.T


def landmark_blocks(cov: np.ndarray, point_ids: list[str]) -> dict[str, np.ndarray]:
    """id -> (3, 3) diagonal block of a (3N, 3N) covariance."""
    return {lid: cov[3 * j:3 * j + 3, 3 * j:3 * j + 3] for j, lid in enumerate(point_ids)}


GAUGE_SD_MM = 0.05
"""A landmark sd below this (mm) is the gauge's (the origin ``g`` is fixed by it), not a
measured one: warnings neither print it nor compare with it."""


def standard_uncertainty(cov: np.ndarray) -> float:
    """Root of the trace of a (3, 3) covariance (mm), 0 for a non-positive trace."""
    return float(math.sqrt(max(np.trace(cov), 0.0)))
