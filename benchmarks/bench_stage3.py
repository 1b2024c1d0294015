"""Stage 3 benchmark: nose surface error of fit / ARAP / smoothing, and re-solve speed.

Truth: random ICT identities (coefficients ~ N(0, 1)) in the SPEC frame (origin g).
Input: the true landmarks plus Gaussian noise (``--noise-mm``, like stage 1's output) and
55 sub-landmarks sampled on the true boundary curves (the mesh curves of the truth,
``naseview.stage2_curves.sublandmarks``) plus noise (``--curve-noise-mm``), as stage 2 gives
them; with ``--synth DIR`` the cases of a ``naseview synth --batch`` folder go through the
real stages 1-2 instead.

Rows (ablation, issue 5; naseview.testbed.surface.ABLATION_ROWS): the paper's steps ``fit`` (the
morphable-model fit on the 21 landmarks), ``fit76`` (the fit on all ad-landmarks),
``arap21`` / ``arap76`` (+ ARAP with the 21 landmarks / all ad-landmarks),
``arap76+smooth`` (+ cotangent smoothing of the positions); naseview's ``fit+warp`` (the
fit bent smoothly towards the ad-landmarks, no ARAP) and ``naseview`` (the default
pipeline: warp, ARAP on the consistent handles, smoothing of the displacement). Each with
the ICT base and with the generic base.

Surface error: distance from 20,000 area-uniform samples of the true nose region to the
reconstructed mesh after rigid landmark alignment (naseview.testbed.surface.surface_error).

    python benchmarks/bench_stage3.py [--cases 30] [--synth DIR]

Targets (issue 5): ICT base mean <= 0.8 mm and p95 <= 2.0 mm; generic base mean <= 1.2 mm;
re-solve after moving one landmark <= 50 ms median.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from _shared import use_shared_ict

from naseview.case import read_case
from naseview.facemodel import FaceModel, load_face_model
from naseview.landmarks import CURVE_LANDMARKS
from naseview.meshio import read_mesh
from naseview.pipeline import reconstruct
from naseview.reconstruction import Reconstruction, read_reconstruction
from naseview.stage2_curves.params import DEFAULT_SUB_LANDMARKS
from naseview.stage2_curves.sublandmarks import ad_landmarks
from naseview.stage3_mesh import RefineParams, RefineResult, refine
from naseview.testbed.surface import ABLATION_ROWS, nose_surface_samples, surface_error

ROWS: dict[str, dict[str, object]] = {
    "fit": ABLATION_ROWS["fit"],
    "fit76": {**ABLATION_ROWS["fit"], "use_sublandmarks": True},
    **{k: v for k, v in ABLATION_ROWS.items() if k != "fit"},
}
DEFAULT_ROW = "naseview"


def true_ad_landmarks(model: FaceModel, Vt: np.ndarray, landmarks: dict[str, np.ndarray]
                      ) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Ad-landmarks sampled on the truth's mesh curves, tagged as stage 2 tags them."""
    curves, anchors = {}, {}
    for name, path in model.curve_vertices.items():
        path = np.asarray(path)
        curves[name] = Vt[path]
        anchors[name] = [(lm, int(np.flatnonzero(path == model.landmark_vertices[lm])[0]))
                         for lm in CURVE_LANDMARKS[name]
                         if lm in model.landmark_vertices
                         and (path == model.landmark_vertices[lm]).any()]
    return ad_landmarks(landmarks, curves, anchors, DEFAULT_SUB_LANDMARKS)


