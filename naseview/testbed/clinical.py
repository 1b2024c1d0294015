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

**The frame.** Some measurements read the frame's vertical (``up``: tip rotation, radix
height and level, tip projection and the Goode and Crumley figures; the angles between
two profile lines and the 3D distances do not). A reconstruction's frame is stage 1's
(:func:`naseview.stage1_landmarks.anatomical_frame`: +y from sn towards g), while a
truth file keeps its scan's or model's own +y, 4-10 degrees from that on james, lps and
ICT faces. So beside the SPEC §6 figure each case also gets ``in_stage1_frame``: the
same errors with the truth turned into stage 1's frame of its own landmarks, and
``frame_tilt_deg``, the angle between the two verticals. Where the two figures differ,
the difference is the convention of the vertical, not the reconstructed shape.

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
from dataclasses import dataclass
from typing import Any

import numpy as np

from naseview.landmarks import LANDMARK_IDS
from naseview.measurements import (
    MEASUREMENT_INFO,
    clinical_measurements,
    facial_profile,
    midline_plane,
)
from naseview.measurements.frame import clean_landmarks
from naseview.measurements.section import topology
from naseview.stage1_landmarks import anatomical_frame

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


@dataclass(frozen=True)
class TruthMeasurements:
    """The truth side of :func:`measurement_errors`, computed once per truth.

    Attributes:
        values: ``clinical_measurements`` of the truth mesh, landmarks and curves as the
            truth files give them (the SPEC §6 figure).
        stage1_values: the same with the truth turned into stage 1's frame of its own
            landmarks (module docstring); empty when that frame cannot be built.
        tilt_deg: angle between the truth's +y and that frame's +y (NaN without it).
        profile: :func:`profile_reach` of the truth.
    """

    values: dict[str, float]
    stage1_values: dict[str, float]
    tilt_deg: float
    profile: dict[str, Any]


def truth_measurements(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                       curves: Mapping[str, np.ndarray] | None = None) -> TruthMeasurements:
    """The truth's measurements, in its own frame and in stage 1's (module docstring).

    Args:
        V, F: the truth mesh (mm). landmarks: id -> (3,) true landmarks.
        curves: the truth's curves, or None.
    """
    curves = curves or None
    values = clinical_measurements(landmarks, curves, V, F)
    pts = {k: np.asarray(landmarks[k], float) for k in LANDMARK_IDS if k in landmarks}
    try:
        o, R = anatomical_frame(pts)
    except ValueError:
        return TruthMeasurements(values, {}, math.nan, profile_reach(landmarks, curves, V, F))
    turn = lambda P: (np.asarray(P, float).reshape(-1, 3) - o) @ R.T  # noqa: E731
    lm1 = {k: turn(v)[0] for k, v in landmarks.items()}
    c1 = None if curves is None else {k: turn(c) for k, c in curves.items()}
    stage1 = clinical_measurements(lm1, c1, turn(V), F)
    tilt = float(np.degrees(np.arccos(np.clip(R[1, 1], -1.0, 1.0))))
    return TruthMeasurements(values, stage1, tilt, profile_reach(landmarks, curves, V, F))


def _pairs(truth: Mapping[str, float], pred: Mapping[str, float]
           ) -> dict[str, dict[str, float]]:
    """name -> ``{"truth", "pred", "error"}`` for the names of either, MEASUREMENT_INFO order."""
    out: dict[str, dict[str, float]] = {}
    for name in MEASUREMENT_INFO:
        if name not in truth and name not in pred:
            continue
        t, p = truth.get(name, math.nan), pred.get(name, math.nan)
        out[name] = {"truth": t, "pred": p, "error": p - t}
    return out


