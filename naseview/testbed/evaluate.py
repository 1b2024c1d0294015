"""Accuracy against synthetic ground truth: ``naseview evaluate CASE_DIRS... [--json]``.

For each case directory with a ``truth.json`` (SPEC §7) the pipeline runs and every
registered :class:`Section` measures the result against the truth; the sections then
summarise over the cases and one printer (:func:`format_report`) lays them out as the
paper's tables:

- ``table1``: the 11 landmark distances of the paper's Table 1 (SPEC §6): per case the
  absolute error |d_pred - d_true| (mm), over the cases the mean and its 95 % confidence
  interval (t distribution), and %Error = mean |d_pred - d_true| / d_true (paper eq. 22);
- ``table2``: mean absolute error of n-prn and prn-sn (the paper's Table 2);
- ``landmarks``: 3D landmark RMSE after the best rigid alignment (Kabsch, no scaling, so a
  scale error counts);
- ``tables45`` (stage 2, paper §3.3): the boundary-curve MAE and Hausdorff distance of the
  paper's Tables 4 and 5 (:mod:`naseview.stage2_curves.metrics`);
- ``surface`` (stage 3, paper §3.4): the nose surface error (SPEC §6 nose region, works
  on a whole-head truth mesh) of the pipeline's mesh, per case and over the cases, by
  region, and of each ablation variant (:mod:`naseview.testbed.surface`);
- ``measurements`` (stage 3, SPEC §6): each clinical measurement of the app on the
  reconstruction minus the same on the truth mesh and landmarks, per case and as the
  mean absolute error (:mod:`naseview.testbed.clinical`).

Each is a :class:`Section` in :data:`SECTIONS`: it computes a dict per case from a
:class:`CaseRun`, summarises the list of those dicts, and formats lines; everything stays
JSON-ready. The file reads top to bottom as metrics, sections, running.

Example
-------
    report = evaluate_cases(["/tmp/synth/case-000"], stages=(1,))
    print(format_report(report))
"""

from __future__ import annotations

import argparse
import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from naseview.case import Case, read_case
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel, load_face_model
from naseview.fileio import read_json
from naseview.geometry.alignment import umeyama
from naseview.landmarks import (
    CURVE_FAMILIES,
    LANDMARK_IDS,
    TABLE1_DISTANCES,
    TABLE2_DISTANCES,
)
from naseview.meshio import read_mesh
from naseview.pipeline import PipelineParams, PipelineResult, parse_stages, reconstruct
from naseview.reconstruction import Reconstruction, read_reconstruction
from naseview.stage2_curves.metrics import (
    FAMILY_LABELS,
    PAPER_TABLE4_MAE,
    PAPER_TABLE5_HAUSDORFF,
    boundary_errors,
    px_per_mm_from_truth,
)
from naseview.testbed.clinical import format_errors, measurement_errors, summarize_errors
from naseview.testbed.regions import error_map_png, region_errors, regions_summary
from naseview.testbed.surface import ablation, nose_surface_samples, surface_error

PAPER_TABLE1_MEAN_MM: dict[str, float] = {
    "mf_l-mf_r": 0.422, "int_l-int_r": 0.957, "alp_l-alp_r": 1.094, "ac_l-ac_r": 0.545,
    "md_l-md_r": 0.542, "g-n": 0.401, "n-prn": 1.253, "prn-c": 0.353, "int_l-ac_l": 0.476,
    "int_r-ac_r": 0.325, "c-sn": 0.469,
}
"""The paper's Table 1, "Mean of All Volunteers" column (mm), for reference."""

PAPER_TABLE1_OVERALL = {"mean_error_mm": 0.631, "percent_error": 2.894}
PAPER_TABLE2_MEAN_MM = 1.034


def _key(a: str, b: str) -> str:
    return f"{a}-{b}"


