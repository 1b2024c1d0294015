"""Dorsal manoeuvres: hump reduction and radix augmentation, per unit amount (mm).

Both are translations ``D(p) = amount * U(p)``; the functions here return ``U`` (K, 3) for
points ``p`` (K, 3) of the rest shape, in the frame of :mod:`.frame` (``n``, ``prn``,
``u``, ``a``, ``e``, nasal length ``L``, width ``W``).

**Hump reduction** (0..5 mm). With ``s = (p - n) . u / L`` (0 at n, 1 at prn), the
lateral offset ``x`` from the midline plane and the height ``h = (p - n) . a`` above the
n-prn line, ``up`` the facial vertical (+y made orthogonal to ``e``), let ``H(s)`` be
the dorsal profile: the upper envelope of the mesh's midline section (the plane of
:func:`naseview.measurements.dorsal_hump_depth`) and of the mid-curve between n and prn,
and ``h_max`` its highest point above the line (the hump depth). Then::
    U(p) = -a * b(s) * w_lat(x) * w_depth(p) * w_tip(p)      (0 unless 0 < s < 1)
    b(s)  = T(s) H+(s) / max_s(T H+)     (h_max >= 0.5 mm; else H+ -> 4 s (1 - s))
    T(s)  = smoothstep(s / 0.1) * smoothstep((1 - s) / 0.03)        (n, prn stay put)
    w_lat = fade(|x|, 0.03 W, 0.25 W)      (1 on the ridge, 0 on the sidewalls)
    w_depth = fade(H(s) - h, 0.1 L, 0.2 L)   (only the dorsal skin, not the lobule's
                                             underside or the columella below it)
    w_tip = smoothstep(((p - prn) . up) / (0.06 L))   (nothing at or below the level
                                             of prn moves: the tip lobule stays)

``H+ = max(H, 0)``; ``H`` is the running maximum over +-0.05 L (a window wider than the
gaps between section points on a coarse mesh), lightly smoothed and interpolated by a
monotone cubic (C1); it is at least the true profile, so every profile point goes down at
least in proportion to its height. The profile point at the peak goes down by exactly
``amount`` along ``-a`` while its ``s`` stays, so the hump measure falls by the amount
(until the dorsum is straight; more makes it concave, and near prn, where the measure
often peaks in the supratip, the slope reaches about 1.1 at 5 mm). The alar width scales
the ridge: 0.25 W is about 9 mm either side on an adult nose, and the lateral slope of a
5 mm reduction is at most 1.5 * 5 / (0.22 W) ≈ 0.9. A real lowered dorsum also narrows a
little, which this field leaves out.

**Radix augmentation** (-2..+4 mm). Direction ``r = unit(unit(g - n) + unit(prn - n))``,
the bisector of the nasofrontal angle (the radix's outward normal; ``a`` without g)::

    U(p) = r * bump(p; centre n, axes (u, a, e),
                    along u: R- = |g - n| (up to the glabella), R+ = 0.4 L (down the dorsum),
                    along a: R = 0.3 L, along e: R = 0.3 W)

``bump`` is 1 at n (so n moves by the amount) and 0 at the glabella.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.ndimage import gaussian_filter1d

from naseview.editing.manoeuvres.frame import NasalFrame, bump, fade, smoothstep, unit

HUMP_BINS = 100
"""Grid steps of the dorsal profile between n and prn (about 0.5 mm on an adult nose)."""

PROFILE_WINDOW = 0.05
"""Half-width (fraction of n-prn, about 2.5 mm) of the upper-envelope window: wider than
the gaps between the midline section's points on a coarse mesh."""

TIP_TAPER = 0.03
"""Fraction of n-prn over which the hump field fades out before prn (the hump measure
often peaks in the supratip, a few mm above prn)."""

TIP_LEVEL = 0.06
"""Height (fraction of n-prn, about 3 mm) above prn over which the hump field fades in:
the lobule at and below the level of prn never moves."""

MIN_HUMP_MM = 0.5
"""Below this hump depth the profile is too flat to scale: a smooth mid-dorsal bump."""


def midline_section(V: np.ndarray, F: np.ndarray, frame: NasalFrame) -> np.ndarray:
    """(K, 3) points where the midline plane (normal e) cuts the mesh's edges
    (V (N, 3) mm, F (M, 3))."""
    s = frame.lateral(V)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.unique(np.sort(E, axis=1), axis=0)
    s0, s1 = s[E[:, 0]], s[E[:, 1]]
    cross = (s0 * s1 <= 0) & (s0 != s1)
    E, s0, s1 = E[cross], s0[cross], s1[cross]
    t = (s0 / (s0 - s1))[:, None]
    return np.asarray(V[E[:, 0]] + t * (V[E[:, 1]] - V[E[:, 0]]))


