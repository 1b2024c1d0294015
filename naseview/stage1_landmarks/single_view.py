"""Landmarks clicked in one photo only (paper §3.2): placed on their viewing rays.

Eq. 1 needs a landmark in two photos. A landmark clicked in one photo is fixed by its
click up to its depth along the viewing ray; the depth comes from the symmetry of the
face (:mod:`.symmetry`) and a weak prior from the generic nose (:mod:`.template`), with an
uncertainty that says how well it is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from naseview.camera import Camera
from naseview.case import Case
from naseview.landmarks import LANDMARKS
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.symmetry import midsagittal_plane, mirror_points
from naseview.stage1_landmarks.template import aligned_template


class _Ray(NamedTuple):
    """The line of sight of one click: camera, centre C (3,), unit direction d (3,)."""

    cam: Camera
    C: np.ndarray
    d: np.ndarray


class _Term(NamedTuple):
    """One row ``a . depths ~ b`` with standard deviation ``sd`` (geometric or prior)."""

    a: np.ndarray
    b: float
    sd: float
    geometric: bool


@dataclass(frozen=True)
class _Priors:
    """What constrains a depth, in the frame of the reconstructed landmarks.

    Attributes:
        c0, nrm: (3,) point on the midsagittal plane and its unit normal.
        H: (3, 3) mirror across the plane (directions).
        template: id -> (3,) generic nose aligned to the landmarks.
        unit: frame units per mm; sd_t, sd_s: template and symmetry sd in frame units.
    """

    c0: np.ndarray
    nrm: np.ndarray
    H: np.ndarray
    template: dict[str, np.ndarray]
    unit: float
    sd_t: float
    sd_s: float

    @staticmethod
    def of(landmarks: dict[str, np.ndarray], params: SfmParams) -> _Priors:
        c0, nrm = midsagittal_plane(landmarks)
        tmpl, unit = aligned_template(landmarks)  # unit: frame units per mm
        return _Priors(c0, nrm, np.eye(3) - 2.0 * np.outer(nrm, nrm), tmpl, unit,
                       params.template_sd_mm * unit, params.symmetry_sd_mm * unit)


def place_single(case: Case, params: SfmParams, single: list[str],
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

    Args:
        single: ids clicked in one photo; seen_in: id -> the photos that show it.
        landmarks, covariance: id -> (3,) position and (3, 3) covariance of the adjusted
            landmarks; cameras: view -> camera, all in one frame.
        sigma_px: click noise (px).
    Returns:
        placed id -> method, and left-out ids.
    """
    if not single:
        return {}, []
    if not params.symmetric_fill:
        return {}, list(single)
    priors = _Priors.of(landmarks, params)
    placed: dict[str, str] = {}
    left_out: list[str] = []
    for group in _groups(single):
        rays = [_ray(case, cameras, seen_in[i][0], i) for i in group]
        terms = _depth_terms(group, rays, priors, landmarks, covariance)
        lam, sd_lam, geo_info = _solve_depths(terms, len(group))
        for k, i in enumerate(group):
            cam, C, d = rays[k]
            if lam[k] <= 0 or sd_lam[k] > params.max_single_view_sd_mm * priors.unit:
                left_out.append(i)
                continue
            X = C + lam[k] * d
            landmarks[i] = X
            sd_cam = _camera_sd(case, seen_in[i][0], covariance, single)
            covariance[i] = ray_covariance(cam, X, d, float(sd_lam[k]), sigma_px, sd_cam)
            if geo_info[k] < 1.0 / priors.sd_t**2:
                placed[i] = "template"
            else:
                placed[i] = "midline" if LANDMARKS[i].partner is None else "symmetry"
    return placed, left_out


def _groups(single: list[str]) -> list[list[str]]:
    """The one-photo ids, a left/right pair clicked in one photo each as one group."""
    groups: list[list[str]] = []
    done: set[str] = set()
    for lid in single:
        if lid in done:
            continue
        p = LANDMARKS[lid].partner
        group = [lid, p] if (p is not None and p in single) else [lid]
        done.update(group)
        groups.append(group)
    return groups


