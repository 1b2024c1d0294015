"""Recompute the ICT Face Model annotations by geometry and compare with the frozen ones.

The landmark vertices, the nostril region and the nose region of the ICT mean face are
frozen as integer constants in :mod:`naseview.facemodel.ict`. This script is how they
were found; it recomputes them on the installed ICT model and prints, per landmark, the
frozen and recomputed vertex and the distance between them (mm), plus the overlap of the
two regions. Usage::

    NASEVIEW_ICT_MODEL=../shared/data/ict-face-model/ict_face_light.npz \\
        python benchmarks/ict_annotations.py

Procedure (mean face, SPEC axes, mm; the mesh is mirror-symmetric, so everything is found
on the subject's left (+x) and mirrored):

- prn: largest z. Midsagittal profile: the x = 0 vertices from above the eyes through prn
  down to the mouth opening.
- g: largest z on the profile above the top of the eye openings; n: smallest z between g
  and prn; k, r: 1/3 and 2/3 of the profile arc length from n to prn.
- ls (upper lip, helper): first local z maximum below the subnasal concavity;
  sn: deepest profile point behind the chord prn-ls; c: profile point between prn and sn
  farthest in front of the chord prn-sn (the lobule/columella break).
- nostril region: ambient occlusion > 0.5 (libigl, rays from the vertex normal) around the
  nose base, largest connected component; its border loop is the nasal sill.
- md: highest (largest y) sill vertex visible from the front (ray along +z);
  alpp: most posterior (smallest z) sill vertex.
- ac: most concave vertex (smallest mean curvature) lateral to the nostril, below its
  centre (the curved alar base); int: most anterior vertex of the concave band
  (H < -0.015 /mm) connected to ac, above the nostril (upper-anterior end of the alar
  groove); al: most lateral vertex of the valley path ac -> int (the alar groove).
- alp: on the bottom-view outline path al -> prn (cost ``1 + 6 |n_y|``), the point of
  least (most concave) curvature of its (x, z) projection, away from both ends: the notch
  where the alar rim meets the lobule.
- mf: most concave vertex on the horizontal band |y - y_n| < 1 mm between a quarter of the
  medial-canthus x and 3 mm medial of the canthus.
- nose region: vertices enclosed by the radix line mf_r-n-mf_l (plain shortest paths), the
  side-curves, ala-curves and the alar-base paths ac-sn (valley cost), flood-filled from
  prn; the enclosing paths are included.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from typing import Any

import igl
import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as cg
from _shared import use_shared_ict
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

from naseview.facemodel import ict, store
from naseview.facemodel import meshcurves as mc
from naseview.geometry.mesh import boundary_edges, vertex_adjacency, vertex_normals


def _visible_along(V: np.ndarray, F: np.ndarray, ids: np.ndarray, d: np.ndarray,
                   eps: float = 0.05) -> np.ndarray:
    """(len(ids),) bool: the ray from each vertex along ``d`` leaves the mesh unobstructed."""
    d = np.asarray(d, dtype=np.float64) / np.linalg.norm(d)
    out = []
    for i in ids:
        hits = igl.ray_mesh_intersect(np.ascontiguousarray(V[i] + eps * d), d, V, F) or []
        out.append(not any(h[3] > eps for h in hits))
    return np.array(out, dtype=bool)


def _flood(A: sp.csr_matrix, seed: int, blocked: np.ndarray) -> np.ndarray:
    """(n,) bool: the vertices reached from ``seed`` along ``A``'s edges without entering
    ``blocked`` (n,) bool."""
    seen = np.zeros(A.shape[0], dtype=bool)
    seen[seed] = True
    front = np.array([seed])
    while front.size:
        nb = np.unique(np.concatenate([A.indices[A.indptr[i]:A.indptr[i + 1]] for i in front]))
        nb = nb[~seen[nb] & ~blocked[nb]]
        seen[nb] = True
        front = nb
    return seen


@dataclass
class _Mesh:
    """The ICT mean face and what every step reads: (n, 3) V, (m, 3) F, the 0/1 adjacency,
    mean curvature H (1/mm), unit normals N, each vertex's mirror image and the curve
    cost fields of :func:`naseview.facemodel.meshcurves.curve_cost_fields`."""

    V: np.ndarray
    F: np.ndarray
    A: sp.csr_matrix
    H: np.ndarray
    N: np.ndarray
    mirror: np.ndarray
    costs: dict[str, np.ndarray]


def _front_of_chord(V: np.ndarray, ids: np.ndarray, a: int, b: int) -> np.ndarray:
    """(len(ids),) signed distance (mm) of vertices in front of the (y, z) chord a-b."""
    p, pa, d = V[ids][:, 1:], V[a, 1:], V[b, 1:] - V[a, 1:]
    nrm = np.array([d[1], -d[0]]) / np.linalg.norm(d)  # (y, z) normal, anterior side
    return (p - pa) @ nrm


def _profile(m: _Mesh, prn: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The midsagittal profile from above the eyes through prn to the mouth opening, the
    left eye opening's border vertices and en (its medial corner)."""
    V, F = m.V, m.F
    on_mid = np.abs(V[:, 0]) <= 1e-6 * np.abs(V).max()
    bv = np.unique(boundary_edges(F))
    eye = bv[(V[bv, 0] > 0) & (V[bv, 1] > V[prn, 1] + 15) & (V[bv, 1] < V[prn, 1] + 60)
             & (V[bv, 2] > V[prn, 2] - 60)]
    en = int(eye[np.argmin(V[eye, 0])])  # medial corner of the left eye opening
    mouth = bv[on_mid[bv] & (V[bv, 1] < V[prn, 1]) & (V[bv, 2] > V[prn, 2] - 40)]
    top = np.nonzero(on_mid & (V[:, 1] > V[en, 1] + 35) & (V[:, 2] > V[prn, 2] - 40))[0]
    G_mid = mc.weighted_edge_graph(V, F, 1.0 + 100.0 * np.abs(V[:, 0]))
    prof = mc.chain_path(G_mid, [int(top[np.argmin(V[top, 1])]), prn,
                                 int(mouth[np.argmax(V[mouth, 1])])])
    assert on_mid[prof].all(), "the profile left the midline"
    return prof, eye, en


