"""The generic face without its nose: a height field ``z = S(x, y)`` (design step 1).

A head ellipse with a midline profile (forehead, glabella, lips, chin), brow ridges, eye
sockets with eyeballs, lids and corneas, cheeks, nasolabial folds, lips with philtrum,
Cupid's bow and mouth line. The generic face's frame: SPEC axes (+x subject's left, +y up,
+z anterior), mm, origin at the design's nasion.

Example
-------
>>> import numpy as np
>>> bool(face_height(np.array([0.0]), np.array([-71.0]))[0] > face_height(np.array([40.0]),
...                                                                      np.array([-71.0]))[0])
True
"""

from __future__ import annotations

import numpy as np

from naseview.facemodel.generic.shapes import Profile, gauss, smax, smoothstep

_Z0 = Profile([(75, -30.0), (62, -15.0), (45, -6.0), (30, -1.2), (20, 1.0), (12, 1.8),
               (5, 1.0), (0, 0.0), (-10, -1.5), (-25, -1.5), (-40, -0.5), (-55, 0.5),
               (-70, 0.5), (-85, -0.5), (-100, -2.0), (-112, -5.0), (-120, -11.0),
               (-130, -28.0)])
"""Midline depth of the head surface (mm) before the midline protrusions."""

_HALF_W = Profile([(75, 67.0), (40, 74.0), (0, 77.5), (-30, 79.0), (-60, 75.0),
                   (-90, 62.0), (-110, 52.0), (-130, 42.0)])
"""Half width of the transverse head ellipse (mm)."""

_PROTRUSION = Profile([(0, 0.0), (-20, 0.0), (-32, 2.0), (-42, 7.5), (-50, 13.2),
                       (-56, 13.8), (-63, 13.5), (-71, 11.5), (-79, 12.5), (-90, 7.0),
                       (-100, 10.5), (-108, 11.0), (-116, 8.0), (-125, 1.0),
                       (-135, -2.0)])
"""Height (mm) of the midline protrusion of the jaws (lips, chin) above the head ellipse."""

_PROTRUSION_W = Profile([(0, 24.0), (-30, 20.0), (-45, 17.5), (-60, 20.0), (-80, 20.0),
                         (-100, 17.0), (-120, 17.0)])
"""Width (mm) of that protrusion."""

HEAD_DEPTH_MM = 95.0
"""Depth (mm) the head ellipse falls back by at its sides."""


def _fissure(x: np.ndarray, y: np.ndarray, side: float) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """Palpebral fissure of one eye: indicator in [0, 1], upper and lower lid margins (y)."""
    cx, cy = 31.0 * side, -8.0
    t = np.clip((x - cx) * side / 15.0, -1.0, 1.0)
    # almond: the upper lid peaks medially of the centre, the lateral canthus is higher
    up = cy + 5.5 * np.cos(0.5 * np.pi * t) * (1.0 - 0.15 * t) + 0.9 * t
    lo = cy - 3.8 * np.cos(0.5 * np.pi * t) * (1.0 + 0.1 * t) + 0.9 * t
    inside_x = smoothstep((15.0 - np.abs(x - cx)) / 1.5)
    ind = (smoothstep((up - y) / 1.4 + 0.5) * smoothstep((y - lo) / 1.4 + 0.5) * inside_x)
    return ind, up, lo


