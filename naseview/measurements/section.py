"""Plane sections of a triangle mesh: the ordered polyline where a plane cuts (V, F).

Definition. For the plane ``{p : (p - o) . m = 0}`` with signed distances
``s_i = (V_i - o) . m``, an edge (i, j) is *crossed* when ``s_i >= 0`` and ``s_j < 0`` (or
the reverse); its crossing point is ``V_i + t (V_j - V_i)``, ``t = s_i / (s_i - s_j)``. A
triangle with a crossed edge has exactly two (the ``>= 0`` convention puts a vertex on the
plane on the positive side, so no case is special); it joins them by one segment. Chaining
the segments through their shared edges gives the section's polylines, each ordered along
the surface, which is what a profile (an ordered curve) needs — the unordered cloud of
crossing points would mix the dorsum with, e.g., the nostril floor.

The edge table of ``F`` is cached by the topology's content (CRC-32 of the int64 array), so
the live editor, which measures every drag of the same topology, builds it once.

Example
-------
>>> import numpy as np
>>> V = np.array([[-1.0, 0, 0], [1, 0, 0], [-1, -1, 0], [1, -1, 0]])
>>> F = np.array([[0, 2, 1], [1, 2, 3]])
>>> topo = topology(F)
>>> chain = section_through(V, topo, np.zeros(3), np.array([1.0, 0, 0]), np.zeros(3))
>>> np.round(chain, 3).tolist()
[[0.0, 0.0, 0.0], [0.0, -0.5, 0.0], [0.0, -1.0, 0.0]]
"""

from __future__ import annotations

import zlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from naseview.geometry.closing import boundary_loops


@dataclass(frozen=True)
class Topology:
    """Edges of a triangle mesh.

    Attributes:
        edges: (E, 2) int64 unique undirected edges ``(i, j)``, ``i < j``.
        face_edges: (m, 3) int64 edge index of the sides (0,1), (1,2), (2,0) of each face.
        edge_faces: (E, 2) int64 the (up to) two faces of each edge, -1 where there is
            none (boundary); a third face of a non-manifold edge is left out.
        loops: the boundary loops (vertex ids, :func:`naseview.geometry.closing.boundary_loops`):
            the outer border and the inner holes (eye and mouth openings of a face).
    """

    edges: np.ndarray
    face_edges: np.ndarray
    edge_faces: np.ndarray
    loops: tuple[np.ndarray, ...]


_CACHE: OrderedDict[tuple[tuple[int, ...], int], Topology] = OrderedDict()
_CACHE_SIZE = 4


def topology(F: np.ndarray) -> Topology:
    """The (cached) :class:`Topology` of triangles ``F`` (m, 3) int."""
    F = np.ascontiguousarray(F, dtype=np.int64)
    key = (F.shape, zlib.crc32(F.tobytes()))
    hit = _CACHE.get(key)
    if hit is not None:
        _CACHE.move_to_end(key)
        return hit
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    n = int(F.max()) + 1 if F.size else 1
    uniq, inv, counts = np.unique(e[:, 0] * n + e[:, 1], return_inverse=True,
                                  return_counts=True)
    m = len(F)
    inv = inv.ravel()
    face_of = np.tile(np.arange(m, dtype=np.int64), 3)
    order = np.argsort(inv, kind="stable")
    first = np.searchsorted(inv[order], np.arange(len(uniq)))
    ef = np.full((len(uniq), 2), -1, dtype=np.int64)
    ef[:, 0] = face_of[order[first]]
    two = counts >= 2
    ef[two, 1] = face_of[order[first[two] + 1]]
    topo = Topology(np.stack([uniq // n, uniq % n], axis=1),
                    inv.reshape(3, m).T.copy(), ef, tuple(boundary_loops(F)))
    _CACHE[key] = topo
    if len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return topo


def section_through(V: np.ndarray, topo: Topology, origin: np.ndarray, normal: np.ndarray,
                    near: np.ndarray, max_start_mm: float = 5.0) -> np.ndarray | None:
    """The section polyline of the mesh by a plane that passes nearest to ``near``.

    Args:
        V: (n, 3) vertices, mm. topo: :func:`topology` of the mesh's triangles.
        origin, normal: (3,) a point of the plane and its (unit) normal.
        near: (3,) the polyline chosen is the one through the crossing point nearest to it.
        max_start_mm: None is returned when no crossing point lies this close to ``near``.
    Returns:
        (K, 3) ordered crossing points (K >= 2; a closed section is opened at the point
        nearest ``near``), or None.
    """
    if len(V) == 0 or len(topo.edges) == 0:
        return None
    s = V @ normal - float(origin @ normal)
    pos = s >= 0.0
    E = topo.edges
    cross_ids = np.flatnonzero(pos[E[:, 0]] != pos[E[:, 1]])
    if len(cross_ids) == 0:
        return None
    faces = np.unique(topo.edge_faces[cross_ids])
    faces = faces[faces >= 0]
    fe = topo.face_edges[faces]                              # (k, 3) edge ids
    fc = pos[E[fe, 0]] != pos[E[fe, 1]]                      # crossed sides
    ok = fc.sum(axis=1) == 2
    fe, fc = fe[ok], fc[ok]
    if len(fe) == 0:
        return None
    order = np.argsort(~fc, axis=1, kind="stable")[:, :2]    # the two crossed sides
    seg = np.take_along_axis(fe, order, axis=1)              # (k, 2) edge ids
    i, j = E[cross_ids, 0], E[cross_ids, 1]
    t = (s[i] / (s[i] - s[j]))[:, None]
    P = V[i] + t * (V[j] - V[i])                             # crossing point per node
    d = np.linalg.norm(P - near, axis=1)
    start = int(np.argmin(d))
    if d[start] > max_start_mm:
        return None
    local = np.searchsorted(cross_ids, seg)                  # segments in node indices
    adj: dict[int, list[int]] = {}
    for a, b in local.tolist():
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    chain = _walk(adj, start)
    return P[chain] if len(chain) >= 2 else None


def _walk(adj: dict[int, list[int]], start: int) -> list[int]:
    """Node ids of the chain through ``start``, in order along it (both directions)."""
    seen = {start}
    halves: list[list[int]] = []
    for first in adj.get(start, [])[:2]:
        if first in seen:
            continue
        half = [first]
        seen.add(first)
        cur = first
        while True:
            nxt = [q for q in adj.get(cur, []) if q not in seen]
            if not nxt:
                break
            cur = nxt[0]
            seen.add(cur)
            half.append(cur)
        halves.append(half)
    if not halves:
        return [start]
    back = halves[1][::-1] if len(halves) > 1 else []
    return [*back, start, *halves[0]]
