"""Initial cameras and landmarks of the bundle adjustment (paper §3.2, start of eq. 1).

Eq. 1 is not convex: its solver needs cameras near the answer. They come from a four-view
rig prior (front; left and right at ~90 degrees yaw; bottom looking up at ~50 degrees;
the optional obliques halfway between the front and each profile),
with the in-plane roll and distance of each photo from a 2D similarity fit of the generic
nose template (:mod:`.template`), then linear (DLT) triangulation and rounds of per-photo
resection (PnP) and re-triangulation. Several rig hypotheses (:func:`hypotheses`) are
tried when the first one does not reach a small reprojection error.

Example
-------
>>> import numpy as np
>>> R = rig_prior_rotation("left")          # camera on the subject's left (+x)
>>> bool(np.allclose(R[2], [-1.0, 0.0, 0.0]))   # it looks along -x
True
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera, intrinsics, look_at
from naseview.case import Case
from naseview.geometry.triangulation import triangulate_dlt
from naseview.landmarks import LANDMARK_IDS
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.template import TEMPLATE_MM


def hypotheses(params: SfmParams) -> list[tuple[float, float]]:
    """(yaw, bottom elevation) degrees of the rig hypotheses, in the order they are tried:
    the prior, then +-``hypothesis_step_deg`` on either angle and on both."""
    y, e, s = params.rig_yaw_deg, params.bottom_elevation_deg, params.hypothesis_step_deg
    return [(y, e), (y - s, e), (y + s, e), (y, e - s), (y, e + s),
            (y - s, e - s), (y + s, e + s), (y - s, e + s), (y + s, e - s)]


def rig_prior_rotation(view: str, yaw_deg: float = 90.0,
                       elevation_deg: float = 50.0) -> np.ndarray:
    """(3, 3) world-to-camera rotation of the four-view rig prior for ``view``.

    ``front`` looks along -z; ``left`` sits on the subject's left (+x) at ``yaw_deg`` from
    the front; ``right`` mirrors it; ``bottom`` sits below the front camera at
    ``elevation_deg`` and looks up at the nose. The optional ``oblique_left`` /
    ``oblique_right`` sit halfway between the front and that profile (``yaw_deg / 2``, 45
    degrees on the prior), level with the nose. Image up is world up tilted with the camera.

    Raises:
        ValueError: ``view`` is not one of the six photos.
    """
    yaw, el = math.radians(yaw_deg), math.radians(elevation_deg)
    half = 0.5 * yaw
    if view == "front":
        eye, up = [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]
    elif view == "left":
        eye, up = [math.sin(yaw), 0.0, math.cos(yaw)], [0.0, 1.0, 0.0]
    elif view == "right":
        eye, up = [-math.sin(yaw), 0.0, math.cos(yaw)], [0.0, 1.0, 0.0]
    elif view == "oblique_left":
        eye, up = [math.sin(half), 0.0, math.cos(half)], [0.0, 1.0, 0.0]
    elif view == "oblique_right":
        eye, up = [-math.sin(half), 0.0, math.cos(half)], [0.0, 1.0, 0.0]
    elif view == "bottom":
        eye, up = [0.0, -math.sin(el), math.cos(el)], [0.0, math.cos(el), math.sin(el)]
    else:
        raise ValueError(f"unknown view {view!r}")
    return look_at(eye, [0.0, 0.0, 0.0], up, 1.0, 2, 2).R


def fit_similarity_2d(src: ArrayLike, dst: ArrayLike) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares 2D similarity ``dst ~ s * Q @ src + b`` (Umeyama, no reflection).

    :func:`naseview.geometry.alignment.umeyama` is the 3D case (its reflection fix is a 3 x 3
    matrix); this one also keeps ``s = 1`` for coincident ``src`` points.

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


def template_camera(R0: np.ndarray, K: np.ndarray, size: tuple[int, int],
                    clicks: dict[str, np.ndarray]) -> Camera:
    """Camera from a prior rotation and the clicks, using the generic nose template.

    A 2D similarity between the template seen orthographically along ``R0`` and the clicks
    gives the in-plane roll (any angle) and the distance. The out-of-plane angles stay
    those of the prior: PnP on the template is not used, because in a profile photo the
    midline landmarks are nearly planar and face the camera, so its yaw flips.

    Args:
        R0: (3, 3) prior rotation; K: (3, 3) intrinsics; size: (width, height) px.
        clicks: id -> (2,) px, the landmark clicks of the photo.
    """
    ids = [i for i in clicks if i in TEMPLATE_MM]
    T = np.array([TEMPLATE_MM[i] for i in ids])
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


def pnp(cam: Camera, X: np.ndarray, uv: np.ndarray) -> Camera | None:
    """Refine the pose of ``cam`` (intrinsics fixed) on points X (N, 3) seen at uv (N, 2)
    px by iterative PnP; None if it fails or puts a point behind the camera."""
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


def initial_cameras(case: Case, views: list[str], point_ids: list[str],
                    yaw_deg: float, elevation_deg: float, params: SfmParams
                    ) -> tuple[list[Camera], np.ndarray]:
    """Initial cameras and 3D points for one rig hypothesis.

    Rig prior -> per-photo template fit (roll, distance) -> DLT triangulation ->
    ``resection_rounds`` x (per-photo resection by PnP on the triangulated points -> DLT).

    Returns:
        cameras (one per view, in the bundle-adjustment frame) and (N, 3) points.
    """
    cams = [_prior_camera(case, v, yaw_deg, elevation_deg, params) for v in views]
    uv, seen = _click_table(case, views, point_ids)
    X = triangulate_dlt(cams, uv, seen)
    for _ in range(params.resection_rounds):
        cams = _resection(cams, X, uv, seen)
        X = triangulate_dlt(cams, uv, seen)
    return cams, X


def _prior_camera(case: Case, v: str, yaw_deg: float, elevation_deg: float,
                  params: SfmParams) -> Camera:
    """The template camera of photo ``v`` on the rig prior (guessed focal length unless
    the case gives the intrinsics)."""
    view = case.views[v]
    K = view.known_K()
    if K is None:
        K = intrinsics(params.focal_guess * max(view.width, view.height), view.width,
                       view.height)
    R0 = rig_prior_rotation(v, yaw_deg, elevation_deg)
    clicks = {i: p for i, p in view.landmarks.items() if i in LANDMARK_IDS}
    return template_camera(R0, K, (view.width, view.height), clicks)


def _click_table(case: Case, views: list[str], point_ids: list[str]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(N, V, 2) clicks (px) of the points in the views, and (N, V) bool: clicked."""
    uv = np.zeros((len(point_ids), len(views), 2))
    seen = np.zeros((len(point_ids), len(views)), dtype=bool)
    for i, v in enumerate(views):
        lm = case.views[v].landmarks
        for j, lid in enumerate(point_ids):
            if lid in lm:
                uv[j, i], seen[j, i] = lm[lid], True
    return uv, seen


def _resection(cams: list[Camera], X: np.ndarray, uv: np.ndarray, seen: np.ndarray
               ) -> list[Camera]:
    """One round of per-photo PnP on the triangulated points X (N, 3); a photo with fewer
    than 4 points, or whose PnP fails, keeps its camera."""
    new = []
    for i, cam in enumerate(cams):
        sel = seen[:, i]
        r = pnp(cam, X[sel], uv[sel, i]) if sel.sum() >= 4 else None
        new.append(r if r is not None else cam)
    return new