def eye_fissure(x: np.ndarray, y: np.ndarray, side: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Palpebral fissure of the left (``side`` = +1) or right (-1) eye at points (x, y).

    Returns the open-eye indicator in [0, 1] (1 between the lids), and the heights y of
    the upper and lower lid margins above x (mm). Used to paint the eyes (synthetic
    photos) on this face.
    """
    return _fissure(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64), side)


def _head(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The head ellipse with its midline depth profile and the jaws' midline protrusion."""
    W = _HALF_W(y)
    u = np.clip(x / W, -0.995, 0.995)
    z = _Z0(y) - HEAD_DEPTH_MM * (1.0 - np.sqrt(1.0 - u * u))
    return z + _PROTRUSION(y) * gauss(x / _PROTRUSION_W(y))


def _brows_and_cheeks(z: np.ndarray, x: np.ndarray, y: np.ndarray, ax: np.ndarray
                      ) -> np.ndarray:
    """``z`` plus the frontal eminences, brow ridges and glabella, the malar cheeks and
    the infraorbital (tear-trough) hollow."""
    z = z + 1.2 * gauss((ax - 24.0) / 14.0) * gauss((y - 42.0) / 12.0)
    z = z + 3.0 * gauss((ax - 27.0) / 15.0) * gauss((y - 15.0) / 6.5)
    z = z + 2.2 * gauss(x / 11.0) * gauss((y - 11.0) / 7.0)
    z = z + 4.0 * gauss((ax - 40.0) / 15.0) * gauss((y + 30.0) / 13.0)
    return z - 1.0 * gauss((ax - 25.0) / 9.0) * gauss((y + 20.0) / 3.5)


def _nasolabial_folds(z: np.ndarray, ax: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``z`` with the nasolabial folds: a groove along a line from beside the ala to beside
    the mouth corner, cheek fullness lateral to it."""
    p0 = np.array([19.0, -43.0])
    p1 = np.array([29.0, -74.0])
    seg = p1 - p0
    L2 = float(seg @ seg)
    s = np.clip(((ax - p0[0]) * seg[0] + (y - p0[1]) * seg[1]) / L2, 0.0, 1.0)
    dx = ax - (p0[0] + s * seg[0])
    dy = y - (p0[1] + s * seg[1])
    dist = np.sqrt(dx * dx + dy * dy)
    along = np.sin(np.pi * s)
    lateral = (dx * seg[1] - dy * seg[0]) / np.sqrt(L2)   # < 0 on the cheek side
    z = z - 1.3 * along * gauss(dist / 2.2)
    return z + 1.6 * along * smoothstep(-lateral / 6.0) * gauss(dist / 9.0)


def _eyes(z: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``z`` with both eyes: socket, then eyeball + lids (smooth max), cornea, upper-lid
    crease and the lower-lid fold."""
    for side in (1.0, -1.0):
        q2 = ((x - 31.0 * side) / 18.0) ** 2 + ((y + 4.0) / 13.5) ** 2
        z = z - 7.5 * np.exp(-(q2 ** 1.25))
        ind, up, lo = _fissure(x, y, side)
        r2 = (x - 31.0 * side) ** 2 + (y + 8.0) ** 2
        r = np.sqrt(r2)
        ball = np.where(r < 12.0, -27.5 + np.sqrt(np.maximum(12.0 ** 2 - r2, 0.0)),
                        -27.5 - 4.0 * (r - 12.0))
        lids = ball + 1.3 * (1.0 - ind)
        cornea = 1.6 * np.exp(-r2 / 25.0) * ind
        z = smax(z, lids + cornea, 2.5)
        crease = gauss((y - up - 5.5) / 1.1) * smoothstep((16.0 - np.abs(x - 31.0 * side))
                                                          / 4.0)
        z = z - 0.9 * crease
        z = z - 0.5 * gauss((y - lo + 2.2) / 1.3) * smoothstep(
            (13.0 - np.abs(x - 31.0 * side)) / 4.0)
    return z


def _lips(z: np.ndarray, x: np.ndarray, y: np.ndarray, ax: np.ndarray) -> np.ndarray:
    """``z`` with the mouth line, the vermilions (steep at the border, rounding into the
    mouth line), the philtrum, the vermilion border with Cupid's bow and the modiolus
    hollows at the mouth corners."""
    y_st = -71.0 - 0.6 * (x / 25.0) ** 2
    taper = smoothstep((26.0 - ax) / 6.0)
    z = z - 1.7 * gauss((y - y_st) / 1.2) * taper
    yu = y - y_st
    up = np.where(yu > 3.5, gauss((yu - 3.5) / 2.2), gauss((yu - 3.5) / 3.2))
    z = z + 3.4 * up * np.exp(-((x / 22.0) ** 4))
    lo = np.where(yu < -5.0, gauss((yu + 5.0) / 3.0), gauss((yu + 5.0) / 3.6))
    z = z + 4.2 * lo * np.exp(-((x / 20.0) ** 4))
    col = 3.4 + 0.16 * np.clip(-52.0 - y, 0.0, 12.0)        # philtral columns widen down
    in_phil = smoothstep((-50.0 - y) / 5.0) * smoothstep((y + 64.0) / 3.0)
    z = z + 0.55 * gauss((ax - col) / 2.2) * in_phil
    z = z - 0.35 * gauss(x / 2.5) * in_phil
    y_vb = -63.2 + 0.9 * gauss((ax - 5.0) / 2.5) - 0.5 * gauss(x / 2.0) \
        - 5.0 * (np.clip(ax - 6.0, 0.0, None) / 20.0) ** 1.6
    z = z + 0.5 * gauss((y - y_vb) / 0.7) * taper
    return z - 1.2 * gauss((ax - 27.0) / 4.0) * gauss((y + 71.0) / 4.0)


def face_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Depth ``z`` (mm) of the face without the nose at ``(x, y)`` (any equal shapes):
    the head, then brows and cheeks, nasolabial folds, eyes and lips added in turn."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    ax = np.abs(x)
    z = _brows_and_cheeks(_head(x, y), x, y, ax)
    z = _nasolabial_folds(z, ax, y)
    return _lips(_eyes(z, x, y), x, y, ax)
