"""Stage 1 benchmark: bundle-adjustment accuracy and speed on synthetic ICT cases.

For each click-noise level, N synthetic cases (``naseview.testbed.synth``, ICT Face Model,
1024 px, the same identities and rigs at every level) go through
:func:`naseview.stage1_landmarks.bundle_adjust` and are measured against their truth like
``naseview evaluate``: the paper's Table 1 (mean |error| of the 11 landmark distances,
%Error), Table 2 (n-prn, prn-sn), the landmark RMSE after rigid alignment, how many cases
converge, and the median stage-1 time (wall clock and CPU; the machine's load average is
printed, since other work on the 2 cores inflates wall time). The targets of issue 3 apply
at 1.5 px.

Cases are rendered once into ``--data`` (default ``$TMPDIR/naseview-bench-stage1``) and
reused. Face model: ICT Face Model (USC Institute for Creative Technologies, MIT).

    python benchmarks/bench_stage1.py [--cases 30] [--noise 0.5,1.5,3] [--data DIR]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from _shared import use_shared_ict

from naseview.case import read_case
from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.reconstruction import read_reconstruction
from naseview.stage1_landmarks import bundle_adjust
from naseview.testbed.evaluate import landmark_rmse_case, table1_case, table2_case
from naseview.testbed.synth import synthesize_case

TARGETS = {"t1": 0.35, "pe": 1.5, "t2": 0.5, "ms": 50.0}
TARGET_NOISE = 1.5


def ensure_cases(root: Path, n: int, noise: float, size: int, model_name: str) -> list[Path]:
    """Case directories ``root/case-000..``; missing ones are rendered by naseview.testbed.synth."""
    dirs = [root / f"case-{i:03d}" for i in range(n)]
    missing = [d for d in dirs if not (d / "case.json").is_file()]
    if missing:
        model = load_face_model(model_name)
        print(f"rendering {len(missing)} synthetic case(s) into {root} ...", flush=True)
        for d in missing:
            synthesize_case(d, model, seed=int(d.name.split("-")[1]), noise_px=noise,
                            size=size)
    return dirs


def run_level(dirs: list[Path], repeats: int) -> dict[str, float]:
    """Stage 1 on each case: accuracy figures, convergence and median times (single run,
    and best of ``repeats`` runs per case, which discounts preemption by other work)."""
    t1, pe, t2, rmse, wall, cpu, best = [], [], [], [], [], [], []
    ok = 0
    bundle_adjust(read_case(dirs[0]))  # warm-up (imports, BLAS thread control)
    for d in dirs:
        case = read_case(d)
        truth = read_reconstruction(d / "truth.json").landmarks
        w0, c0 = time.perf_counter(), time.process_time()
        try:
            res = bundle_adjust(case)
        except NaseviewError as e:
            print(f"  {d.name}: FAILED {e}")
            continue
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
        runs = [wall[-1]]
        for _ in range(repeats - 1):
            w0 = time.perf_counter()
            bundle_adjust(case)
            runs.append(time.perf_counter() - w0)
        best.append(min(runs))
        ok += int(res.converged)
        a = table1_case(res.landmarks, truth)
        t1.append(a["mean_error_mm"])
        pe.append(a["percent_error"])
        t2.append(table2_case(res.landmarks, truth)["mean_error_mm"])
        rmse.append(landmark_rmse_case(res.landmarks, truth)["rmse_mm"])
    return {"t1": float(np.nanmean(t1)), "pe": float(np.nanmean(pe)),
            "t2": float(np.nanmean(t2)), "rmse": float(np.nanmean(rmse)), "ok": ok,
            "n": len(dirs), "ms": 1000 * float(np.median(wall)),
            "cpu_ms": 1000 * float(np.median(cpu)), "best_ms": 1000 * float(np.median(best))}


def main(argv: list[str] | None = None) -> int:
    use_shared_ict()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=30)
    ap.add_argument("--noise", default="0.5,1.5,3", help="click noise levels, px")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--model", default="ict")
    ap.add_argument("--repeats", type=int, default=3,
                    help="runs per case for the best-of timing (default 3)")
    ap.add_argument("--data", type=Path,
                    default=Path(tempfile.gettempdir()) / "naseview-bench-stage1")
    args = ap.parse_args(argv)
    levels = [float(x) for x in args.noise.split(",")]
    rows = []
    for noise in levels:
        dirs = ensure_cases(args.data / f"noise-{noise:g}", args.cases, noise, args.size,
                            args.model)
        rows.append((noise, run_level(dirs, max(1, args.repeats))))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"\nStage 1 (bundle adjustment), {args.cases} synthetic ICT cases, {args.size} px; "
          f"load average {load:.1f} on {os.cpu_count()} cores")
    print(f"{'noise px':>8} {'T1 mm':>7} {'%Error':>7} {'T2 mm':>7} {'RMSE mm':>8} "
          f"{'converged':>10} {'wall ms':>8} {'best ms':>8} {'cpu ms':>7}")
    for noise, r in rows:
        print(f"{noise:>8g} {r['t1']:>7.3f} {r['pe']:>6.2f}% {r['t2']:>7.3f} {r['rmse']:>8.3f} "
              f"{r['ok']:>5}/{r['n']:<4} {r['ms']:>8.1f} {r['best_ms']:>8.1f} "
              f"{r['cpu_ms']:>7.1f}")
    print(f"(median over cases; wall: one run, best: best of {args.repeats} runs, cpu: process "
          "time of one run)")
    target = dict(rows).get(TARGET_NOISE)
    if target is not None:
        checks = [("Table 1 mean error", target["t1"], TARGETS["t1"], "mm"),
                  ("Table 1 %Error", target["pe"], TARGETS["pe"], "%"),
                  ("Table 2 mean error", target["t2"], TARGETS["t2"], "mm"),
                  ("median stage-1 time, best-of", target["best_ms"], TARGETS["ms"], "ms"),
                  ("median stage-1 time, 1 run", target["ms"], TARGETS["ms"], "ms")]
        print(f"\ntargets at {TARGET_NOISE:g} px (issue 3; paper: 0.631 mm, 2.894 %, 1.034 mm)")
        for name, val, lim, unit in checks:
            print(f"  {name:<29} {val:8.3f} {unit:<3} <= {lim:g} {unit:<3} "
                  f"{'PASS' if val <= lim else 'FAIL'}")
        conv = target["ok"] == target["n"]
        print(f"  {'converged':<29} {target['ok']:>4}/{target['n']:<7} all      "
              f"{'PASS' if conv else 'FAIL'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