def synthetic_cases(truth_model: FaceModel, n: int, noise_mm: float, curve_noise_mm: float,
                    seed0: int = 1000
                    ) -> Iterator[tuple[np.ndarray, dict[str, np.ndarray], Reconstruction]]:
    """Yield (truth V, truth landmarks, Reconstruction) for random identities.

    Landmarks get independent Gaussian noise. A boundary curve from stage 2 passes through
    the (noisy) landmarks and strays smoothly between them, so a sub-landmark at fraction s
    of the segment a-b gets ``(1-s) e_a + s e_b + sin(pi s) d`` with e the landmarks' errors
    and d ~ N(0, curve_noise_mm^2 I) one draw per segment.
    """
    g = truth_model.landmark_vertices["g"]
    for i in range(n):
        rng = np.random.default_rng(seed0 + i)
        Vt = truth_model.shape(rng.normal(size=truth_model.n_modes))
        Vt = Vt - Vt[g]
        true_lm = truth_model.landmark_positions(Vt)
        err = {k: rng.normal(0, noise_mm, 3) for k in true_lm}
        err["g"] = np.zeros(3)                     # stage 1 puts g at the origin exactly
        lm = {k: p + err[k] for k, p in true_lm.items()}
        ad, tags = true_ad_landmarks(truth_model, Vt, lm)
        ad = ad.copy()
        seg_err: dict[tuple, np.ndarray] = {}
        for j, tag in enumerate(tags):
            if tag["id"] in lm:
                continue
            a, b = (tag.get("between") or ["", ""])
            key = (tag["curve"], a, b)
            if key not in seg_err:
                seg_err[key] = rng.normal(0, curve_noise_mm, 3)
            s = float(tag.get("s", tag["t"]))
            ea, eb = err.get(a, np.zeros(3)), err.get(b, np.zeros(3))
            ad[j] += (1 - s) * ea + s * eb + np.sin(np.pi * s) * seg_err[key]
        yield Vt, true_lm, Reconstruction(landmarks=lm, ad_landmarks=ad, ad_landmark_tags=tags)


def synth_dir_cases(root: Path, model: FaceModel
                    ) -> Iterator[tuple[np.ndarray, np.ndarray, dict[str, np.ndarray],
                                        Reconstruction]]:
    """Yield (truth V, truth F, truth landmarks, Reconstruction) from a synth batch folder
    through the real stages 1-2 (naseview.pipeline)."""
    for d in sorted(p for p in root.iterdir() if (p / "case.json").is_file()):
        truth = read_reconstruction(d / "truth.json")
        tV, tF = read_mesh(d / "truth_face.ply")
        res = reconstruct(read_case(d), model=model, stages=(1, 2))
        yield tV, tF, truth.landmarks, res.reconstruction


def resolve_times(res: RefineResult, rng: np.random.Generator, n: int = 10) -> list[float]:
    """Seconds per re-solve after moving one random landmark handle by 1-3 mm."""
    dfm = res.deformer
    assert dfm is not None, "the default row runs ARAP"
    H = res.handles.targets.copy()
    lm_idx = np.flatnonzero(res.handles.is_landmark)
    out = []
    for _ in range(n):
        j = int(rng.choice(lm_idx))
        H[j] = H[j] + rng.normal(size=3) * (rng.uniform(1, 3) / np.sqrt(3))
        t = time.perf_counter()
        dfm.solve(H)
        out.append(time.perf_counter() - t)
    return out


Case = tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], Reconstruction]
"""(truth V, truth F, truth landmarks, stage 1-2 reconstruction)."""


@dataclass
class _Tally:
    """Per (base, row) the surface figures of every case; per base the default row's
    refine times, re-solve times and warning count."""

    table: dict[tuple[str, str], list[dict[str, float]]] = field(default_factory=dict)
    times: dict[str, list[float]] = field(default_factory=dict)
    resolve: dict[str, list[float]] = field(default_factory=dict)
    warnings: dict[str, int] = field(default_factory=dict)


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--cases", type=int, default=30)
    ap.add_argument("--noise-mm", type=float, default=0.3,
                    help="landmark noise SD per axis (stage 1 output)")
    ap.add_argument("--curve-noise-mm", type=float, default=0.5,
                    help="SD per axis of a boundary curve's smooth stray between its "
                         "landmarks (stage 2 output)")
    ap.add_argument("--synth", type=Path, default=None,
                    help="folder of synth cases (naseview synth --batch) run through stages 1-2")
    ap.add_argument("--bases", default="ict,generic")
    return ap.parse_args(argv)


