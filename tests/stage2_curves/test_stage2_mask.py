"""Background colour, mask and mid-curve profile (paper eq. 2-3): stage2_curves.mask."""

from __future__ import annotations

import cv2
import numpy as np

from naseview.stage2_curves.mask import estimate_background, foreground_mask, profile_contour
from naseview.stage2_curves.metrics import point_to_polyline


def _profile_photo(border_noise: bool = False) -> tuple[np.ndarray, np.ndarray]:
    img = np.full((240, 240, 3), (235, 180, 60), np.uint8)   # uniform blue backdrop (BGR)
    head = np.array([[60, 20], [150, 20], [150, 90], [120, 110], [135, 150], [110, 160],
                     [150, 200], [150, 240], [60, 240]], np.int32)
    cv2.fillPoly(img, [head], (120, 150, 200))
    if border_noise:
        rng = np.random.default_rng(4)
        img[:40] = rng.integers(0, 255, (40, 240, 3))
        img[:, -40:] = rng.integers(0, 255, (240, 40, 3))
    return img, head


def test_background_estimated_from_border_and_profile_found() -> None:
    img, head = _profile_photo()
    bg = estimate_background(img, border_px=8)
    assert bg.uniform and bg.inlier_fraction > 0.85   # the neck touches the border
    mask = foreground_mask(img, bg)
    truth = np.zeros(mask.shape, np.uint8)
    cv2.fillPoly(truth, [head], 1)
    assert (mask != truth.astype(bool)).mean() < 0.01
    # profile from (150, 40) to (150, 190), face pointing to the image right
    prof = profile_contour(mask, [150.0, 40.0], [150.0, 190.0], anterior=+1)
    assert prof is not None
    assert point_to_polyline([[120.0, 110.0], [135.0, 150.0], [110.0, 160.0]], prof).max() < 2
    assert prof[:, 0].max() <= 151 and prof[:, 1].min() >= 35


def test_non_uniform_border_is_detected() -> None:
    img, _ = _profile_photo(border_noise=True)
    assert not estimate_background(img, border_px=8).uniform
