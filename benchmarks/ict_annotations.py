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
from pathlib import Path

import numpy as np
import scipy.sparse.csgraph as cg
from _shared import use_shared_ict
from scipy.ndimage import gaussian_filter1d
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from naseview.facemodel import ict  # noqa: E402
from naseview.facemodel import meshcurves as mc  # noqa: E402


def _visible_along(V: np.ndarray, F: np.ndarray, ids: np.ndarray, d: np.ndarray,
                   eps: float = 0.05) -> np.ndarray:
    """(len(ids),) bool: the ray from each vertex along ``d`` leaves the mesh unobstructed."""
    import igl

    d = np.asarray(d, dtype=np.float64) / np.linalg.norm(d)
    out = []
    for i in ids:
        hits = igl.ray_mesh_intersect(np.ascontiguousarray(V[i] + eps * d), d, V, F) or []
        out.append(not any(h[3] > eps for h in hits))
    return np.array(out, dtype=bool)


def _flood(A, seed: int, blocked: np.ndarray) -> np.ndarray:
    seen = np.zeros(A.shape[0], dtype=bool)
    seen[seed] = True
    front = np.array([seed])
    while front.size:
        nb = np.unique(np.concatenate([A.indices[A.indptr[i]:A.indptr[i + 1]] for i in front]))
        nb = nb[~seen[nb] & ~blocked[nb]]
        seen[nb] = True
        front = nb
    return seen