def _dist(points: dict[str, np.ndarray], a: str, b: str) -> float:
    if a not in points or b not in points:
        return math.nan
    return float(np.linalg.norm(np.asarray(points[a]) - np.asarray(points[b])))


def distance_errors(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray],
                    pairs: Sequence[tuple[str, str]]) -> dict[str, dict[str, float]]:
    """Per pair ``"a-b"``: true and predicted distance and absolute error (mm; NaN when a
    landmark is missing from the prediction)."""
    out = {}
    for a, b in pairs:
        dt, dp = _dist(truth, a, b), _dist(pred, a, b)
        out[_key(a, b)] = {"true_mm": dt, "pred_mm": dp, "error_mm": abs(dp - dt)}
    return out


def table1_case(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> dict[str, Any]:
    """Paper Table 1 for one case: per distance errors, their mean (mm) and %Error."""
    d = distance_errors(pred, truth, TABLE1_DISTANCES)
    err = np.array([v["error_mm"] for v in d.values()])
    rel = np.array([v["error_mm"] / v["true_mm"] for v in d.values()])
    ok = np.isfinite(err)
    return {"distances": d,
            "mean_error_mm": float(err[ok].mean()) if ok.any() else math.nan,
            "percent_error": float(100.0 * rel[ok].mean()) if ok.any() else math.nan,
            "missing": int((~ok).sum())}


def table2_case(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> dict[str, Any]:
    """Paper Table 2 for one case: |error| of n-prn and prn-sn and their mean (mm)."""
    d = distance_errors(pred, truth, TABLE2_DISTANCES)
    err = np.array([v["error_mm"] for v in d.values()])
    ok = np.isfinite(err)
    return {"distances": d, "mean_error_mm": float(err[ok].mean()) if ok.any() else math.nan}


def landmark_rmse_case(pred: dict[str, np.ndarray], truth: dict[str, np.ndarray]
                       ) -> dict[str, Any]:
    """3D landmark errors (mm) after rigid alignment of the prediction onto the truth."""
    ids = [i for i in pred if i in truth]
    if len(ids) < 3:
        return {"rmse_mm": math.nan, "max_mm": math.nan, "n": len(ids), "per_landmark_mm": {}}
    P = np.array([pred[i] for i in ids], dtype=np.float64)
    Q = np.array([truth[i] for i in ids], dtype=np.float64)
    _, R, t = umeyama(P, Q, with_scale=False)
    e = np.linalg.norm(P @ R.T + t - Q, axis=1)
    return {"rmse_mm": float(np.sqrt(np.mean(e**2))), "max_mm": float(e.max()), "n": len(ids),
            "per_landmark_mm": {i: float(x) for i, x in zip(ids, e, strict=True)}}


def mean_ci95(values: Iterable[float]) -> dict[str, float]:
    """Mean and 95 % confidence interval of the mean (t distribution) of finite values."""
    from scipy.stats import t as student_t  # lazy: scipy.stats adds 0.45 s to every start

    x = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=np.float64)
    n = len(x)
    if n == 0:
        return {"mean": math.nan, "ci_low": math.nan, "ci_high": math.nan, "n": 0}
    m = float(x.mean())
    if n == 1:
        return {"mean": m, "ci_low": math.nan, "ci_high": math.nan, "n": 1}
    h = float(student_t.ppf(0.975, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return {"mean": m, "ci_low": m - h, "ci_high": m + h, "n": n}


@dataclass
class CaseRun:
    """One evaluated case: its directory, the truth and the pipeline result."""

    case_dir: Path
    case: Case
    truth: Reconstruction
    result: PipelineResult
    stages: tuple[int, ...]
    maps_dir: Path | None = None
    ablate: bool = True
    _truth_mesh: tuple[np.ndarray, np.ndarray] | None = None

    def truth_mesh(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``truth_face.ply`` (V, F), read once; None when the case has none."""
        path = self.case_dir / "truth_face.ply"
        if self._truth_mesh is None and path.is_file():
            self._truth_mesh = read_mesh(path)
        return self._truth_mesh


@dataclass(frozen=True)
class Section:
    """One block of the report.

    Attributes:
        key: JSON key (``"table1"``).
        title: printed heading.
        stage: the stage whose output it measures (skipped when that stage did not run).
        per_case: CaseRun -> JSON-ready dict.
        summarize: list of per-case dicts -> JSON-ready dict.
        format: (per-case dicts, summary, case ids) -> printed lines.
    """

    key: str
    title: str
    stage: int
    per_case: Callable[[CaseRun], dict[str, Any]]
    summarize: Callable[[list[dict[str, Any]]], dict[str, Any]]
    format: Callable[[list[dict[str, Any]], dict[str, Any], list[str]], list[str]]


def _fmt(x: Any, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}f}"


def _table1_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    per = {}
    for a, b in TABLE1_DISTANCES:
        k = _key(a, b)
        per[k] = mean_ci95(c["distances"][k]["error_mm"] for c in cases)
    all_err = [c["distances"][k]["error_mm"] for c in cases for k in per]
    return {"distances": per, "mean_error_mm": mean_ci95(all_err)["mean"],
            "percent_error": mean_ci95(c["percent_error"] for c in cases),
            "case_mean_error_mm": mean_ci95(c["mean_error_mm"] for c in cases)}


def _table1_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                   ids: list[str]) -> list[str]:
    show = ids if len(ids) <= 4 else []  # per-case columns like the paper's A-D
    w = max([len(i) for i in show] + [8]) + 2
    head = f"{'distance':<12}" + "".join(f"{i:>{w}}" for i in show)
    head += f"{'mean':>9}{'95% CI':>18}{'paper':>8}"
    lines = [head]
    for k, s in summ["distances"].items():
        row = f"{k:<12}" + "".join(f"{_fmt(c['distances'][k]['error_mm']):>{w}}"
                                   for c in cases[:len(show)])
        ci = f"[{_fmt(s['ci_low'])}, {_fmt(s['ci_high'])}]"
        lines.append(row + f"{_fmt(s['mean']):>9}{ci:>18}{PAPER_TABLE1_MEAN_MM[k]:>8.3f}")
    pe = summ["percent_error"]
    row = f"{'%Error':<12}" + "".join(f"{_fmt(c['percent_error'], 2) + '%':>{w}}"
                                      for c in cases[:len(show)])
    ci = f"[{_fmt(pe['ci_low'], 2)}, {_fmt(pe['ci_high'], 2)}]%"
    lines.append(row + f"{_fmt(pe['mean'], 2) + '%':>9}{ci:>18}"
                       f"{PAPER_TABLE1_OVERALL['percent_error']:>7.3f}%")
    lines.append(f"mean error over all distances: {_fmt(summ['mean_error_mm'])} mm "
                 f"(paper {PAPER_TABLE1_OVERALL['mean_error_mm']:.3f} mm)")
    return lines


def _table2_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    vals = [c["mean_error_mm"] for c in cases]
    finite = [v for v in vals if math.isfinite(v)]
    out = {"mean_error_mm": mean_ci95(vals),
           "min_mm": min(finite) if finite else math.nan,
           "max_mm": max(finite) if finite else math.nan}
    for a, b in TABLE2_DISTANCES:
        out[_key(a, b)] = mean_ci95(c["distances"][_key(a, b)]["error_mm"] for c in cases)
    return out


def _table2_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                   ids: list[str]) -> list[str]:
    m = summ["mean_error_mm"]
    parts = ", ".join(f"{_key(a, b)} {_fmt(summ[_key(a, b)]['mean'])}"
                      for a, b in TABLE2_DISTANCES)
    return [f"mean absolute error {_fmt(m['mean'])} mm (95% CI [{_fmt(m['ci_low'])}, "
            f"{_fmt(m['ci_high'])}]; min {_fmt(summ['min_mm'])}, max {_fmt(summ['max_mm'])}; "
            f"paper {PAPER_TABLE2_MEAN_MM:.3f} mm)", parts]


def _rmse_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    return {"rmse_mm": mean_ci95(c["rmse_mm"] for c in cases),
            "max_mm": max((c["max_mm"] for c in cases if math.isfinite(c["max_mm"])),
                          default=math.nan)}


def _rmse_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                 ids: list[str]) -> list[str]:
    r = summ["rmse_mm"]
    return [f"landmark RMSE after rigid alignment: mean {_fmt(r['mean'])} mm "
            f"(95% CI [{_fmt(r['ci_low'])}, {_fmt(r['ci_high'])}]), worst landmark "
            f"{_fmt(summ['max_mm'])} mm"]


def _landmarks(run: CaseRun) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    return run.result.reconstruction.landmarks, run.truth.landmarks





def boundary_case(run: CaseRun) -> dict[str, Any]:
    """Paper Tables 4-5 for one case: boundary MAE and Hausdorff (mm) per curve family.

    The reconstructed curves are projected with the reconstructed cameras into the photos
    of ``truth_boundaries.json``; px -> mm with the true front-view scale at al_l-al_r
    (:func:`naseview.stage2_curves.metrics.boundary_errors`). Empty without the truth file.
    """
    path = run.case_dir / "truth_boundaries.json"
    if not path.is_file() or "front" not in run.truth.cameras:
        return {}
    rec = run.result.reconstruction
    ppm = px_per_mm_from_truth(run.truth.landmarks, run.truth.cameras["front"])
    return boundary_errors(rec.curves, rec.cameras, read_truth_boundaries(path), ppm)


def read_truth_boundaries(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """``truth_boundaries.json`` (SPEC §7): curve name -> view -> (M, 2) points (px).

    Raises:
        NaseviewError: not a JSON object of objects of ``[[x, y], ...]`` lists of finite
            numbers, naming the file and the key.
    """
    obj = read_json(path)
    out: dict[str, dict[str, np.ndarray]] = {}
    for name, per_view in obj.items():
        if not isinstance(per_view, dict):
            raise NaseviewError(f"{path}: key {name!r}: expected an object of view -> "
                                "[[x, y], ...] points (SPEC §7)")
        out[name] = {}
        for view, pts in per_view.items():
            try:
                P = np.asarray(pts, dtype=np.float64) if isinstance(pts, list) else None
            except (TypeError, ValueError):              # not numbers, or ragged
                P = None
            if P is None or (P.size and (P.ndim != 2 or P.shape[1] != 2
                                         or not np.isfinite(P).all())):
                raise NaseviewError(f"{path}: key {name}.{view}: expected a list of [x, y] "
                                    "pixel points of finite numbers (SPEC §7)")
            out[name][view] = P.reshape(-1, 2)
    return out


def _read_truth(path: Path) -> Reconstruction:
    """``truth.json`` with every landmark (SPEC §7: the true landmarks, all 21)."""
    truth = read_reconstruction(path)
    missing = [k for k in LANDMARK_IDS if k not in (truth.landmarks or {})]
    if missing:
        raise NaseviewError(f"{path}: key 'landmarks' lacks {', '.join(missing)}; a case's "
                            "truth gives all 21 landmarks (as naseview synth writes them)")
    return truth


def _boundary_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    cases = [c for c in cases if c]
    fams = {f: {m: mean_ci95(c["families"][f][m] for c in cases if f in c["families"])
                for m in ("mae_mm", "hausdorff_mm")} for f in CURVE_FAMILIES}
    return {"families": fams, "mean_mae_mm": mean_ci95(c["mean_mae_mm"] for c in cases),
            "mean_hausdorff_mm": mean_ci95(c["mean_hausdorff_mm"] for c in cases)}


def _boundary_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                     ids: list[str]) -> list[str]:
    lines = [f"{'boundary':<14}{'MAE':>8}{'95% CI':>15}{'paper':>8}{'Hausdorff':>11}"
             f"{'paper':>8}"]
    for f, s in summ["families"].items():
        m, h = s["mae_mm"], s["hausdorff_mm"]
        ci = f"{_fmt(m['ci_low'])}-{_fmt(m['ci_high'])}"
        lines.append(f"{FAMILY_LABELS[f]:<14}{_fmt(m['mean']):>8}{ci:>15}"
                     f"{PAPER_TABLE4_MAE[f]:>8.3f}{_fmt(h['mean']):>11}"
                     f"{PAPER_TABLE5_HAUSDORFF[f]:>8.3f}")
    lines.append(f"{'Mean':<14}{_fmt(summ['mean_mae_mm']['mean']):>8}{'':>15}"
                 f"{np.mean(list(PAPER_TABLE4_MAE.values())):>8.3f}"
                 f"{_fmt(summ['mean_hausdorff_mm']['mean']):>11}"
                 f"{np.mean(list(PAPER_TABLE5_HAUSDORFF.values())):>8.3f}")
    return lines




def surface_case(run: CaseRun) -> dict[str, Any]:
    """SPEC §6 surface figures of one case and the stage-3 ablation on the same inputs.

    Nose samples of ``truth_face.ply`` (the SPEC §6 nose region of the truth landmarks:
    :func:`naseview.testbed.surface.nose_region`) to the refined
    mesh after rigid landmark alignment (:func:`naseview.testbed.surface.surface_error`),
    for the pipeline's mesh and for each :data:`naseview.testbed.surface.ABLATION_ROWS`
    variant (default stage-3 parameters). Empty without stage 3 or the truth mesh.
    """
    refined = run.result.refined
    rec = run.result.reconstruction
    mesh = run.truth_mesh()
    if refined is None or mesh is None:
        return {}
    tV, tF = mesh
    samples = nose_surface_samples(tV, tF, run.truth.landmarks,
                                   source=str(run.case_dir / "truth.json"),
                                   mesh_source=str(run.case_dir / "truth_face.ply"))
    out: dict[str, Any] = {"pipeline": surface_error(tV, tF, run.truth.landmarks, refined.V,
                                                     refined.F, rec.landmarks, samples=samples)}
    out["regions"] = region_errors(tV, tF, run.truth.landmarks, refined.V, refined.F,
                                   rec.landmarks)
    if run.maps_dir is not None:
        png = Path(run.maps_dir) / f"{run.case_dir.name}-surface-error.png"
        out["map_png"] = str(error_map_png(png, tV, tF, run.truth.landmarks, refined.V,
                                           refined.F, rec.landmarks, title=run.case.id))
    if refined.model is not None and run.ablate:
        out["ablation"] = ablation(refined.model, rec, tV, tF, run.truth.landmarks,
                                   samples=samples)
    return out


def _surface_rows(case: dict[str, Any]) -> dict[str, Any]:
    """Row name -> surface figures of one case: ``pipeline``, then the ablation rows."""
    return {"pipeline": case["pipeline"], **case.get("ablation", {})}


def _surface_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    per_case = [_surface_rows(c) for c in cases if c]
    rows = list(per_case[0]) if per_case else []
    out: dict[str, Any] = {row: {k: mean_ci95(r[row][k] for r in per_case if row in r)
                                 for k in ("mean_mm", "p95_mm")} for row in rows}
    regions = regions_summary([c["regions"] for c in cases if c and "regions" in c])
    if regions:
        out["regions"] = regions
    return out


def _surface_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                    ids: list[str]) -> list[str]:
    lines = []
    if len(ids) <= 8:
        lines.append(f"{'case':<20}{'mean mm':>9}{'p95 mm':>9}")
        for cid, c in zip(ids, cases, strict=True):
            if c:
                p = c["pipeline"]
                lines.append(f"{cid:<20}{_fmt(p['mean_mm']):>9}{_fmt(p['p95_mm']):>9}")
        lines.append("")
    lines.append(f"{'variant':<16}{'mean mm':>9}{'95% CI':>15}{'p95 mm':>9}")
    for row, s in summ.items():
        if row == "regions":
            continue
        m, p = s["mean_mm"], s["p95_mm"]
        ci = f"{_fmt(m['ci_low'])}-{_fmt(m['ci_high'])}"
        lines.append(f"{row:<16}{_fmt(m['mean']):>9}{ci:>15}{_fmt(p['mean']):>9}")
    if len([r for r in summ if r != "regions"]) > 1:
        lines.append("paper's steps: fit = morphable-model fit (21 landmarks); arap21 / arap76 "
                     "= + ARAP with the 21 landmarks / all ad-landmarks; arap76+smooth = + "
                     "cotangent smoothing. fit+warp = fit bent smoothly to the ad-landmarks; "
                     "naseview = the pipeline, -all76 with every sub-landmark (ABLATION_ROWS)")
    lines.append("nose region (SPEC §6): truth triangles between sn.y - 3 and n.y + 3, within "
                 "|al_l.x - al_r.x| / 2 + 3 of the alae's middle, in front of min(ac.z) - 3, "
                 "facing forward, ambient occlusion <= 0.6")
    if "regions" in summ:
        lines += ["", f"{'region (pipeline)':<20}{'mean mm':>9}{'p95 mm':>9}{'area %':>8}"]
        for name, r in summ["regions"].items():
            lines.append(f"{name:<20}{_fmt(r['mean_mm']):>9}{_fmt(r['p95_mm']):>9}"
                         f"{100 * r['fraction']:>8.1f}")
        lines.append("regions from the truth landmarks (naseview.testbed.regions); the "
                     "headline figure leaves out the nostril interior")
    return lines


def measurements_case(run: CaseRun) -> dict[str, Any]:
    """SPEC §6 clinical measurement errors of one case
    (:func:`naseview.testbed.clinical.measurement_errors`): the pipeline's landmarks,
    curves and mesh against ``truth_face.ply`` with the truth landmarks and curves.
    Empty without stage 3 or the truth mesh."""
    refined = run.result.refined
    mesh = run.truth_mesh()
    if refined is None or mesh is None:
        return {}
    rec = run.result.reconstruction
    return measurement_errors(mesh[0], mesh[1], run.truth.landmarks, refined.V, refined.F,
                              rec.landmarks, rec.curves, run.truth.curves)


def _measurements_summary(cases: list[dict[str, Any]]) -> dict[str, Any]:
    have = [c for c in cases if c]
    return {"errors": summarize_errors(have),
            "in_stage1_frame": summarize_errors(have, "in_stage1_frame")}


def _measurements_format(cases: list[dict[str, Any]], summ: dict[str, Any],
                         ids: list[str]) -> list[str]:
    have = [(i, c) for i, c in zip(ids, cases, strict=True) if c]
    return format_errors([c for _, c in have], summ["errors"], [i for i, _ in have])


SECTIONS: list[Section] = [
    Section("table1", "Table 1: landmark distance error (mm)", 1,
            lambda r: table1_case(*_landmarks(r)), _table1_summary, _table1_format),
    Section("table2", "Table 2: n-prn and prn-sn absolute error (mm)", 1,
            lambda r: table2_case(*_landmarks(r)), _table2_summary, _table2_format),
    Section("landmarks", "3D landmarks", 1,
            lambda r: landmark_rmse_case(*_landmarks(r)), _rmse_summary, _rmse_format),
    Section("tables45", "Tables 4-5: boundary-curve MAE and Hausdorff (mm)", 2,
            boundary_case, _boundary_summary, _boundary_format),
    Section("surface", "Nose surface error after rigid alignment (mm)", 3,
            surface_case, _surface_summary, _surface_format),
    Section("measurements", "Clinical measurement error, reconstruction - truth", 3,
            measurements_case, _measurements_summary, _measurements_format),
]
"""The report's sections, in print order; ``stage`` says which run each needs."""


def _case_info(run: CaseRun) -> dict[str, Any]:
    res = run.result
    sfm = res.sfm
    return {
        "case": run.case.id,
        "dir": str(run.case_dir),
        "stage_seconds": dict(res.stage_seconds),
        "reprojection_rmse_px": float(sfm.reprojection_rmse_px) if sfm else math.nan,
        "suspect_clicks": [s.to_json() for s in sfm.suspect_clicks] if sfm else [],
        "warnings": list(res.warnings),
    }


class _CaseFailed(Exception):
    """One case could not be evaluated: a file of it is bad or the pipeline failed on it
    (the evaluation goes on with the others)."""

    def __init__(self, case_id: str, d: Path, error: NaseviewError) -> None:
        super().__init__(str(error))
        self.record = {"case": case_id, "dir": str(d), "error": str(error)}


def _evaluate_case(d: Path, model: FaceModel | str | None, stages: tuple[int, ...],
                   params: PipelineParams | None, maps_dir: Path | None = None,
                   ablate: bool = True) -> tuple[dict[str, Any], PipelineResult]:
    """The pipeline on one case directory and every section of ``stages`` on its result.

    Raises:
        _CaseFailed: no or a bad ``truth.json``, ``case.json``, truth mesh or truth
            boundaries, or the pipeline failed (the one-line error names the file).
    """
    case_id = d.name
    try:
        if not (d / "truth.json").is_file():
            raise NaseviewError(f"{d / 'truth.json'}: file not found; evaluate needs "
                                "synthetic cases with ground truth (naseview synth)")
        truth = _read_truth(d / "truth.json")
        case = read_case(d)
        case_id = case.id
        result = reconstruct(case, model=model, stages=stages, params=params)
        run = CaseRun(d, case, truth, result, stages, maps_dir, ablate)
        info = _case_info(run)
        info["notes"] = [f"no {name}: no {what}" for name, stage, what in (
            ("truth_boundaries.json", 2, "boundary figures (Tables 4-5)"),
            ("truth_face.ply", 3, "surface error, map or measurement errors"))
            if stage in stages
            and not (d / name).is_file()]
        for sec in SECTIONS:
            if sec.stage in stages:
                info[sec.key] = sec.per_case(run)
    except NaseviewError as e:
        raise _CaseFailed(case_id, d, e) from e
    return info, result


def _summary(cases: list[dict[str, Any]], n_failed: int,
             stages: tuple[int, ...]) -> dict[str, Any]:
    """Every section's summary over the cases, the counts and the median stage times."""
    summary = {sec.key: sec.summarize([c[sec.key] for c in cases])
               for sec in SECTIONS if sec.stage in stages and cases}
    summary["converged"] = {"ok": len(cases), "failed": n_failed}
    for name in ("landmarks", "curves", "mesh"):
        t = [c["stage_seconds"][name] for c in cases if name in c["stage_seconds"]]
        if t:
            summary.setdefault("stage_seconds_median", {})[name] = float(np.median(t))
    return summary


def evaluate_cases(case_dirs: Sequence[str | os.PathLike[str]],
                   model: FaceModel | str | None = None,
                   stages: Iterable[int] | str = (1, 2, 3),
                   params: PipelineParams | None = None,
                   progress: Callable[[str], object] | None = None,
                   maps_dir: str | os.PathLike[str] | None = None,
                   ablate: bool = True) -> dict[str, Any]:
    """Run the pipeline on synthetic cases and measure every section against the truth.

    Args:
        case_dirs: case directories, each with ``truth.json`` (SPEC §7).
        model, stages, params: passed to :func:`naseview.pipeline.reconstruct` (a model
            name is loaded once, when stage 3 runs).
        progress: called with one line per finished case.
        maps_dir: write each case's error colour map
            (:func:`naseview.testbed.regions.error_map_png`) into this folder as
            ``<case folder>-surface-error.png``.
        ablate: also run the stage-3 ablation rows (``surface.ablation``).
    Returns:
        ``{"cases": [per-case dict], "failed": [{"case", "dir", "error"}], "summary":
        {section key: summary}, "stages": [...]}`` (JSON-ready, NaN for missing values).
        A case that cannot be evaluated (a missing or bad file of it, or a pipeline
        error) is in ``failed`` with its one-line error; the others are still evaluated.
    """
    stages = parse_stages(stages)
    if isinstance(model, str) and 3 in stages:
        model = load_face_model(model)
    cases: list[dict[str, Any]] = []
    failed: list[dict[str, str]] = []
    for d in map(Path, case_dirs):
        try:
            info, result = _evaluate_case(d, model, stages, params,
                                          None if maps_dir is None else Path(maps_dir), ablate)
        except _CaseFailed as e:
            failed.append(e.record)
            if progress:
                progress(f"{d.name}: FAILED {e}")
            continue
        cases.append(info)
        if progress:
            t1 = info.get("table1", {}).get("mean_error_mm", math.nan)
            progress(f"{d.name}: Table 1 mean error {_fmt(t1)} mm, stage times "
                     + ", ".join(f"{k} {v:.2f} s" for k, v in result.stage_seconds.items())
                     + "".join(f"; {n}" for n in info["notes"]))
    return {"stages": list(stages), "cases": cases, "failed": failed,
            "summary": _summary(cases, len(failed), stages)}


def format_report(report: dict[str, Any]) -> str:
    """The printed tables of an :func:`evaluate_cases` report."""
    cases, summary = report["cases"], report["summary"]
    ids = [c["case"] for c in cases]
    conv = summary["converged"]
    lines = [f"naseview evaluate: {conv['ok']} case(s) reconstructed, {conv['failed']} failed"]
    for f in report["failed"]:
        lines.append(f"  FAILED {f['case']}: {f['error']}")
    for c in cases:
        lines += [f"  note {c['case']}: {n}" for n in c.get("notes", [])]
    for sec in SECTIONS:
        if sec.key not in summary:
            continue
        lines += ["", sec.title]
        lines += sec.format([c[sec.key] for c in cases], summary[sec.key], ids)
    if "stage_seconds_median" in summary:
        lines += ["", "median stage time: " + ", ".join(
            f"{k} {v * 1000:.0f} ms" for k, v in summary["stage_seconds_median"].items())]
    return "\n".join(lines)


def _json_ready(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_ready(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.ndarray):
        return _json_ready(obj.tolist())
    return obj


def evaluate_command(args: argparse.Namespace) -> int:
    """``naseview evaluate CASE_DIRS... [--json] [--stages 1,2,3] [--model M]``: exit 0
    when every case was evaluated, 1 when some failed (listed), 2 when none could be."""
    quiet = bool(getattr(args, "json", False))
    maps = getattr(args, "maps", None)
    if maps is not None:
        try:
            Path(maps).mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise NaseviewError(f"{maps}: cannot create the --maps folder ({e})") from None
    report = evaluate_cases(args.case_dirs, model=getattr(args, "model", None),
                            stages=getattr(args, "stages", "1,2,3"),
                            progress=None if quiet else (lambda s: print(s, flush=True)),
                            maps_dir=maps, ablate=not getattr(args, "no_ablation", False))
    if quiet:
        print(json.dumps(_json_ready(report), indent=1))
    else:
        print()
        print(format_report(report))
    if not report["cases"]:
        return 2                                    # nothing could be evaluated
    return 1 if report["failed"] else 0             # some cases failed: a script sees it
