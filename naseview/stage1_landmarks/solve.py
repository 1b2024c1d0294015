"""Stage 1: 3D landmarks and cameras by bundle adjustment (paper section 3.2, eq. 1).

From the 2D clicks of the 21 landmarks in the four photos, recover the 3D landmarks and a
pinhole camera per photo by minimising the reprojection error

    sum_ij rho(|| uv_ij - project(K_i, R_i, t_i, X_j) ||^2)

with :func:`scipy.optimize.least_squares` (method ``trf``, robust loss ``rho``, analytic
Jacobian with a fixed sparsity pattern, ``x_scale="jac"``; the dense exact trust-region
solver is the fastest at this size, the sparse ``lsmr`` one is available). Unknowns: per
photo an axis-angle rotation, a translation and the focal length (principal point at the
image centre, unless the case gives the intrinsics), and the 3D landmarks seen in at least
two photos.

Initialisation (:func:`initial_cameras`): a four-view rig prior (front; left and right at
~90 degrees yaw; bottom looking up at ~50 degrees), with the in-plane roll and distance
of each photo from a 2D similarity fit of a generic nose template, then linear (DLT)
triangulation and rounds of per-photo resection (PnP) and re-triangulation. Several rig
hypotheses are tried when the first one does not reach a small reprojection error; the
lowest robust cost wins. Suspect clicks that leave-one-out triangulation pins on one
photo are left out of a second solve. Landmarks clicked in one photo only are placed on
their viewing ray (:func:`_place_single`).

The result is expressed in the SPEC §4 frame (:func:`anatomical_frame`): origin at ``g``,
+x to the subject's left (mean of the ``_r`` -> ``_l`` pair vectors), +y up (``sn`` ->
``g`` orthogonalised), +z = x cross y (anterior; checked with ``prn``), and millimetres
from ``case.scale_mm`` (least squares over all given distances).

Per landmark the result reports the reprojection residual in each photo, a 3D uncertainty
(mm, from ``sigma^2 (J^T J)^+`` propagated through the gauge) and suspect clicks.

Example
-------
>>> from naseview.case import read_case
>>> res = bundle_adjust(read_case("assets/demo-case"))      # doctest: +SKIP
>>> res.landmarks["prn"], res.uncertainty_mm["prn"]         # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from naseview.camera import Camera, intrinsics, look_at
from naseview.case import Case
from naseview.errors import NaseviewError
from naseview.geometry.mesh import umeyama
from naseview.landmarks import LANDMARK_IDS, LANDMARKS, MIDLINE_IDS, VIEWS

# A generic adult nose in the SPEC frame (mm, origin g), written by hand from textbook
# soft-tissue proportions (alar width 34 mm, nasal length n-prn ~ 44 mm, tip projection
# ~ 20 mm). Only used to start the camera estimation; never part of a result.
_TEMPLATE_MM: dict[str, tuple[float, float, float]] = {
    "g": (0.0, 0.0, 0.0), "n": (0.0, -12.0, -6.0), "k": (0.0, -24.0, -1.0),
    "r": (0.0, -31.0, 3.0), "prn": (0.0, -47.0, 14.0), "c": (0.0, -53.0, 9.0),
    "sn": (0.0, -57.0, -3.0),
    "mf_l": (9.0, -10.0, -11.0), "int_l": (11.0, -40.0, 1.0), "al_l": (17.0, -48.0, -6.0),
    "alp_l": (7.0, -52.0, 7.0), "alpp_l": (5.0, -55.0, 3.0), "ac_l": (15.0, -52.0, -10.0),
    "md_l": (6.0, -51.0, 9.0),
}
for _k in list(_TEMPLATE_MM):
    if _k.endswith("_l"):
        _x, _y, _z = _TEMPLATE_MM[_k]
        _TEMPLATE_MM[_k[:-2] + "_r"] = (-_x, _y, _z)

_PAIR_BASES: tuple[str, ...] = tuple(
    lid[:-2] for lid in LANDMARK_IDS if lid.endswith("_l"))


@dataclass(frozen=True)
class SfmParams:
    """Every tunable of stage 1, with its default.

    Attributes:
        loss: robust loss of :func:`scipy.optimize.least_squares` (``"linear"``,
            ``"huber"``, ``"soft_l1"``, ``"cauchy"``, ``"arctan"``), applied per pixel
            coordinate.
        loss_scale_px: residual (px) where the robust loss starts to flatten.
        max_iterations: cap on residual evaluations of one least-squares solve.
        rig_yaw_deg: prior yaw of the left / right cameras from the front (degrees).
        bottom_elevation_deg: prior elevation of the bottom camera below the front one.
        hypothesis_step_deg: offset of the alternative rig hypotheses (degrees).
        accept_rmse_px: stop trying rig hypotheses once the inlier RMSE is below this.
        resection_rounds: rounds of per-photo resection (PnP) and re-triangulation that
            refine the initial cameras before the bundle adjustment.
        focal_guess: initial focal length as a multiple of the larger image side, for
            photos without known intrinsics.
        focal_coupling: soft prior tying the per-photo focal lengths together: the
            standard deviation of log(f_photo / f_mean) (0.1: photos within ~10 % of each
            other, as with one phone; ~0.02 means "same camera, same zoom"; give the focal
            lengths in case.json when photos were taken at different zooms). Without it a
            photo with few, shallow landmarks (the bottom one) can drift towards an
            infinite focal length, because focal length and distance are nearly
            interchangeable there. 0 disables it.
        focal_prior_sd: very weak prior on the mean focal length of the photos without
            known intrinsics: sd of log(f / (focal_guess x larger image side)) (3: a factor
            20 is one sd). It only keeps all photos from drifting together to an infinite
            focal length (orthographic), where a depth-reversed nose fits as well; when the
            clicks barely constrain the focal length it still pulls it a few percent
            towards the guess. 0 disables it.
        max_focal_factor: a focal length above this multiple of the larger image side
            (nearly orthographic: depth may be reversed) or below a quarter of it gets a
            warning.
        tr_solver: trust-region solver of ``least_squares``: ``"exact"`` (dense SVD, the
            fastest for ~21 landmarks x 4 photos) or ``"lsmr"`` (sparse Jacobian).
        presolve_lm: start the robust trf solve from a Levenberg-Marquardt solution with
            the squared loss (faster; same minimum).
        tolerance: ``xtol``, ``ftol`` and ``gtol`` of ``least_squares``.
        min_clicks_per_photo: fewer landmark clicks in a photo is an error.
        min_spread_ratio: a photo whose clicks are thinner than this fraction of their
            length (ratio of the 2D singular values) is "collinear" and an error.
        max_rmse_px: inlier reprojection RMSE above this after all hypotheses means the
            adjustment failed (error).
        max_suspect_fraction: more suspect clicks than this fraction also means failure.
        suspect_min_px, suspect_factor: a click is suspect when its residual exceeds
            ``max(suspect_min_px, suspect_factor * median residual)``.
        min_sigma_px: floor of the click noise (px) used for the 3D uncertainty.
        max_uncertainty_mm: a landmark with a larger 3D uncertainty gets a warning.
        drop_suspects: re-solve once without suspect clicks that leave-one-out
            triangulation pins on one photo (landmarks clicked in 3+ photos); they are
            reported as ignored.
        symmetric_fill: place a landmark clicked in one photo only on its viewing ray
            (:func:`_place_single`: symmetry, midline plane, template depth); else it is
            left out.
        symmetry_sd_mm: how far (sd, mm) a landmark may be from the mirror image of its
            partner, or a midline landmark from the midsagittal plane.
        template_sd_mm: sd (mm) of the weak depth prior from the generic nose template.
        max_single_view_sd_mm: a one-photo landmark whose depth is more uncertain than
            this is left out.
    """

    loss: str = "huber"
    loss_scale_px: float = 3.0
    max_iterations: int = 200
    rig_yaw_deg: float = 90.0
    bottom_elevation_deg: float = 50.0
    hypothesis_step_deg: float = 20.0
    accept_rmse_px: float = 4.0
    resection_rounds: int = 3
    focal_guess: float = 2.0
    focal_coupling: float = 0.1
    focal_prior_sd: float = 3.0
    max_focal_factor: float = 8.0
    tr_solver: str = "exact"
    presolve_lm: bool = True
    tolerance: float = 1e-6
    min_clicks_per_photo: int = 6
    min_spread_ratio: float = 0.03
    max_rmse_px: float = 8.0
    max_suspect_fraction: float = 0.25
    suspect_min_px: float = 3.0
    suspect_factor: float = 4.0
    min_sigma_px: float = 0.5
    max_uncertainty_mm: float = 3.0
    drop_suspects: bool = True
    symmetric_fill: bool = True
    symmetry_sd_mm: float = 1.0
    template_sd_mm: float = 4.0
    max_single_view_sd_mm: float = 5.0


@dataclass(frozen=True)
class SuspectClick:
    """A click whose reprojection residual is far above the rest.

    Attributes:
        landmark, view: the click.
        residual_px: its distance (px) from the reprojection of the adjusted landmark.
        ignored: the click was left out of the final adjustment (the landmark's other
            photos agree with each other and not with it).
        other_views: for a landmark clicked in two photos only, the other photo: the two
            clicks disagree and either may be wrong.
    """

    landmark: str
    view: str
    residual_px: float
    ignored: bool = False
    other_views: tuple[str, ...] = ()

    def message(self) -> str:
        if self.other_views:
            others = " and ".join(repr(v) for v in self.other_views)
            return (f"landmark {self.landmark!r}: the clicks in photos {self.view!r} and "
                    f"{others} disagree ({self.residual_px:.1f} px); check both")
        action = "it was left out; check it" if self.ignored else "check it"
        return (f"click {self.landmark!r} in photo {self.view!r} is {self.residual_px:.1f} px "
                f"from where the other photos put it; {action}")

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"landmark": self.landmark, "view": self.view,
                               "residual_px": round(float(self.residual_px), 3),
                               "ignored": self.ignored}
        if self.other_views:
            out["other_views"] = list(self.other_views)
        return out


@dataclass
class SfmResult:
    """Stage-1 result in the SPEC frame (mm, origin g).

    Attributes:
        landmarks: id -> (3,) position (mm) of every landmark that could be placed.
        cameras: view -> :class:`~naseview.camera.Camera` in the same frame.
        residuals_px: view -> id -> reprojection residual (px) of each click.
        uncertainty_mm: id -> 3D standard uncertainty (mm, root of the covariance trace),
            relative to the frame the adjusted landmarks define: 0 for an adjusted ``g``
            (the origin); for a ``g`` clicked in one photo, its placement uncertainty.
        covariance_mm2: id -> (3, 3) covariance (mm^2).
        reprojection_rmse_px: RMS reprojection error over the adjusted clicks.
        suspect_clicks: clicks with a residual far above the rest.
        warnings: one-line messages for the user.
        one_photo: ids clicked in one photo only and placed on their viewing ray -> how:
            ``"symmetry"`` (mirror image of the partner), ``"midline"`` (midsagittal
            plane) or ``"template"`` (depth of the generic nose; weak).
        left_out: ids that were clicked but could not be placed.
        sigma_px: click noise used for the uncertainty (estimate, floored).
        hypothesis: the rig hypothesis that won, e.g. ``"yaw 90, bottom 50"``.
        converged: the least-squares solver reported convergence.
        n_evaluations: residual evaluations of the final solve.
    """

    landmarks: dict[str, np.ndarray]
    cameras: dict[str, Camera]
    residuals_px: dict[str, dict[str, float]]
    uncertainty_mm: dict[str, float]
    covariance_mm2: dict[str, np.ndarray]
    reprojection_rmse_px: float
    suspect_clicks: list[SuspectClick] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    one_photo: dict[str, str] = field(default_factory=dict)
    left_out: tuple[str, ...] = ()
    sigma_px: float = 0.0
    hypothesis: str = ""
    converged: bool = True
    n_evaluations: int = 0


# --------------------------------------------------------------------------- geometry


def _skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices ``[v]x``."""
    k = np.zeros(v.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2] = -v[..., 2], v[..., 1]
    k[..., 1, 0], k[..., 1, 2] = v[..., 2], -v[..., 0]
    k[..., 2, 0], k[..., 2, 1] = -v[..., 1], v[..., 0]
    return k