def annotate_ict(V: np.ndarray, F: np.ndarray, ao_samples: int = 500) -> dict:
    """Landmark vertices, nostril ids and nose ids of the ICT mean face (see module doc)."""
    import igl

    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    n_v = len(V)
    A = mc.vertex_adjacency(n_v, F)
    H = mc.mean_curvature(V, F)
    N = mc.vertex_normals(V, F)
    mirror = cKDTree(V).query(V * [-1.0, 1.0, 1.0])[1]
    costs = mc.curve_cost_fields(V, F)
    lm: dict[str, int] = {}

    # midsagittal profile
    tol = 1e-6 * np.abs(V).max()
    on_mid = np.abs(V[:, 0]) <= tol
    prn = int(np.argmax(V[:, 2]))
    lm["prn"] = prn
    bv = np.unique(mc._boundary_edges(F))
    eye = bv[(V[bv, 0] > 0) & (V[bv, 1] > V[prn, 1] + 15) & (V[bv, 1] < V[prn, 1] + 60)
             & (V[bv, 2] > V[prn, 2] - 60)]
    en = int(eye[np.argmin(V[eye, 0])])  # medial corner of the left eye opening
    mouth = bv[on_mid[bv] & (V[bv, 1] < V[prn, 1]) & (V[bv, 2] > V[prn, 2] - 40)]
    top = np.nonzero(on_mid & (V[:, 1] > V[en, 1] + 35) & (V[:, 2] > V[prn, 2] - 40))[0]
    G_mid = mc.weighted_edge_graph(V, F, 1.0 + 100.0 * np.abs(V[:, 0]))
    prof = mc.chain_path(G_mid, [int(top[np.argmin(V[top, 1])]), prn,
                                 int(mouth[np.argmax(V[mouth, 1])])])
    assert on_mid[prof].all(), "the profile left the midline"
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

    def front_of_chord(ids: np.ndarray, a: int, b: int) -> np.ndarray:
        p, pa, d = V[ids][:, 1:], V[a, 1:], V[b, 1:] - V[a, 1:]
        nrm = np.array([d[1], -d[0]]) / np.linalg.norm(d)  # (y, z) normal, anterior side
        return (p - pa) @ nrm

    seg = dn[: i1 + 1]
    lm["sn"] = sn = int(seg[np.argmin(front_of_chord(seg, prn, ls))])
    seg = dn[: int(np.nonzero(dn == sn)[0][0]) + 1]
    lm["c"] = int(seg[np.argmax(front_of_chord(seg, prn, sn))])

    # nostril (left), by ambient occlusion
    box = np.nonzero((V[:, 0] > 0) & (V[:, 0] < 25) & (np.abs(V[:, 1] - V[prn, 1]) < 20)
                     & (V[:, 2] > V[prn, 2] - 35))[0]
    ao = np.zeros(n_v)
    ao[box] = igl.ambient_occlusion(V, F, V[box] + 1e-3 * N[box], N[box], ao_samples)
    m = ao > 0.5
    ids = np.nonzero(m)[0]
    _, lab = cg.connected_components(A[m][:, m], directed=False)
    nos_l = np.sort(ids[lab == np.argmax(np.bincount(lab))])
    rim = mc.region_boundary_loops(F, nos_l)[0]
    rv = rim[_visible_along(V, F, rim, np.array([0.0, 0.0, 1.0]))]
    lm["md_l"] = int(rv[np.argmax(V[rv, 1])])
    lm["alpp_l"] = int(rim[np.argmin(V[rim, 2])])

    # alar groove: ac, int, al
    xm, yc = V[rim, 0].max(), V[rim, 1].mean()
    cand = np.nonzero((V[:, 0] > xm) & (V[:, 0] < xm + 10) & (V[:, 1] < yc)
                      & (V[:, 1] > V[rim, 1].min() - 6) & (V[:, 2] > V[rim, 2].min() - 10))[0]
    lm["ac_l"] = ac = int(cand[np.argmin(H[cand])])
    m = H < -0.015
    ids = np.nonzero(m)[0]
    _, lab = cg.connected_components(A[m][:, m], directed=False)
    comp = ids[lab == lab[np.searchsorted(ids, ac)]]
    upper = comp[(V[comp, 1] > V[rim, 1].max()) & (V[comp, 1] < V[rim, 1].max() + 20)
                 & (V[comp, 0] > 0)]
    lm["int_l"] = int_ = int(upper[np.argmax(V[upper, 2])])
    G_valley = mc.weighted_edge_graph(V, F, costs["valley"])
    groove = mc.shortest_path(G_valley, ac, int_)
    lm["al_l"] = al = int(groove[np.argmax(V[groove, 0])])

    # alp: notch of the bottom-view outline al -> prn
    path = mc.shortest_path(mc.weighted_edge_graph(V, F, costs["bottom"]), al, prn)
    p = V[path][:, [0, 2]]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], 60)
    q = gaussian_filter1d(np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], 1),
                          2, axis=0, mode="nearest")
    d1 = np.gradient(q, axis=0)
    d2 = np.gradient(d1, axis=0)
    curv = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.linalg.norm(d1, axis=1) ** 3
    inner = np.nonzero((t > 0.15 * t[-1]) & (t < 0.85 * t[-1]))[0]
    j = inner[np.argmin(curv[inner])]
    lm["alp_l"] = int(path[np.argmin(np.linalg.norm(p - q[j], axis=1))])

    # mf: medial orbital rim beside the nasal root
    band = np.nonzero((np.abs(V[:, 1] - V[nn, 1]) < 1.0) & (V[:, 0] > 0.25 * V[en, 0])
                      & (V[:, 0] < V[en, 0] - 3) & (V[:, 2] > V[en, 2]))[0]
    lm["mf_l"] = int(band[np.argmin(H[band])])

    for k in [k for k in lm if k.endswith("_l")]:
        lm[k[:-2] + "_r"] = int(mirror[lm[k]])

    # nose region: enclosed by radix line, side-, ala-curves and alar-base paths
    G_plain = mc.weighted_edge_graph(V, F)
    G_front = mc.weighted_edge_graph(V, F, costs["front"])
    left = np.concatenate([
        mc.shortest_path(G_plain, nn, lm["mf_l"]),
        mc.shortest_path(G_front, lm["mf_l"], lm["int_l"]),
        mc.chain_path(G_valley, [lm["int_l"], al, ac, sn]),
    ])
    right = mc.chain_path(G_plain, mirror[left])  # mirrored ids joined (diagonals differ)
    wall = np.zeros(n_v, dtype=bool)
    wall[left] = True
    wall[right] = True
    inside = _flood(A, prn, wall) | wall
    inside |= inside[mirror]
    nostril = np.unique(np.concatenate([nos_l, mirror[nos_l]]))
    return {"landmarks": lm, "nostril": nostril, "nose": np.nonzero(inside)[0],
            "ls": ls, "en": en}


def main() -> int:
    use_shared_ict()
    from naseview.facemodel import store

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
