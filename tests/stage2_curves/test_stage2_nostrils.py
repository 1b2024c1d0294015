"""Dark nostrils, closing and contour tracing (paper eq. 13-14): stage2_curves.nostrils."""

from __future__ import annotations

import cv2
import numpy as np

from naseview.stage2_curves.metrics import point_to_polyline
from naseview.stage2_curves.nostrils import nostril_contour


def test_nostril_contour_found_on_a_drawn_dark_blob() -> None:
    img = np.full((200, 200, 3), (120, 150, 190), np.uint8)
    cv2.ellipse(img, (90, 110), (30, 16), 20, 0, 360, (30, 30, 40), -1)
    rng = np.random.default_rng(3)
    speck = rng.uniform(size=img.shape[:2]) < 0.03           # bright specks inside: closing
    img[speck] = 140
    ang = np.deg2rad(20)
    seed = np.array([90 + 33 * np.cos(ang), 110 + 33 * np.sin(ang)])   # just outside the rim
    loop = nostril_contour(img, seed, threshold=80, closing_px=5, search_px=12)
    assert loop is not None and len(loop) > 50
    # distance of the traced loop to the drawn ellipse
    t = np.linspace(0, 2 * np.pi, 720)
    E = np.column_stack([30 * np.cos(t), 16 * np.sin(t)]) @ np.array(
        [[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]]) + [90, 110]
    assert point_to_polyline(loop, E, closed=True).max() < 1.6
    assert np.linalg.norm(loop[0] - seed) < 5                # loop starts next to al''
    assert nostril_contour(img, [190.0, 10.0], 80, 5, 12) is None     # nothing dark there
