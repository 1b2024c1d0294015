"""Alar base narrowing: each ala with its crease moves medially (mm per side, 0..4).

Frame of :mod:`.frame` (``e`` lateral, ``x = (p - g) . e`` the offset from the midline
plane, width ``W``). For the left side (the right is the mirror, with its own landmarks
and ``x -> -x``), with ``xi = x`` the lateral offset towards that side, ``x_sill`` and
``x_ala`` the lateral offsets of the nostril sill point alpp and of the outermost of al,
ac, and ``m`` the mean of al, ac, alpp::

    U(p) = -e * w_x(xi) * w_v(p)
    w_x(xi) = smoothstep(xi / x_sill)                          (0 on the midline)
              * fade(xi, x_ala + 0.03 W, x_ala + 0.38 W)         (fades into the cheek)
    w_v(p)  = fade(|P_ua (p - m)|, r_ala, r_ala + 0.3 W)          (the lip, the sidewall)
              * fade(p_z - z_front, 0.05 W, 0.25 W)                 (the tip lobule stays)

``z_front`` is the largest z of al, ac, alpp (the lobule lies in front of it).
``P_ua`` keeps the components along ``u`` and ``a`` (the sagittal plane), ``r_ala`` is the
largest such distance from ``m`` to al, ac and alpp plus 0.03 W: weight 1 on the whole ala,
the alar crease (ac, al), the alar groove and the sill, so the crease moves with the ala
(never al alone, which pinches the ala). The cheek band (0.35 W, about 13 mm) keeps the
stretch gradient of a 4 mm move near 1.5 * 4 / 13 ≈ 0.45; the nostril floor between the
sill and the columella takes the compression (the nostril gets smaller, as after a
sill excision) over the whole half-width up to the sill (slope 1.5 / x_sill per mm), and
the columella base narrows a little (its sides are near the midline, where ``w_x`` is
small). ``x_sill`` is at least 0.6 x_ala (without alpp, exactly that): a sill closer to the
midline (a narrow nostril, as on the generic face) moves by most of the amount, not all
of it, so that the nostril floor is never crushed (slope <= 1.5 / (0.6 x_ala) per mm).
"""

from __future__ import annotations

import numpy as np

from naseview.editing.manoeuvres.frame import NasalFrame, fade, smoothstep

MIN_RAMP = 0.6
"""The medial ramp spans at least this fraction of the ala's lateral offset (a medial
sill would otherwise crush the nostril floor)."""

TIP_FADE = (0.05, 0.25)
"""In front (+z) of the most anterior of al, ac, alpp the field fades between these
distances (fractions of the alar width ``W``, about 2 and 9 mm), so the tip lobule and
its domes (md) stay where they are: narrowing the alar base is not narrowing the tip."""

ALAR_IDS = ("al", "ac")
"""Landmarks (per side, ``_l`` / ``_r``) an alar base narrowing needs."""


def alar_base_field(frame: NasalFrame, P: np.ndarray) -> np.ndarray:
    """(K, 3) displacement per mm (per side) of alar base narrowing at points P (K, 3)."""
    out = np.zeros((len(P), 3))
    W = frame.width
    x = frame.lateral(P)
    X = np.asarray(P, np.float64)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        ids = [f"{k}_{side}" for k in (*ALAR_IDS, "alpp")]
        pts = [frame.landmarks[i] for i in ids if i in frame.landmarks]
        if len(pts) < 2:
            continue
        pts_a = np.stack(pts)
        xs = sign * frame.lateral(pts_a)
        x_ala = float(xs[:2].max())
        x_sill = float(xs[2]) if len(pts) == 3 else 0.6 * x_ala
        x_sill = float(np.clip(x_sill, MIN_RAMP * x_ala, 0.9 * x_ala))
        xi = sign * x
        w_x = smoothstep(xi / x_sill) \
            * fade(xi, x_ala + 0.03 * W, x_ala + 0.38 * W)
        m = pts_a.mean(axis=0)
        ua = frame.axes[:2]
        r_ala = float(np.linalg.norm((pts_a - m) @ ua.T, axis=1).max()) + 0.03 * W
        d = np.linalg.norm((X - m) @ ua.T, axis=1)
        w = w_x * fade(d, r_ala, r_ala + 0.3 * W)
        front = float(pts_a[:, 2].max())   # the most anterior of al, ac, alpp
        w = w * fade(X[:, 2] - front, TIP_FADE[0] * W, TIP_FADE[1] * W)   # the lobule stays
        out += (-sign * w)[:, None] * frame.e[None, :]
    return out
