"""Boundary-shape accuracy, paper Tables 4 and 5 (SPEC §6).

Each reconstructed 3D curve is projected into the photo where its ground truth is given
(2D points, ``truth_boundaries.json``, SPEC §7) with the *reconstructed* camera of that
photo, as the paper projects with its estimated P. MAE is the mean over ground-truth
points of the distance to the projected polyline. Hausdorff is the symmetric Hausdorff
distance between the ground truth and the corresponding part of the projected polyline:
the ground-truth points, in their order, form polylines (closed for a sill seen whole)
that are split where points are missing (hidden in that photo); for each piece the
projected polyline is trimmed to the stretch between the points nearest to the piece's
ends, as the paper compares "corresponding points". Pixels become mm with the front
photo's px-per-mm at al_l-al_r.

Example
-------
>>> import numpy as np
>>> P = np.array([[0.0, 0.0], [10.0, 0.0]])
>>> Q = np.array([[0.0, 1.0], [5.0, 1.0], [10.0, 1.0]])
>>> float(point_to_polyline(Q, P).mean()), hausdorff_polylines(P, Q)
(1.0, 1.0)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera
from naseview.geometry.polyline import cumulative_length, polyline_length
from naseview.landmarks import CURVE_FAMILIES

PAPER_TABLE4_MAE: dict[str, float] = {"mid": 1.347, "bottom": 2.565, "ala": 1.573,
                                      "c": 1.377, "sill": 1.421, "side": 2.144}
"""Paper Table 4: boundary MAE (mm), mean of 30 volunteers."""

PAPER_TABLE5_HAUSDORFF: dict[str, float] = {"mid": 2.350, "bottom": 3.762, "ala": 2.634,
                                            "c": 2.326, "sill": 2.740, "side": 3.393}
"""Paper Table 5: boundary Hausdorff distance (mm), mean of 30 volunteers."""

FAMILY_LABELS: dict[str, str] = {"mid": "Mid-curve", "bottom": "Bottom-curve",
                                 "ala": "Ala-curve", "c": "C-curve", "sill": "Nasal-sill",
                                 "side": "Side-curve"}


def point_to_polyline(Q: ArrayLike, P: ArrayLike, closed: bool = False) -> np.ndarray:
    """(M,) distance of each of the (M, D) points Q to the (N, D) polyline P."""
    Q = np.asarray(Q, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    if len(P) == 0:
        return np.full(len(Q), np.inf)
    if closed and len(P) > 2:
        P = np.vstack([P, P[:1]])
    if len(P) == 1:
        return np.linalg.norm(Q - P[0], axis=1)
    A, B = P[:-1], P[1:]
    d = B - A
    L2 = np.maximum((d * d).sum(1), 1e-18)
    t = np.clip(np.einsum("mkd,kd->mk", Q[:, None, :] - A[None], d) / L2, 0.0, 1.0)
    foot = A[None] + t[..., None] * d[None]
    return np.sqrt(((Q[:, None, :] - foot) ** 2).sum(-1)).min(axis=1)


def hausdorff_polylines(P: ArrayLike, Q: ArrayLike, closed: bool = False) -> float:
    """Symmetric Hausdorff distance between two (N, D) / (M, D) polylines (vertices to
    the other polyline, both ways)."""
    return float(max(point_to_polyline(Q, P, closed).max(),
                     point_to_polyline(P, Q, closed).max()))


def split_at_gaps(T: ArrayLike, closed: bool = False,
                  gap_factor: float = 4.0) -> list[tuple[np.ndarray, bool]]:
    """Split ordered (M, 2) points where a step exceeds ``gap_factor`` x the median step.

    Returns:
        [(piece (m, 2), is_closed)]: one closed piece for a loop without gaps, else open
        pieces (a loop is cut at its gaps, its wrap-around kept).
    """
    T = np.asarray(T, dtype=np.float64)
    if len(T) < 3:
        return [(T, False)]
    nxt = np.roll(T, -1, axis=0) if closed else T[1:]
    steps = np.linalg.norm(nxt - T[:len(nxt)], axis=1)
    lim = gap_factor * max(float(np.median(steps)), 1e-9)
    gaps = np.nonzero(steps > lim)[0]          # a gap after point i
    if closed:
        if len(gaps) == 0:
            return [(T, True)]
        T = np.roll(T, -(int(gaps[-1]) + 1), axis=0)
        gaps = np.sort((gaps - gaps[-1] - 1) % len(T))[:-1]
    cuts = [0] + [int(g) + 1 for g in gaps] + [len(T)]
    return [(T[i:j], False) for i, j in zip(cuts[:-1], cuts[1:], strict=True) if j > i]


def _nearest_param(P: np.ndarray, q: np.ndarray) -> float:
    """Arc-length position along polyline P of the point nearest to q."""
    A, B = P[:-1], P[1:]
    d = B - A
    L2 = np.maximum((d * d).sum(1), 1e-18)
    t = np.clip(((q - A) * d).sum(1) / L2, 0, 1)
    k = int(np.argmin(np.linalg.norm(A + t[:, None] * d - q, axis=1)))
    seg = np.sqrt(L2)
    return float(seg[:k].sum() + t[k] * seg[k])


def _sub_polyline(P: np.ndarray, s0: float, s1: float) -> np.ndarray:
    """The stretch of polyline P between arc-length positions s0 and s1 (any order)."""
    s = cumulative_length(P)
    a, b = sorted((s0, s1))
    inner = P[(s > a) & (s < b)]
    ends = [np.array([np.interp(x, s, P[:, j]) for j in range(P.shape[1])]) for x in (a, b)]
    return np.vstack([ends[0], inner, ends[1]])


def _hausdorff_piece(piece: np.ndarray, Q: np.ndarray, pc: bool, qc: bool) -> float:
    return float(max(point_to_polyline(piece, Q, qc).max(),
                     point_to_polyline(Q, piece, pc).max()))


def boundary_hausdorff(P: ArrayLike, T: ArrayLike, closed: bool = False) -> float:
    """Hausdorff distance between ground-truth points T (M, 2) and polyline P (N, 2).

    T is split at gaps (:func:`split_at_gaps`); each open piece is compared with the
    stretch of P between the points nearest to its ends (for a closed P, the better of
    the two arcs), a closed piece with the whole of P.
    """
    P = np.asarray(P, dtype=np.float64)
    worst = 0.0
    for piece, pc in split_at_gaps(T, closed):
        if len(piece) < 2 or len(P) < 2:   # a lone point: its distance to the curve
            worst = max(worst, float(point_to_polyline(piece, P, closed).max()))
            continue
        if pc:
            worst = max(worst, _hausdorff_piece(piece, P, pc, closed))
            continue
        Pc = np.vstack([P, P[:1]]) if closed else P
        s0, s1 = _nearest_param(Pc, piece[0]), _nearest_param(Pc, piece[-1])
        cands = [_sub_polyline(Pc, s0, s1)]
        if closed:
            total = polyline_length(Pc)
            a, b = sorted((s0, s1))
            P2 = np.vstack([Pc, Pc[1:]])  # the loop twice, to take the wrap-around arc
            cands.append(_sub_polyline(P2, b, a + total))
        worst = max(worst, min(_hausdorff_piece(piece, Q, False, False) for Q in cands))
    return worst


def px_per_mm_from_truth(landmarks: Mapping[str, ArrayLike], front: Camera) -> float:
    """Front-photo scale from ground truth: the true al_l, al_r projected with the true
    front camera; their distance in px over their 3D distance in mm."""
    A = np.array([landmarks["al_l"], landmarks["al_r"]], dtype=np.float64)
    uv = front.project(A)
    return float(np.linalg.norm(uv[0] - uv[1]) / np.linalg.norm(A[0] - A[1]))


def _curve_error(P3: np.ndarray, camera: Camera, T: np.ndarray, closed: bool,
                 px_per_mm: float) -> tuple[float, float]:
    """MAE and Hausdorff (mm) of the (N, 3) curve projected with ``camera`` against the
    (M, 2) ground-truth points; both infinite for an empty curve."""
    if len(P3) == 0:
        return float("inf"), float("inf")
    P = camera.project(P3)
    return (float(point_to_polyline(T, P, closed).mean()) / px_per_mm,
            boundary_hausdorff(P, T, closed) / px_per_mm)


def _mean_or_nan(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


def boundary_errors(curves: Mapping[str, ArrayLike], cameras: Mapping[str, Camera],
                    truth_boundaries: Mapping[str, Mapping[str, ArrayLike]],
                    px_per_mm: float) -> dict[str, Any]:
    """Per-curve and per-family boundary MAE and Hausdorff (mm) of one case.

    Args:
        curves: SPEC §5 curve name -> (N, 3) reconstructed polyline (mm).
        cameras: view -> reconstructed camera.
        truth_boundaries: curve name -> view -> (M, 2) ground-truth points (px).
        px_per_mm: front photo's px-per-mm at al_l-al_r.
    Returns:
        ``{"curves": {"name/view": {"mae_mm", "hausdorff_mm", "n"}},
        "families": {family: {"mae_mm", "hausdorff_mm"}}, "mean_mae_mm",
        "mean_hausdorff_mm"}``; families without ground truth are left out, a curve
        missing from ``curves`` counts as infinitely far.
    """
    per: dict[str, dict[str, float]] = {}
    fams: dict[str, dict[str, list[float]]] = {}
    for family, names in CURVE_FAMILIES.items():
        for name in names:
            for view, pts in truth_boundaries.get(name, {}).items():
                T = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
                if len(T) == 0 or view not in cameras:
                    continue
                P3 = np.asarray(curves.get(name, np.zeros((0, 3))), dtype=np.float64)
                mae, hd = _curve_error(P3, cameras[view], T, family == "sill", px_per_mm)
                per[f"{name}/{view}"] = {"mae_mm": mae, "hausdorff_mm": hd, "n": len(T)}
                f = fams.setdefault(family, {"mae_mm": [], "hausdorff_mm": []})
                f["mae_mm"].append(mae)
                f["hausdorff_mm"].append(hd)
    families = {k: {m: float(np.mean(v)) for m, v in d.items()} for k, d in fams.items()}
    return {
        "curves": per, "families": families,
        "mean_mae_mm": _mean_or_nan([f["mae_mm"] for f in families.values()]),
        "mean_hausdorff_mm": _mean_or_nan([f["hausdorff_mm"] for f in families.values()]),
    }


def tables_4_5(results: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """Mean over cases of :func:`boundary_errors` per family: {family: {mae, hausdorff}}."""
    acc: dict[str, dict[str, list[float]]] = {}
    for r in results:
        for fam, d in r["families"].items():
            a = acc.setdefault(fam, {"mae_mm": [], "hausdorff_mm": []})
            a["mae_mm"].append(d["mae_mm"])
            a["hausdorff_mm"].append(d["hausdorff_mm"])
    return {f: {m: float(np.mean(v)) for m, v in acc[f].items()}
            for f in CURVE_FAMILIES if f in acc}


def format_tables_4_5(table: Mapping[str, Mapping[str, float]], n_cases: int) -> str:
    """Tables 4 and 5 beside the paper's numbers, as text."""
    lines = [f"Boundary shape (paper Tables 4-5), mean of {n_cases} case(s), mm",
             f"{'boundary':<14}{'MAE':>8}{'paper':>8}{'Hausdorff':>11}{'paper':>8}"]
    maes, hds = [], []
    for fam in CURVE_FAMILIES:
        if fam not in table:
            continue
        m, h = table[fam]["mae_mm"], table[fam]["hausdorff_mm"]
        maes.append(m)
        hds.append(h)
        lines.append(f"{FAMILY_LABELS[fam]:<14}{m:>8.3f}{PAPER_TABLE4_MAE[fam]:>8.3f}"
                     f"{h:>11.3f}{PAPER_TABLE5_HAUSDORFF[fam]:>8.3f}")
    if maes:
        pm = np.mean([PAPER_TABLE4_MAE[f] for f in CURVE_FAMILIES if f in table])
        ph = np.mean([PAPER_TABLE5_HAUSDORFF[f] for f in CURVE_FAMILIES if f in table])
        lines.append(f"{'Mean':<14}{np.mean(maes):>8.3f}{pm:>8.3f}{np.mean(hds):>11.3f}"
                     f"{ph:>8.3f}")
    return "\n".join(lines)
