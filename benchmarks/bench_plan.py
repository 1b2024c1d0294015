"""Does each manoeuvre move the measurement it names by the amount typed? (issue 27 item 3)

For all seven manoeuvres at a few amounts, on the demo case (``assets/demo-case``,
reconstructed) and on james (``../shared/data/scan-cases/james-a``, ICT base): the typed
amount against the change of the named measurement as the app computes it (the app's
solver, :class:`naseview.editing.solver.NoseEditSolver`: the manoeuvre fields on the
reconstruction, the moved landmarks and curves, :func:`clinical_measurements`). The
expected change is :data:`naseview.editing.manoeuvres.info.MEASURES` (name, sign, scale:
``expected = factor * amount``; a hump reduction at most the hump, where the dorsum is
straight and the panel says so); a row passes within 10 % of the expected change
(or 0.1 mm / deg for small ones).

    python benchmarks/bench_plan.py [--model ict|generic] [--keep DIR]

Reconstructs both cases into a temporary folder (about 15 s), then about 10 s of solves.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from _shared import use_shared_ict

REPO = Path(__file__).resolve().parents[1]
CASES = {"demo": REPO / "assets" / "demo-case",
         "james": REPO.parent / "shared" / "data" / "scan-cases" / "james-a"}
AMOUNTS = {"hump_reduction": (1.0, 2.0, 3.0), "radix_augmentation": (-1.0, 1.0, 2.0),
           "tip_projection": (-2.0, 1.0, 2.0), "tip_rotation": (-5.0, 5.0, 10.0),
           "tip_narrowing": (1.0, 2.0, 3.0), "alar_base_narrowing": (1.0, 2.0, 3.0),
           "columella_setback": (1.0, 2.0, 3.0)}
REL_TOL = 0.10
ABS_TOL = 0.1


def _reconstruct(case: Path, out: Path, model: str) -> None:
    if (out / "reconstruction.json").is_file():
        return
    subprocess.run([sys.executable, "-m", "naseview", "reconstruct", str(case), "-o",
                    str(out), "--model", model], check=True, capture_output=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="ict")
    ap.add_argument("--keep", type=Path, default=None,
                    help="reconstruct into (or reuse) this folder")
    args = ap.parse_args()
    use_shared_ict()
    from naseview.editing.baseline import baseline_from_output_dir
    from naseview.editing.manoeuvres import MANOEUVRES
    from naseview.editing.manoeuvres.info import MEASURES, expected_change
    from naseview.editing.solver import NoseEditSolver

    root = args.keep or Path(tempfile.mkdtemp(prefix="bench-plan-"))
    fails = total = 0
    print(f"{'case':6s} {'manoeuvre':20s} {'typed':>7s} {'measurement':18s} "
          f"{'expected':>9s} {'measured':>9s} {'ratio':>6s}  ok")
    for name, case in CASES.items():
        if not case.is_dir():
            print(f"{name}: {case} missing, skipped")
            continue
        out = root / name
        _reconstruct(case, out, args.model)
        b = baseline_from_output_dir(out)
        solver = NoseEditSolver(b)
        lms = {k: v.copy() for k, v in b.landmarks.items()}
        m0 = solver(lms).measurements
        for m in MANOEUVRES:
            key = MEASURES[m][0]
            for x in AMOUNTS[m]:
                exp = expected_change(m, x)
                if m == "hump_reduction" and solver.plan.hump_depth is not None:
                    exp = max(exp, -solver.plan.hump_depth)   # capped: the dorsum straight
                got = solver(lms, manoeuvres={m: x})
                if key not in got.measurements or key not in m0:
                    print(f"{name:6s} {m:20s} {x:7.1f} {key:18s} {exp:9.2f} {'-':>9s}")
                    fails += 1
                    total += 1
                    continue
                d = got.measurements[key] - m0[key]
                ok = abs(d - exp) <= max(REL_TOL * abs(exp), ABS_TOL)
                fails += not ok
                total += 1
                ratio = d / exp if exp else float("nan")
                print(f"{name:6s} {m:20s} {x:7.1f} {key:18s} {exp:9.2f} {d:9.2f} "
                      f"{ratio:6.2f}  {'pass' if ok else 'FAIL'}"
                      + (f"  ({'; '.join(got.warnings)})" if got.warnings else ""))
    print(f"{total - fails}/{total} within {REL_TOL:.0%} (or {ABS_TOL})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