def _ray(case: Case, cameras: dict[str, Camera], v: str, lid: str) -> _Ray:
    """The viewing ray of the click of ``lid`` in photo ``v``."""
    C, d = cameras[v].rays(case.views[v].landmarks[lid])
    return _Ray(cameras[v], C, d[0])


def _axis_sd(cov: np.ndarray) -> float:
    """Per-axis standard deviation of a (3, 3) covariance: sqrt(trace / 3)."""
    return math.sqrt(max(np.trace(cov), 0.0) / 3.0)


def _depth_terms(group: list[str], rays: list[_Ray], priors: _Priors,
                 landmarks: dict[str, np.ndarray], covariance: dict[str, np.ndarray]
                 ) -> list[_Term]:
    """Rows on the depths of ``group`` along ``rays``: template prior, midline plane or
    partner's mirror image, and for a pair, each the mirror image of the other."""
    terms: list[_Term] = []
    for k, i in enumerate(group):
        _, C, d = rays[k]
        e = np.zeros(len(group))
        e[k] = 1.0
        terms.append(_Term(e, float((priors.template[i] - C) @ d), priors.sd_t, False))
        q = LANDMARKS[i].partner
        if q is None:
            terms.append(_Term(float(priors.nrm @ d) * e, float(priors.nrm @ (priors.c0 - C)),
                               priors.sd_s, True))
        elif q in landmarks:
            Xm = mirror_points(landmarks[q], priors.c0, priors.nrm)[0]
            sd = math.hypot(priors.sd_s, _axis_sd(covariance[q]))
            terms.append(_Term(e, float((Xm - C) @ d), sd, True))
    if len(group) == 2:
        (_, Ca, da), (_, Cb, db) = rays
        Cm = mirror_points(Cb, priors.c0, priors.nrm)[0]
        M = np.column_stack([da, -priors.H @ db])
        terms += [_Term(M[r], float(Cm[r] - Ca[r]), priors.sd_s, True) for r in range(3)]
    return terms


def _solve_depths(terms: list[_Term], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least squares of the terms: depths (n,), their sd (n,), and the
    information (n,) the geometric terms alone carry."""
    A = np.array([t.a / t.sd for t in terms])
    rhs = np.array([t.b / t.sd for t in terms])
    geo_info = sum(((t.a / t.sd) ** 2 for t in terms if t.geometric), np.zeros(n))
    info = A.T @ A
    lam = np.linalg.solve(info, A.T @ rhs)
    sd_lam = np.sqrt(np.diag(np.linalg.inv(info)))
    return lam, sd_lam, geo_info


def _camera_sd(case: Case, v: str, covariance: dict[str, np.ndarray], single: list[str]
               ) -> float:
    """The camera's own uncertainty (per axis, mm): median per-axis sd of the adjusted
    landmarks (not g) clicked in photo ``v``."""
    return float(np.median([_axis_sd(covariance[j]) for j in covariance
                            if j in case.views[v].landmarks and j not in single
                            and j != "g"] or [0.0]))


def ray_covariance(cam: Camera, X: np.ndarray, d: np.ndarray, sd_along: float,
                   sigma_px: float, sd_camera: float) -> np.ndarray:
    """(3, 3) covariance of a point X (3,) on a viewing ray of unit direction d (3,):
    ``sd_along`` along the ray; across it the click noise (``sigma_px`` at the point's
    depth) and the camera's own uncertainty ``sd_camera`` (per axis, mm)."""
    lateral = math.hypot(sigma_px * float(cam.depth(X)[0]) / cam.focal_px, sd_camera)
    P = np.outer(d, d)
    return (sd_along**2 + sd_camera**2) * P + lateral**2 * (np.eye(3) - P)


def one_photo_sight_lines(case: Case, cameras: dict[str, Camera],
                          ids: list[str]) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """Id -> (photo, camera centre (3,), unit ray direction (3,)) of each landmark in
    ``ids`` that is clicked in exactly one photo with a camera (stage 3 places it where
    this line meets the fitted face)."""
    out: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}
    for lid in ids:
        views = [v for v, view in case.views.items() if lid in view.landmarks]
        if len(views) == 1 and views[0] in cameras:
            C, d = cameras[views[0]].rays(case.views[views[0]].landmarks[lid])
            out[lid] = (views[0], np.asarray(C, float), np.asarray(d[0], float))
    return out