def _profile_landmarks(V: np.ndarray, prof: np.ndarray, prn: int, eye: np.ndarray,
                       lm: dict[str, int]) -> int:
    """g, n, k, r, sn and c on the profile, added to ``lm``; returns ls (upper lip)."""
    ip = int(np.nonzero(prof == prn)[0][0])
    up, dn = prof[: ip + 1], prof[ip:]
    cand = up[V[up, 1] > V[eye, 1].max()]
    lm["g"] = g = int(cand[np.argmax(V[cand, 2])])
    seg = up[int(np.nonzero(up == g)[0][0]):]
    lm["n"] = nn = int(seg[np.argmin(V[seg, 2])])
    seg = up[int(np.nonzero(up == nn)[0][0]):]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(V[seg], axis=0), axis=1))])
    lm["k"] = int(seg[np.argmin(np.abs(s - s[-1] / 3))])
    lm["r"] = int(seg[np.argmin(np.abs(s - 2 * s[-1] / 3))])
    z = V[dn, 2]
    i0 = next(i for i in range(1, len(z) - 1) if z[i] <= z[i - 1] and z[i] < z[i + 1])
    i1 = next(i for i in range(i0 + 1, len(z) - 1) if z[i] >= z[i - 1] and z[i] > z[i + 1])
    ls = int(dn[i1])
    seg = dn[: i1 + 1]
    lm["sn"] = sn = int(seg[np.argmin(_front_of_chord(V, seg, prn, ls))])
    seg = dn[: int(np.nonzero(dn == sn)[0][0]) + 1]
    lm["c"] = int(seg[np.argmax(_front_of_chord(V, seg, prn, sn))])
    return ls