def dorsal_profile(V: np.ndarray, F: np.ndarray, frame: NasalFrame,
                   mid: np.ndarray | None = None) -> tuple[PchipInterpolator, float]:
    """The dorsal profile ``H(s)`` (mm above the n-prn line, s in [0, 1]) and its raw
    maximum ``h_max`` (the hump depth on the mesh, mm; may be <= 0).

    The profile points are the mesh's midline section (V (N, 3), F (M, 3)) plus the
    mid-curve ``mid`` (L, 3) when given; ``H`` at each of :data:`HUMP_BINS` + 1 grid
    values of s is the highest point within ``PROFILE_WINDOW`` of it (the upper envelope:
    the dorsal skin, not the columella below the tip), gaps interpolated, smoothed over
    one grid step and interpolated by a monotone cubic (C1)."""
    X = midline_section(V, F, frame)
    if mid is not None and len(mid):
        X = np.concatenate([X, np.asarray(mid, np.float64).reshape(-1, 3)])
    X = X - frame.n
    s = X @ frame.u / frame.length
    h = X @ frame.a
    inside = (s > 0.0) & (s < 1.0)
    s, h = s[inside], h[inside]
    h_max = float(h.max()) if len(h) else 0.0
    grid = np.linspace(0.0, 1.0, HUMP_BINS + 1)
    near = np.abs(s[None, :] - grid[:, None]) <= PROFILE_WINDOW
    env = np.where(near, h[None, :], -np.inf).max(axis=1, initial=-np.inf)
    ok = np.isfinite(env)
    if not ok.any():
        return PchipInterpolator([0.0, 1.0], [0.0, 0.0]), 0.0
    env = np.interp(grid, grid[ok], env[ok])
    env = gaussian_filter1d(env, 1.0, mode="nearest")
    env[0] = env[-1] = 0.0
    return PchipInterpolator(grid, env), h_max


def _taper(s: np.ndarray) -> np.ndarray:
    """``T(s)``: 0 at n and prn, 1 from 0.1 to 1 - TIP_TAPER (C1)."""
    return np.asarray(smoothstep(s / 0.1) * smoothstep((1.0 - s) / TIP_TAPER))


def hump_reduction_field(frame: NasalFrame, P: np.ndarray, V: np.ndarray,
                         F: np.ndarray, mid: np.ndarray | None = None) -> np.ndarray:
    """(K, 3) displacement per mm of hump reduction at points P (K, 3) (module docstring),
    from the profile of the rest mesh V (N, 3), F (M, 3) and mid-curve ``mid`` (L, 3)."""
    H, h_max = dorsal_profile(V, F, frame, mid)
    X = np.asarray(P, np.float64) - frame.n
    s = np.clip(X @ frame.u / frame.length, 0.0, 1.0)
    taper = _taper(s)
    grid = np.linspace(0.0, 1.0, 1001)
    tg = _taper(grid)
    if h_max >= MIN_HUMP_MM:
        shape, shape_g = np.maximum(H(s), 0.0), np.maximum(H(grid), 0.0)
    else:
        shape, shape_g = 4.0 * s * (1.0 - s), 4.0 * grid * (1.0 - grid)
    top = float((tg * shape_g).max())
    if top <= 0.0:
        return np.zeros_like(X)
    b = taper * shape / top
    w_lat = fade(np.abs(frame.lateral(P)), 0.03 * frame.width, 0.25 * frame.width)
    below = H(s) - X @ frame.a
    w_depth = fade(below, 0.1 * frame.length, 0.2 * frame.length)
    along = X @ frame.u
    up = np.array([0.0, 1.0, 0.0]) - frame.e[1] * frame.e
    w_tip = smoothstep((np.asarray(P, np.float64) - frame.prn) @ unit(up)
                       / (TIP_LEVEL * frame.length))
    inside = (along > 0.0) & (along < frame.length)
    w = np.where(inside, b * w_lat * w_depth * w_tip, 0.0)
    return np.asarray(-w[:, None] * frame.a[None, :])


def radix_direction(frame: NasalFrame) -> np.ndarray:
    """(3,) unit bisector of the nasofrontal angle at n (``a`` without g)."""
    g = frame.landmarks.get("g")
    if g is None or np.linalg.norm(g - frame.n) < 1e-6:
        return frame.a
    r = unit(unit(g - frame.n) + frame.u)
    return r if np.linalg.norm(r) > 0.5 and r @ frame.a > 0.0 else frame.a


def radix_reach_up(frame: NasalFrame) -> float:
    """Radius (mm) of the radix bump towards the glabella: |g - n|, else 0.3 L."""
    g = frame.landmarks.get("g")
    d = 0.0 if g is None else float(np.linalg.norm(g - frame.n))
    return d if d > 0.1 * frame.length else 0.3 * frame.length


def radix_augmentation_field(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K, 3) displacement per mm of radix augmentation at points P (K, 3)."""
    L, W = frame.length, frame.width
    w = bump(P, frame.n, frame.axes,
             ((radix_reach_up(frame), 0.4 * L), (0.3 * L, 0.3 * L), (0.3 * W, 0.3 * W)))
    return np.asarray(w[:, None] * radix_direction(frame)[None, :])