def _cases(args: argparse.Namespace, ict: FaceModel) -> tuple[list[Case], str]:
    """The cases (synth folder or random ICT identities) and a line saying which."""
    if args.synth is not None:
        cases = [(tV, tF, tl, rec) for tV, tF, tl, rec in synth_dir_cases(args.synth, ict)]
        return cases, f"{len(cases)} synth cases of {args.synth} through stages 1-2"
    cases = [(Vt, ict.faces, tl, rec) for Vt, tl, rec in
             synthetic_cases(ict, args.cases, args.noise_mm, args.curve_noise_mm)]
    return cases, (f"{len(cases)} random ICT identities, landmark noise {args.noise_mm} mm, "
                   f"sub-landmark noise {args.curve_noise_mm} mm")


def _run_case(tally: _Tally, bname: str, model: FaceModel, case: Case, samples: np.ndarray,
              rng: np.random.Generator) -> None:
    """Every row of one case on one base; the default row is also timed and re-solved."""
    tV, tF, tl, rec = case
    for row, kw in ROWS.items():
        p = dataclasses.replace(RefineParams(), **kw)
        t = time.perf_counter()
        res = refine(model, rec, p)
        dt = time.perf_counter() - t
        e = surface_error(tV, tF, tl, res.V, res.F, rec.landmarks, samples=samples)
        e["folded"] = 0 if res.report is None else len(res.report.folded_faces)
        tally.table.setdefault((bname, row), []).append(e)
        if row == DEFAULT_ROW:
            tally.times.setdefault(bname, []).append(dt)
            tally.resolve.setdefault(bname, []).extend(resolve_times(res, rng))
            tally.warnings[bname] = tally.warnings.get(bname, 0) + len(res.warnings)


def _print_tables(tally: _Tally, bases: Iterable[str]) -> None:
    """The surface table (mean, p95, worst case mean, folds) and the timing table."""
    print(f"\n{'base':8s} {'row':14s} {'mean mm':>8s} {'p95 mm':>8s} {'worst mean':>10s}"
          f" {'folds':>6s}")
    for (bname, row), errs in tally.table.items():
        m = np.array([e["mean_mm"] for e in errs])
        p95 = np.array([e["p95_mm"] for e in errs])
        nf = sum(int(e["folded"]) for e in errs)
        print(f"{bname:8s} {row:14s} {m.mean():8.3f} {p95.mean():8.3f} {m.max():10.3f} "
              f"{nf:6d}")
    print(f"\n{'base':8s} {'refine s (median)':>18s} {'re-solve ms median':>19s} {'p95':>6s}"
          f" {'warnings':>9s}")
    for bname in bases:
        r = np.array(tally.resolve[bname]) * 1000
        print(f"{bname:8s} {np.median(tally.times[bname]):18.3f} {np.median(r):19.1f} "
              f"{np.percentile(r, 95):6.1f} {tally.warnings[bname]:9d}")


def main(argv: list[str] | None = None) -> int:
    use_shared_ict()
    args = _arguments(argv)
    ict = load_face_model("ict")
    bases = {b: (ict if b == "ict" else load_face_model(b)) for b in args.bases.split(",")}
    cases, src = _cases(args, ict)
    print(f"stage 3 benchmark: {src}")
    samples = [nose_surface_samples(tV, tF, tl) for tV, tF, tl, _ in cases]
    rng = np.random.default_rng(0)
    tally = _Tally()
    for bname, model in bases.items():
        for ci, case in enumerate(cases):
            _run_case(tally, bname, model, case, samples[ci], rng)
            print(f"  {bname} case {ci + 1}/{len(cases)}", end="\r", file=sys.stderr)
    print(" " * 40, end="\r", file=sys.stderr)
    _print_tables(tally, bases)
    print(f"\ntargets: ict {DEFAULT_ROW} mean <= 0.8, p95 <= 2.0; generic mean <= 1.2; "
          "re-solve median <= 50 ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
