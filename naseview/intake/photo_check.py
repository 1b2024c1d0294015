"""Does an uploaded photo look like its slot? One line at upload, never a refusal.

No neural network: what naseview already has. The photo (downscaled to 512 px) is cut
from its uniform background (:mod:`naseview.stage2_curves.mask`, paper eq. 2) when there
is one and it is not skin (a face filling the photo); skin is a YCrCb box. Then:

- **no face**: less than :data:`MIN_SKIN` of the photo is skin in one blob, or that blob
  is not in the middle third of the width: "a house" as the front photo;
- **a profile in the front or bottom slot**: the skin is not left-right symmetric about
  its own centre (:data:`MIN_SYMMETRY`; the skin blob of the scan cases' front and bottom
  photos is 0.92-0.99 symmetric, their profiles 0.75-0.88, synthetic front photos of a
  yawed camera down to 0.88: a profile is only caught when clearly one).

The line is worded as the stage-1 check of swapped photos words it
(:func:`naseview.stage1_landmarks.plausibility.slot_message`: one home).

Example
-------
>>> import numpy as np
>>> house = np.full((300, 400, 3), (235, 206, 135), np.uint8)    # sky
>>> house[120:300, 80:320] = (60, 60, 160)                        # red walls
>>> photo_warning("front", house)[:36]
"the 'front' photo looks like no face"
"""

from __future__ import annotations

import cv2
import numpy as np

from naseview.stage1_landmarks.plausibility import slot_message
from naseview.stage2_curves.mask import estimate_background, foreground_mask

MIN_SKIN = 0.05
"""Smallest fraction of the photo that is skin (one blob) for a face."""

MIN_SYMMETRY = 0.87
"""Smallest left-right symmetry of the skin of a front or bottom photo (fraction of skin
pixels whose mirror about the skin's centre column is skin too)."""


def _skin(img: np.ndarray) -> np.ndarray:
    """Bool mask of the skin-coloured pixels of (H, W, 3) BGR (YCrCb box)."""
    ycc = cv2.cvtColor(img, cv2.COLOR_BGR2YCrCb)
    return ((ycc[..., 0] > 40) & (ycc[..., 1] >= 133) & (ycc[..., 1] <= 170)
            & (ycc[..., 2] >= 77) & (ycc[..., 2] <= 135))


def photo_warning(view: str, image: np.ndarray) -> str | None:
    """One line when the (H, W, 3) uint8 BGR ``image`` does not look like a ``view``
    photo (no face; a profile in the front or bottom slot), else ``None``."""
    h, w = image.shape[:2]
    s = 512.0 / max(h, w)
    img = cv2.resize(image, (max(1, round(w * s)), max(1, round(h * s))),
                     interpolation=cv2.INTER_AREA) if s < 1 else image
    skin = _skin(img)
    bg = estimate_background(img)
    border = np.r_[skin[:8].ravel(), skin[-8:].ravel(), skin[:, :8].ravel(),
                   skin[:, -8:].ravel()]
    if bg.uniform and border.mean() < 0.5:     # not a face filling the photo
        skin &= foreground_mask(img, bg)
    n, lab, st, cen = cv2.connectedComponentsWithStats(skin.astype(np.uint8), connectivity=8)
    if n <= 1:
        return slot_message(view, "no face", "no skin colour found")
    k = 1 + int(np.argmax(st[1:, cv2.CC_STAT_AREA]))
    H, W = skin.shape
    if st[k, cv2.CC_STAT_AREA] < MIN_SKIN * H * W:
        return slot_message(view, "no face", "hardly any skin colour")
    if not W / 6 <= cen[k][0] <= 5 * W / 6:
        return slot_message(view, "no face", "no skin in the middle of the photo")
    if view in ("front", "bottom"):
        blob = lab == k
        ys, xs = np.nonzero(blob)
        mx = np.round(2 * cen[k][0] - xs).astype(int)
        ok = (mx >= 0) & (mx < W)
        sym = float(blob[ys[ok], mx[ok]].sum()) / len(xs)
        if sym < MIN_SYMMETRY:
            return slot_message(view, "a profile", f"the face is not left-right "
                                f"symmetric: {100 * sym:.0f} %")
    return None


__all__ = ["MIN_SKIN", "MIN_SYMMETRY", "photo_warning"]
