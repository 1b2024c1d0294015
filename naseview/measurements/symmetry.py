"""Symmetry: deviation of the dorsum and the tip from the facial midline, nostril areas.

Definitions (SPEC frame, mm; the facial midline plane of :mod:`.frame`, lateral offsets
signed + towards the subject's left):

- ``dorsal_deviation`` (mm): the lateral offset of the dorsal ridge of largest magnitude
  (signed) over 8 levels evenly spaced from 15 % to 85 % of the way from n to prn. With a
  mesh, the ridge at a level is the middle of the dorsum there: the section of the mesh by
  the horizontal plane (normal ``up``) at that level, the crossing points within 4 mm of
  the most anterior one and 12 mm of the midline, and the middle of their lateral extent
  (its ends interpolated where the section crosses that depth): for a symmetric cap its
  apex, for a flat or hollow top (a dorsum lowered past its hump) the middle between the
  shoulders, never one of them. Without a mesh: the largest offset of the mid-curve
  points between n and prn, else of k and r.
- ``tip_deviation`` (mm): the lateral offset of prn.
- ``nostril_symmetry``: smaller / larger area of the nostril outlines ``sill_l``,
  ``sill_r`` projected on their common base plane (the least-squares plane of both
  outlines), shoelace formula; 1 = equal areas. Omitted without both curves.

Example
-------
>>> import numpy as np
>>> t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
>>> ring = lambda x0, r: np.stack([x0 + r * np.cos(t), np.zeros_like(t), r * np.sin(t)], 1)
>>> round(nostril_symmetry({"sill_l": ring(8, 4.0), "sill_r": ring(-8, 2.0)}), 3)
0.25
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from naseview.measurements.frame import MidlinePlane, landmark, landmarks_of
from naseview.measurements.section import Topology

_LEVELS = np.linspace(0.15, 0.85, 8)
"""Fractions of the way from n to prn where the ridge is located."""


def _polygon_area(P: np.ndarray) -> float:
    """Area (mm^2) of the closed 2D polygon ``P`` (K, 2) (shoelace; a repeated last
    point changes nothing)."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def nostril_symmetry(curves: Mapping[str, np.ndarray] | None) -> float | None:
    """Smaller / larger projected nostril area (module docstring), or None."""
    if curves is None:
        return None
    sills = []
    for name in ("sill_l", "sill_r"):
        c = curves.get(name)
        if c is None:
            return None
        P = np.asarray(c, np.float64).reshape(-1, 3)
        P = P[np.isfinite(P).all(axis=1)]
        if len(P) < 3:
            return None
        sills.append(P)
    allp = np.concatenate(sills)
    centre = allp.mean(axis=0)
    _, _, Vt = np.linalg.svd(allp - centre, full_matrices=False)
    axes = Vt[:2].T                               # (3, 2) in-plane axes of the base plane
    areas = [_polygon_area((P - centre) @ axes) for P in sills]
    big = max(areas)
    return None if big < 1e-6 else min(areas) / big


_BAND_MM = 12.0
"""Half-width (mm) around the facial midline searched for the top band of a flat or hollow
dorsum (both its shoulders)."""

_BAND_DEPTH_MM = 4.0
"""Depth (mm) behind the most anterior crossing of the band whose middle is the ridge of a
flat or hollow dorsum: deeper than the hollow a 5 mm hump reduction leaves, so both
shoulders and sidewalls are in it."""

def _ridge_offset(X: np.ndarray, T: np.ndarray) -> float:
    """Lateral offset of the ridge from crossing points (lateral ``X``, anterior ``T``)
    of one horizontal section: the middle of the band of points within
    :data:`_BAND_DEPTH_MM` of the most anterior one (module docstring)."""
    sel = np.abs(X) <= _BAND_MM
    if not sel.any():
        return float(X[int(np.argmax(T))])
    order = np.argsort(X[sel])
    x, t = X[sel][order], T[sel][order]
    level = float(t.max()) - _BAND_DEPTH_MM
    inside = np.flatnonzero(t >= level)
    first, last = int(inside[0]), int(inside[-1])

    def edge(i: int, j: int) -> float:
        """x where the section crosses ``level`` between points i (in) and j (out)."""
        if not 0 <= j < len(x) or t[i] == t[j]:
            return float(x[i])
        return float(x[j] + (level - t[j]) * (x[i] - x[j]) / (t[i] - t[j]))

    return 0.5 * (edge(first, first - 1) + edge(last, last + 1))