def _left_nostril(m: _Mesh, prn: int, ao_samples: int, lm: dict[str, int]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The left nostril by ambient occlusion (> 0.5, largest component) and its border
    loop; md_l and alpp_l added to ``lm``."""
    V, F, N = m.V, m.F, m.N
    box = np.nonzero((V[:, 0] > 0) & (V[:, 0] < 25) & (np.abs(V[:, 1] - V[prn, 1]) < 20)
                     & (V[:, 2] > V[prn, 2] - 35))[0]
    ao = np.zeros(len(V))
    ao[box] = igl.ambient_occlusion(V, F, V[box] + 1e-3 * N[box], N[box], ao_samples)
    occluded = ao > 0.5
    ids = np.nonzero(occluded)[0]
    _, lab = cg.connected_components(m.A[occluded][:, occluded], directed=False)
    nos_l = np.sort(ids[lab == np.argmax(np.bincount(lab))])
    rim = mc.region_boundary_loops(F, nos_l)[0]
    rv = rim[_visible_along(V, F, rim, np.array([0.0, 0.0, 1.0]))]
    lm["md_l"] = int(rv[np.argmax(V[rv, 1])])
    lm["alpp_l"] = int(rim[np.argmin(V[rim, 2])])
    return nos_l, rim


def _alar_groove(m: _Mesh, rim: np.ndarray, lm: dict[str, int]) -> sp.csr_matrix:
    """ac_l, int_l and al_l (the alar groove) added to ``lm``; returns the valley graph."""
    V, H = m.V, m.H
    xm, yc = V[rim, 0].max(), V[rim, 1].mean()
    cand = np.nonzero((V[:, 0] > xm) & (V[:, 0] < xm + 10) & (V[:, 1] < yc)
                      & (V[:, 1] > V[rim, 1].min() - 6) & (V[:, 2] > V[rim, 2].min() - 10))[0]
    lm["ac_l"] = ac = int(cand[np.argmin(H[cand])])
    concave = H < -0.015
    ids = np.nonzero(concave)[0]
    _, lab = cg.connected_components(m.A[concave][:, concave], directed=False)
    comp = ids[lab == lab[np.searchsorted(ids, ac)]]
    upper = comp[(V[comp, 1] > V[rim, 1].max()) & (V[comp, 1] < V[rim, 1].max() + 20)
                 & (V[comp, 0] > 0)]
    lm["int_l"] = int_ = int(upper[np.argmax(V[upper, 2])])
    G_valley = mc.weighted_edge_graph(V, m.F, m.costs["valley"])
    groove = mc.shortest_path(G_valley, ac, int_)
    lm["al_l"] = int(groove[np.argmax(V[groove, 0])])
    return G_valley


def _alar_notch(m: _Mesh, al: int, prn: int) -> int:
    """alp_l: the most concave point of the bottom-view outline al -> prn, away from both
    ends (the notch where the alar rim meets the lobule)."""
    path = mc.shortest_path(mc.weighted_edge_graph(m.V, m.F, m.costs["bottom"]), al, prn)
    p = m.V[path][:, [0, 2]]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], 60)
    q = gaussian_filter1d(np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], 1),
                          2, axis=0, mode="nearest")
    d1 = np.gradient(q, axis=0)
    d2 = np.gradient(d1, axis=0)
    curv = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.linalg.norm(d1, axis=1) ** 3
    inner = np.nonzero((t > 0.15 * t[-1]) & (t < 0.85 * t[-1]))[0]
    j = inner[np.argmin(curv[inner])]
    return int(path[np.argmin(np.linalg.norm(p - q[j], axis=1))])


def _maxillofrontale(m: _Mesh, nn: int, en: int) -> int:
    """mf_l: the most concave vertex of the medial orbital rim beside the nasal root."""
    V = m.V
    band = np.nonzero((np.abs(V[:, 1] - V[nn, 1]) < 1.0) & (V[:, 0] > 0.25 * V[en, 0])
                      & (V[:, 0] < V[en, 0] - 3) & (V[:, 2] > V[en, 2]))[0]
    return int(band[np.argmin(m.H[band])])


def _nose_region(m: _Mesh, lm: dict[str, int], G_valley: sp.csr_matrix) -> np.ndarray:
    """(n,) bool: enclosed by the radix line, the side- and ala-curves and the alar-base
    paths, flood-filled from prn, the enclosing paths included, mirror-symmetric."""
    V, F, mirror = m.V, m.F, m.mirror
    G_plain = mc.weighted_edge_graph(V, F)
    G_front = mc.weighted_edge_graph(V, F, m.costs["front"])
    left = np.concatenate([
        mc.shortest_path(G_plain, lm["n"], lm["mf_l"]),
        mc.shortest_path(G_front, lm["mf_l"], lm["int_l"]),
        mc.chain_path(G_valley, [lm["int_l"], lm["al_l"], lm["ac_l"], lm["sn"]]),
    ])
    right = mc.chain_path(G_plain, mirror[left])  # mirrored ids joined (diagonals differ)
    wall = np.zeros(len(V), dtype=bool)
    wall[left] = True
    wall[right] = True
    inside = _flood(m.A, lm["prn"], wall) | wall
    inside |= inside[mirror]
    return inside


def annotate_ict(V: np.ndarray, F: np.ndarray, ao_samples: int = 500) -> dict[str, Any]:
    """Landmark vertices, nostril ids and nose ids of the ICT mean face (see module doc)."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    m = _Mesh(V, F, vertex_adjacency(len(V), F), mc.mean_curvature(V, F), vertex_normals(V, F),
              cKDTree(V).query(V * [-1.0, 1.0, 1.0])[1], mc.curve_cost_fields(V, F))
    prn = int(np.argmax(V[:, 2]))
    lm: dict[str, int] = {"prn": prn}
    prof, eye, en = _profile(m, prn)
    ls = _profile_landmarks(V, prof, prn, eye, lm)
    nos_l, rim = _left_nostril(m, prn, ao_samples, lm)
    G_valley = _alar_groove(m, rim, lm)
    lm["alp_l"] = _alar_notch(m, lm["al_l"], prn)
    lm["mf_l"] = _maxillofrontale(m, lm["n"], en)
    for k in [k for k in lm if k.endswith("_l")]:
        lm[k[:-2] + "_r"] = int(m.mirror[lm[k]])
    inside = _nose_region(m, lm, G_valley)
    nostril = np.unique(np.concatenate([nos_l, m.mirror[nos_l]]))
    return {"landmarks": lm, "nostril": nostril, "nose": np.nonzero(inside)[0],
            "ls": ls, "en": en}


