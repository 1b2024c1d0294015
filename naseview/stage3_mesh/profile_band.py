"""The profile band: the part of the face whose outline the profile photos show (issue 23).

The measurements a surgeon plans from read the facial profile beyond the nose: the
nasofrontal angle reads the glabella above nasion, the nasolabial angle the upper lip
below subnasale. The profile photos show that whole outline against the backdrop, so
stage 3 matches it from above g down to the upper lip, not only on the nose:

- :func:`profile_band` - the vertices that may take a profile-silhouette match: within
  ``half_width_mm`` of the facial midline, from ``above_g_mm`` above g down to
  ``below_sn_mm`` below sn (the upper lip, to where it turns forward into the
  vermilion);
- :func:`matched_region` - the nose and, with a face model rich enough to follow it,
  the band: the vertices matched to the profile photos
  (``RefineParams.uses_profile_band``);
- :func:`profile_box` - the photo box searched for that silhouette: the nose's box
  (:func:`~naseview.stage3_mesh.silhouette.nose_box`) grown to the band's ends.

The band is measured in the SPEC frame (mm; +x subject's left, +y up, +z anterior), on
the face it is applied to; the midline's x is the mean of the midline landmarks'.

Example
-------
>>> V = np.array([[0.0, 5.0, 0.0], [0.0, -90.0, 5.0], [30.0, -40.0, 0.0]])
>>> lm = {"g": np.zeros(3), "n": np.array([0.0, -18, -2]), "sn": np.array([0.0, -72, 8])}
>>> profile_band(V, lm, above_g_mm=10, below_sn_mm=15, half_width_mm=12).tolist()
[True, False, False]
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from naseview.camera import Camera
from naseview.facemodel import FaceModel
from naseview.stage3_mesh.params import RefineParams
from naseview.stage3_mesh.silhouette import nose_box

MIDLINE_IDS: tuple[str, ...] = ("g", "n", "k", "r", "prn", "c", "sn")
"""Landmarks on the facial midline; their mean x is the midline's."""


def band_limits(landmarks: Mapping[str, np.ndarray], above_g_mm: float, below_sn_mm: float
                ) -> tuple[float, float, float] | None:
    """``(x_mid, y_top, y_bottom)`` mm of the band, or None without g (or n) and sn."""
    top = landmarks.get("g", landmarks.get("n"))
    if top is None or "sn" not in landmarks:
        return None
    xs = [float(np.asarray(landmarks[k], float)[0]) for k in MIDLINE_IDS if k in landmarks]
    return (float(np.mean(xs)), float(np.asarray(top, float)[1]) + above_g_mm,
            float(np.asarray(landmarks["sn"], float)[1]) - below_sn_mm)


def profile_band(V: np.ndarray, landmarks: Mapping[str, np.ndarray], above_g_mm: float,
                 below_sn_mm: float, half_width_mm: float) -> np.ndarray:
    """(n,) bool: the vertices of ``V`` (n, 3) mm within ``half_width_mm`` of the midline
    and between ``above_g_mm`` above g and ``below_sn_mm`` below sn (all False when g/n
    or sn is missing)."""
    lim = band_limits(landmarks, above_g_mm, below_sn_mm)
    if lim is None:
        return np.zeros(len(V), bool)
    x_mid, y_top, y_bottom = lim
    return np.asarray((np.abs(V[:, 0] - x_mid) <= half_width_mm) & (V[:, 1] <= y_top)
                      & (V[:, 1] >= y_bottom))


def matched_region(model: FaceModel, V: np.ndarray, landmarks: Mapping[str, np.ndarray],
                   params: RefineParams) -> np.ndarray:
    """(n,) bool: the vertices of the face ``V`` (n, 3) whose occluding contour stage 3
    matches to the profile photos: the model's nose, and the profile band
    (:func:`profile_band` with ``params``' reach) when
    ``params.uses_profile_band(model.n_modes)``."""
    out = np.zeros(len(V), bool)
    out[np.asarray(model.nose_vertices, np.int64)] = True
    if params.uses_profile_band(model.n_modes):
        out |= profile_band(V, landmarks, params.profile_above_g_mm,
                            params.profile_below_sn_mm, params.profile_half_width_mm)
    return out


def profile_box(cam: Camera, landmarks: Mapping[str, np.ndarray], above_g_mm: float,
                below_sn_mm: float, margin_px: int = 60) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) px: :func:`~naseview.stage3_mesh.silhouette.nose_box` grown to
    hold the band's ends (a point ``above_g_mm`` above g, one ``below_sn_mm`` below sn)
    with half the margin; None where ``nose_box`` is."""
    box = nose_box(cam, landmarks, margin_px)
    lim = band_limits(landmarks, above_g_mm, below_sn_mm)
    if box is None or lim is None:
        return box
    x_mid, y_top, y_bottom = lim
    top = np.asarray(landmarks.get("g", landmarks.get("n")), float)
    sn = np.asarray(landmarks["sn"], float)
    P = np.array([[top[0], y_top, top[2]], [sn[0], y_bottom, sn[2]]])
    if not (cam.depth(P) > 0).all():
        return box
    uv = cam.project(P)
    m = margin_px // 2
    x0, y0 = np.floor(uv.min(0)).astype(int) - m
    x1, y1 = np.ceil(uv.max(0)).astype(int) + m
    return (max(min(box[0], int(x0)), 0), max(min(box[1], int(y0)), 0),
            min(max(box[2], int(x1)), cam.width), min(max(box[3], int(y1)), cam.height))