def _mesh_ridge(V: np.ndarray, topo: Topology, plane: MidlinePlane, n: np.ndarray,
                prn: np.ndarray, half_width: float) -> list[float]:
    """Ridge offsets at :data:`_LEVELS` from horizontal sections of the nose box (the
    vertices within ``half_width`` mm of the midline plane, between n and prn +- 2 mm)."""
    D = V - plane.origin
    up = D @ plane.up
    hn, hp = float((n - plane.origin) @ plane.up), float((prn - plane.origin) @ plane.up)
    lo, hi = min(hn, hp) - 2.0, max(hn, hp) + 2.0
    lat = D @ plane.normal
    box = (np.abs(lat) <= half_width) & (up >= lo) & (up <= hi)
    E = topo.edges
    E = E[box[E[:, 0]] & box[E[:, 1]]]
    if len(E) == 0:
        return []
    ant = D @ plane.anterior
    i, j = E[:, 0], E[:, 1]
    levels = hn + _LEVELS * (hp - hn)
    d0 = up[i][None, :] - levels[:, None]                  # (levels, edges)
    d1 = up[j][None, :] - levels[:, None]
    crossed = (d0 >= 0) != (d1 >= 0)
    out = []
    for k in range(len(levels)):
        c = np.flatnonzero(crossed[k])
        if len(c) < 3:
            continue
        w = d0[k, c] / (d0[k, c] - d1[k, c])
        ic, jc = i[c], j[c]
        out.append(_ridge_offset(lat[ic] + w * (lat[jc] - lat[ic]),
                                 ant[ic] + w * (ant[jc] - ant[ic])))
    return out


def deviation_measurements(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                           curves: Mapping[str, np.ndarray] | None,
                           V: np.ndarray | None, topo: Topology | None) -> dict[str, float]:
    """``dorsal_deviation``, ``tip_deviation`` and ``nostril_symmetry`` (module docstring);
    ``V`` (N, 3) mm and ``topo`` its topology, or None."""
    out: dict[str, float] = {}
    prn = landmark(landmarks, "prn")
    if prn is not None:
        out["tip_deviation"] = float(plane.lateral(prn)[0])
    p = landmarks_of(landmarks, "n", "prn")
    if p is not None and float(np.linalg.norm(p[1] - p[0])) > 1e-6:
        offsets: list[float] = []
        if V is not None and topo is not None:
            w = landmarks_of(landmarks, "al_l", "al_r")
            half = 0.5 * float(np.linalg.norm(w[0] - w[1])) if w is not None else 15.0
            offsets = _mesh_ridge(V, topo, plane, p[0], p[1], max(half, 8.0))
        if not offsets:
            offsets = _curve_ridge(landmarks, plane, curves, p[0], p[1])
        if offsets:
            out["dorsal_deviation"] = float(offsets[int(np.argmax(np.abs(offsets)))])
    sym = nostril_symmetry(curves)
    if sym is not None:
        out["nostril_symmetry"] = sym
    return out


def _curve_ridge(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                 curves: Mapping[str, np.ndarray] | None, n: np.ndarray,
                 prn: np.ndarray) -> list[float]:
    """Lateral offsets of the mid-curve points strictly between n and prn (along n->prn),
    else of k and r."""
    mid = None if curves is None else curves.get("mid")
    u = prn - n
    L2 = float(u @ u)
    if mid is not None:
        M = np.asarray(mid, np.float64).reshape(-1, 3)
        M = M[np.isfinite(M).all(axis=1)]
        s = (M - n) @ u / L2
        M = M[(s > 0.0) & (s < 1.0)]
        if len(M):
            return [float(x) for x in plane.lateral(M)]
    pts = [q for q in (landmark(landmarks, k) for k in ("k", "r")) if q is not None]
    return [float(x) for x in plane.lateral(np.array(pts))] if pts else []