def _so3_coefficients(th: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sin(t)/t, (1-cos t)/t^2, (t-sin t)/t^3 with series near 0."""
    small = th < 1e-4
    ts = np.where(small, 1.0, th)
    t2 = th * th
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(ts)) / ts**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (ts - np.sin(ts)) / ts**3)
    return a, b, c


def so3_exp(rvec: ArrayLike) -> np.ndarray:
    """(V, 3) axis-angle (radians) -> (V, 3, 3) rotations (vectorised Rodrigues)."""
    r = np.asarray(rvec, dtype=np.float64).reshape(-1, 3)
    a, b, _ = _so3_coefficients(np.sqrt((r * r).sum(1)))
    k = _skew(r)
    return np.eye(3) + a[:, None, None] * k + b[:, None, None] * (k @ k)


def so3_left_jacobian(rvec: ArrayLike) -> np.ndarray:
    """(V, 3) axis-angle -> (V, 3, 3) left Jacobian J with exp(r + d) ~ exp(J d) exp(r)."""
    r = np.asarray(rvec, dtype=np.float64).reshape(-1, 3)
    _, b, c = _so3_coefficients(np.sqrt((r * r).sum(1)))
    k = _skew(r)
    return np.eye(3) + b[:, None, None] * k + c[:, None, None] * (k @ k)


def rig_prior_rotation(view: str, yaw_deg: float = 90.0,
                       elevation_deg: float = 50.0) -> np.ndarray:
    """(3, 3) world-to-camera rotation of the four-view rig prior for ``view``.

    ``front`` looks along -z; ``left`` sits on the subject's left (+x) at ``yaw_deg`` from
    the front; ``right`` mirrors it; ``bottom`` sits below the front camera at
    ``elevation_deg`` and looks up at the nose. Image up is world up tilted with the camera.
    """
    yaw, el = math.radians(yaw_deg), math.radians(elevation_deg)
    if view == "front":
        eye, up = [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]
    elif view == "left":
        eye, up = [math.sin(yaw), 0.0, math.cos(yaw)], [0.0, 1.0, 0.0]
    elif view == "right":
        eye, up = [-math.sin(yaw), 0.0, math.cos(yaw)], [0.0, 1.0, 0.0]
    elif view == "bottom":
        eye, up = [0.0, -math.sin(el), math.cos(el)], [0.0, math.cos(el), math.sin(el)]
    else:
        raise ValueError(f"unknown view {view!r}")
    return look_at(eye, [0.0, 0.0, 0.0], up, 1.0, 2, 2).R


def fit_similarity_2d(src: ArrayLike, dst: ArrayLike) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares 2D similarity ``dst ~ s * Q @ src + b`` (Umeyama, no reflection).

    Args:
        src, dst: (N, 2) corresponding points, N >= 2.
    Returns:
        scale s, (2, 2) rotation Q, (2,) translation b.
    """
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    u, sv, vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    q = u @ np.diag([1.0, d]) @ vt
    var = float((a**2).sum())
    s = float((sv * [1.0, d]).sum() / var) if var > 0 else 1.0
    return s, q, md - s * q @ ms


def triangulate_dlt(cameras: Sequence[Camera], uv: ArrayLike, seen: ArrayLike) -> np.ndarray:
    """Linear (DLT) triangulation of N points, each seen by two or more of V cameras.

    Args:
        cameras: the V cameras.
        uv: (N, V, 2) pixel observations (ignored where not ``seen``).
        seen: (N, V) bool, which camera sees which point (>= 2 per point).
    Returns:
        (N, 3) points in the cameras' world frame.
    """
    uv = np.asarray(uv, dtype=np.float64)
    seen = np.asarray(seen, dtype=bool)
    N, V = seen.shape
    A = np.zeros((N, 2 * V, 4))
    for i, cam in enumerate(cameras):
        h = np.concatenate([uv[:, i], np.ones((N, 1))], axis=1)
        xn = np.linalg.solve(cam.K, h.T).T  # normalised image coordinates
        P = np.hstack([cam.R, cam.t[:, None]])
        w = seen[:, i, None].astype(np.float64)
        A[:, 2 * i] = w * (xn[:, 0, None] * P[2] - xn[:, 2, None] * P[0])
        A[:, 2 * i + 1] = w * (xn[:, 1, None] * P[2] - xn[:, 2, None] * P[1])
    _, _, vt = np.linalg.svd(A)
    h = vt[:, -1]
    return h[:, :3] / h[:, 3:4]


@dataclass(frozen=True)
class _GaugeSpec:
    """Landmark indices that define the SPEC frame of N points (internal)."""

    origin: int         # g (n when g is not among the points)
    left: np.ndarray    # (P,) indices of _l members of pairs
    right: np.ndarray   # (P,) their _r partners
    low: int            # sn, else c, else prn
    scale_a: np.ndarray  # (S,) scale distance endpoints
    scale_b: np.ndarray
    scale_mm: np.ndarray  # (S,)

    @staticmethod
    def build(point_ids: Sequence[str], scale_mm: dict[tuple[str, str], float] | None = None
              ) -> _GaugeSpec:
        """Raises ValueError naming what is missing."""
        idx = {lid: j for j, lid in enumerate(point_ids)}
        origin = "g" if "g" in idx else "n"  # n: provisional origin while g is placed
        if origin not in idx:
            raise ValueError("g (or n) is needed for the origin")
        pairs = [(idx[b + "_l"], idx[b + "_r"]) for b in _PAIR_BASES
                 if b + "_l" in idx and b + "_r" in idx]
        if not pairs:
            raise ValueError("no left/right landmark pair")
        low = next((idx[i] for i in ("sn", "c", "prn") if i in idx), None)
        if low is None:
            raise ValueError("no lower midline landmark (sn, c or prn)")
        sc = [(idx[a], idx[b], d) for (a, b), d in (scale_mm or {}).items()
              if a in idx and b in idx]
        return _GaugeSpec(idx[origin], np.array([p[0] for p in pairs]),
                          np.array([p[1] for p in pairs]), low,
                          np.array([c[0] for c in sc], dtype=np.int64),
                          np.array([c[1] for c in sc], dtype=np.int64),
                          np.array([c[2] for c in sc], dtype=np.float64))

    def frames(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, N, 3) points -> origins (B, 3) and rotations (B, 3, 3) (rows x, y, z)."""
        x = (X[:, self.left] - X[:, self.right]).sum(1)
        x /= np.linalg.norm(x, axis=1, keepdims=True)
        y = X[:, self.origin] - X[:, self.low]
        y -= (y * x).sum(1, keepdims=True) * x
        y /= np.linalg.norm(y, axis=1, keepdims=True)
        return X[:, self.origin], np.stack([x, y, np.cross(x, y)], axis=1)

    def scales(self, X: np.ndarray) -> np.ndarray:
        """(B, N, 3) -> (B,) least-squares scale to millimetres; without a usable distance,
        the scale making the RMS distance from the origin 1 (so the gauge stays fixed)."""
        if not len(self.scale_mm):
            r = X - X[:, self.origin][:, None]
            return 1.0 / np.sqrt((r * r).sum(2).mean(1))
        d = np.linalg.norm(X[:, self.scale_a] - X[:, self.scale_b], axis=2)
        return (d * self.scale_mm).sum(1) / (d * d).sum(1)

    def apply(self, X: np.ndarray) -> np.ndarray:
        """(B, N, 3) points in any similarity frame -> (B, N, 3) SPEC-frame points (mm)."""
        o, R = self.frames(X)
        return self.scales(X)[:, None, None] * np.einsum("bij,bnj->bni", R, X - o[:, None])


def anatomical_frame(points: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Origin and axes of the SPEC §4 frame from landmark positions (any similarity frame).

    +x: sum of the ``_r`` -> ``_l`` pair vectors; +y: from ``sn`` (else ``c``, else
    ``prn``) towards ``g``, orthogonalised against x; +z = x cross y.

    Args:
        points: id -> (3,) positions; must hold ``g``, a lower midline landmark and at
            least one left/right pair.
    Returns:
        origin (3,) (= g) and (3, 3) rotation whose rows are the x, y, z axes, so that
        ``Rg @ (X - origin)`` are SPEC coordinates (before scaling).
    Raises:
        ValueError: the landmarks needed are missing.
    """
    ids = list(points)
    spec = _GaugeSpec.build(ids)
    X = np.array([points[i] for i in ids], dtype=np.float64)[None]
    o, R = spec.frames(X)
    return o[0], R[0]


def midsagittal_plane(points: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Plane fitted to the midline landmarks and the midpoints of left/right pairs.

    Returns:
        a point (3,) on the plane and its unit normal (3,), oriented towards the subject's
        left (along the ``_r`` -> ``_l`` pair vectors).
    """
    pts = [points[i] for i in MIDLINE_IDS if i in points]
    dirs = np.zeros(3)
    for base in _PAIR_BASES:
        left, right = points.get(base + "_l"), points.get(base + "_r")
        if left is not None and right is not None:
            pts.append(0.5 * (left + right))
            dirs += left - right
    P = np.asarray(pts)
    c = P.mean(0)
    _, _, vt = np.linalg.svd(P - c)
    n = vt[-1]
    if np.linalg.norm(dirs) > 0 and n @ dirs < 0:
        n = -n
    return c, n


def mirror_points(X: ArrayLike, plane_point: ArrayLike, normal: ArrayLike) -> np.ndarray:
    """(N, 3) points mirrored across the plane through ``plane_point`` with unit ``normal``."""
    X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normal, dtype=np.float64)
    d = (X - plane_point) @ n
    return X - 2.0 * d[:, None] * n


# ------------------------------------------------------------------- bundle adjustment


@dataclass
class _Problem:
    """Observations and parameter layout of one bundle adjustment (internal).

    Parameters: per view a rotation increment on ``R0`` (3), the translation ``t_x, t_y``
    (mm), ``log t_z`` and, when the focal length is unknown, ``log m`` with the
    magnification ``m = f / t_z`` (px per mm at the origin's depth); then the points
    (N x 3). With (m, t_z) instead of (f, t_z), the near-ambiguity between focal length and
    distance (weak perspective) lies along one parameter axis, where ``x_scale="jac"``
    lets the trust region take long steps.
    """

    views: list[str]
    point_ids: list[str]
    obs_view: np.ndarray   # (M,) view index
    obs_point: np.ndarray  # (M,) point index
    obs_uv: np.ndarray     # (M, 2) px
    K0: np.ndarray         # (V, 3, 3) intrinsics (focal overwritten where free)
    sizes: list[tuple[int, int]]
    free: np.ndarray       # (V,) bool, focal length estimated
    focal_weight: float = 0.0  # weight of the focal coupling prior (px per unit log f)
    focal_abs_weight: float = 0.0  # weight of the prior on the mean log focal length
    log_f0: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (V,) its centre
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

    def __post_init__(self) -> None:
        sizes = np.where(self.free, 7, 6)
        self.cam_cols = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        """(V,) first column of each view's block (7 columns if free focal, else 6)."""
        self.n_cam_params = int(sizes.sum())
        # Focal priors, linear in the parameters (log f = log m + log t_z):
        # coupling rows w (log f_i - mean log f), and one row w_abs mean(log f - log f0).
        P = self.n_cam_params + 3 * self.n_points
        fc = self.cam_cols[self.free]
        n = len(fc)
        L = np.zeros((n, P))  # row i: log f of free view i
        L[np.arange(n), fc + 5] = 1.0
        L[np.arange(n), fc + 6] = 1.0
        rows, rhs = [], []
        if self.focal_weight > 0 and n >= 2:
            rows.append(self.focal_weight * (L - L.mean(0)))
            rhs.append(np.zeros(n))
        if self.focal_abs_weight > 0 and n >= 1:
            rows.append(self.focal_abs_weight * L.mean(0)[None])
            rhs.append([self.focal_abs_weight * float(np.mean(self.log_f0[self.free]))])
        self.prior_A = np.vstack(rows) if rows else np.zeros((0, P))
        self.prior_b = np.concatenate(rhs) if rhs else np.zeros(0)

    @property
    def n_prior(self) -> int:
        """Rows of the focal priors (coupling of 2+ free focal lengths, mean focal)."""
        return len(self.prior_b)


def _unpack(prob: _Problem, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                    np.ndarray, np.ndarray]:
    """Parameters -> (rvec (V,3), R (V,3,3), t (V,3), K (V,3,3), X (N,3))."""
    cc = prob.cam_cols
    cam = x[cc[:, None] + np.arange(6)]
    rvec = cam[:, :3]
    t = np.column_stack([cam[:, 3:5], np.exp(np.clip(cam[:, 5], -30.0, 30.0))])
    R = so3_exp(rvec) @ prob.R0
    K = prob.K0.copy()
    free = prob.free
    f = np.exp(np.clip(x[cc[free] + 6], -30.0, 30.0)) * t[free, 2]
    K[free, 0, 0] = f
    K[free, 1, 1] = f
    X = x[prob.n_cam_params:].reshape(-1, 3)
    return rvec, R, t, K, X


def _project(prob: _Problem, R: np.ndarray, t: np.ndarray, K: np.ndarray, X: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per observation: rotated points R X (M,3), homogeneous pixels K x_cam (M,3), uv (M,2)."""
    vi, pj = prob.obs_view, prob.obs_point
    RX = np.einsum("mij,mj->mi", R[vi], X[pj])
    p = np.einsum("mij,mj->mi", K[vi], RX + t[vi])
    return RX, p, p[:, :2] / p[:, 2:3]


def _residuals(x: np.ndarray, prob: _Problem) -> np.ndarray:
    """(2M + prior,) reprojection residuals (px), then the focal priors."""
    _, R, t, K, X = _unpack(prob, x)
    r = (_project(prob, R, t, K, X)[2] - prob.obs_uv).ravel()
    if prob.n_prior:
        r = np.concatenate([r, prob.prior_A @ x - prob.prior_b])
    return r


def _jac_structure(prob: _Problem) -> tuple[np.ndarray, np.ndarray]:
    """Row and column indices of the Jacobian entries, in the order of :func:`_jac_values`.

    Each observation has 2 rows x 10 entries (rotation 3, t_x, t_y, log t_z, log m,
    point 3); the log-m entry of a photo with known intrinsics points at a dummy column P.
    """
    M = prob.n_obs
    P = prob.n_cam_params + 3 * prob.n_points
    cc = prob.cam_cols[prob.obs_view]
    cols = np.empty((M, 10), dtype=np.int64)
    cols[:, :6] = cc[:, None] + np.arange(6)
    cols[:, 6] = np.where(prob.free[prob.obs_view], cc + 6, P)
    cols[:, 7:] = prob.n_cam_params + 3 * prob.obs_point[:, None] + np.arange(3)
    rows = np.repeat(np.arange(2 * M), 10)
    cols = np.repeat(cols[:, None, :], 2, axis=1).ravel()
    pr, pc = np.nonzero(prob.prior_A)
    return np.concatenate([rows, 2 * M + pr]), np.concatenate([cols, pc])


def _jac_values(x: np.ndarray, prob: _Problem) -> np.ndarray:
    """Analytic Jacobian entries of :func:`_residuals`, in :func:`_jac_structure` order.

    With ``x_cam = exp(r) R0 X + t`` and ``p = K x_cam``, ``uv = p[:2] / p[2]``:
    d uv/d x_cam = (K[:2] - uv K[2]) / p[2]; d x_cam/d r = -[R X]x J_l(r);
    d x_cam/d t = I; d x_cam/d X = R; d t_z/d log t_z = t_z; d uv/d log f = uv - c, and
    log f = log m + log t_z for a free focal length.
    """
    rvec, R, t, K, X = _unpack(prob, x)
    vi = prob.obs_view
    RX, p, uv = _project(prob, R, t, K, X)
    Km = K[vi]
    duv_dxc = (Km[:, :2, :] - uv[:, :, None] * Km[:, 2:3, :]) / p[:, 2, None, None]
    dlogf = uv - Km[:, :2, 2]
    free = prob.free[vi][:, None]
    data = np.empty((len(vi), 2, 10))
    data[:, :, 0:3] = duv_dxc @ (-_skew(RX) @ so3_left_jacobian(rvec)[vi])
    data[:, :, 3:5] = duv_dxc[:, :, :2]
    data[:, :, 5] = duv_dxc[:, :, 2] * t[vi, 2, None] + np.where(free, dlogf, 0.0)
    data[:, :, 6] = dlogf
    data[:, :, 7:10] = duv_dxc @ R[vi]
    return np.concatenate([data.ravel(), prob.prior_A[np.nonzero(prob.prior_A)]])


def _jacobian_dense(x: np.ndarray, prob: _Problem, structure: tuple[np.ndarray, np.ndarray]
                    ) -> np.ndarray:
    rows, cols = structure
    P = len(x)
    J = np.zeros((2 * prob.n_obs + prob.n_prior, P + 1))
    J[rows, cols] = _jac_values(x, prob)
    return J[:, :P]


def _jacobian_sparse(x: np.ndarray, prob: _Problem, structure: tuple[np.ndarray, np.ndarray]
                     ) -> scipy.sparse.csr_matrix:
    rows, cols = structure
    P = len(x)
    J = scipy.sparse.csr_matrix((_jac_values(x, prob), (rows, cols)),
                                shape=(2 * prob.n_obs + prob.n_prior, P + 1))
    return J[:, :P]


def jacobian_sparsity(prob: _Problem) -> scipy.sparse.csr_matrix:
    """Boolean (rows, P) non-zero pattern of the bundle-adjustment Jacobian.

    Usable as ``least_squares(..., jac_sparsity=...)`` with finite differences (kept for
    checking the analytic Jacobian and for large problems).
    """
    rows, cols = _jac_structure(prob)
    P = prob.n_cam_params + 3 * prob.n_points
    keep = cols < P
    return scipy.sparse.csr_matrix(
        (np.ones(int(keep.sum()), dtype=bool), (rows[keep], cols[keep])),
        shape=(2 * prob.n_obs + prob.n_prior, P))


def _solve(prob: _Problem, x0: np.ndarray, params: SfmParams) -> Any:
    """scipy least_squares (trf, robust loss, x_scale='jac') with the analytic Jacobian.

    With ``params.presolve_lm``, MINPACK's Levenberg-Marquardt (squared loss, QR instead
    of the SVD of each trf step) first runs from ``x0``; the robust trf solve then starts
    from its answer and needs only a few steps. Same minimum, ~20 % less time.
    """
    structure = _jac_structure(prob)
    if params.tr_solver == "exact":
        def jac(x: np.ndarray, p: _Problem) -> Any:
            return _jacobian_dense(x, p, structure)
    else:
        def jac(x: np.ndarray, p: _Problem) -> Any:
            return _jacobian_sparse(x, p, structure)
    if params.presolve_lm and len(x0) <= 2 * prob.n_obs + prob.n_prior:
        pre = least_squares(
            _residuals, x0, jac=lambda x, p: _jacobian_dense(x, p, structure), args=(prob,),
            method="lm", x_scale="jac", max_nfev=params.max_iterations,
            xtol=params.tolerance, ftol=params.tolerance, gtol=params.tolerance)
        f_pre = np.exp(prob.prior_A[-1:] @ pre.x / max(prob.focal_abs_weight, 1e-300)) \
            if prob.focal_abs_weight > 0 and prob.free.any() else np.ones(1)
        f_0 = np.exp(float(np.mean(prob.log_f0[prob.free]))) if prob.free.any() else 1.0
        # an LM answer drifting to a near-orthographic camera may be the depth-reversed
        # nose; then the trust-region solve starts from the initial cameras instead
        if (np.all(np.isfinite(pre.x)) and float(f_pre[0]) < 4.0 * f_0
                and pre.cost <= 0.5 * float(np.sum(_residuals(x0, prob) ** 2))):
            x0 = pre.x
    return least_squares(
        _residuals, x0, jac=jac, args=(prob,), method="trf", loss=params.loss,
        f_scale=params.loss_scale_px, x_scale="jac", max_nfev=params.max_iterations,
        tr_solver=params.tr_solver, xtol=params.tolerance, ftol=params.tolerance,
        gtol=params.tolerance)


def _pack(prob: _Problem, cams: list[Camera], X: np.ndarray) -> np.ndarray | None:
    """Parameter vector for cameras whose rotations equal ``prob.R0`` (zero increments);
    ``None`` when a camera has the origin behind it."""
    x = np.zeros(prob.n_cam_params + 3 * prob.n_points)
    for i, c in zip(prob.cam_cols, cams, strict=True):
        if c.t[2] <= 0:
            return None
        x[i + 3:i + 5] = c.t[:2]
        x[i + 5] = math.log(c.t[2])
    for v in np.flatnonzero(prob.free):
        c = cams[v]
        x[prob.cam_cols[v] + 6] = math.log(c.focal_px / c.t[2])
    x[prob.n_cam_params:] = X.ravel()
    return x


def _cameras_from_x(prob: _Problem, x: np.ndarray) -> list[Camera]:
    _, R, t, K, _ = _unpack(prob, x)
    return [Camera(K[i].copy(), R[i].copy(), t[i].copy(), *prob.sizes[i])
            for i in range(prob.n_views)]


# ----------------------------------------------------------------------- initialisation


def _pnp(cam: Camera, X: np.ndarray, uv: np.ndarray) -> Camera | None:
    """Refine the pose of ``cam`` (intrinsics fixed) by iterative PnP; None if it fails."""
    import cv2

    rvec, _ = cv2.Rodrigues(cam.R)
    ok, rvec, tvec = cv2.solvePnP(X.astype(np.float64), uv.astype(np.float64), cam.K, None,
                                  rvec.copy(), cam.t.reshape(3, 1).copy(),
                                  useExtrinsicGuess=True, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok or not np.all(np.isfinite(tvec)):
        return None
    R, _ = cv2.Rodrigues(rvec)
    new = Camera(cam.K, R, tvec.ravel(), cam.width, cam.height)
    if np.any(new.depth(X) <= 0):
        return None
    return new


def _template_camera(R0: np.ndarray, K: np.ndarray, size: tuple[int, int],
                     clicks: dict[str, np.ndarray]) -> Camera:
    """Camera from a prior rotation and the clicks, using the generic nose template.

    A 2D similarity between the template seen orthographically along ``R0`` and the clicks
    gives the in-plane roll (any angle) and the distance. The out-of-plane angles stay
    those of the prior: PnP on the template is not used, because in a profile photo the
    midline landmarks are nearly planar and face the camera, so its yaw flips.
    """
    ids = [i for i in clicks if i in _TEMPLATE_MM]
    T = np.array([_TEMPLATE_MM[i] for i in ids])
    uv = np.array([clicks[i] for i in ids])
    p2 = T @ R0[:2].T  # orthographic camera x (right), y (down)
    s, q, b = fit_similarity_2d(p2, uv)
    roll = np.eye(3)
    roll[:2, :2] = q
    R = roll @ R0
    f = 0.5 * (K[0, 0] + K[1, 1])
    d = f / max(s, 1e-9)
    c3 = T.mean(0)
    uc = s * q @ (R0[:2] @ c3) + b
    xc = np.array([(uc[0] - K[0, 2]) / f * d, (uc[1] - K[1, 2]) / f * d, d])
    return Camera(K, R, xc - R @ c3, *size)


def initial_cameras(case: Case, views: list[str], point_ids: list[str],
                    yaw_deg: float, elevation_deg: float, params: SfmParams
                    ) -> tuple[list[Camera], np.ndarray]:
    """Initial cameras and 3D points for one rig hypothesis.

    Rig prior -> per-photo template fit (roll, distance) -> DLT triangulation ->
    ``resection_rounds`` x (per-photo resection by PnP on the triangulated points -> DLT).

    Returns:
        cameras (one per view, in the bundle-adjustment frame) and (N, 3) points.
    """
    cams = []
    for v in views:
        view = case.views[v]
        K = view.known_K()
        if K is None:
            K = intrinsics(params.focal_guess * max(view.width, view.height), view.width,
                           view.height)
        R0 = rig_prior_rotation(v, yaw_deg, elevation_deg)
        clicks = {i: p for i, p in view.landmarks.items() if i in LANDMARK_IDS}
        cams.append(_template_camera(R0, K, (view.width, view.height), clicks))

    uv = np.zeros((len(point_ids), len(views), 2))
    seen = np.zeros((len(point_ids), len(views)), dtype=bool)
    for i, v in enumerate(views):
        lm = case.views[v].landmarks
        for j, lid in enumerate(point_ids):
            if lid in lm:
                uv[j, i], seen[j, i] = lm[lid], True
    X = triangulate_dlt(cams, uv, seen)
    for _ in range(params.resection_rounds):
        new = []
        for i, cam in enumerate(cams):
            sel = seen[:, i]
            r = _pnp(cam, X[sel], uv[sel, i]) if sel.sum() >= 4 else None
            new.append(r if r is not None else cam)
        cams = new
        X = triangulate_dlt(cams, uv, seen)
    return cams, X


# ------------------------------------------------------------------------ validation


def _case_file(case: Case) -> str:
    return str(case.root / "case.json")


def _check_inputs(case: Case, params: SfmParams) -> None:
    """One-line errors for photos with too few or collinear clicks and a missing g."""
    where = _case_file(case)
    for v in [v for v in VIEWS if v in case.views]:  # a subset: [NEW] guidance hints
        view = case.views[v]
        ids = [i for i in view.landmarks if i in LANDMARK_IDS]
        if len(ids) < params.min_clicks_per_photo:
            raise NaseviewError(
                f"{where}: key 'views.{v}.landmarks': only {len(ids)} landmark clicks in "
                f"photo {v!r}; click at least {params.min_clicks_per_photo} of the 21 "
                "landmarks in every photo")
        P = np.array([view.landmarks[i] for i in ids])
        sv = np.linalg.svd(P - P.mean(0), compute_uv=False)
        if sv[0] <= 0 or sv[1] / sv[0] < params.min_spread_ratio:
            raise NaseviewError(
                f"{where}: key 'views.{v}.landmarks': the clicks in photo {v!r} lie on one "
                "line; check that they were placed on this photo (they must spread over "
                "the nose)")
    for v, top in (("front", ("g", "n", "prn")), ("bottom", ("prn", "c"))):
        if v in case.views and _sides_swapped(case.views[v].landmarks, top):
            raise NaseviewError(
                f"{where}: key 'views.{v}.landmarks': in photo {v!r} the _l landmarks lie on "
                "the image left of their _r partners; _l/_r are the subject's sides (the "
                f"subject's left is on the image right in the {v} photo): swap the labels")
    if not any("g" in case.views[v].landmarks for v in case.views):
        raise NaseviewError(
            f"{where}: key 'views.*.landmarks.g': glabella g (the origin of the 3D frame) is "
            "not clicked; click it in the front photo and in a profile photo")


def _sides_swapped(clicks: dict[str, np.ndarray], top: tuple[str, ...]) -> bool:
    """True when most left/right pairs are mirrored in a photo facing the subject.

    "Up" in the photo is from ``sn`` to the first available of ``top``; the subject's left
    is then 90 degrees clockwise of it on screen (image right when upright), whatever the
    roll of the photo. Needs ``sn`` and two pairs; otherwise False.
    """
    up_id = next((i for i in top if i in clicks), None)
    if "sn" not in clicks or up_id is None:
        return False
    u = clicks[up_id] - clicks["sn"]
    left = np.array([-u[1], u[0]])  # image y points down
    votes = [float(np.sign((clicks[b + "_l"] - clicks[b + "_r"]) @ left))
             for b in _PAIR_BASES if b + "_l" in clicks and b + "_r" in clicks]
    return len(votes) >= 2 and sum(votes) < 0


def _check_scale(case: Case, placed: set[str]) -> None:
    usable = [(a, b) for (a, b) in case.scale_mm if a in placed and b in placed]
    if not usable:
        keys = ", ".join(f"{a}-{b}" for a, b in case.scale_mm)
        missing = sorted({i for pair in case.scale_mm for i in pair} - placed)
        raise NaseviewError(
            f"{_case_file(case)}: key 'scale_mm': no scale distance ({keys}) can be used "
            f"because {', '.join(missing)} could not be reconstructed; click these "
            "landmarks in at least two photos or give a distance between reconstructed "
            "landmarks (e.g. al_l-al_r)")


# ------------------------------------------------------------------------ main entry


def _robust_stats(res_norm: np.ndarray, params: SfmParams) -> tuple[np.ndarray, float]:
    """Suspect mask and inlier RMSE of per-click residual norms (px)."""
    med = float(np.median(res_norm)) if res_norm.size else 0.0
    thr = max(params.suspect_min_px, params.suspect_factor * med)
    suspect = res_norm > thr
    inl = res_norm[~suspect]
    rmse = float(np.sqrt(np.mean(inl**2))) if inl.size else float("inf")
    return suspect, rmse


def _hypotheses(params: SfmParams) -> list[tuple[float, float]]:
    y, e, s = params.rig_yaw_deg, params.bottom_elevation_deg, params.hypothesis_step_deg
    return [(y, e), (y - s, e), (y + s, e), (y, e - s), (y, e + s),
            (y - s, e - s), (y + s, e + s), (y - s, e + s), (y + s, e - s)]


@functools.lru_cache(maxsize=1)
def _blas_controller() -> Any:
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # optional (pip install threadpoolctl); only speed depends on it
        return None
    return ThreadpoolController()


def _single_thread_blas() -> Any:
    """Context limiting BLAS to one thread: the matrices here are ~100 x 100, where thread
    hand-offs cost more than they save (and far more on a busy machine)."""
    ctl = _blas_controller()
    return contextlib.nullcontext() if ctl is None else ctl.limit(limits=1, user_api="blas")


class _MirroredError(NaseviewError):
    """The adjusted nose is mirrored (pronasale behind glabella)."""


def bundle_adjust(case: Case, params: SfmParams | None = None) -> SfmResult:
    """Stage 1: 3D landmarks and cameras of a case by bundle adjustment.

    Args:
        case: a validated case (SPEC §3): clicks in px, at least one ``scale_mm`` distance.
        params: tunables (defaults: :class:`SfmParams`).
    Returns:
        :class:`SfmResult` in the SPEC §4 frame (mm, origin g).
    Raises:
        NaseviewError: a photo with fewer than ``min_clicks_per_photo`` clicks or collinear
            clicks, g not clicked in two photos, no usable scale distance, left/right
            labels swapped, or the adjustment did not converge (names the worst photo).
    """
    params = params or SfmParams()
    # trial steps far off (rejected by the solver) may overflow: not worth a warning
    with _single_thread_blas(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        try:
            return _bundle_adjust(case, params)
        except _MirroredError as e:
            if "left" not in case.views or "right" not in case.views:
                raise
            mirrored = e
        # The left and right photos in each other's slot also give a mirrored nose: the
        # rig prior put them on the wrong sides. If they fit on swapped sides, say so.
        try:
            _bundle_adjust(case, replace(params, rig_yaw_deg=-params.rig_yaw_deg))
        except NaseviewError:
            raise mirrored from None
        raise NaseviewError(
            f"{_case_file(case)}: key 'views.left.image': the photos of 'left' and 'right' "
            "look swapped (the camera of 'left' must be on the subject's left side); swap "
            "their image and landmarks in case.json")


def _bundle_adjust(case: Case, params: SfmParams) -> SfmResult:
    _check_inputs(case, params)
    views = [v for v in VIEWS if v in case.views]  # all four, or a subset ([NEW] hints)
    seen_in: dict[str, list[str]] = {
        lid: [v for v in views if lid in case.views[v].landmarks] for lid in LANDMARK_IDS}
    point_ids = [lid for lid in LANDMARK_IDS if len(seen_in[lid]) >= 2]
    single = [lid for lid in LANDMARK_IDS if len(seen_in[lid]) == 1]
    where = _case_file(case)
    for v in views:
        n = sum(1 for lid in point_ids if lid in case.views[v].landmarks)
        if n < 4:
            raise NaseviewError(
                f"{where}: key 'views.{v}.landmarks': only {n} clicks in photo {v!r} are "
                "also clicked in another photo; at least 4 shared landmarks are needed to "
                "place this camera")
    obs_view, obs_point, obs_uv = [], [], []
    for i, v in enumerate(views):
        for j, lid in enumerate(point_ids):
            if lid in case.views[v].landmarks:
                obs_view.append(i)
                obs_point.append(j)
                obs_uv.append(case.views[v].landmarks[lid])
    known_K = [case.views[v].known_K() for v in views]
    sizes = [(case.views[v].width, case.views[v].height) for v in views]
    K0 = np.stack([K if K is not None else intrinsics(1.0, *sz)
                   for K, sz in zip(known_K, sizes, strict=True)])
    base = dict(views=views, point_ids=point_ids, obs_view=np.array(obs_view),
                obs_point=np.array(obs_point), obs_uv=np.array(obs_uv, dtype=np.float64),
                K0=K0, sizes=sizes, free=np.array([K is None for K in known_K]),
                focal_weight=1.0 / params.focal_coupling if params.focal_coupling > 0 else 0.0,
                focal_abs_weight=(1.0 / params.focal_prior_sd if params.focal_prior_sd > 0
                                  else 0.0),
                log_f0=np.log([params.focal_guess * max(sz) for sz in sizes]))

    best = None
    for yaw, elev in _hypotheses(params):
        cams0, X0 = initial_cameras(case, views, point_ids, yaw, elev, params)
        prob = _Problem(R0=np.stack([c.R for c in cams0]), **base)
        x0 = _pack(prob, cams0, X0)
        if x0 is None:
            continue
        sol = _solve(prob, x0, params)
        res_norm = np.linalg.norm(sol.fun[:2 * prob.n_obs].reshape(-1, 2), axis=1)
        _, rmse = _robust_stats(res_norm, params)
        if best is None or sol.cost < best[1].cost:
            best = (prob, sol, f"yaw {yaw:g}, bottom {elev:g}")
        if rmse <= params.accept_rmse_px:
            break
    if best is None:
        raise NaseviewError(
            f"{where}: key 'views': no camera arrangement fits the clicks; check that each "
            "photo's clicks belong to that photo (front, left, right, bottom)")
    prob, sol, hyp = best
    dropped: list[tuple[str, str]] = []
    if params.drop_suspects:
        culprits = _attribute_suspects(prob, sol, params)
        if culprits:
            keep = np.ones(prob.n_obs, dtype=bool)
            keep[culprits] = False
            dropped = [(prob.views[prob.obs_view[k]], prob.point_ids[prob.obs_point[k]])
                       for k in culprits]
            prob = replace(prob, obs_view=prob.obs_view[keep], obs_point=prob.obs_point[keep],
                           obs_uv=prob.obs_uv[keep])
            sol = _solve(prob, sol.x, params)
    return _finish(case, params, prob, sol, hyp, seen_in, single, dropped)


def _attribute_suspects(prob: _Problem, sol: Any, params: SfmParams) -> list[int]:
    """Observations to leave out: suspect clicks pinned on one photo by leave-one-out.

    For each landmark with a suspect click and 3+ photos, triangulate it (DLT, adjusted
    cameras) without each photo in turn; the photo whose removal makes all remaining
    clicks fit (below the suspect threshold) while its own click does not, is the culprit.
    At most one click per landmark, and never one that would leave its photo with fewer
    than 5 clicks.
    """
    res_norm = np.linalg.norm(sol.fun[:2 * prob.n_obs].reshape(-1, 2), axis=1)
    suspect, _ = _robust_stats(res_norm, params)
    if not suspect.any():
        return []
    thr = max(params.suspect_min_px, params.suspect_factor * float(np.median(res_norm)))
    cams = _cameras_from_x(prob, sol.x)
    per_view = np.bincount(prob.obs_view, minlength=prob.n_views)
    out = []
    for j in np.unique(prob.obs_point[suspect]):
        idx = np.flatnonzero(prob.obs_point == j)
        if len(idx) < 3:
            continue
        best = (np.inf, -1, 0.0)
        for k in idx:
            others = idx[idx != k]
            X = triangulate_dlt([cams[prob.obs_view[o]] for o in others],
                                prob.obs_uv[others][None], np.ones((1, len(others)), bool))[0]
            r = [np.linalg.norm(cams[prob.obs_view[o]].project(X)[0] - prob.obs_uv[o])
                 for o in idx]
            r_others = max(r[i] for i, o in enumerate(idx) if o != k)
            if r_others < best[0]:
                best = (r_others, int(k), float(r[list(idx).index(k)]))
        r_others, k, r_k = best
        if r_others <= thr < r_k and per_view[prob.obs_view[k]] > 5:
            out.append(k)
            per_view[prob.obs_view[k]] -= 1
    return out


def _finish(case: Case, params: SfmParams, prob: _Problem, sol: Any, hyp: str,
            seen_in: dict[str, list[str]], single: list[str],
            dropped: list[tuple[str, str]]) -> SfmResult:
    """Checks, gauge, uncertainty, residuals and one-photo landmarks of a solved problem."""
    where = _case_file(case)
    views, point_ids = prob.views, prob.point_ids
    res = sol.fun[:2 * len(prob.obs_view)].reshape(-1, 2)
    res_norm = np.linalg.norm(res, axis=1)
    suspect, inlier_rmse = _robust_stats(res_norm, params)
    if (inlier_rmse > params.max_rmse_px
            or suspect.mean() > params.max_suspect_fraction):
        per_view = [float(np.sqrt(np.mean(res_norm[prob.obs_view == i] ** 2)))
                    for i in range(prob.n_views)]
        wv = int(np.argmax(per_view))
        worst = int(np.argmax(np.where(prob.obs_view == wv, res_norm, -1.0)))
        raise NaseviewError(
            f"{where}: key 'views.{views[wv]}.landmarks': bundle adjustment did not converge "
            f"(reprojection RMSE {inlier_rmse:.1f} px; worst photo {views[wv]!r}, worst click "
            f"{point_ids[prob.obs_point[worst]]!r} at {res_norm[worst]:.1f} px); check the "
            "clicks of that photo and that _l/_r mean the subject's left/right")
    cams_ba = _cameras_from_x(prob, sol.x)
    X_ba = sol.x[prob.n_cam_params:].reshape(-1, 3)
    try:
        spec = _GaugeSpec.build(point_ids, case.scale_mm)
    except ValueError as e:
        raise NaseviewError(
            f"{where}: key 'views': cannot set up the 3D frame ({e}); click g, n, sn and at "
            "least one left/right pair (e.g. al_l and al_r) in two photos each") from None

    # Provisional frame: SPEC axes, origin g (n while g is not yet placed), mm when a scale
    # distance joins two adjusted landmarks (else bundle-adjustment units for now).
    o, Rgs = spec.frames(X_ba[None])
    s = float(spec.scales(X_ba[None])[0])
    X = spec.apply(X_ba[None])[0]
    landmarks = {lid: X[j] for j, lid in enumerate(point_ids)}
    cameras = {v: _similarity_camera(c, o[0], Rgs[0], s)
               for v, c in zip(views, cams_ba, strict=True)}
    dof = res.size + prob.n_prior - len(sol.x) + 7
    sigma_hat = math.sqrt(2.0 * sol.cost / dof) if dof > 0 else 0.0
    sigma = max(sigma_hat, params.min_sigma_px)
    cov = _landmark_covariance(sol.jac, prob, X_ba, sigma, spec)
    covariance = {lid: cov[3 * j:3 * j + 3, 3 * j:3 * j + 3] for j, lid in enumerate(point_ids)}

    residuals: dict[str, dict[str, float]] = {v: {} for v in views}
    suspects: list[SuspectClick] = []
    for k in range(len(res_norm)):
        v, lid = views[prob.obs_view[k]], point_ids[prob.obs_point[k]]
        residuals[v][lid] = float(res_norm[k])
        if suspect[k]:
            others = tuple(u for u in seen_in[lid] if u != v)
            pair = others if len(seen_in[lid]) == 2 else ()
            if pair and any(sc.landmark == lid for sc in suspects):
                continue  # the same disagreement, already reported from the other photo
            suspects.append(SuspectClick(lid, v, float(res_norm[k]), other_views=pair))
    for v, lid in dropped:
        r = float(np.linalg.norm(cameras[v].project(landmarks[lid])[0]
                                 - case.views[v].landmarks[lid]))
        residuals[v][lid] = r
        suspects.append(SuspectClick(lid, v, r, ignored=True))
    suspects.sort(key=lambda sc: -sc.residual_px)
    warnings = [sc.message() for sc in suspects]
    if not sol.success:
        warnings.append(f"bundle adjustment stopped after {sol.nfev} evaluations without "
                        "full convergence; the result may be slightly off")

    # One-photo landmarks on their viewing rays (symmetry, midline plane, template depth),
    # then the scale when it needs one of them.
    placed, left_out = _place_single(case, params, single, seen_in, landmarks, covariance,
                                     cameras, sigma)
    if not len(spec.scale_mm):
        s2 = _scale_from(case.scale_mm, landmarks)
        if s2 is None:
            _check_scale(case, set(landmarks))
        assert s2 is not None
        landmarks = {k: s2 * p for k, p in landmarks.items()}
        covariance = {k: s2**2 * c for k, c in covariance.items()}
        cameras = {v: _similarity_camera(c, np.zeros(3), np.eye(3), s2)
                   for v, c in cameras.items()}
        warnings.append("the scale distance uses a landmark clicked in one photo only; "
                        "click both ends in two photos each for an exact scale")
    if "g" not in landmarks:
        raise NaseviewError(
            f"{where}: key 'views.*.landmarks.g': glabella g (the origin) could not be "
            f"placed from photo(s) {', '.join(seen_in['g']) or 'none'}; click it in the front "
            "photo and in a profile photo")

    # Final frame: origin g, axes from the adjusted landmarks (a no-op when g was adjusted).
    if "g" not in point_ids:
        frame_pts = {k: landmarks[k] for k in point_ids} | {"g": landmarks["g"]}
        og, Rf = anatomical_frame(frame_pts)
        landmarks = {k: Rf @ (p - og) for k, p in landmarks.items()}
        covariance = {k: Rf @ c @ Rf.T for k, c in covariance.items()}
        cameras = {v: _similarity_camera(c, og, Rf, 1.0) for v, c in cameras.items()}
    if "prn" in landmarks and landmarks["prn"][2] <= 0:
        raise _MirroredError(
            f"{where}: key 'views.*.landmarks': the nose comes out mirrored (pronasale "
            "behind glabella); left/right labels look swapped: _l is the subject's left, "
            "on the image right in the front photo")
    for v, cam in cameras.items():
        side = max(cam.width, cam.height)
        if not 0.25 * side < cam.focal_px < params.max_focal_factor * side:
            warnings.append(
                f"photo {v!r} fits an implausible focal length ({cam.focal_px:.0f} px for a "
                f"{side} px photo); check that every photo is in its slot and that _l/_r "
                "are the subject's left/right, or give the focal length in case.json")
            break
    uncertainty = {k: float(math.sqrt(max(np.trace(c), 0.0))) for k, c in covariance.items()}

    how = {"symmetry": "by left/right symmetry", "midline": "on the midsagittal plane",
           "template": "at the depth of a generic nose (weak prior)"}
    for lid, method in placed.items():
        v = seen_in[lid][0]
        r = cameras[v].project(landmarks[lid])[0] - case.views[v].landmarks[lid]
        residuals[v][lid] = float(np.linalg.norm(r))
        warnings.append(f"landmark {lid!r} is clicked in photo {v!r} only; placed {how[method]} "
                        f"(+-{uncertainty[lid]:.1f} mm); click it in a second photo")
    for lid in left_out:
        warnings.append(f"landmark {lid!r} is clicked in photo {seen_in[lid][0]!r} only and "
                        "cannot be placed; click it in a second photo")
    for lid in point_ids:
        if uncertainty[lid] > params.max_uncertainty_mm:
            views_of = ", ".join(seen_in[lid])
            warnings.append(
                f"landmark {lid!r} is poorly determined (+-{uncertainty[lid]:.1f} mm): the "
                f"photos that show it ({views_of}) see it from similar directions; click it "
                "in a photo taken from another side")
    order = {lid: i for i, lid in enumerate(LANDMARK_IDS)}
    landmarks = dict(sorted(landmarks.items(), key=lambda kv: order[kv[0]]))
    return SfmResult(
        landmarks=landmarks, cameras=cameras, residuals_px=residuals,
        uncertainty_mm={k: uncertainty[k] for k in landmarks},
        covariance_mm2={k: covariance[k] for k in landmarks},
        reprojection_rmse_px=float(np.sqrt(np.mean(res_norm**2))),
        suspect_clicks=suspects, warnings=warnings,
        one_photo=dict(placed), left_out=tuple(left_out),
        sigma_px=sigma, hypothesis=hyp, converged=bool(sol.success),
        n_evaluations=int(sol.nfev))


def _similarity_camera(cam: Camera, origin: np.ndarray, R: np.ndarray, s: float) -> Camera:
    """The same camera after the world change ``X' = s R (X - origin)`` (pixels unchanged)."""
    return Camera(cam.K, cam.R @ R.T, s * (cam.R @ origin + cam.t), cam.width, cam.height)


def _scale_from(scale_mm: dict[tuple[str, str], float], pts: dict[str, np.ndarray]
                ) -> float | None:
    """Least-squares factor s minimising sum (s d_i - D_i)^2; None without a usable pair."""
    num = den = 0.0
    for (a, b), D in scale_mm.items():
        if a in pts and b in pts:
            d = float(np.linalg.norm(pts[a] - pts[b]))
            num += d * D
            den += d * d
    return num / den if den > 0 else None


def _landmark_covariance(jac: Any, prob: _Problem, X_ba: np.ndarray, sigma: float,
                         spec: _GaugeSpec) -> np.ndarray:
    """(3N, 3N) covariance of the landmarks in the (provisional) SPEC frame.

    ``sigma^2 (J^T J)^+`` of the free-gauge problem, restricted to the points and
    propagated through the gauge map (origin, axes and scale taken from the landmarks).
    The gauge map is invariant to similarity transforms of its input, so its Jacobian
    annihilates the 7 gauge directions and the pseudo-inverse gives the exact result.

    Args:
        jac: (rows, P) Jacobian at the solution (dense or sparse).
        X_ba: (N, 3) points in the bundle-adjustment frame.
        sigma: click noise (px).
        spec: the gauge (origin, axes, scale) definition.
    """
    J = jac.toarray() if scipy.sparse.issparse(jac) else np.asarray(jac)
    Hp = np.linalg.pinv(J.T @ J, rcond=1e-12, hermitian=True)
    nc = prob.n_cam_params
    Cx = sigma**2 * Hp[nc:, nc:]
    n3 = X_ba.size
    h = 1e-6 * max(float(np.ptp(X_ba, axis=0).max()), 1e-9)
    batch = np.repeat(X_ba.ravel()[None], n3 + 1, axis=0)
    batch[1:] += h * np.eye(n3)
    Y = spec.apply(batch.reshape(n3 + 1, -1, 3)).reshape(n3 + 1, n3)
    G = ((Y[1:] - Y[0]) / h).T  # (3N out, 3N in)
    return G @ Cx @ G.T


def _ray_covariance(cam: Camera, X: np.ndarray, d: np.ndarray, sd_along: float,
                    sigma_px: float, sd_camera: float) -> np.ndarray:
    """Covariance of a point on a viewing ray: ``sd_along`` along the ray; across it the
    click noise (``sigma_px`` at the point's depth) and the camera's own uncertainty
    ``sd_camera`` (per axis, mm)."""
    lateral = math.hypot(sigma_px * float(cam.depth(X)[0]) / cam.focal_px, sd_camera)
    P = np.outer(d, d)
    return (sd_along**2 + sd_camera**2) * P + lateral**2 * (np.eye(3) - P)


def _aligned_template(landmarks: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], float]:
    """The generic nose template moved onto ``landmarks`` by a least-squares similarity.

    Returns:
        id -> (3,) template position in the frame of ``landmarks``, and the scale (frame
        units per template mm).
    """
    ids = [i for i in landmarks if i in _TEMPLATE_MM]
    T = np.array([_TEMPLATE_MM[i] for i in ids])
    P = np.array([landmarks[i] for i in ids])
    s, R, t = umeyama(T, P)
    return {k: s * R @ np.array(v) + t for k, v in _TEMPLATE_MM.items()}, s


def _place_single(case: Case, params: SfmParams, single: list[str],
                  seen_in: dict[str, list[str]], landmarks: dict[str, np.ndarray],
                  covariance: dict[str, np.ndarray], cameras: dict[str, Camera],
                  sigma_px: float) -> tuple[dict[str, str], list[str]]:
    """Place landmarks clicked in one photo on their viewing rays (in place).

    The click fixes the landmark up to its depth along the ray. The depths (one, or two for
    a left/right pair clicked in one photo each) solve a small linear least-squares
    problem with, per landmark:

    - ``"midline"``: distance to the midsagittal plane (sd ``symmetry_sd_mm``);
    - ``"symmetry"``: for a side landmark, the mirror image of its partner (sd
      ``symmetry_sd_mm`` plus the partner's uncertainty), or for a pair both clicked in
      one photo, each one the mirror image of the other;
    - always, a weak depth prior: the generic nose template aligned to the reconstructed
      landmarks (sd ``template_sd_mm``), so that a photo looking along the plane (a
      front photo) still gets a bounded answer.

    The method reported is the strongest geometric constraint, or ``"template"`` when the
    prior carries more information than the geometry. ``landmarks`` and ``covariance``
    gain the placed ids (same frame and units as ``landmarks``).

    Returns:
        placed id -> method, and left-out ids.
    """
    if not single:
        return {}, []
    if not params.symmetric_fill:
        return {}, list(single)
    c0, nrm = midsagittal_plane(landmarks)
    H = np.eye(3) - 2.0 * np.outer(nrm, nrm)
    tmpl, unit = _aligned_template(landmarks)  # unit: frame units per mm
    sd_t, sd_s = params.template_sd_mm * unit, params.symmetry_sd_mm * unit
    placed: dict[str, str] = {}
    left_out: list[str] = []
    done: set[str] = set()
    for lid in single:
        if lid in done:
            continue
        p = LANDMARKS[lid].partner
        group = [lid, p] if (p is not None and p in single) else [lid]
        done.update(group)
        rays = []
        for i in group:
            v = seen_in[i][0]
            C, d = cameras[v].rays(case.views[v].landmarks[i])
            rays.append((cameras[v], C, d[0]))
        # terms (a, b, sd, geometric): a . depths ~ b with standard deviation sd
        terms: list[tuple[np.ndarray, float, float, bool]] = []
        for k, i in enumerate(group):
            _, C, d = rays[k]
            e = np.zeros(len(group))
            e[k] = 1.0
            terms.append((e, float((tmpl[i] - C) @ d), sd_t, False))
            q = LANDMARKS[i].partner
            if q is None:
                terms.append((float(nrm @ d) * e, float(nrm @ (c0 - C)), sd_s, True))
            elif q in landmarks:
                Xm = mirror_points(landmarks[q], c0, nrm)[0]
                sd = math.hypot(sd_s, math.sqrt(max(np.trace(covariance[q]), 0.0) / 3.0))
                terms.append((e, float((Xm - C) @ d), sd, True))
        if len(group) == 2:
            (_, Ca, da), (_, Cb, db) = rays
            Cm = mirror_points(Cb, c0, nrm)[0]
            M = np.column_stack([da, -H @ db])
            terms += [(M[r], float(Cm[r] - Ca[r]), sd_s, True) for r in range(3)]
        A = np.array([a / sd for a, _, sd, _ in terms])
        rhs = np.array([b / sd for _, b, sd, _ in terms])
        geo_info = sum(((a / sd) ** 2 for a, _, sd, geo in terms if geo),
                       np.zeros(len(group)))
        info = A.T @ A
        lam = np.linalg.solve(info, A.T @ rhs)
        sd_lam = np.sqrt(np.diag(np.linalg.inv(info)))
        for k, i in enumerate(group):
            cam, C, d = rays[k]
            if lam[k] <= 0 or sd_lam[k] > params.max_single_view_sd_mm * unit:
                left_out.append(i)
                continue
            X = C + lam[k] * d
            landmarks[i] = X
            v = seen_in[i][0]
            sd_cam = float(np.median([math.sqrt(max(np.trace(covariance[j]), 0.0) / 3.0)
                                      for j in covariance if j in case.views[v].landmarks
                                      and j not in single and j != "g"] or [0.0]))
            covariance[i] = _ray_covariance(cam, X, d, float(sd_lam[k]), sigma_px, sd_cam)
            if geo_info[k] < 1.0 / sd_t**2:
                placed[i] = "template"
            else:
                placed[i] = "midline" if LANDMARKS[i].partner is None else "symmetry"
    return placed, left_out
