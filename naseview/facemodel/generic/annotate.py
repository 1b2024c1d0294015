"""The generic face's annotations: its 21 landmarks and its nose region (design step 4).

Each landmark of SPEC §1 is found on the mean mesh from its anatomical definition (most
anterior, deepest, most lateral, ...); the nose region is where the nose stands out of the
face. The curves come from :func:`naseview.facemodel.meshcurves.curve_paths`.

Example
-------
>>> from naseview.facemodel.generic.mesh import generic_mesh
>>> lm = find_landmarks(generic_mesh())                                # doctest: +SKIP
>>> len(lm)                                                            # doctest: +SKIP
21
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from naseview.facemodel.generic.mesh import GenericMesh
from naseview.facemodel.generic.nose import membership, nose_parts
from naseview.facemodel.generic.shapes import smax
from naseview.facemodel.meshcurves import region_boundary_loops
from naseview.geometry.mesh import vertex_adjacency
from naseview.landmarks import LANDMARK_IDS

MF_HALF_WIDTH_MM = 10.0
"""Half of the mf-mf distance used to place maxillofrontale."""


def _farthest_from_chord(P: np.ndarray, a: np.ndarray, b: np.ndarray,
                         toward: np.ndarray) -> int:
    """Index of the point (rows of P) farthest from line a-b on the side of ``toward``."""
    u = (b - a) / np.linalg.norm(b - a)
    q = P - a
    perp = q - np.outer(q @ u, u)
    return int(np.argmax(perp @ toward))


def nostril_rim(F: np.ndarray, nostril: np.ndarray) -> np.ndarray:
    """(R,) vertices of the nostril region that have a neighbour outside it."""
    inside = np.zeros(int(F.max()) + 1, dtype=bool)
    inside[nostril] = True
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    cross = inside[e[:, 0]] & ~inside[e[:, 1]]
    return np.unique(e[cross, 0])


def _pick(cands: np.ndarray, score: np.ndarray) -> int:
    """The candidate vertex with the largest score."""
    return int(cands[int(np.argmax(score))])


def _midline_landmarks(V: np.ndarray, mid: np.ndarray) -> dict[str, int]:
    """prn (most anterior), n (deepest above it), g (most anterior above n), sn (deepest
    below prn), c (the lobule/columella break), r and k on the dorsum; ``mid``: the
    midline (x = 0) vertex ids."""
    y, z = V[:, 1], V[:, 2]
    lm: dict[str, int] = {}
    lm["prn"] = _pick(mid, z[mid])
    p = V[lm["prn"]]
    root = mid[(y[mid] > p[1] + 25.0) & (y[mid] < p[1] + 55.0)]
    lm["n"] = _pick(root, -z[root])
    n_ = V[lm["n"]]
    brow = mid[(y[mid] > n_[1]) & (y[mid] < n_[1] + 25.0)]
    lm["g"] = _pick(brow, z[brow])
    below = mid[(y[mid] < p[1] - 3.0) & (y[mid] > p[1] - 22.0)]
    lm["sn"] = _pick(below, -z[below])
    s_ = V[lm["sn"]]
    tipc = mid[(y[mid] < p[1]) & (y[mid] > s_[1]) & (z[mid] > s_[2])]
    lm["c"] = int(tipc[_farthest_from_chord(V[tipc], p, s_, np.array([0.0, -1.0, 1.0]))])
    dors = mid[(y[mid] < n_[1]) & (y[mid] > p[1])]
    frac = (n_[1] - y[dors]) / (n_[1] - p[1])
    lm["r"] = int(dors[np.argmin(np.abs(frac - 0.55))])
    upper = dors[(frac > 0.15) & (frac < 0.5)]
    lm["k"] = int(upper[_farthest_from_chord(V[upper], n_, p, np.array([0.0, 0.6, 0.8]))])
    return lm


def _maxillofrontale(V: np.ndarray, left: np.ndarray, n_: np.ndarray) -> int:
    """mf_l: on the medial orbital rim at the height of n. This face has no distinct
    frontonasal-orbital groove there, so the rim point is taken at the population
    half-distance (mf-mf about 20 mm, Farkas)."""
    target = np.array([MF_HALF_WIDTH_MM, n_[1]])
    return int(left[np.argmin(np.linalg.norm(V[left][:, :2] - target, axis=1))])


def _alar_landmarks(mesh: GenericMesh, left: np.ndarray, m: np.ndarray,
                    parts: dict[str, np.ndarray], front: np.ndarray) -> dict[str, int]:
    """al_l (most lateral point of the alar lobule standing clear of the cheek), ac_l
    (deepest point of the crease where the ala meets the cheek) and int_l (the upper end
    of the alar groove); ``m``: :func:`membership`, ``front``: dorsum and lobule."""
    V = mesh.V
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    lm: dict[str, int] = {}
    ala_dom = left[(parts["ala"][left] > front[left]) & (mesh.nostril_side[left] == 0)]
    ala = ala_dom[m[ala_dom] > 1.5]
    lm["al_l"] = _pick(ala, x[ala])
    al = V[lm["al_l"]]
    near_ala = left[(parts["ala"][left] > front[left] - 1.5) & (mesh.nostril_side[left] == 0)]
    crease = near_ala[(np.abs(m[near_ala]) < 0.5) & (y[near_ala] <= al[1] - 1.0)]
    lm["ac_l"] = _pick(crease, -z[crease])
    groove = left[(np.abs(parts["ala"][left] - front[left]) < 0.5) & (m[left] > 1.0)
                  & (y[left] > al[1])]
    lm["int_l"] = _pick(groove, y[groove] + z[groove])
    return lm


def _nostril_landmarks(mesh: GenericMesh) -> dict[str, int]:
    """On the left nostril rim: alpp_l, the sill (most posterior), and md_l, the arch apex
    seen from the front (the middle of its flat top)."""
    V = mesh.V
    rim = nostril_rim(mesh.F, np.flatnonzero(mesh.nostril_side != 0))
    rim_l = rim[V[rim, 0] > 0]
    alpp = _pick(rim_l, -V[rim_l, 2])
    top = rim_l[V[rim_l, 1] >= V[rim_l, 1].max() - 0.4]      # the flat top of the arch
    md = int(top[np.argmin(np.linalg.norm(V[top] - V[top].mean(axis=0), axis=1))])
    return {"alpp_l": alpp, "md_l": md}


def _alar_break(mesh: GenericMesh, left: np.ndarray, m: np.ndarray,
                parts: dict[str, np.ndarray], p: np.ndarray, al: np.ndarray) -> int:
    """alp_l (al'): on the bottom-view outline (largest x per depth band), the first point
    from al towards prn (``al``, ``p`` their positions) where the tip lobule takes over
    from the ala."""
    V = mesh.V
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    base = left[(m[left] > 0.3) & (y[left] < p[1] + 3.0) & (z[left] > al[2])
                & (z[left] < p[2]) & (mesh.nostril_side[left] == 0)]
    bands = np.floor(z[base] / 0.75).astype(np.int64)
    order = np.lexsort((-x[base], bands))
    first = np.r_[True, bands[order][1:] != bands[order][:-1]]
    outline = base[order][first]                       # ordered from al towards prn
    lob = parts["lobule"][outline] >= parts["ala"][outline]
    return int(outline[int(np.argmax(lob))] if lob.any() else outline[-1])


def find_landmarks(mesh: GenericMesh) -> dict[str, int]:
    """Vertex of each of the 21 landmarks of SPEC §1 on the mean mesh.

    Every landmark is found from its anatomical definition on the surface (most anterior,
    deepest, most lateral, ...); left ones on x > 0, right ones are their mirror images.
    """
    V = mesh.V
    lm = _midline_landmarks(V, np.flatnonzero(np.abs(V[:, 0]) < 1e-9))
    left = np.flatnonzero(V[:, 0] > 1e-9)
    m = membership(mesh.V_uncarved)
    parts = nose_parts(mesh.V_uncarved[:, 0], mesh.V_uncarved[:, 1])
    front = smax(parts["ridge"], parts["lobule"], 5.0)
    lm["mf_l"] = _maxillofrontale(V, left, V[lm["n"]])
    lm.update(_alar_landmarks(mesh, left, m, parts, front))
    lm.update(_nostril_landmarks(mesh))
    lm["alp_l"] = _alar_break(mesh, left, m, parts, V[lm["prn"]], V[lm["al_l"]])
    for k in [k for k in lm if k.endswith("_l")]:
        lm[k[:-2] + "_r"] = int(mesh.mirror[lm[k]])
    return {k: lm[k] for k in LANDMARK_IDS}


def nose_region(mesh: GenericMesh, landmarks: dict[str, int]) -> np.ndarray:
    """(N,) sorted vertex ids of the external nose, radix to subnasale and alar creases.

    The connected part around prn of the surface where the nose's height field is above
    the face's, or less than 0.5 mm below it (so the alar creases and the nasofacial
    junction are included), below the radix line through n and the two mf, plus the
    strip between the mf and the nostrils; holes filled.
    """
    V, F, lm = mesh.V, mesh.F, landmarks
    m = membership(mesh.V_uncarved)
    y_top = max(V[lm["n"], 1], V[lm["mf_l"], 1]) + 0.5
    x_mf = abs(V[lm["mf_l"], 0]) + 0.5
    keep = (m >= -0.5) & (V[:, 1] <= y_top)
    keep |= (V[:, 1] <= y_top) & (np.abs(V[:, 0]) <= x_mf) & (V[:, 1] >= V[lm["sn"], 1])
    keep[mesh.nostril_side != 0] = True
    keep[list(lm.values())] = True
    A = vertex_adjacency(len(V), F)
    ids = np.flatnonzero(keep)
    _, comp = connected_components(A[ids][:, ids], directed=False)
    main = comp[np.searchsorted(ids, lm["prn"])]
    return _fill_holes(F, A, ids[comp == main])


def _fill_holes(F: np.ndarray, A: sp.csr_matrix, region: np.ndarray) -> np.ndarray:
    """(N,) sorted ``region`` plus every vertex not reachable from the mesh border without
    crossing it (``A``: the vertex adjacency)."""
    inside = np.zeros(A.shape[0], dtype=bool)
    inside[region] = True
    rest = np.flatnonzero(~inside)
    _, comp = connected_components(A[rest][:, rest], directed=False)
    border = np.unique(region_boundary_loops(F, np.arange(A.shape[0]))[0])
    outer = np.unique(comp[np.searchsorted(rest, border[~inside[border]])])
    inside[rest[~np.isin(comp, outer)]] = True
    return np.flatnonzero(inside)
