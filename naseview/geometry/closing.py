"""Closing open face meshes: hole caps (eyes, mouth) and a watertight solid for printing.

A face mesh ``V`` (n, 3) mm (SPEC frame: +x subject's left, +y up, +z anterior), ``F``
(m, 3) counter-clockwise seen from outside, is an open shell: a few inner holes (eye and
mouth openings) and one long outer border. :func:`cap_holes` closes the inner holes with a
fan to each hole's centre (optionally recessed into the face); :func:`close_solid` also
closes the outer border into a solid: the border is extruded straight back (-z) to a plane
behind the rearmost vertex and that plane is capped by an ear-clipped polygon, so the result
is watertight and consistently oriented (outward normals, positive volume) - an STL a
slicer can print. The input vertices and triangles come first, unchanged, in both results.

Example
-------
>>> import numpy as np
>>> V = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]])
>>> F = np.array([[0, 1, 2], [0, 2, 3]])
>>> Vs, Fs = close_solid(V, F, back_mm=5.0)
>>> len(Vs), len(Fs), float(Vs[:, 2].min())
(8, 12, -5.0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from naseview.geometry.mesh import boundary_edges, vertex_normals

__all__ = ["boundary_loops", "cap_holes", "cap_values", "close_solid", "ear_clip"]


def boundary_loops(F: ArrayLike) -> list[np.ndarray]:
    """The boundary loops of a triangle mesh, each in the direction its edges run in ``F``.

    Args:
        F: (m, 3) triangles (manifold along the boundary).
    Returns:
        list of (k,) int64 vertex loops, sorted by vertex count (ascending).
    """
    E = boundary_edges(F)
    if len(E) == 0:
        return []
    nxt = dict(zip(E[:, 0].tolist(), E[:, 1].tolist(), strict=True))
    loops: list[np.ndarray] = []
    seen: set[int] = set()
    for start in E[:, 0].tolist():
        if start in seen:
            continue
        loop = [start]
        seen.add(start)
        v = nxt[start]
        while v != start and v not in seen and v in nxt:
            loop.append(v)
            seen.add(v)
            v = nxt[v]
        if len(loop) >= 3:
            loops.append(np.asarray(loop, dtype=np.int64))
    loops.sort(key=len)
    return loops


def _perimeter(V: np.ndarray, loop: np.ndarray) -> float:
    P = V[loop]
    return float(np.linalg.norm(P - np.roll(P, -1, axis=0), axis=1).sum())


def _inner_and_outer(V: np.ndarray, F: np.ndarray) -> tuple[list[np.ndarray],
                                                            np.ndarray | None]:
    """Inner loops (all but the longest by perimeter) and the outer loop (or None)."""
    loops = sorted(boundary_loops(F), key=lambda lp: _perimeter(V, lp))
    if not loops:
        return [], None
    return loops[:-1], loops[-1]


def cap_holes(V: ArrayLike, F: ArrayLike, recess: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """Close every boundary loop but the outer one (longest perimeter) with a fan.

    Each hole gets one new vertex at its centroid, moved ``recess`` x the hole's mean
    radius into the face (against the mean normal of its rim), and one triangle per rim
    edge, oriented like the mesh. The outer border stays open.

    Args:
        V: (n, 3) vertices (mm); F: (m, 3) triangles.
        recess: depth of the cap centre as a fraction of the hole radius (0 = flat).
    Returns:
        ``(V2, F2)``: (n + h, 3) vertices (the h cap centres appended, in the order of
        :func:`cap_values`) and (m + sum of rim lengths, 3) triangles (``F`` first).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    inner, _ = _inner_and_outer(V, F)
    if not inner:
        return V.copy(), F.copy()
    N = vertex_normals(V, F) if recess else None
    centres, fans = [], []
    for h, loop in enumerate(inner):
        c = V[loop].mean(axis=0)
        if N is not None:
            nrm = N[loop].mean(axis=0)
            nrm /= max(float(np.linalg.norm(nrm)), 1e-12)
            c = c - recess * float(np.linalg.norm(V[loop] - c, axis=1).mean()) * nrm
        centres.append(c)
        # rim edge a -> b runs this way in F; the cap uses b -> a
        fans.append(np.column_stack([np.roll(loop, -1), loop,
                                     np.full(len(loop), len(V) + h)]))
    return np.vstack([V, np.array(centres)]), np.vstack([F, *fans])


def cap_values(values: ArrayLike, F: ArrayLike, V: ArrayLike) -> np.ndarray:
    """Per-vertex ``values`` (n, C) extended to the cap centres of :func:`cap_holes`.

    Each cap centre gets the mean of its rim's values (e.g. texture coordinates or
    colours), so a renderer can texture the caps like their surroundings.

    Args:
        values: (n, C) per-vertex values of the open mesh; F: (m, 3); V: (n, 3) mm (it
            decides which loop is the outer border).
    Returns:
        (n + h, C) values, same dtype as ``values`` when it is floating, else float64.
    """
    vals = np.asarray(values)
    inner, _ = _inner_and_outer(np.asarray(V, dtype=np.float64), np.asarray(F, np.int64))
    if not inner:
        return vals.copy()
    extra = np.array([vals[loop].mean(axis=0) for loop in inner])
    return np.concatenate([vals, extra.astype(vals.dtype if vals.dtype.kind == "f"
                                              else np.float64)])


