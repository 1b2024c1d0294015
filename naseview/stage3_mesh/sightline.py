"""Landmarks clicked in one photo, placed where their line of sight meets the fitted face.

A click fixes its landmark up to the depth along the viewing ray (paper §3.2: eq. 1
needs two photos). Stage 1 guesses that depth from left/right symmetry or a generic nose
template; stage 3 knows better once the face model is fitted to the other landmarks: the
landmark is on the skin, so it is where its ray first meets the fitted face. Fit and
placement alternate a few times (:func:`place_one_photo_landmarks`), since the placed
landmark also pulls the fit; the face the rays meet is the fit bent smoothly through the
other landmarks and sub-landmarks (stage 3's warp), which a real nose's surface follows
more closely than the bare model. The uncertainty along the ray is the fit's own misfit
(median) at the landmarks seen in two or more photos (at least half of
``fit_sigma_mm``), divided by how square the ray meets the surface (``|n . d|``, at least
0.3): a grazing ray makes the depth less certain. SPEC frame, mm.

Example
-------
>>> import numpy as np
>>> V = np.array([[-1., -1, 0], [1, -1, 0], [0, 1, 0]])
>>> F = np.array([[0, 1, 2]])
>>> hit = first_hit(V, F, np.array([0., 0, 10]), np.array([0., 0, -1]))
>>> point, triangle = hit
>>> [round(float(v), 6) for v in point], triangle
([0.0, 0.0, 0.0], 0)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from naseview.facemodel import FaceModel
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh.fit import fit_face_model
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.solve import sublandmarks, warped_base

MIN_INCIDENCE = 0.3
"""Smallest ``|n . d|`` used in the along-ray uncertainty (a grazing ray: at most 3.3x)."""


@dataclass(frozen=True)
class SightLine:
    """The line of sight of one click: the photo, camera centre C (3,), unit direction d (3,)."""

    view: str
    C: np.ndarray
    d: np.ndarray


@dataclass(frozen=True)
class Placed:
    """A landmark placed on its line of sight.

    Attributes:
        position: (3,) where the ray first meets the fitted face (mm).
        sd_along_mm: its standard deviation along the ray (mm).
        view: the photo of the click.
    """

    position: np.ndarray
    sd_along_mm: float
    view: str


def first_hit(V: np.ndarray, F: np.ndarray, C: np.ndarray, d: np.ndarray
              ) -> tuple[np.ndarray, int] | None:
    """The first point where the ray ``C + s d`` (s > 0) meets the mesh, and its triangle
    (Moller-Trumbore, both triangle sides); None when it misses."""
    A, B, Cc = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1, e2 = B - A, Cc - A
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = C - A
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
    if not hit.any():
        return None
    k = int(np.flatnonzero(hit)[np.argmin(t[hit])])
    return C + t[k] * d, k


def place_on_face(V: np.ndarray, F: np.ndarray, lines: Mapping[str, SightLine],
                  misfit_mm: float) -> dict[str, Placed]:
    """Each line of sight's first hit on the face (V, F); lines that miss are left out.

    Args:
        V, F: the fitted face (mm, SPEC frame).
        lines: landmark id -> its :class:`SightLine`.
        misfit_mm: how well the fitted face is known near the landmarks (RMS misfit of
            the fit at the landmarks seen in two or more photos, mm).
    Returns:
        id -> :class:`Placed`.
    """
    out: dict[str, Placed] = {}
    for lid, ln in lines.items():
        h = first_hit(V, F, ln.C, ln.d)
        if h is None:
            continue
        X, k = h
        n = np.cross(V[F[k, 1]] - V[F[k, 0]], V[F[k, 2]] - V[F[k, 0]])
        cos = abs(float(n @ ln.d)) / max(float(np.linalg.norm(n)), 1e-12)
        out[lid] = Placed(X, misfit_mm / max(cos, MIN_INCIDENCE), ln.view)
    return out


def place_one_photo_landmarks(model: FaceModel, reconstruction: Reconstruction,
                              lines: Mapping[str, SightLine],
                              params: RefineParams | None = None) -> dict[str, Placed]:
    """Alternate the face-model fit and the line-of-sight placement of one-photo landmarks.

    The fit (:func:`~naseview.stage3_mesh.fit.fit_face_model`, with the stage-2
    sub-landmarks when present) starts from stage 1's landmarks (one-photo landmarks at
    their symmetry/template placement, those stage 1 left out not at all); each round puts
    every one-photo landmark where its line of sight first meets the fitted face and fits
    again, ``params.sight_iterations`` rounds. A line that misses the face keeps stage 1's
    placement (the fallback).

    Returns:
        id -> :class:`Placed` of the last round (empty without lines or rounds).
    """
    params = params or RefineParams()
    if not lines or params.sight_iterations == 0:
        return {}
    work = {k: np.asarray(v, float) for k, v in (reconstruction.landmarks or {}).items()}
    sub = sublandmarks(reconstruction)
    placed: dict[str, Placed] = {}
    F = np.asarray(model.faces, np.int64)
    for _ in range(params.sight_iterations):
        fit = fit_face_model(model, work, params, *sub)
        others = [d for k, d in fit.residuals_mm.items() if k not in lines]
        misfit = float(np.median(others)) if others else params.fit_sigma_mm
        known = {k: v for k, v in work.items() if k not in lines}
        base = warped_base(model, fit, known, sub, params)[0]
        placed = place_on_face(base, F, lines, max(misfit, params.fit_sigma_mm * 0.5))
        if not placed:
            break
        work.update({k: p.position for k, p in placed.items()})
    return placed
