"""Clinical measurement errors against a truth mesh (SPEC §6, last bullet).

For each measurement of the app (:func:`naseview.measurements.clinical_measurements`,
names in :data:`naseview.measurements.MEASUREMENT_INFO`): the value on the
reconstruction (its landmarks, curves and mesh, in its own frame, as the app shows it)
minus the value the same function gives on the truth mesh with the truth landmarks (and
the truth curves, where the truth has them). Degrees or mm; per case and, over cases, as
the mean absolute error. No alignment: a reconstruction whose facial vertical is off
reads a tip rotation that is off, as the surgeon would.

The profile measurements read the mesh's midline section (``facial_profile``); each side's
profile is reported with its source (``mesh``, else ``mid`` or ``landmarks``) and how far
it reaches below sn (the nasolabial angle needs about 4 mm of it, its tangent is fitted
to 8 mm), so a measurement missing on one side says why.

Used by ``naseview evaluate`` (:mod:`naseview.testbed.evaluate`) and
``benchmarks/bench_real.py``.

Example
-------
    e = measurement_errors(truth_V, truth_F, truth_landmarks, res.face_vertices,
                           res.faces, rec.landmarks, rec.curves)
    e["measurements"]["nasolabial_angle"]   # {"truth": 122.4, "pred": 85.9, "error": -36.5}
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from naseview.measurements import (
    MEASUREMENT_INFO,
    clinical_measurements,
    facial_profile,
    midline_plane,
)
from naseview.measurements.frame import clean_landmarks
from naseview.measurements.section import topology

HEADLINE: tuple[str, ...] = ("nasolabial_angle", "nasofrontal_angle", "tip_rotation",
                             "radix_height", "tip_projection", "nasal_length")
"""The measurements a surgeon plans from (issue 23), in report order."""

MAE_TARGETS: dict[str, float] = {
    "nasolabial_angle": 3.0, "nasofrontal_angle": 2.0, "tip_rotation": 2.0,
    "radix_height": 1.0, "tip_projection": 0.7, "nasal_length": 0.7,
}
"""Issue 23's "must reach" mean absolute errors (degrees or mm) of :data:`HEADLINE`."""

SHORT: dict[str, str] = {
    "nasolabial_angle": "nasolabial", "nasofrontal_angle": "nasofrontal",
    "tip_rotation": "tip rot.", "radix_height": "radix h.", "tip_projection": "tip proj.",
    "nasal_length": "nasal len.",
}
"""Column titles of :data:`HEADLINE` in the printed tables."""


def _unit(name: str) -> str:
    return {"deg": "deg", "mm": "mm"}.get(MEASUREMENT_INFO[name].unit, "")


def profile_reach(landmarks: Mapping[str, np.ndarray],
                  curves: Mapping[str, np.ndarray] | None = None,
                  V: np.ndarray | None = None, F: np.ndarray | None = None
                  ) -> dict[str, Any]:
    """The midline profile the profile measurements read, in brief.

    Returns:
        ``{"source": "mesh" | "mid" | "landmarks" | "none", "below_sn_mm": arc length of
        the profile from its point nearest sn on}`` (0 when it stops at sn, NaN without a
        profile or when it misses sn by more than 5 mm).
    """
    clean = clean_landmarks(landmarks)
    plane = midline_plane(clean)
    topo = None
    if V is not None and F is not None and len(F):
        V = np.asarray(V, np.float64).reshape(-1, 3)
        topo = topology(np.asarray(F, np.int64).reshape(-1, 3))
    prof = facial_profile(clean, plane, curves, V if topo is not None else None, topo)
    if prof is None:
        return {"source": "none", "below_sn_mm": math.nan}
    sn = clean.get("sn")
    below = math.nan
    if sn is not None:
        i = prof.index_after(plane.to_2d(sn)[0], prof.i_prn)
        if i is not None:
            below = float(np.linalg.norm(np.diff(prof.points[i:], axis=0), axis=1).sum())
    return {"source": prof.source, "below_sn_mm": below}


def measurement_errors(truth_V: np.ndarray, truth_F: np.ndarray,
                       truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray,
                       F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                       curves: Mapping[str, np.ndarray] | None = None,
                       truth_curves: Mapping[str, np.ndarray] | None = None,
                       truth_values: Mapping[str, float] | None = None) -> dict[str, Any]:
    """Clinical measurement errors of one case (module docstring): reconstruction minus truth.

    Args:
        truth_V, truth_F: ground-truth mesh (``truth_face.ply``; a face or a whole head),
            SPEC frame, mm.
        truth_landmarks: id -> (3,) true landmarks (``truth.json``).
        V, F: the reconstructed face mesh (mm), in the reconstruction's frame.
        landmarks: id -> (3,) reconstructed landmarks (same frame as V).
        curves: the reconstruction's SPEC §5 curves, or None.
        truth_curves: the truth's curves, or None (a scan's truth may have none).
        truth_values: precomputed ``clinical_measurements`` of the truth (a benchmark
            measuring one truth many times), else computed here.
    Returns:
        ``{"measurements": {name: {"truth", "pred", "error"}}, "profile": {"truth":
        profile_reach, "pred": profile_reach}}`` with every name of
        :data:`MEASUREMENT_INFO` found on either side, in its order; ``error`` = pred -
        truth, NaN where one side lacks the measurement.
    """
    tc = truth_curves or None
    truth = dict(truth_values) if truth_values is not None else clinical_measurements(
        truth_landmarks, tc, truth_V, truth_F)
    pred = clinical_measurements(landmarks, curves or None, V, F)
    out: dict[str, dict[str, float]] = {}
    for name in MEASUREMENT_INFO:
        if name not in truth and name not in pred:
            continue
        t, p = truth.get(name, math.nan), pred.get(name, math.nan)
        out[name] = {"truth": t, "pred": p, "error": p - t}
    return {"measurements": out,
            "profile": {"truth": profile_reach(truth_landmarks, tc, truth_V, truth_F),
                        "pred": profile_reach(landmarks, curves or None, V, F)}}