def ear_clip(P: ArrayLike) -> np.ndarray:
    """Triangulate a simple polygon (ear clipping), counter-clockwise triangles.

    Args:
        P: (k, 2) polygon corners in order (either orientation), no self-intersection.
    Returns:
        (k - 2, 3) int64 corner indices, each triangle counter-clockwise in the plane.
        A polygon that is not simple falls back to a fan from corner 0 for what remains.
    """
    P = np.asarray(P, dtype=np.float64)
    idx = list(range(len(P)))
    area = 0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if area < 0:
        idx.reverse()
    tris: list[tuple[int, int, int]] = []

    def cross(a: int, b: int, c: int) -> float:
        return float((P[b, 0] - P[a, 0]) * (P[c, 1] - P[a, 1])
                     - (P[b, 1] - P[a, 1]) * (P[c, 0] - P[a, 0]))

    def inside(p: np.ndarray, a: int, b: int, c: int) -> np.ndarray:
        A, B, C = P[a], P[b], P[c]
        d1 = (B[0] - A[0]) * (p[:, 1] - A[1]) - (B[1] - A[1]) * (p[:, 0] - A[0])
        d2 = (C[0] - B[0]) * (p[:, 1] - B[1]) - (C[1] - B[1]) * (p[:, 0] - B[0])
        d3 = (A[0] - C[0]) * (p[:, 1] - C[1]) - (A[1] - C[1]) * (p[:, 0] - C[0])
        return (d1 >= 0) & (d2 >= 0) & (d3 >= 0)

    i = 0
    guard = 0
    while len(idx) > 3 and guard < 2 * len(idx) + 2:
        n = len(idx)
        a, b, c = idx[(i - 1) % n], idx[i % n], idx[(i + 1) % n]
        ear = cross(a, b, c) > 1e-12
        if ear:
            others = np.array([j for j in idx if j not in (a, b, c)], dtype=np.int64)
            ear = not inside(P[others], a, b, c).any() if len(others) else True
        if ear:
            tris.append((a, b, c))
            idx.pop(i % n)
            guard = 0
        else:
            i += 1
            guard += 1
    if len(idx) > 3:  # not simple: fan what is left
        tris += [(idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1)]
    elif len(idx) == 3:
        tris.append((idx[0], idx[1], idx[2]))
    return np.asarray(tris, dtype=np.int64).reshape(-1, 3)


def close_solid(V: ArrayLike, F: ArrayLike, back_mm: float = 10.0
                ) -> tuple[np.ndarray, np.ndarray]:
    """A watertight solid from an open face (or nose) mesh, for STL printing.

    Inner holes are capped flat (:func:`cap_holes`); the outer border is extruded straight
    back along -z to the plane ``z = min(V_z) - back_mm`` (a side wall of one quad per
    border edge) and that plane is closed by an ear-clipped polygon (the border seen
    along z, which must not cross itself - true for a face, whose border runs round the
    head). Orientation follows ``F`` (counter-clockwise from outside), so the solid has
    outward normals and a positive volume.

    Args:
        V: (n, 3) vertices (mm, SPEC frame, +z anterior); F: (m, 3) triangles.
        back_mm: distance of the back plane behind the rearmost vertex (mm, > 0).
    Returns:
        ``(V2, F2)``: vertices (``V`` first, then cap centres, then the back-plane copies of
        the border) and triangles (``F`` first). A mesh without a border is returned capped.
    """
    V2, F2 = cap_holes(V, F)
    Vo = np.asarray(V, dtype=np.float64)
    _, outer = _inner_and_outer(Vo, np.asarray(F, dtype=np.int64))
    if outer is None:
        return V2, F2
    z_back = float(Vo[:, 2].min()) - max(float(back_mm), 1e-3)
    k = len(outer)
    base = len(V2)
    back = Vo[outer].copy()
    back[:, 2] = z_back
    a, b = outer, np.roll(outer, -1)                     # border edge a -> b runs in F
    a2 = base + np.arange(k)
    b2 = base + np.roll(np.arange(k), -1)
    wall = np.concatenate([np.column_stack([b, a, a2]), np.column_stack([b, a2, b2])])
    tri = ear_clip(back[:, :2])                          # counter-clockwise seen from +z
    P = back[:, :2]
    ccw = float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1])) > 0
    # the cap runs the border edges backwards (b' -> a'), like every neighbour pair in F:
    # a border running counter-clockwise seen from +z needs triangles facing -z
    cap = base + (tri[:, ::-1] if ccw else tri)
    return np.vstack([V2, back]), np.vstack([F2, wall, cap])
