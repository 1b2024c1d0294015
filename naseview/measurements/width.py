"""Distances and widths: the paper's Table 1, nasal size, intercanthal width.

Definitions (SPEC frame, mm; straight 3D Euclidean distances):

- ``"<a>-<b>"`` for each pair of :data:`naseview.landmarks.TABLE1_DISTANCES`: |a - b|;
- ``nasal_length`` |n - prn|, ``nasal_height`` |n - sn|, ``nasal_width`` |al_l - al_r|,
  ``alar_base`` |ac_l - ac_r|; ``nasal_index`` = nasal_width / nasal_height x 100;
- ``intercanthal_width`` |en_l - en_r| with the endocanthion en *estimated from the face
  mesh*: en is not a clicked landmark, so each eye's opening is taken as the boundary loop
  of (V, F) (not the outer border) whose centroid lies 10-60 mm to that side of the facial
  midline plane and within 30 mm of the height of n (nearest n), and en as its vertex
  nearest the midline plane (the medial corner). Omitted when the mesh has no such pair
  of openings. ``alar_intercanthal_ratio`` = nasal_width / intercanthal_width.

Example
-------
>>> import numpy as np
>>> d = distances({"al_l": np.array([17.0, -48, 5]), "al_r": np.array([-17.0, -48, 5])})
>>> d["nasal_width"]
34.0
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from naseview.landmarks import TABLE1_DISTANCES
from naseview.measurements.frame import MidlinePlane, landmark, landmarks_of
from naseview.measurements.section import Topology

NAMED_DISTANCES: tuple[tuple[str, str, str], ...] = (
    ("nasal_length", "n", "prn"), ("nasal_height", "n", "sn"),
    ("nasal_width", "al_l", "al_r"), ("alar_base", "ac_l", "ac_r"),
    ("tip_width", "md_l", "md_r"),
)
"""Rhinometric distances: (name, landmark a, landmark b)."""


def distance_key(a: str, b: str) -> str:
    """Key of the distance between landmarks ``a`` and ``b`` (``"mf_l-mf_r"``)."""
    return f"{a}-{b}"


def distances(landmarks: Mapping[str, np.ndarray]) -> dict[str, float]:
    """The Table 1 distances, then :data:`NAMED_DISTANCES` and ``nasal_index``, where the
    landmarks exist (module docstring)."""
    out: dict[str, float] = {}
    pairs = [(distance_key(a, b), a, b) for a, b in TABLE1_DISTANCES]
    for name, a, b in (*pairs, *NAMED_DISTANCES):
        p = landmarks_of(landmarks, a, b)
        if p is not None:
            out[name] = float(np.linalg.norm(p[0] - p[1]))
    if "nasal_width" in out and out.get("nasal_height", 0.0) > 1e-6:
        out["nasal_index"] = out["nasal_width"] / out["nasal_height"] * 100.0
    return out


def endocanthia(V: np.ndarray, topo: Topology, plane: MidlinePlane,
                n: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Estimated (en_l, en_r), (3,) each, from the mesh's eye openings (module docstring),
    or None. ``V`` (N, 3) mm, ``topo`` its topology, ``n`` (3,) nasion."""
    loops = topo.loops
    if len(loops) < 3:                 # the outer border and two eyes at least
        return None
    V = np.asarray(V, np.float64)
    inner = sorted(loops, key=len)[:-1]          # the outer border is the longest loop
    best: dict[int, tuple[float, np.ndarray]] = {}
    for lp in inner:
        P = V[lp]
        c = P.mean(axis=0)
        lat = float(plane.lateral(c)[0])
        dh = float((c - n) @ plane.up)
        if not 10.0 <= abs(lat) <= 60.0 or abs(dh) > 30.0:
            continue
        side = 1 if lat > 0 else -1
        dist = float(np.linalg.norm(c - n))
        if side not in best or dist < best[side][0]:
            best[side] = (dist, P[int(np.argmin(np.abs(plane.lateral(P))))])
    if 1 not in best or -1 not in best:
        return None
    return best[1][1], best[-1][1]


def intercanthal(landmarks: Mapping[str, np.ndarray], plane: MidlinePlane,
                 V: np.ndarray | None, topo: Topology | None,
                 nasal_width: float | None) -> dict[str, float]:
    """``intercanthal_width`` and ``alar_intercanthal_ratio`` (module docstring); ``V``
    (N, 3) mm and ``topo`` its topology, or None."""
    n = landmark(landmarks, "n")
    if V is None or topo is None or n is None:
        return {}
    en = endocanthia(V, topo, plane, n)
    if en is None:
        return {}
    w = float(np.linalg.norm(en[0] - en[1]))
    if w < 1e-6:
        return {}
    out = {"intercanthal_width": w}
    if nasal_width is not None:
        out["alar_intercanthal_ratio"] = nasal_width / w
    return out
