"""Nasal sills: nostril borders in the bottom photo (paper eq. 13-14) and their 3D plane.

The nostrils are the dark areas of the bottom view. A value threshold isolates them, a
morphological closing (eq. 13) removes the specks, and the border of the dark region next
to the al'' landmark is traced (eq. 14, :func:`cv2.findContours`). The sill has only one
landmark (al''), so the paper places it in 3D on a plane through al'' whose normal is
perpendicular to the md-c line and parallel to the Oxy plane.

Example
-------
>>> import numpy as np, cv2
>>> img = np.full((80, 80, 3), 170, np.uint8)
>>> _ = cv2.ellipse(img, (40, 40), (15, 9), 0, 0, 360, (25, 25, 30), -1)
>>> loop = nostril_contour(img, seed=(55, 40), threshold=85, closing_px=3, search_px=6)
>>> bool(np.abs(np.hypot((loop[:, 0] - 40) / 15, (loop[:, 1] - 40) / 9) - 1).max() < 0.15)
True
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike


def dark_mask(image: np.ndarray, threshold: float) -> np.ndarray:
    """(H, W) bool: HSV value (max of B, G, R) below ``threshold`` (colour thresholding)."""
    v = image.max(axis=2) if image.ndim == 3 else image
    return v < threshold


def auto_dark_threshold(image: np.ndarray, roi: tuple[int, int, int, int],
                        ratio: float = 0.5) -> float:
    """``ratio`` times the median HSV value inside ``roi`` = (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = roi
    patch = image[y0:y1:2, x0:x1:2]
    v = patch.max(axis=2) if patch.ndim == 3 else patch
    return float(ratio * np.median(v)) if v.size else 0.0


def close_mask(mask: np.ndarray, kernel_px: int) -> np.ndarray:
    """Morphological closing (I dilate B) erode B with an elliptical B (eq. 13)."""
    if kernel_px <= 1:
        return mask.copy()
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel_px, kernel_px))
    return cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, k) > 0


def nostril_region(mask: np.ndarray, seed: ArrayLike, search_px: float,
                   min_area_px: int = 30) -> np.ndarray | None:
    """(H, W) bool: the connected dark region nearest to ``seed`` within ``search_px``.

    Regions smaller than ``min_area_px`` are ignored; holes are filled. None when no
    region qualifies (nostril not visible).
    """
    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return None
    sx, sy = (float(c) for c in np.asarray(seed, dtype=np.float64))
    H, W = mask.shape
    r = int(np.ceil(search_px))
    x0, x1 = max(0, int(sx) - r), min(W, int(sx) + r + 2)
    y0, y1 = max(0, int(sy) - r), min(H, int(sy) + r + 2)
    win = lab[y0:y1, x0:x1]
    yy, xx = np.mgrid[y0:y1, x0:x1]
    d = np.hypot(xx - sx, yy - sy)
    best, best_d = 0, np.inf
    for k in np.unique(win):
        if k == 0 or stats[k, cv2.CC_STAT_AREA] < min_area_px:
            continue
        dk = float(d[win == k].min())
        if dk <= search_px and dk < best_d:
            best, best_d = int(k), dk
    if best == 0:
        return None
    region = (lab == best).astype(np.uint8)
    ff = np.pad(region, 1)
    cv2.floodFill(ff, None, (0, 0), 1)
    return (region > 0) | (ff[1:-1, 1:-1] == 0)


def trace_contour(region: np.ndarray) -> np.ndarray:
    """(N, 2) boundary pixels ``[x, y]`` of a region, as a loop (eq. 14)."""
    contours, _ = cv2.findContours(region.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_NONE)
    if not contours:
        return np.zeros((0, 2))
    return max(contours, key=len)[:, 0, :].astype(np.float64)


def nostril_contour(image: np.ndarray, seed: ArrayLike, threshold: float,
                    closing_px: int = 5, search_px: float = 10.0,
                    min_area_px: int = 30,
                    roi: tuple[int, int, int, int] | None = None) -> np.ndarray | None:
    """Nostril border next to ``seed`` (al''): threshold, closing, contour tracing.

    Args:
        image: (H, W, 3) uint8 BGR bottom photo.
        seed: (2,) al'' in px. threshold: value threshold (0..255).
        closing_px: closing kernel (eq. 13); search_px: how far from the seed the dark
            region may be; min_area_px: smallest region.
        roi: optional (x0, y0, x1, y1) to which the search is restricted (speed).
    Returns:
        (N, 2) closed loop (first point not repeated) starting at the contour pixel
        nearest to the seed, in px; None when no nostril is visible.
    """
    x0, y0 = 0, 0
    img = image
    if roi is not None:
        x0, y0, x1, y1 = roi
        img = image[y0:y1, x0:x1]
    m = close_mask(dark_mask(img, threshold), closing_px)
    s = np.asarray(seed, dtype=np.float64) - (x0, y0)
    region = nostril_region(m, s, search_px, min_area_px)
    if region is None:
        return None
    loop = trace_contour(region)
    if len(loop) < 6:
        return None
    k = int(np.argmin(np.linalg.norm(loop - s, axis=1)))
    return np.roll(loop, -k, axis=0) + (x0, y0)


def sill_plane(alpp: ArrayLike, md: ArrayLike, c: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The sill plane: through al'', normal perpendicular to md-c and parallel to Oxy.

    Args:
        alpp, md, c: (3,) landmarks (mm) of the same side.
    Returns:
        point (3,) and unit normal (3,). The normal lies in the Oxy plane (z = 0) and is
        perpendicular to md - c, i.e. ``(d_y, -d_x, 0)`` normalised; it is oriented +y.
    """
    d = np.asarray(md, dtype=np.float64) - np.asarray(c, dtype=np.float64)
    nrm = np.array([d[1], -d[0], 0.0])
    if np.linalg.norm(nrm) < 1e-9:
        nrm = np.array([0.0, 1.0, 0.0])
    nrm /= np.linalg.norm(nrm)
    if nrm[1] < 0:
        nrm = -nrm
    return np.asarray(alpp, dtype=np.float64).copy(), nrm
