"""Clinical nasal measurements from the 3D landmarks, the mid-curve and the refined mesh.

The 11 landmark distances of the paper's Table 1 (section 4; SPEC §6) and, beyond the
paper, common rhinometric measurements (nasal index, nasofrontal angle, Goode ratio,
dorsal hump depth). All inputs are in the SPEC frame (mm, origin g, +x subject's left,
+y up, +z anterior). :func:`clinical_measurements` returns a flat ``{name: value}`` dict
(mm, degrees or a plain ratio) for ``reconstruction.json``; a measurement whose landmarks
are missing is omitted. :data:`MEASUREMENT_INFO` describes every name for the app and
reports.

Example
-------
>>> m = clinical_measurements({"n": np.array([0.0, -15, -3]), "prn": np.array([0.0, -45, 25])})
>>> round(m["n-prn"], 2), round(m["nasal_length"], 2), MEASUREMENT_INFO["nasal_length"].unit
(41.04, 41.04, 'mm')
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from naseview.landmarks import TABLE1_DISTANCES


@dataclass(frozen=True)
class MeasurementInfo:
    """What one measurement means.

    Attributes:
        name: key in the measurements dict.
        unit: ``"mm"``, ``"deg"`` or ``""`` (ratio / index).
        description: one line definition.
        normal: typical adult range ``(low, high)`` or ``None`` when no norm is established.
        source: where the range comes from (approximate; varies with sex and ancestry).
    """

    name: str
    unit: str
    description: str
    normal: tuple[float, float] | None = None
    source: str = ""


def distance_key(a: str, b: str) -> str:
    """Key of the distance between landmarks ``a`` and ``b`` (``"mf_l-mf_r"``)."""
    return f"{a}-{b}"


_FARKAS = ("Farkas LG et al., International anthropometric study of facial morphology, "
           "J Craniofac Surg 16(4):615-646, 2005 (young adults, North American white norms "
           "+-2 SD, both sexes; other populations differ, mostly wider noses)")

_INFO: list[MeasurementInfo] = [
    *(MeasurementInfo(distance_key(a, b), "mm",
                      f"straight-line 3D distance {a}-{b} (paper Table 1)")
      for a, b in TABLE1_DISTANCES),
    MeasurementInfo("nasal_length", "mm", "nasal length: 3D distance nasion-pronasale (n-prn)"),
    MeasurementInfo("nasal_height", "mm", "nasal height: 3D distance nasion-subnasale (n-sn)",
                    (44.0, 61.0), _FARKAS),
    MeasurementInfo("nasal_width", "mm", "nasal width: 3D distance alare-alare (al_l-al_r)",
                    (27.0, 39.0), _FARKAS),
    MeasurementInfo("alar_base", "mm",
                    "alar base width: 3D distance between the alar curvature points (ac_l-ac_r)"),
    MeasurementInfo("nasal_index", "", "nasal index: nasal_width / nasal_height x 100; a "
                    "classification, not a norm: <70 leptorrhine, 70-85 mesorrhine, >85 "
                    "platyrrhine (Martin & Saller, Lehrbuch der Anthropologie, 1957)"),
    MeasurementInfo("nasofrontal_angle", "deg",
                    "nasofrontal angle: angle at n between the rays n->g and n->prn",
                    (115.0, 135.0), "Powell N, Humphreys B, Proportions of the Aesthetic "
                    "Face, Thieme 1984"),
    MeasurementInfo("tip_projection", "mm",
                    "tip projection (Goode): anterior (+z) distance from the alar crease "
                    "(mean of ac_l, ac_r) to pronasale, i.e. from prn to the vertical alar "
                    "line through ac"),
    MeasurementInfo("goode_ratio", "", "Goode ratio: tip_projection / nasal_length (n-prn); "
                    "the range is the aesthetic ideal",
                    (0.55, 0.60), "Goode's method as reported in Powell & Humphreys 1984; "
                    "Byrd HS, Hobar PC, Plast Reconstr Surg 91(4):642-654, 1993"),
    MeasurementInfo("dorsal_hump_depth", "mm",
                    "dorsal hump depth: largest distance of the dorsum (mid-curve between n "
                    "and prn) anterior to the straight n-prn line; 0 for a straight or "
                    "concave dorsum (the aesthetic female dorsum lies about 2 mm behind a "
                    "line from the radix to the tip; Sheen JH, Aesthetic Rhinoplasty, 1987)"),
]

MEASUREMENT_INFO: dict[str, MeasurementInfo] = {m.name: m for m in _INFO}
"""Every measurement :func:`clinical_measurements` can return, by name, in report order."""


def _get(landmarks: Mapping[str, np.ndarray], *ids: str) -> list[np.ndarray] | None:
    """(3,) float positions of ``ids``, or None when one is missing or not finite."""
    out = []
    for i in ids:
        p = landmarks.get(i)
        if p is None:
            return None
        p = np.asarray(p, dtype=np.float64).reshape(3)
        if not np.isfinite(p).all():
            return None
        out.append(p)
    return out


def angle_deg(a: np.ndarray, vertex: np.ndarray, b: np.ndarray) -> float:
    """Angle a-vertex-b in degrees (0..180) between the rays vertex->a and vertex->b."""
    u = np.asarray(a, float) - vertex
    v = np.asarray(b, float) - vertex
    c = float(np.dot(u, v) / max(np.linalg.norm(u) * np.linalg.norm(v), 1e-12))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _dorsum_frame(n: np.ndarray, prn: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Unit n->prn direction ``u``, unit anterior direction ``a`` (+z made orthogonal to u,
    the anterior normal of the line in the sagittal plane), and the n-prn length."""
    d = prn - n
    length = float(np.linalg.norm(d))
    u = d / max(length, 1e-12)
    z = np.array([0.0, 0.0, 1.0])
    a = z - np.dot(z, u) * u
    na = np.linalg.norm(a)
    if na < 1e-6:  # n-prn along z: fall back to +y made orthogonal
        y = np.array([0.0, 1.0, 0.0])
        a = y - np.dot(y, u) * u
        na = np.linalg.norm(a)
    return u, a / na, length


