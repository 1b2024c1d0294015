"""Eyes of the synthetic face: eyeballs behind eye holes, or eyes painted on a mesh that
models them (the built-in generic face).

- :func:`eyeball`: a sphere fitted behind an eye-hole loop (sclera, iris, limbal ring,
  pupil as latitude rings around +z);
- :func:`modelled_eyes`, :func:`paint_modelled_eyes`: the palpebral fissure and cornea of
  the generic face's design (:func:`naseview.facemodel.generic.eye_fissure`), painted on
  the face after :func:`refine_around_eyes` made the mesh locally 16 x finer.

Example
-------
>>> import numpy as np
>>> F = np.array([[0, 1, 2]]); V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0]])
>>> F2, (V2,) = subdivide(F, np.array([True]), [V])
>>> len(F2), V2[3:].tolist()
(4, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
"""

from __future__ import annotations

import numpy as np

from naseview.facemodel import FaceModel
from naseview.facemodel.generic import eye_fissure
from naseview.testbed.synth.blend import smoothstep
from naseview.testbed.synth.head import sphere_grid

IRIS_RGB: tuple[tuple[float, float, float], ...] = (
    (70, 45, 28), (105, 70, 40), (80, 110, 140), (95, 115, 80), (50, 35, 25),
)
"""Iris colour anchors (RGB 0-255); a case picks a point between two."""

GENERIC_EYES_MM = np.array([[31.0, -8.0], [-31.0, -8.0]])
"""Cornea centres (x, y) of the generic face's eyes in its model frame (its eye design)."""


def modelled_eyes(model: FaceModel) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per side: (V,) palpebral-fissure indicator and (V,) distance (mm) to the cornea
    centre, on the model's mean, for a mesh that models the eyes (no eye holes).

    Only the built-in generic face does so; its eye design (fissure shape, cornea at
    x = +-31, y = -8 mm in its model frame) is read from :mod:`naseview.facemodel.generic`.
    The weights are attached to vertices, so they follow any identity.
    """
    if model.name != "generic":
        return {}
    x, y = model.mean[:, 0], model.mean[:, 1]
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for (cx, cy), side, sign in zip(GENERIC_EYES_MM, ("l", "r"), (1.0, -1.0), strict=True):
        ind, _, _ = eye_fissure(x, y, sign)
        out[side] = (np.asarray(ind, dtype=float), np.hypot(x - cx, y - cy))
    return out


def paint_modelled_eyes(mean_xy: np.ndarray, N: np.ndarray, C: np.ndarray,
                         spec: np.ndarray, iris_bgr: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Sclera, iris, pupil and lash line painted on a mesh that models the eyes.

    Args:
        mean_xy: (P, 2) positions of the points on the model's mean (model frame, mm).
        N: (P, 3) normals; C: (P, 3) albedo; spec: (P,) highlight multipliers.
    Returns:
        the new albedo and highlight multipliers.
    """
    x, y = mean_xy[:, 0], mean_xy[:, 1]
    C = C.copy()
    spec = spec.copy()
    for (cx, cy), sign in zip(GENERIC_EYES_MM, (1.0, -1.0), strict=True):
        ind, _, _ = eye_fissure(x, y, sign)
        r = np.hypot(x - cx, y - cy)
        iris_w = smoothstep((5.6 - r) / 0.5)
        pupil_w = smoothstep((2.2 - r) / 0.4)
        ec = np.array([0.74, 0.77, 0.84]) * (1 - iris_w[:, None]) + iris_w[:, None] * iris_bgr
        ec = ec * (1 - pupil_w[:, None]) + pupil_w[:, None] * 0.03
        ec = ec * (1 - 0.45 * smoothstep((r - 4.8) / 0.5) * iris_w)[:, None]
        w = ind * smoothstep((N[:, 2] - 0.1) / 0.3)
        C = C * (1 - w[:, None]) + w[:, None] * ec
        C *= (1.0 - 0.7 * 4.0 * ind * (1.0 - ind))[:, None]       # lash line
        spec = spec + 1.0 * w
    return C, spec


