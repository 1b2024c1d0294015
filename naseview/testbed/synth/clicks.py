"""The clicks a surgeon would make in a synthetic photo (SPEC §1-§3 landmark policy).

A landmark is listed only if it is visible and lies at least 3 px inside the image.
Visible means: within 4 px (at 1024 px) of its projection the rendered surface is nowhere
more than 1.5 mm in front of it, so a landmark right behind an occluding contour (g on a
slightly turned profile, md behind the alar rim) is still clicked there, as a surgeon
would, while one hidden behind the nose or the eye (al_r in the left view, mf in a true
profile) is not. Which landmarks a view may have is
:data:`naseview.landmarks.VIEW_LANDMARKS`.

A click is the exact projection of the landmark vertex plus Gaussian noise of standard
deviation ``noise_px`` per axis (so the mean click error is ``1.25 noise_px``); the
helpers ``add_x`` are the projection of :func:`~naseview.testbed.synth.truth.
helper_position` plus the same noise.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from naseview.camera import Camera
from naseview.landmarks import VIEW_LANDMARKS
from naseview.render import visible_points
from naseview.testbed.synth.rig import DEFAULT_SIZE
from naseview.testbed.synth.truth import helper_position

CLICK_MARGIN_PX = 3.0
"""Smallest distance of a click from the image border (px)."""

VISIBILITY_TOL_MM = 1.5
"""How far a landmark may lie behind the rendered surface and still be clicked (mm)."""

CONTOUR_RADIUS_PX = 4
"""Neighbourhood of the depth test at 1024 px (scaled with the photo size)."""


def contour_radius(size: int) -> int:
    """:data:`CONTOUR_RADIUS_PX` scaled to a photo of ``size`` px (at least 1)."""
    return max(1, int(round(CONTOUR_RADIUS_PX * size / DEFAULT_SIZE)))


def _targets(ids: list[str], camera: Camera, landmarks: Mapping[str, np.ndarray],
             helpers: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) 3D point of every id and (n,) bool whether it is known."""
    X = np.zeros((len(ids), 3))
    known = np.zeros(len(ids), dtype=bool)
    for k, lid in enumerate(ids):
        if lid in helpers:
            X[k] = helper_position(helpers[lid], camera)
            known[k] = True
        elif lid in landmarks:
            X[k] = landmarks[lid]
            known[k] = True
    return X, known


def view_clicks(view: str, camera: Camera, depth: np.ndarray,
                landmarks: Mapping[str, np.ndarray], helpers: Mapping[str, np.ndarray],
                rng: np.random.Generator, noise_px: float) -> dict[str, np.ndarray]:
    """Id -> (2,) click (px, 3 decimals) of every visible landmark of ``view``.

    Args:
        view: the photo; camera: its true camera; depth: its (H, W) rendered depth (mm).
        landmarks: id -> (3,) true landmark (mm); helpers: :func:`~naseview.testbed.
            synth.truth.helper_points`.
        rng: the click stream: one (2,) draw per id of the view, visible or not, so the
            noise of a click does not depend on the others' visibility.
        noise_px: standard deviation of the click noise per axis (px).
    """
    ids = list(VIEW_LANDMARKS[view])
    noise = rng.normal(0.0, noise_px, size=(len(ids), 2))
    X, known = _targets(ids, camera, landmarks, helpers)
    vis = known & visible_points(X, camera, depth, VISIBILITY_TOL_MM,
                                 contour_radius(camera.width))
    uv = camera.project(X) + noise
    m = CLICK_MARGIN_PX
    size = camera.width
    inside = np.all((uv >= m) & (uv <= size - 1 - m), axis=1)
    return {ids[k]: np.round(uv[k], 3) for k in np.flatnonzero(vis & inside)}
