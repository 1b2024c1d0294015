"""Background removal (paper eq. 2) and the profile of the mid-curve (eq. 3).

The photos are taken against a monochrome background. Its colour is estimated from the
image border (median HSV of a ``border_px`` wide frame), the threshold T_thresh is a box
around it in HSV, and the foreground mask is what falls outside the box, cleaned and
reduced to its largest connected part. The mid-curve is the part of the silhouette facing
the anterior side between g and sn.

Example
-------
>>> import numpy as np
>>> img = np.full((64, 64, 3), (200, 120, 40), np.uint8)        # blue-ish background
>>> img[16:48, 20:44] = (90, 120, 180)                           # skin-coloured block
>>> bg = estimate_background(img, border_px=4)
>>> bool(bg.uniform), int(foreground_mask(img, bg, clean_px=0).sum())
(True, 768)
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class Background:
    """Background colour of one photo.

    Attributes:
        hsv: (3,) median OpenCV HSV (H 0..180, S and V 0..255) of the border.
        inlier_fraction: fraction of border pixels inside the threshold box T_thresh.
        uniform: ``inlier_fraction >= min_inlier``.
        hue_tol, sat_tol, val_tol, grey_sat: the threshold box (see CurveParams).
    """

    hsv: np.ndarray
    inlier_fraction: float
    uniform: bool
    hue_tol: float
    sat_tol: float
    val_tol: float
    grey_sat: float


def _border_pixels(a: np.ndarray, w: int) -> np.ndarray:
    w = max(1, min(w, min(a.shape[:2]) // 4))
    return np.concatenate([a[:w].reshape(-1, a.shape[2]), a[-w:].reshape(-1, a.shape[2]),
                           a[w:-w, :w].reshape(-1, a.shape[2]),
                           a[w:-w, -w:].reshape(-1, a.shape[2])])


def _in_box(hsv: np.ndarray, ref: np.ndarray, hue_tol: float, sat_tol: float,
            val_tol: float, use_hue: bool) -> np.ndarray:
    """Bool mask of the (..., 3) uint8 HSV pixels inside the box T_thresh around ``ref``."""
    s_lo, s_hi = int(round(ref[1] - sat_tol)), int(round(ref[1] + sat_tol))
    v_lo, v_hi = int(round(ref[2] - val_tol)), int(round(ref[2] + val_tol))
    img = np.ascontiguousarray(hsv.reshape(-1, 1, 3) if hsv.ndim != 3 else hsv)
    if not use_hue:
        grey = cv2.inRange(img, (0, max(s_lo, 0), max(v_lo, 0)), (255, min(s_hi, 255),
                                                                   min(v_hi, 255)))
        return grey.reshape(hsv.shape[:-1]) > 0
    h0, ht = int(round(ref[0])), int(round(hue_tol))
    out: np.ndarray = np.zeros(img.shape[:2], np.uint8)
    for lo, hi in ((h0 - ht, h0 + ht), (h0 - ht + 180, h0 + ht + 180),
                   (h0 - ht - 180, h0 + ht - 180)):
        lo, hi = max(lo, 0), min(hi, 179)
        if lo <= hi:
            out |= cv2.inRange(img, (lo, max(s_lo, 0), max(v_lo, 0)),
                               (hi, min(s_hi, 255), min(v_hi, 255)))
    return out.reshape(hsv.shape[:-1]) > 0


def estimate_background(image: np.ndarray, border_px: int = 12, hue_tol: float = 10.0,
                        sat_tol: float = 25.0, val_tol: float = 60.0, grey_sat: float = 40.0,
                        min_inlier: float = 0.4) -> Background:
    """Background colour from the image border, and whether the border is uniform.

    The subject usually touches the border (neck, hair, a tight crop), so the colour is
    the *dominant* one of the border, not its median: the peak of a coarse S-V histogram,
    refined by the median of the border pixels inside the threshold box around it (hue
    included when the background is coloured). The border counts as a uniform background
    when at least ``min_inlier`` of its pixels fall inside that box.

    Args:
        image: (H, W, 3) uint8 BGR photo.
        border_px: width of the border frame (px).
        hue_tol, sat_tol, val_tol: half-widths of the HSV box T_thresh (eq. 2).
        grey_sat: below this background saturation the hue is ignored.
        min_inlier: smallest fraction of border pixels inside the box for a uniform border.
    """
    w = max(1, min(border_px, min(image.shape[:2]) // 4))
    border_bgr = _border_pixels(image, w)
    border = cv2.cvtColor(border_bgr[None], cv2.COLOR_BGR2HSV)[0]
    s = border[:, 1].astype(np.int32)
    v = border[:, 2].astype(np.int32)
    hist = np.bincount((s // 16) * 16 + v // 16, minlength=256)
    peak = int(np.argmax(hist))
    ref = np.array([0.0, (peak // 16) * 16 + 8.0, (peak % 16) * 16 + 8.0])
    for _ in range(3):
        inl = _in_box(border[None], ref, hue_tol, sat_tol, val_tol, False)[0]
        if not inl.any():
            break
        ref[1], ref[2] = np.median(s[inl]), np.median(v[inl])
    use_hue = bool(ref[1] >= grey_sat)
    if use_hue:
        inl = _in_box(border[None], ref, hue_tol, sat_tol, val_tol, False)[0]
        h = border[inl, 0].astype(np.int32)
        hp = int(np.argmax(np.bincount(h, minlength=180)))
        ref[0] = (np.median((h - hp + 90) % 180) + hp - 90) % 180
    frac = float(_in_box(border[None], ref, hue_tol, sat_tol, val_tol, use_hue).mean())
    return Background(ref, frac, frac >= min_inlier, hue_tol, sat_tol, val_tol, grey_sat)


def foreground_mask(image: np.ndarray, bg: Background, clean_px: int = 3,
                    roi: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """(H, W) bool mask of the subject: pixels outside T_thresh (eq. 2), cleaned.

    Opening and closing with a ``clean_px`` disc remove specks; the largest connected
    foreground part is kept and its holes filled. With ``roi`` = (x0, y0, x1, y1) only
    that box is computed (False elsewhere).
    """
    H, W = image.shape[:2]
    x0, y0, x1, y1 = roi if roi is not None else (0, 0, W, H)
    hsv = cv2.cvtColor(image[y0:y1, x0:x1], cv2.COLOR_BGR2HSV)
    back = _in_box(hsv, bg.hsv, bg.hue_tol, bg.sat_tol, bg.val_tol, bg.hsv[1] >= bg.grey_sat)
    fg: np.ndarray = (~back).astype(np.uint8)
    if clean_px > 1:
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (clean_px, clean_px))
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, k)
        fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, k)
    out = np.zeros((H, W), bool)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(fg, connectivity=8)
    if n <= 1:
        return out
    big = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    part = (lab == big).astype(np.uint8)
    # fill holes: flood the background from outside
    ff = np.pad(part, 1)
    cv2.floodFill(ff, None, (0, 0), 1)
    out[y0:y1, x0:x1] = (part > 0) | (ff[1:-1, 1:-1] == 0)
    return out


def profile_rows(mask: np.ndarray, y0: float, y1: float, anterior: int) -> np.ndarray:
    """Eq. 3: per row, the first foreground pixel seen from the anterior side.

    Args:
        mask: (H, W) bool foreground.
        y0, y1: rows (px) between which to scan (inclusive, any order).
        anterior: -1 when the face points to the image left (scan left to right, as in
            the paper's left view), +1 when it points right.
    Returns:
        (N, 2) pixels ``[x, y]`` ordered from y0 to y1; rows without foreground skipped.
    """
    H, W = mask.shape
    lo, hi = sorted((int(round(y0)), int(round(y1))))
    lo, hi = max(lo, 0), min(hi, H - 1)
    rows = mask[lo:hi + 1]
    has = rows.any(axis=1)
    if anterior < 0:
        x = np.argmax(rows, axis=1)
    else:
        x = W - 1 - np.argmax(rows[:, ::-1], axis=1)
    ys = np.arange(lo, hi + 1)
    pts = np.column_stack([x, ys]).astype(np.float64)[has]
    return pts if y0 <= y1 else pts[::-1]


def silhouette_contour(mask: np.ndarray) -> np.ndarray:
    """(N, 2) outer boundary pixels ``[x, y]`` of the mask's largest part, as a loop."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_NONE)
    if not contours:
        return np.zeros((0, 2))
    c = max(contours, key=len)
    return c[:, 0, :].astype(np.float64)


def profile_contour(mask: np.ndarray, start: ArrayLike, end: ArrayLike, anterior: int,
                    max_snap_px: float = np.inf) -> np.ndarray | None:
    """The silhouette between ``start`` (g) and ``end`` (sn) on the anterior side.

    The outer contour of the mask is split at the boundary pixels nearest to ``start``
    and ``end``; of the two arcs the one reaching further to the anterior side is kept.
    Unlike :func:`profile_rows` this keeps near-horizontal parts (c-sn).

    Args:
        mask: (H, W) bool foreground.
        start, end: (2,) pixels near the silhouette.
        anterior: -1 face to the image left, +1 to the right.
        max_snap_px: give up (return None) when start or end is farther than this from
            the silhouette.
    Returns:
        (N, 2) pixels from start to end, or None.
    """
    loop = silhouette_contour(mask)
    if len(loop) < 8:
        return None
    s = np.asarray(start, dtype=np.float64)
    e = np.asarray(end, dtype=np.float64)
    ds = np.linalg.norm(loop - s, axis=1)
    de = np.linalg.norm(loop - e, axis=1)
    i, j = int(np.argmin(ds)), int(np.argmin(de))
    if ds[i] > max_snap_px or de[j] > max_snap_px or i == j:
        return None
    n = len(loop)
    fwd = loop[(i + np.arange((j - i) % n + 1)) % n]
    bwd = loop[(i - np.arange((i - j) % n + 1)) % n]
    score_f = anterior * np.mean(fwd[:, 0])
    score_b = anterior * np.mean(bwd[:, 0])
    return fwd if score_f >= score_b else bwd