def summarize_errors(cases: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """Over the cases' :func:`measurement_errors`: name -> ``{"mae", "mean_error", "n",
    "missing"}`` (mean absolute and mean signed error over the cases where both sides have
    it; ``missing``: cases where one side lacks it), :data:`MEASUREMENT_INFO` order."""
    out: dict[str, dict[str, float]] = {}
    for name in MEASUREMENT_INFO:
        rows = [c["measurements"][name] for c in cases if name in c.get("measurements", {})]
        if not rows:
            continue
        e = np.array([r["error"] for r in rows], float)
        ok = np.isfinite(e)
        out[name] = {"mae": float(np.abs(e[ok]).mean()) if ok.any() else math.nan,
                     "mean_error": float(e[ok].mean()) if ok.any() else math.nan,
                     "n": int(ok.sum()), "missing": int((~ok).sum())}
    return out


def _num(x: float, digits: int = 2, sign: bool = True) -> str:
    if x is None or not math.isfinite(x):
        return "-"
    return f"{x:+.{digits}f}" if sign else f"{x:.{digits}f}"


def _reach(mm: float) -> str:
    """How far a profile reaches below sn, for print (``20+ mm`` past 20 mm)."""
    return "-" if not math.isfinite(mm) else "20+ mm" if mm > 20 else f"{mm:.1f} mm"


def format_errors(cases: Sequence[Mapping[str, Any]], summary: Mapping[str, Any],
                  ids: Sequence[str], max_cases: int = 8) -> list[str]:
    """Printed table: one row per measurement (:data:`HEADLINE` first, ``*`` marking them,
    then the other clinical ones; the Table 1 distances are their own section), the signed
    error per case (up to ``max_cases`` columns), the MAE, the issue-23 target where there
    is one; then each case's truth value of the headline ones and its profiles."""
    show = list(ids) if len(ids) <= max_cases else []
    clinical = [n for n in HEADLINE if n in summary] + [
        n for n in summary if n not in HEADLINE and MEASUREMENT_INFO[n].group != "distance"]
    names = [n for n in clinical if summary[n]["n"] > 0]
    one_side = [n for n in clinical if summary[n]["n"] == 0]
    w = max([len(i) for i in show] + [8]) + 2
    lines = [f"{'measurement':<26}{'unit':<5}" + "".join(f"{i:>{w}}" for i in show)
             + f"{'MAE':>8}{'n':>4}{'target':>8}"]
    for name in names:
        s = summary[name]
        row = f"{name + (' *' if name in HEADLINE else ''):<26}{_unit(name):<5}"
        row += "".join(f"{_num(c['measurements'].get(name, {}).get('error', math.nan)):>{w}}"
                       for c in cases[:len(show)])
        tgt = MAE_TARGETS.get(name)
        miss = "!" if tgt is not None and math.isfinite(s["mae"]) and s["mae"] > tgt else ""
        row += f"{_num(s['mae'], sign=False) + miss:>8}{s['n']:>4}"
        row += f"{'<=' + format(tgt, 'g') if tgt is not None else '':>8}"
        lines.append(row)
    lines.append("error = reconstruction - truth (same function on the truth mesh and "
                 "landmarks); * the surgeon's headline measurements; ! MAE above the "
                 "issue-23 target")
    if one_side:
        lines.append("not compared (on one side only in every case): " + ", ".join(one_side))
    for cid, c in zip(show, cases, strict=False):
        tv = ", ".join(f"{SHORT[n]} {_num(c['measurements'][n]['truth'], 1, False)}"
                       for n in HEADLINE if n in c["measurements"])
        pr = c.get("profile", {})
        prof = "; ".join(f"{side} {p['source']} to {_reach(p['below_sn_mm'])} below sn"
                         for side, p in pr.items())
        lines.append(f"  {cid}: truth {tv}; profile {prof}")
        lost = [n for n in HEADLINE if n in c["measurements"]
                and not math.isfinite(c["measurements"][n]["error"])]
        if lost:
            lines.append(f"  {cid}: not found on one side: {', '.join(lost)}")
    return lines
