"""The facial profile and the profile measurements: dorsum, radix, tip, columella, lip.

**The profile** is the section of the mesh (V, F) by the facial midline plane
(:mod:`.frame`), the polyline through the crossing point nearest nasion, ordered from n
down over the dorsum, the tip, the columella and on below subnasale (the upper lip), in
the lateral projection ``(t, h)`` (anterior, up) mm. Without a mesh (or when the section
misses n or prn by more than 5 mm) it is ``curves["mid"]`` (g-n-k-r-prn-c-sn; it stops at
sn), then the landmark polyline n-k-r-prn-c-sn. Landmarks are projected the same way;
``n``, ``prn`` ... below denote their projections, ``L = |prn - n|`` (lateral projection).

Measurements (all in the lateral projection, like a lateral photograph):

- ``dorsal_hump_depth`` (mm): with ``u = (prn - n) / L`` and ``a`` its anterior normal, the
  largest ``(P - n) . a`` over profile points P from n to prn with ``0 < (P - n) . u < L``;
  0 when no point is in front of the line n-prn. Lowering the dorsum (profile points) by
  ``d`` along ``-a`` at the apex lowers it by ``d``.
- ``nasofrontal_angle`` (deg): angle at n between the ray n->g and the dorsal tangent from
  n, the ray n->P* of largest anterior inclination over the profile points P from n to prn
  at least 0.2 L from n (the line from n touching the dorsum; n->prn for a straight or
  concave dorsum; the 0.2 L keeps the radix's small facets from setting it).
- ``nasolabial_angle`` (deg): angle at sn between the columella tangent (total-least-squares
  line of the profile from c to sn, directed to c) and the upper-lip tangent (line of the
  profile from sn to 8 mm of arc below it, directed down). Mesh profile only.
- ``tip_rotation`` (deg): the columellar-facial angle, between the columella tangent
  (directed anteriorly, towards c) and the downward facial vertical ``-up``: 90 for a
  horizontal columella, larger for an upturned (rotated) tip, +1 per degree of rotation.
- ``tip_projection`` (mm, Goode): ``(prn - ac) . anterior``, the distance of prn in front
  of the alar line (the vertical through the alar crease; ac = mean of ac_l, ac_r);
  ``goode_ratio`` = tip_projection / L.
- Crumley's triangle n, ac, prn: ``crumley_projection`` = distance of prn from the line
  n-ac (the perpendicular through the tip), ``crumley_ratio`` = it / L (ideal 3/5 = 0.6),
  ``crumley_height_ratio`` = |n - foot of that perpendicular| / L (ideal 4/5 = 0.8).
- ``radix_height`` (mm): ``(n - mf) . anterior``, mf = mean of mf_l, mf_r (3D); ``radix_level``
  (mm): ``(n - mf) . up``, + when n lies above the medial orbital rims' landmark.
- ``columellar_show`` (mm): how far the columella shows below the alar rim in the lateral
  view: per side, the height of the alar rim (the lateral half of the nostril
  outline ``sill_l`` / ``sill_r``: its points farther from the midline than the
  outline's median) above the columella's lower border (the mesh profile between c and
  sn, interpolated at the rim point's anterior position; without a mesh profile the
  columella tangent) at the middle of the columella (half-way from sn to c in the
  lateral projection, interpolated between the rim points; the nearest rim point when
  the rim does not reach it), averaged over the sides. An approximation of Gunter's
  alar-columellar distance (alar rim to columella on the lateral view, 2-4 mm); the
  outlines come from the bottom view, so a rim part hidden in the lateral view still
  counts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from naseview.measurements.frame import (
    MidlinePlane,
    angle_deg,
    direction_angle_deg,
    landmark,
    landmarks_of,
    mean_landmark,
)
from naseview.measurements.section import Topology, section_through

_MATCH_MM = 5.0
"""A profile must pass this close to n and prn (lateral projection) to be used."""

LIP_ARC_MM = 8.0
"""Arc length (mm) of the upper lip below sn that its tangent is fitted to."""


@dataclass(frozen=True)
class Profile:
    """The facial profile in the lateral projection (module docstring).

    Attributes:
        points: (K, 2) ``(anterior, up)`` mm, ordered from n downwards.
        source: ``"mesh"``, ``"mid"`` (curves["mid"]) or ``"landmarks"``.
        n, prn: (2,) projected nasion and pronasale.
        i_prn: index of the profile point nearest prn (the dorsum is ``points[:i_prn+1]``).
    """

    points: np.ndarray
    source: str
    n: np.ndarray
    prn: np.ndarray
    i_prn: int

    @property
    def length(self) -> float:
        """L = |prn - n| (lateral projection), mm."""
        return float(np.linalg.norm(self.prn - self.n))

    def index_after(self, q: np.ndarray, start: int) -> int | None:
        """Index >= ``start`` of the profile point nearest ``q`` (2,), None if > 5 mm off."""
        if start >= len(self.points):
            return None
        d = np.linalg.norm(self.points[start:] - q, axis=1)
        i = int(np.argmin(d))
        return start + i if d[i] <= _MATCH_MM else None


def _oriented(P2: np.ndarray, n2: np.ndarray, prn2: np.ndarray) -> tuple[np.ndarray, int] | None:
    """``P2`` (K, 2) trimmed to start at its point nearest n and run towards prn, with the
    index of prn in it; None when it misses n or prn by more than 5 mm."""
    dn = np.linalg.norm(P2 - n2, axis=1)
    dp = np.linalg.norm(P2 - prn2, axis=1)
    i_n, i_p = int(np.argmin(dn)), int(np.argmin(dp))
    if dn[i_n] > _MATCH_MM or dp[i_p] > _MATCH_MM or i_n == i_p:
        return None
    K = len(P2)
    closed = K > 8 and float(np.linalg.norm(P2[0] - P2[-1])) < 2.0 * float(
        np.median(np.linalg.norm(np.diff(P2, axis=0), axis=1)))
    if closed:
        fwd = np.roll(P2, -i_n, axis=0)
        back = np.concatenate([fwd[:1], fwd[:0:-1]])
        k_f, k_b = (i_p - i_n) % K, (i_n - i_p) % K
        return (fwd, k_f) if k_f <= k_b else (back, k_b)
    if i_p < i_n:
        P2, i_n, i_p = P2[::-1], K - 1 - i_n, K - 1 - i_p
    return P2[i_n:], i_p - i_n


def _projected_pair(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane, a: str,
                    b: str) -> tuple[np.ndarray, np.ndarray] | None:
    """Landmarks ``a`` and ``b`` in the lateral projection, (2,) each, or None when one is
    missing or they coincide there."""
    p = landmarks_of(landmarks, a, b)
    if p is None:
        return None
    a2, b2 = plane.to_2d(np.array(p))
    return None if float(np.linalg.norm(b2 - a2)) < 1e-6 else (a2, b2)


def facial_profile(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                   curves: Mapping[str, np.ndarray] | None = None,
                   V: np.ndarray | None = None, topo: Topology | None = None
                   ) -> Profile | None:
    """The profile: mesh section, else ``curves["mid"]``, else landmarks (module docstring).

    Args:
        landmarks: id -> (3,) mm. plane: the facial midline plane.
        curves: optional curves (``mid``). V: optional (N, 3) float64 mesh vertices, mm.
        topo: :func:`naseview.measurements.section.topology` of the mesh's faces.
    Returns:
        The profile, or None without n and prn, or when n and prn coincide.
    """
    p = landmarks_of(landmarks, "n", "prn")
    pair = _projected_pair(landmarks, plane, "n", "prn")
    if p is None or pair is None:
        return None
    n2, prn2 = pair
    candidates: list[tuple[str, np.ndarray]] = []
    if V is not None and topo is not None:
        chain = section_through(V, topo, plane.origin, plane.normal, p[0], _MATCH_MM)
        if chain is not None:
            candidates.append(("mesh", plane.to_2d(chain)))
    mid = None if curves is None else curves.get("mid")
    if mid is not None:
        M = np.asarray(mid, np.float64).reshape(-1, 3)
        M = M[np.isfinite(M).all(axis=1)]
        if len(M) >= 2:
            candidates.append(("mid", plane.to_2d(M)))
    lms = [q for q in (landmark(landmarks, k) for k in ("n", "k", "r", "prn", "c", "sn"))
           if q is not None]
    candidates.append(("landmarks", plane.to_2d(np.array(lms))))
    for source, P2 in candidates:
        got = _oriented(P2, n2, prn2)
        if got is not None:
            return Profile(got[0], source, n2, prn2, got[1])
    return None


def dorsal_hump_depth(n: np.ndarray, prn: np.ndarray, profile: np.ndarray) -> float:
    """Largest height (mm) of profile points in front of the line n-prn, 0 if none.

    Args:
        n, prn: (2,) or (3,) nasion and pronasale (lateral projection, or 3D points whose
            sagittal plane is the one spanned by n->prn and +z).
        profile: (K, 2) or (K, 3) dorsal profile points; only those whose projection on
            n->prn falls strictly between n and prn count.
    """
    n = np.asarray(n, np.float64)
    d = np.asarray(profile, np.float64).reshape(-1, len(n)) - n
    u = np.asarray(prn, np.float64) - n
    L = float(np.linalg.norm(u))
    if L < 1e-9 or len(d) == 0:
        return 0.0
    u /= L
    if len(n) == 2:
        a = np.array([-u[1], u[0]])
        a = a if a[0] >= 0 else -a
    else:
        z = np.array([0.0, 0.0, 1.0])
        a = z - (z @ u) * u
        if np.linalg.norm(a) < 1e-6:
            a = np.array([0.0, 1.0, 0.0]) - u[1] * u
        a /= np.linalg.norm(a)
    along = d @ u
    inside = (along > 0.0) & (along < L)
    if not inside.any():
        return 0.0
    return float(max(0.0, (d[inside] @ a).max()))


def _line_direction(P: np.ndarray, towards: np.ndarray) -> np.ndarray | None:
    """Unit direction (2,) of the total-least-squares line of ``P`` (K, 2), K >= 2, signed
    so that ``towards`` (2,) (a vector along the line) has a positive component on it."""
    if len(P) < 2:
        return None
    Q = P - P.mean(axis=0)
    if float(np.abs(Q).max()) < 1e-9:
        return None
    d = np.linalg.svd(Q, full_matrices=False)[2][0]
    return d if d @ towards >= 0 else -d


def _columella(prof: Profile, landmarks: Mapping[str, np.ndarray], plane: MidlinePlane
               ) -> tuple[np.ndarray, np.ndarray, int | None, int | None] | None:
    """(sn (2,), columella direction (2,) towards c, indices of c and sn in the profile or
    None)."""
    pair = _projected_pair(landmarks, plane, "c", "sn")
    if pair is None:
        return None
    c2, sn2 = pair
    i_c = prof.index_after(c2, prof.i_prn)
    i_sn = None if i_c is None else prof.index_after(sn2, i_c)
    pts = prof.points[i_c:i_sn + 1] if i_c is not None and i_sn is not None else np.zeros((0, 2))
    d = _line_direction(pts, c2 - sn2) if len(pts) >= 2 else None
    if d is None:
        d = (c2 - sn2) / np.linalg.norm(c2 - sn2)
    return sn2, d, i_c, i_sn


def _upper_lip(prof: Profile, sn2: np.ndarray, i_sn: int | None) -> np.ndarray | None:
    """Unit direction (2,) of the upper lip below sn (profile arc 0..8 mm), or None when the
    profile does not reach 4 mm below sn (mid-curve and landmark profiles stop at sn)."""
    if i_sn is None:
        return None
    P = prof.points[i_sn:]
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    keep = arc <= LIP_ARC_MM
    if arc[keep][-1] < 0.5 * LIP_ARC_MM:
        return None
    Q = P[keep]
    return _line_direction(Q, Q[-1] - Q[0])


def profile_measurements(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                         prof: Profile | None,
                         curves: Mapping[str, np.ndarray] | None = None) -> dict[str, float]:
    """The profile measurements of the module docstring that have their inputs.

    Args:
        landmarks: id -> (3,) mm. plane: the facial midline plane.
        prof: :func:`facial_profile` (None: only the radix figures).
        curves: optional curves; ``sill_l``, ``sill_r`` give the columellar show.
    """
    out: dict[str, float] = {}
    sills = [q for q in (_finite_curve(curves, k) for k in ("sill_l", "sill_r")) if q is not None]
    if prof is not None:
        L = prof.length
        dorsum = prof.points[:prof.i_prn + 1]
        out["dorsal_hump_depth"] = dorsal_hump_depth(prof.n, prof.prn, dorsum)
        g = landmark(landmarks, "g")
        if g is not None:
            g2 = plane.to_2d(g)[0]
            d = dorsum - prof.n
            far = np.linalg.norm(d, axis=1) >= 0.2 * L
            if far.any() and float(np.linalg.norm(g2 - prof.n)) > 1e-6:
                incl = np.arctan2(d[far, 0], -d[far, 1])      # from the downward vertical
                tangent = dorsum[far][int(np.argmax(incl))]
                out["nasofrontal_angle"] = angle_deg(g2, prof.n, tangent)
        col = _columella(prof, landmarks, plane)
        if col is not None:
            sn2, d_col, i_c, i_sn = col
            out["tip_rotation"] = direction_angle_deg(d_col, np.array([0.0, -1.0]))
            lip = _upper_lip(prof, sn2, i_sn) if prof.source == "mesh" else None
            if lip is not None:
                out["nasolabial_angle"] = direction_angle_deg(d_col, lip)
            col_pts = prof.points[i_c:i_sn + 1] if prof.source == "mesh" \
                and i_c is not None and i_sn is not None else None
            show = _columellar_show(landmarks, plane, sn2, d_col, sills, col_pts)
            if show is not None:
                out["columellar_show"] = show
        out.update(_tip_projection(landmarks, plane, prof))
    out.update(_radix(landmarks, plane))
    return out


def _finite_curve(curves: Mapping[str, np.ndarray] | None, name: str) -> np.ndarray | None:
    """(K, 3) finite points of ``curves[name]``, None when absent or shorter than 2."""
    c = None if curves is None else curves.get(name)
    if c is None:
        return None
    P = np.asarray(c, np.float64).reshape(-1, 3)
    P = P[np.isfinite(P).all(axis=1)]
    return P if len(P) >= 2 else None


def _tip_projection(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                    prof: Profile) -> dict[str, float]:
    """Goode's and Crumley's tip projection figures (module docstring)."""
    ac = mean_landmark(landmarks, "ac_l", "ac_r")
    if ac is None:
        return {}
    ac2 = plane.to_2d(ac)[0]
    n2, prn2, L = prof.n, prof.prn, prof.length
    out = {"tip_projection": float(prn2[0] - ac2[0])}
    out["goode_ratio"] = out["tip_projection"] / L
    h = ac2 - n2
    H = float(np.linalg.norm(h))
    if H > 1e-6:
        h /= H
        q = prn2 - n2
        foot = float(q @ h)
        out["crumley_projection"] = float(abs(q[0] * h[1] - q[1] * h[0]))
        out["crumley_ratio"] = out["crumley_projection"] / L
        out["crumley_height_ratio"] = foot / L
    return out


def _radix(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane) -> dict[str, float]:
    """``radix_height`` and ``radix_level`` of n against the mean of mf_l, mf_r."""
    p = landmarks_of(landmarks, "n", "mf_l", "mf_r")
    if p is None:
        return {}
    d = p[0] - 0.5 * (p[1] + p[2])
    return {"radix_height": float(d @ plane.anterior), "radix_level": float(d @ plane.up)}


MID_COLUMELLA = 0.5
"""Where along the columella (0 at sn, 1 at c, in the lateral projection) the columellar
show is read: Gunter's alar-columellar distance is taken at the middle of the nostril;
at sn the alar base stands far above the columella's foot, which is no "show"."""