def _polyline_between(curve: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Sub-polyline of ``curve`` (N, 3) between its vertices nearest to ``p`` and ``q``."""
    i = int(np.argmin(np.linalg.norm(curve - p, axis=1)))
    j = int(np.argmin(np.linalg.norm(curve - q, axis=1)))
    lo, hi = min(i, j), max(i, j)
    return curve[lo:hi + 1]


def _midline_section(V: np.ndarray, F: np.ndarray | None, n: np.ndarray,
                     u: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Points where the sagittal plane through n spanned by (u, a) cuts the mesh (K, 3).

    With faces, the crossing points of the mesh edges; without, the vertices within 1 mm
    of the plane.
    """
    normal = np.cross(u, a)
    s = (V - n) @ normal
    if F is None:
        return V[np.abs(s) < 1.0]
    F = np.asarray(F, dtype=np.int64)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.unique(np.sort(E, axis=1), axis=0)
    s0, s1 = s[E[:, 0]], s[E[:, 1]]
    cross = (s0 * s1 <= 0) & (s0 != s1)
    E, s0, s1 = E[cross], s0[cross], s1[cross]
    t = (s0 / (s0 - s1))[:, None]
    on = V[np.abs(s) < 1e-12]
    return np.concatenate([V[E[:, 0]] + t * (V[E[:, 1]] - V[E[:, 0]]), on])


def dorsal_hump_depth(n: np.ndarray, prn: np.ndarray, profile: np.ndarray) -> float:
    """Largest distance (mm) of profile points anterior to the n-prn line, 0 if none.

    Args:
        n, prn: (3,) nasion and pronasale.
        profile: (K, 3) points of the dorsal profile (mid-curve or a midline mesh section);
            only points whose projection on n->prn falls strictly between n and prn count.
    """
    u, a, length = _dorsum_frame(n, prn)
    d = np.asarray(profile, dtype=np.float64).reshape(-1, 3) - n
    along = d @ u
    inside = (along > 0.0) & (along < length)
    if not inside.any():
        return 0.0
    return float(max(0.0, (d[inside] @ a).max()))


def clinical_measurements(landmarks: Mapping[str, np.ndarray],
                          curves: Mapping[str, np.ndarray] | None = None,
                          V: np.ndarray | None = None,
                          F: np.ndarray | None = None) -> dict[str, float]:
    """The paper's 11 distances and common rhinometric measurements.

    Definitions (SPEC frame, mm; all distances are straight 3D Euclidean distances):

    - ``"<a>-<b>"`` for each pair of :data:`naseview.landmarks.TABLE1_DISTANCES`
      (``"mf_l-mf_r"``, ..., ``"c-sn"``): |a - b|, the paper's Table 1.
    - ``nasal_length``: |n - prn|.
    - ``nasal_height``: |n - sn|.
    - ``nasal_width``: |al_l - al_r|.
    - ``alar_base``: |ac_l - ac_r|.
    - ``nasal_index``: nasal_width / nasal_height * 100.
    - ``nasofrontal_angle``: angle at n between n->g and n->prn, degrees (180 when g, n,
      prn are collinear).
    - ``tip_projection``: Goode's tip projection, the distance from prn to the alar line,
      i.e. (prn - ac) . z, with ac the mean of ac_l and ac_r (whichever exist) and the
      alar line vertical (+y, perpendicular to the Frankfort horizontal, which the SPEC
      frame of a natural-head-position photo set approximates).
    - ``goode_ratio``: tip_projection / nasal_length (Goode: 0.55-0.60 ideal).
    - ``dorsal_hump_depth``: max over the dorsal profile between n and prn of the distance
      anterior to the straight n-prn line (anterior = +z made perpendicular to n->prn);
      0 for a straight or concave dorsum. The profile is ``curves["mid"]`` between its
      points nearest n and prn; without it, the cut of the mesh (V, F) by the sagittal
      plane through n and prn; without either, omitted.

    Args:
        landmarks: id -> (3,) position, mm (any subset of the 21).
        curves: optional SPEC §5 curves, name -> (N, 3).
        V, F: optional refined mesh (n, 3) mm / (m, 3) int, for the hump depth.
    Returns:
        name -> value; names of :data:`MEASUREMENT_INFO` whose inputs are present.
    """
    out = _distances(landmarks)
    out.update(_nasal_index(out))
    out.update(_nasofrontal_angle(landmarks))
    out.update(_tip_projection(landmarks, out))
    out.update(_dorsal_hump(landmarks, curves, V, F))
    return out


_NAMED_DISTANCES: tuple[tuple[str, str, str], ...] = (
    ("nasal_length", "n", "prn"), ("nasal_height", "n", "sn"),
    ("nasal_width", "al_l", "al_r"), ("alar_base", "ac_l", "ac_r"),
)
"""Rhinometric distances: (name, landmark a, landmark b)."""


def _distances(landmarks: Mapping[str, np.ndarray]) -> dict[str, float]:
    """The Table 1 distances, then :data:`_NAMED_DISTANCES`, where both ends exist."""
    out: dict[str, float] = {}
    pairs = [(distance_key(a, b), a, b) for a, b in TABLE1_DISTANCES]
    for name, a, b in (*pairs, *_NAMED_DISTANCES):
        p = _get(landmarks, a, b)
        if p is not None:
            out[name] = float(np.linalg.norm(p[0] - p[1]))
    return out


def _nasal_index(dist: Mapping[str, float]) -> dict[str, float]:
    """``nasal_index`` from the nasal width and a positive nasal height."""
    if "nasal_width" in dist and dist.get("nasal_height", 0.0) > 0.0:
        return {"nasal_index": dist["nasal_width"] / dist["nasal_height"] * 100.0}
    return {}


def _nasofrontal_angle(landmarks: Mapping[str, np.ndarray]) -> dict[str, float]:
    """``nasofrontal_angle`` at n between n->g and n->prn."""
    p = _get(landmarks, "g", "n", "prn")
    return {} if p is None else {"nasofrontal_angle": angle_deg(p[0], p[1], p[2])}


def _tip_projection(landmarks: Mapping[str, np.ndarray],
                    dist: Mapping[str, float]) -> dict[str, float]:
    """Goode's ``tip_projection`` from the alar crease, and ``goode_ratio`` when the nasal
    length is known."""
    acs = [q[0] for q in (_get(landmarks, "ac_l"), _get(landmarks, "ac_r")) if q is not None]
    p = _get(landmarks, "prn")
    if not acs or p is None:
        return {}
    out = {"tip_projection": float(p[0][2] - np.mean(acs, axis=0)[2])}
    if dist.get("nasal_length", 0.0) > 0.0:
        out["goode_ratio"] = out["tip_projection"] / dist["nasal_length"]
    return out


def _dorsal_hump(landmarks: Mapping[str, np.ndarray],
                 curves: Mapping[str, np.ndarray] | None,
                 V: np.ndarray | None, F: np.ndarray | None) -> dict[str, float]:
    """``dorsal_hump_depth`` along the mid-curve, else along the mesh's midline section."""
    p = _get(landmarks, "n", "prn")
    if p is None or np.linalg.norm(p[1] - p[0]) <= 1e-6:
        return {}
    n, prn = p
    mid = None if curves is None else curves.get("mid")
    if mid is not None and len(np.asarray(mid).reshape(-1, 3)) >= 2:
        profile = _polyline_between(np.asarray(mid, float).reshape(-1, 3), n, prn)
    elif V is not None:
        u, anterior, _ = _dorsum_frame(n, prn)
        profile = _midline_section(np.asarray(V, float), F, n, u, anterior)
    else:
        return {}
    return {"dorsal_hump_depth": dorsal_hump_depth(n, prn, profile)}


def format_measurements(values: Mapping[str, float]) -> list[str]:
    """One human-readable line per measurement, in :data:`MEASUREMENT_INFO` order, with the
    typical range when one is known (for reports and the CLI)."""
    lines = []
    for name, info in MEASUREMENT_INFO.items():
        if name not in values:
            continue
        unit = {"deg": " deg", "mm": " mm"}.get(info.unit, "")
        rng = (f"  (typical {info.normal[0]:g}-{info.normal[1]:g}{unit})"
               if info.normal else "")
        lines.append(f"{name:20s} {values[name]:8.2f}{unit}{rng}")
    return lines
