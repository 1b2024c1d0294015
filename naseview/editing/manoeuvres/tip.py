"""Tip manoeuvres: projection, rotation and narrowing of the tip lobule.

Frame of :mod:`.frame` (``n``, ``prn``, ``u``, ``a``, ``e``, nasal length ``L``, width
``W``); ``d_sn = max(|(sn - prn) . a|, 0.3 L)``, the depth of the columella from the tip to
the lip along ``a``. All weights are :func:`.frame.bump` ellipsoids in the axes
``(u, a, e)`` centred on ``prn`` (radii ``(R-, R+)`` per axis).

**Tip projection** (-4..+4 mm), a translation along +z (anterior, away from the face;
Goode's tip projection grows by the amount)::

    U(p) = z * bump(p; u: (0.3 L, 0.3 L), a: (d_sn, 0.3 L), e: (0.35 W, 0.35 W))

1 at prn (prn moves by the amount), 0 at sn, half-way up the supratip and at the alae.

**Tip rotation** (-10..+15 deg, + = cephalic). Pivot ``c = (ac_l + ac_r) / 2``, axis
``-e`` (so that a positive angle turns the tip up), ``R_theta`` the rotation by theta::

    D(p) = w(p) * (R_theta (p - c) - (p - c))
    w(p) = bump(p; u: (0.7 L, 0.3 L), a: (1.3 d_sn, 0.3 L), e: (0.5 W, 0.5 W), plateau 0.15)

prn (on the plateau) turns by exactly theta about the pivot; the weight fades over the
supratip and the lower dorsum (to 0.7 L above prn: a cephalic rotation shortens the nose,
and the long fade spreads that shortening so no edge shrinks below about 60 %), the alae
and into the upper lip. Points near the pivot axis
(alar base, lip) barely move whatever their weight.

**Tip narrowing** (0..4 mm, total). With ``x = (p - g) . e`` (the offset from the
midline plane), ``x_md`` the mean lateral offset of md_l, md_r and
``x_out = max(x_al, x_md + 0.15 W)`` (x_al the mean lateral offset of the alare)::

    U(p) = -(1/2) * sigma(x) * w_lob(p) * e
    sigma(x) = sin(pi x / (2 x_md))                          for |x| <= x_md
             = sign(x) * fade(|x|, x_md, x_out)              beyond
    w_lob(p) = bump(p; u: (0.35 L, 0.3 L), a: (R_a, 0.3 L), e: infinite, plateau rho0)

``sigma`` is odd and smooth across the midline (no crease at x = 0) and peaks at the
domes, so md_l and md_r each move medially by half the amount; ``R_a = max(d_sn,
1.3 |(md - prn) . a|)`` and the plateau ``rho0`` holds both domes.
"""

from __future__ import annotations

import numpy as np

from naseview.editing.manoeuvres.frame import NasalFrame, bump, fade

_FAR = 1e9
"""A radius that switches an axis off (mm)."""


def columella_depth(frame: NasalFrame) -> float:
    """``d_sn``: depth (mm) from prn to sn along -a, at least 0.3 L."""
    sn = frame.landmarks.get("sn")
    d = 0.0 if sn is None else abs(float((sn - frame.prn) @ frame.a))
    return max(d, 0.3 * frame.length)


def tip_projection_field(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K, 3) displacement per mm of tip projection at points P (K, 3)."""
    L, W, d = frame.length, frame.width, columella_depth(frame)
    w = bump(P, frame.prn, frame.axes,
             ((0.3 * L, 0.3 * L), (d, 0.3 * L), (0.35 * W, 0.35 * W)))
    out = np.zeros((len(w), 3))
    out[:, 2] = w
    return out


def tip_rotation_pivot(frame: NasalFrame) -> tuple[np.ndarray, np.ndarray]:
    """Pivot (3,) = mean of ac_l, ac_r, and unit axis (3,) = -e (positive = cephalic)."""
    c = 0.5 * (frame.landmarks["ac_l"] + frame.landmarks["ac_r"])
    return np.asarray(c, np.float64), -frame.e


def tip_rotation_weight(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K,) weight of the tip rotation at points P (K, 3) (module docstring)."""
    L, W, d = frame.length, frame.width, columella_depth(frame)
    return bump(P, frame.prn, frame.axes,
                ((0.7 * L, 0.3 * L), (1.3 * d, 0.3 * L), (0.5 * W, 0.5 * W)), plateau=0.15)


def rotation_matrix(axis: np.ndarray, degrees: float) -> np.ndarray:
    """(3, 3) rotation by ``degrees`` about unit ``axis`` (right hand, Rodrigues)."""
    k = np.asarray(axis, np.float64)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    t = np.radians(degrees)
    return np.asarray(np.eye(3) + np.sin(t) * K + (1.0 - np.cos(t)) * K @ K)


def _lateral_of(frame: NasalFrame, left: str, right: str) -> float | None:
    """Mean |lateral offset| (mm) of two landmarks, or None when one is missing."""
    if not frame.has(left, right):
        return None
    x = frame.lateral(np.stack([frame.landmarks[left], frame.landmarks[right]]))
    return float(np.mean(np.abs(x)))


def tip_narrowing_field(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K, 3) displacement per mm of (total) tip narrowing at points P (K, 3)."""
    L, W = frame.length, frame.width
    x_md = _lateral_of(frame, "md_l", "md_r") or 0.28 * W
    x_al = _lateral_of(frame, "al_l", "al_r") or 0.5 * W
    x_out = max(x_al, x_md + 0.15 * W)
    x = frame.lateral(P)
    ax = np.abs(x)
    sigma = np.where(ax <= x_md, np.sin(0.5 * np.pi * np.clip(x / x_md, -1.0, 1.0)),
                     np.sign(x) * fade(ax, x_md, x_out))
    md = [frame.landmarks[k] for k in ("md_l", "md_r") if k in frame.landmarks]
    q = [(m - frame.prn) @ frame.axes.T for m in md]
    r_u, r_a = 0.35 * L, max(columella_depth(frame),
                             1.3 * max([abs(v[1]) for v in q], default=0.0))
    rho = max([np.hypot(v[0] / (r_u if v[0] < 0 else 0.3 * L), v[1] / r_a) for v in q],
              default=0.5)
    w = bump(P, frame.prn, frame.axes, ((r_u, 0.3 * L), (r_a, 0.3 * L), (_FAR, _FAR)),
             plateau=min(0.8, float(rho) + 0.05))
    return np.asarray(-0.5 * (sigma * w)[:, None] * frame.e[None, :])
