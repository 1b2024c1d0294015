"""Vertex paths of the SPEC §5 nasal boundary curves on a face mesh.

The paper (section 3.3) draws six boundary curves through the landmarks: the mid-curve
(g-n-k-r-prn-c-sn), the bottom-curve (ac-al-al'-add-prn-add-al'-al-ac), the ala-curves
(ac-al-int), the C-curve (md-c-md), the nasal sills (closed nostril borders) and the
side-curves (int-mf). On a face model the same curves are vertex paths: consecutive
landmark vertices are joined by shortest paths on the mesh edge graph, with edge costs that
keep each curve on the feature it follows in the photos:

========  =============================================  ==================================
curve     feature                                        cost multiplier per vertex
========  =============================================  ==================================
mid       midsagittal profile                            ``1 + midline_weight |x - x_mid| / mm``
bottom    outline of the nose base seen from below       ``1 + silhouette_weight |n_y|``
c         lower outline of the lobule seen from front    ``1 + silhouette_weight |n_z|``
side      lateral outline of the sidewall seen from      ``1 + silhouette_weight |n_z|``
          front (its steepest band)
ala       alar groove (a valley)                         ``exp(valley_weight H L)``
sill      border of the nostril region                   (boundary loop, no search)
========  =============================================  ==================================

with ``n`` the unit vertex normal, ``H`` the signed mean curvature (1/mm, > 0 convex) and
``L`` = 4 mm. The 2D-only ``add`` helper clicks have no vertex, so the bottom-curve goes
from al' straight to prn. Everything works on any triangle mesh in the SPEC axes (+x the
subject's left, +y up, +z anterior, mm): the ICT model and naseview's generic face use it.

Example
-------
    paths = curve_paths(V, F, model.landmark_vertices, model.nostril_vertices)
    V[paths["mid"]]            # (L, 3) polyline g ... sn on the mesh
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from naseview.geometry.laplacian import cotangent_laplacian, voronoi_mass
from naseview.geometry.mesh import boundary_edges, mesh_edges, vertex_adjacency, vertex_normals
from naseview.landmarks import CURVE_LANDMARKS, CURVE_NAMES, HELPER_IDS

VALLEY_LENGTH_MM = 4.0
"""Length scale ``L`` turning mean curvature (1/mm) into the dimensionless valley cost."""


def mean_curvature(V: np.ndarray, F: np.ndarray, smooth_iterations: int = 2) -> np.ndarray:
    """(V,) signed mean curvature in 1/mm (> 0 convex like the nose tip, < 0 in creases).

    Cotangent Laplacian estimate ``H = -<(M^-1 L V), n> / 2`` (``L`` negative
    semi-definite, ``M`` Voronoi mass), then ``smooth_iterations`` rounds of averaging over
    the 1-ring to calm the irregular-triangle noise. Boundary vertices get the mean of
    their interior neighbours' values through the smoothing.
    """
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    L = cotangent_laplacian(V, F)
    m = voronoi_mass(V, F)
    m = np.where(m > 0, m, np.inf)
    Hn = -(L @ V) / m[:, None]
    H = 0.5 * np.einsum("ij,ij->i", Hn, vertex_normals(V, F))
    boundary = np.zeros(len(V), dtype=bool)
    boundary[np.unique(boundary_edges(F))] = True
    H[boundary] = 0.0
    A = vertex_adjacency(len(V), F)
    interior = (~boundary).astype(np.float64)
    for _ in range(max(int(smooth_iterations), 0)):
        num = A @ (H * interior) + H * interior
        den = A @ interior + interior
        H = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return H


def weighted_edge_graph(V: np.ndarray, F: np.ndarray,
                        vertex_cost: np.ndarray | None = None) -> sp.csr_matrix:
    """(V, V) symmetric CSR graph, edge weight = length (mm) x mean of the endpoint costs.

    Args:
        V: (V, 3) vertices, mm.
        F: (F, 3) triangles.
        vertex_cost: (V,) positive multipliers (default 1: plain edge lengths).
    """
    V = np.asarray(V, dtype=np.float64)
    E = mesh_edges(F)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    if vertex_cost is not None:
        c = np.asarray(vertex_cost, dtype=np.float64)
        w = w * 0.5 * (c[E[:, 0]] + c[E[:, 1]])
    w = np.maximum(w, 1e-12)  # csgraph drops explicit zeros
    n = len(V)
    G = sp.coo_matrix((w, (E[:, 0], E[:, 1])), shape=(n, n))
    return (G + G.T).tocsr()


def shortest_path(G: sp.csr_matrix, source: int, target: int) -> np.ndarray:
    """(L,) int64 vertex path from ``source`` to ``target`` (both included) on graph ``G``.

    Raises:
        ValueError: the two vertices are not connected.
    """
    source, target = int(source), int(target)
    if source == target:
        return np.array([source], dtype=np.int64)
    dist, pred = dijkstra(G, directed=False, indices=source, return_predecessors=True)
    if not np.isfinite(dist[target]):
        raise ValueError(f"vertices {source} and {target} are not connected on the mesh")
    path = [target]
    while path[-1] != source:
        path.append(int(pred[path[-1]]))
    return np.array(path[::-1], dtype=np.int64)


def chain_path(G: sp.csr_matrix, vertices: Sequence[int]) -> np.ndarray:
    """(L,) int64 path through ``vertices`` in order: shortest paths joined end to end."""
    parts = [np.array([int(vertices[0])], dtype=np.int64)]
    for a, b in zip(vertices[:-1], vertices[1:], strict=True):
        parts.append(shortest_path(G, a, b)[1:])
    return np.concatenate(parts)


def region_boundary_loops(F: np.ndarray, vertex_ids: np.ndarray) -> list[np.ndarray]:
    """Closed vertex loops bounding the triangles whose 3 vertices are all in ``vertex_ids``.

    Each loop is an (L,) int64 array, first vertex not repeated, oriented like the
    triangles' boundary (counter-clockwise seen from outside the surface for CCW faces);
    longest loop first. Empty list when the region has no triangle.
    """
    F = np.asarray(F, dtype=np.int64)
    ids = np.asarray(vertex_ids, dtype=np.int64)
    if ids.size == 0:
        return []
    inside = np.zeros(int(max(F.max(), ids.max())) + 1, dtype=bool)
    inside[ids] = True
    Fs = F[inside[F].all(axis=1)]
    if len(Fs) == 0:
        return []
    nxt: dict[int, list[int]] = {}
    for a, b in boundary_edges(Fs):
        nxt.setdefault(int(a), []).append(int(b))
    loops: list[np.ndarray] = []
    while nxt:
        start = next(iter(nxt))
        loop = [start]
        cur = start
        while True:
            outs = nxt.get(cur)
            if not outs:
                break
            b = outs.pop()
            if not outs:
                del nxt[cur]
            if b == start:
                break
            loop.append(b)
            cur = b
        loops.append(np.array(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def smooth_vertex_values(values: np.ndarray, F: np.ndarray, iterations: int) -> np.ndarray:
    """(V,) or (V, d) values averaged ``iterations`` times with their 1-ring neighbours."""
    out = np.asarray(values, dtype=np.float64).copy()
    if iterations <= 0:
        return out
    A = vertex_adjacency(out.shape[0], F)
    deg = np.asarray(A.sum(axis=1)).ravel() + 1.0
    for _ in range(int(iterations)):
        out = (out + A @ out) / (deg if out.ndim == 1 else deg[:, None])
    return out


def curve_cost_fields(V: np.ndarray, F: np.ndarray, x_mid: float = 0.0,
                      midline_weight: float = 4.0, silhouette_weight: float = 6.0,
                      valley_weight: float = 6.0,
                      smooth_iterations: int = 6) -> dict[str, np.ndarray]:
    """(V,) per-vertex cost multipliers by feature kind (see the module table).

    The normals behind the silhouette costs are averaged ``smooth_iterations`` times over
    the 1-ring first, so that paths follow the feature rather than the triangulation.
    Returns keys ``"midline"``, ``"bottom"`` (silhouette seen along y), ``"front"``
    (silhouette seen along z) and ``"valley"``.
    """
    V = np.asarray(V, dtype=np.float64)
    N = smooth_vertex_values(vertex_normals(V, F), F, smooth_iterations)
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-12)
    H = mean_curvature(V, F)
    valley = np.exp(np.clip(valley_weight * H * VALLEY_LENGTH_MM, -3.0, 3.0))
    return {
        "midline": 1.0 + midline_weight * np.abs(V[:, 0] - x_mid),
        "bottom": 1.0 + silhouette_weight * np.abs(N[:, 1]),
        "front": 1.0 + silhouette_weight * np.abs(N[:, 2]),
        "valley": valley,
    }


_CURVE_COST = {"mid": "midline", "bottom": "bottom", "c": "front", "ala_l": "valley",
               "ala_r": "valley", "side_l": "front", "side_r": "front"}


def curve_paths(V: np.ndarray, F: np.ndarray, landmark_vertices: Mapping[str, int],
                nostril_vertices: np.ndarray) -> dict[str, np.ndarray]:
    """Vertex paths of the nine SPEC §5 curves on a face mesh.

    Args:
        V: (V, 3) vertices in the SPEC axes (+x subject's left, +y up, +z anterior), mm.
        F: (F, 3) int triangles, counter-clockwise seen from outside.
        landmark_vertices: landmark id -> vertex index for the 21 landmarks of SPEC §1.
        nostril_vertices: (M,) vertex ids of both nostril regions (openings and interior).
    Returns:
        Curve name -> (L,) int64 vertex path. Open curves run through their landmarks in
        the SPEC order (``add`` helpers skipped) and start/end at the first/last landmark
        vertex. ``sill_l`` / ``sill_r`` are the closed borders of the nostril region on the
        +x / -x side (first vertex not repeated), starting at the border vertex nearest to
        ``alpp_l`` / ``alpp_r`` and running counter-clockwise seen from below (bottom
        view); empty when that side has no nostril triangles.
    Raises:
        KeyError: a landmark of a curve is missing from ``landmark_vertices``.
        ValueError: two consecutive landmarks are not connected on the mesh.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    lm = {k: int(v) for k, v in landmark_vertices.items()}
    out = _open_curve_paths(V, F, lm)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        out[f"sill_{side}"] = _sill_loop(V, F, np.asarray(nostril_vertices, dtype=np.int64),
                                         sign, lm.get(f"alpp_{side}"))
    return {name: out[name] for name in CURVE_NAMES}


def _cost_graphs(V: np.ndarray, F: np.ndarray, lm: dict[str, int]) -> dict[str, sp.csr_matrix]:
    """Feature kind -> edge graph weighted by its cost field, the midline at the median x
    of the mid-curve landmarks."""
    mid_ids = [i for i in CURVE_LANDMARKS["mid"] if i in lm]
    x_mid = float(np.median(V[[lm[i] for i in mid_ids], 0])) if mid_ids else 0.0
    costs = curve_cost_fields(V, F, x_mid=x_mid)
    return {kind: weighted_edge_graph(V, F, c) for kind, c in costs.items()}


def _open_curve_paths(V: np.ndarray, F: np.ndarray, lm: dict[str, int]
                      ) -> dict[str, np.ndarray]:
    """Every open curve: its landmark vertices (no ``add`` helpers) joined by shortest
    paths on the edge graph of the curve's feature cost (module table)."""
    graphs = _cost_graphs(V, F, lm)
    out: dict[str, np.ndarray] = {}
    for name in CURVE_NAMES:
        if not name.startswith("sill"):
            ids = [i for i in CURVE_LANDMARKS[name] if i not in HELPER_IDS]
            out[name] = chain_path(graphs[_CURVE_COST[name]], [lm[i] for i in ids])
    return out


def _sill_loop(V: np.ndarray, F: np.ndarray, nostril: np.ndarray, sign: float,
               alpp: int | None) -> np.ndarray:
    """Border loop of the nostril region on one side (``sign`` of x relative to the mean)."""
    if nostril.size == 0:
        return np.zeros(0, dtype=np.int64)
    x0 = float(np.mean(V[nostril, 0]))
    side = nostril[np.sign(V[nostril, 0] - x0) == sign]
    loops = region_boundary_loops(F, side)
    if not loops:
        return np.zeros(0, dtype=np.int64)
    loop = loops[0]
    # counter-clockwise seen from below: the bottom camera looks along +y with image
    # right = +x and image down = -z, so use the signed area of (x, -z).
    p = np.stack([V[loop, 0], -V[loop, 2]], axis=1)
    area = 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    if area > 0:  # image y points down, so a positive shoelace area is clockwise on screen
        loop = loop[::-1]
    if alpp is not None:
        start = int(np.argmin(np.linalg.norm(V[loop] - V[alpp], axis=1)))
        loop = np.roll(loop, -start)
    return loop