def main() -> int:
    use_shared_ict()
    path = store.find_ict_npz()
    if path is None:
        print("ICT model not installed; set NASEVIEW_ICT_MODEL or run `naseview model fetch`")
        return 1
    fm = store.load_ict_npz(path)
    t0 = time.perf_counter()
    ann = annotate_ict(fm.mean, fm.faces)
    dt = time.perf_counter() - t0
    print(f"ICT annotations recomputed on {path} in {dt:.2f} s")
    print(f"{'landmark':<9}{'frozen':>8}{'now':>8}{'dist mm':>9}")
    V = fm.mean
    for k, v in ict.ICT_LANDMARK_VERTICES.items():
        w = ann["landmarks"][k]
        print(f"{k:<9}{v:>8}{w:>8}{np.linalg.norm(V[v] - V[w]):>9.2f}")
    for name, frozen in (("nostril", ict.ICT_NOSTRIL_VERTICES), ("nose", ict.ICT_NOSE_VERTICES)):
        a, b = set(frozen.tolist()), set(ann[name].tolist())
        print(f"{name:<9} frozen {len(a)}, now {len(b)}, Jaccard {len(a & b) / len(a | b):.3f}")
    if os.environ.get("NASEVIEW_PRINT_ANNOTATIONS"):
        print(ann)
    return 0


if __name__ == "__main__":
    sys.exit(main())