def subdivide(F: np.ndarray, select: np.ndarray, attrs: list[np.ndarray]
               ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Split the selected triangles 1 -> 4 at their edge midpoints (flat: the surface is
    unchanged), interpolating every per-vertex attribute linearly.

    Args:
        F: (F, 3) triangles; select: (F,) bool.
        attrs: per-vertex arrays (V, ...) (positions, colours, normals...).
    Returns:
        new triangles (old vertex ids kept, midpoints appended) and the new attributes.
    """
    Fs = F[select]
    e = np.concatenate([Fs[:, [1, 2]], Fs[:, [2, 0]], Fs[:, [0, 1]]])
    key, inv = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True)
    n = len(attrs[0])
    mid = n + inv.reshape(3, -1).T                         # (S, 3): midpoint opposite k
    a, b, c = Fs[:, 0], Fs[:, 1], Fs[:, 2]
    ma, mb, mc = mid[:, 0], mid[:, 1], mid[:, 2]
    new_F = np.concatenate([F[~select], np.column_stack([a, mc, mb]),
                            np.column_stack([mc, b, ma]), np.column_stack([mb, ma, c]),
                            np.column_stack([ma, mb, mc])])
    new_attrs = [np.concatenate([x, 0.5 * (x[key[:, 0]] + x[key[:, 1]])]) for x in attrs]
    return new_F, new_attrs


def refine_around_eyes(F: np.ndarray, mean: np.ndarray, attrs: list[np.ndarray]
                       ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Twice :func:`subdivide` the triangles near the generic eyes (16 x finer there), so
    the painted lid margins are crisp.

    Args:
        F: (F, 3) triangles; mean: (V, 3) the model's mean (model frame, mm), which
            locates the eyes; attrs: other per-vertex arrays (V, ...) to interpolate.
    Returns:
        the new triangles and ``[mean, *attrs]`` on the new vertices.
    """
    Fv = F
    out = [mean, *attrs]
    for _ in range(2):
        sel = out[0][Fv][:, :, :2].mean(axis=1)[:, None, :] - GENERIC_EYES_MM
        sel = np.any((np.abs(sel[:, :, 0]) < 18.0) & (np.abs(sel[:, :, 1]) < 10.0), axis=1)
        Fv, out = subdivide(Fv, sel, out)
    return Fv, out


def eyeball(loop_pts: np.ndarray, iris_bgr: np.ndarray, s: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """An eyeball sphere fitted behind an eye-hole loop, looking along +z.

    Returns vertices, triangles, BGR colours, specular multipliers.
    """
    R = 12.0 * s
    m = loop_pts.mean(axis=0)
    cen = m - np.array([0.0, 0.0, R * 0.75])
    for _ in range(10):                               # fit |p - c| = R (Gauss-Newton)
        d = loop_pts - cen
        n = np.linalg.norm(d, axis=1)
        J = -d / n[:, None]
        res = n - R
        cen = cen - np.linalg.lstsq(J, res, rcond=None)[0]
    if np.linalg.norm(cen[:2] - m[:2]) > 5 * s:       # degenerate fit: sit behind the hole
        cen = m - np.array([0.0, 0.0, R * 0.75])
    # lon/lat sphere whose pole looks forwards (+z): iris and pupil are latitude rings
    lon, lat, EF = sphere_grid(48, 36)
    ang = 90.0 - np.degrees(lat)                       # angle from the gaze direction
    dirs = np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon),
                            np.sin(lat)])
    EV = cen + R * dirs
    sclera = np.array([0.80, 0.82, 0.88])
    col = np.tile(sclera, (len(EV), 1))
    col[ang < 29.0] = iris_bgr
    col[(ang > 24.0) & (ang < 29.0)] *= 0.55           # limbal ring
    col[ang < 9.0] = 0.03
    spec = np.full(len(EV), 2.0)
    return EV, EF, col, spec