def measurement_errors(truth_V: np.ndarray, truth_F: np.ndarray,
                       truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray,
                       F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                       curves: Mapping[str, np.ndarray] | None = None,
                       truth_curves: Mapping[str, np.ndarray] | None = None,
                       truth: TruthMeasurements | None = None) -> dict[str, Any]:
    """Clinical measurement errors of one case (module docstring): reconstruction minus truth.

    Args:
        truth_V, truth_F: ground-truth mesh (``truth_face.ply``; a face or a whole head),
            SPEC frame, mm.
        truth_landmarks: id -> (3,) true landmarks (``truth.json``).
        V, F: the reconstructed face mesh (mm), in the reconstruction's frame.
        landmarks: id -> (3,) reconstructed landmarks (same frame as V).
        curves: the reconstruction's SPEC §5 curves, or None.
        truth_curves: the truth's curves, or None (a scan's truth may have none).
        truth: precomputed :func:`truth_measurements` of this truth (a benchmark measuring
            one truth many times), else computed here.
    Returns:
        ``{"measurements": {name: {"truth", "pred", "error"}}, "in_stage1_frame": the same
        with the truth in stage 1's frame, "frame_tilt_deg": float, "profile": {"truth":
        profile_reach, "pred": profile_reach}}``, every name of :data:`MEASUREMENT_INFO`
        found on either side, in its order; ``error`` = pred - truth, NaN where one side
        lacks the measurement.
    """
    if truth is None:
        truth = truth_measurements(truth_V, truth_F, truth_landmarks, truth_curves)
    pred = clinical_measurements(landmarks, curves or None, V, F)
    return {"measurements": _pairs(truth.values, pred),
            "in_stage1_frame": _pairs(truth.stage1_values, pred) if truth.stage1_values
            else {},
            "frame_tilt_deg": truth.tilt_deg,
            "profile": {"truth": truth.profile,
                        "pred": profile_reach(landmarks, curves or None, V, F)}}


def summarize_errors(cases: Sequence[Mapping[str, Any]], key: str = "measurements"
                     ) -> dict[str, dict[str, float]]:
    """Over the cases' :func:`measurement_errors`: name -> ``{"mae", "mean_error", "n",
    "missing"}`` (mean absolute and mean signed error over the cases where both sides have
    it; ``missing``: cases where one side lacks it), :data:`MEASUREMENT_INFO` order.
    ``key``: ``"measurements"`` (SPEC §6) or ``"in_stage1_frame"``."""
    out: dict[str, dict[str, float]] = {}
    for name in MEASUREMENT_INFO:
        rows = [c[key][name] for c in cases if name in c.get(key, {})]
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


def _frame_lines(cases: Sequence[Mapping[str, Any]], show: Sequence[str], w: int
                 ) -> list[str]:
    """The headline measurements that read the vertical, again with the truth in stage 1's
    frame (module docstring): per case and MAE, and each truth's tilt."""
    summ = summarize_errors(cases, "in_stage1_frame")
    spec = summarize_errors(cases)
    names = [n for n in HEADLINE if n in summ and n in spec and summ[n]["n"]
             and abs(summ[n]["mae"] - spec[n]["mae"]) > 0.005]
    if not names:
        return []
    t = [float(c.get("frame_tilt_deg", math.nan)) for c in cases]
    tilts = ", ".join(_num(x, 1, False) for x in t) if len(t) <= 8 else \
        f"{np.nanmin(t):.1f} to {np.nanmax(t):.1f}"
    lines = ["", f"the same with the truth in stage 1's frame (+y from sn towards g, as a "
                 f"reconstruction's; the truth's own +y is {tilts} deg from it):"]
    for name in names:
        row = f"{name:<26}{_unit(name):<5}"
        row += "".join(f"{_num(c['in_stage1_frame'].get(name, {}).get('error', math.nan)):>{w}}"
                       for c in cases[:len(show)])
        tgt = MAE_TARGETS.get(name)
        miss = "!" if tgt is not None and summ[name]["mae"] > tgt else ""
        lines.append(row + f"{_num(summ[name]['mae'], sign=False) + miss:>8}"
                           f"{summ[name]['n']:>4}")
    return lines


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
    lines += _frame_lines(cases, show, w)
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