def _columellar_show(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                     sn2: np.ndarray, d_col: np.ndarray, sills: list[np.ndarray],
                     columella: np.ndarray | None = None) -> float | None:
    """Columellar show (module docstring), mm, or None without a nostril outline over
    the columella. ``sills``: the (K, 3) nostril outlines present (sill_l, sill_r);
    ``columella``: (J, 2) profile points from c to sn, or None (the tangent line)."""
    c = landmark(landmarks, "c")
    if c is None or abs(float(d_col[0])) < 0.1 or not sills:
        return None
    c2 = plane.to_2d(c)[0]
    lo, hi = sorted((float(c2[0]), float(sn2[0])))
    use_profile = columella is not None and len(columella) >= 2 \
        and float(np.ptp(columella[:, 0])) > 0.5
    gaps = []
    for sill in sills:
        R = plane.to_2d(sill)
        lateral = np.abs(plane.lateral(sill))
        rim = (lateral >= np.median(lateral)) & (R[:, 0] >= lo) & (R[:, 0] <= hi)
        if not rim.any():
            continue
        if use_profile:
            assert columella is not None
            o = np.argsort(columella[:, 0])
            h_col = np.interp(R[rim, 0], columella[o, 0], columella[o, 1])
        else:
            h_col = sn2[1] + (R[rim, 0] - sn2[0]) * d_col[1] / d_col[0]
        gap = R[rim, 1] - h_col
        t = (R[rim, 0] - float(sn2[0])) / (float(c2[0]) - float(sn2[0]))
        o = np.argsort(t)
        gaps.append(float(np.interp(MID_COLUMELLA, t[o], gap[o])))
    return float(np.mean(gaps)) if gaps else None
