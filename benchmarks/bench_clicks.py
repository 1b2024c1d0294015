"""Stage 1 benchmark: one bad click, and low photo resolution (issue 13).

**One-bad-click sweep.** On generic synthetic cases (``naseview synth --model generic``,
1024 px, 1.5 px click noise), every landmark clicked in 3+ photos has, in turn, one of its
clicks moved by ``--px`` (15 and 30 px) in two directions (image right, image down; or
``--directions down-right,up-right``), one trial per landmark x photo x direction. Each
trial is counted as

- correct: that click is blamed (a suspect click naming that landmark and photo alone),
  and no other click is left out;
- wrong: another click is left out, or another photo alone is blamed for the landmark;
- ambiguous: the landmark is flagged, but the photos disagree and none is pinned;
- unflagged: nothing names the click.

On the standard rig the image axes are the epipolar directions (front-left and
front-right pairs share the horizontal, front-bottom the vertical), so most axis moves
slide a click along the epipolar line of another photo: that pair still agrees, and with
three photos two re-solves fit every click equally well; only the symmetry prior can then
pick the wrong click. The table counts those trials (``along epi``: within 15 degrees of
such a line) and the correct blame among the rest (``correct off-epi``).

**Six photos** (issue 24): the same sweep on the same cases rendered with the two oblique
photos as well (``--views front,left,right,bottom,oblique_left,oblique_right``: the four
photos and their clicks are those of the four-photo case), a row per offset beside the
four-photo one (``--photos 4,6``, the default). An oblique photo's epipolar lines cross
the four-photo rig's, so a move along one line of the rig is off the oblique's.

It also prints the worst landmark error (mm, after rigid alignment to the clean-click
solve) and how many trials leave a landmark more than 1 mm from its clean-click position
with no warning that names it (the target is 0).

**Resolution sweep.** The same cases rendered at 1024, 768, 640, 512, 256, 200 and 120 px:
Table 1 mean error (and its ratio to the first size's), the landmark RMSE against the
truth, the pixels per mm at the nose that stage 1 measures, whether the low-resolution
warning fires, and whether a warning blames the cameras instead (viewing directions,
focal length, swapped or rotated photos). ``SfmParams.min_px_per_mm`` is set from it.

Cases are rendered once into ``--data`` (default ``$TMPDIR/naseview-bench-clicks``).

    python benchmarks/bench_clicks.py [--seeds 1,2] [--px 15,30] [--photos 4,6]
                                      [--sizes 1024,768,512]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from naseview.case import Case, read_case
from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.landmarks import ALL_VIEWS, VIEWS
from naseview.reconstruction import read_reconstruction
from naseview.stage1_landmarks import SfmResult, bundle_adjust
from naseview.stage1_landmarks.plausibility import px_per_mm
from naseview.testbed.evaluate import landmark_rmse_case, table1_case
from naseview.testbed.synth import synthesize_case

DIRECTIONS = {"right": np.array([1.0, 0.0]), "down": np.array([0.0, 1.0]),
              "down-right": np.array([1.0, 1.0]) / np.sqrt(2.0),
              "up-right": np.array([1.0, -1.0]) / np.sqrt(2.0)}
"""Directions a click is moved in (image x right, y down); the default sweep takes the
first two, which on the standard rig lie along the epipolar lines (see ``epipolar_angle``)."""
EPIPOLAR_DEG = 15.0
"""A move within this angle of an epipolar line of its photo counts as 'along' one."""
TARGET_15 = 0.98
MOVE_LIMIT_MM = 1.0


PHOTOS: dict[int, tuple[str, ...]] = {4: VIEWS, 6: ALL_VIEWS}
"""``--photos`` -> the views rendered: the four, or the four and both obliques."""


def ensure_case(d: Path, seed: int, size: int, views: tuple[str, ...] = VIEWS) -> Path:
    """A generic synthetic case ``d`` of ``views`` (rendered when missing)."""
    if not (d / "case.json").is_file():
        synthesize_case(d, load_face_model("generic"), seed=seed, noise_px=1.5, size=size,
                        views=views)
    return d


def case_folder(root: Path, size: int, photos: int, seed: int) -> Path:
    """``root/size-1024/case-001`` (four photos, the folders of earlier runs) or
    ``root/size-1024-6/case-001`` (six)."""
    return root / (f"size-{size}" if photos == 4 else f"size-{size}-{photos}") / f"case-{seed:03d}"


def with_click(case: Case, view: str, lid: str, uv: np.ndarray) -> Case:
    """The case with one click moved to ``uv``."""
    v = case.views[view]
    views = dict(case.views)
    views[view] = replace(v, landmarks={**v.landmarks, lid: uv})
    return replace(case, views=views)


def classify(res: SfmResult, view: str, lid: str) -> str:
    """correct / wrong / ambiguous / unflagged (see the module docstring)."""
    if any(sc.ignored and (sc.view, sc.landmark) != (view, lid) for sc in res.suspect_clicks):
        return "wrong"
    mine = [sc for sc in res.suspect_clicks if sc.landmark == lid]
    if any(sc.view == view and not sc.other_views for sc in mine):
        return "correct"
    if any(not sc.other_views for sc in mine):
        return "wrong"
    if any(view in (sc.view, *sc.other_views) for sc in mine):
        return "ambiguous"
    return "unflagged"


def moved(res: SfmResult, clean: SfmResult) -> dict[str, float]:
    """id -> distance (mm) from the clean-click solve after rigid alignment."""
    per = landmark_rmse_case(res.landmarks, clean.landmarks)["per_landmark_mm"]
    return {k: float(v) for k, v in per.items()}


def named(res: SfmResult, lid: str) -> bool:
    return any(f"'{lid}'" in w for w in res.warnings)


def epipolar_angle(clean: SfmResult, case: Case, view: str, lid: str,
                   dvec: np.ndarray) -> float:
    """Smallest angle (degrees) between the move ``dvec`` (2,) of the click ``lid`` in
    ``view`` and the epipolar lines there of the landmark's other photos (the image in
    ``view`` of another photo's line of sight through its click, clean-click cameras).

    A move along such a line leaves that photo pair consistent: with three photos, the
    two re-solves without the moved click and without the third photo's both fit every
    click, and only priors (symmetry) can say which click was wrong."""
    cam = clean.cameras[view]
    X = clean.landmarks[lid]
    best = 90.0
    for other, v in case.views.items():
        if other == view or lid not in v.landmarks or other not in clean.cameras:
            continue
        oc = clean.cameras[other]
        C = oc.center
        d = X - C
        uv = cam.project(np.stack([C + 0.9 * d, C + 1.1 * d]))
        e = uv[1] - uv[0]
        if np.linalg.norm(e) < 1e-9:
            continue
        c = abs(float(e @ dvec)) / float(np.linalg.norm(e) * np.linalg.norm(dvec))
        best = min(best, float(np.degrees(np.arccos(min(1.0, c)))))
    return best


def click_sweep(dirs: list[Path], px: float, directions: list[str]) -> dict[str, object]:
    counts: Counter[str] = Counter()
    along: Counter[str] = Counter()
    worst, silent, worst_silent = 0.0, 0, 0.0
    failures: list[str] = []
    for d in dirs:
        case = read_case(d)
        clean = bundle_adjust(case)
        for lid in {k for v in case.views.values() for k in v.landmarks}:
            seen = [v for v in case.views if lid in case.views[v].landmarks]
            if len(seen) < 3:
                continue
            for view in seen:
                for dname in directions:
                    dvec = DIRECTIONS[dname]
                    bad = with_click(case, view, lid,
                                     case.views[view].landmarks[lid] + px * dvec)
                    try:
                        res = bundle_adjust(bad)
                    except NaseviewError as e:
                        counts["error"] += 1
                        failures.append(f"{d.name} {lid}@{view} {dname}: error {e}")
                        continue
                    kind = classify(res, view, lid)
                    counts[kind] += 1
                    if epipolar_angle(clean, case, view, lid, dvec) <= EPIPOLAR_DEG:
                        along[kind] += 1
                    if kind != "correct":
                        failures.append(f"{d.name} {lid}@{view} {dname}: {kind}; "
                                        f"{res.warnings[:2]}")
                    mv = moved(res, clean)
                    worst = max(worst, max(mv.values()))
                    quiet = {k: m for k, m in mv.items() if m > MOVE_LIMIT_MM and not named(res, k)}
                    if quiet:
                        silent += 1
                        worst_silent = max(worst_silent, max(quiet.values()))
                        failures.append(f"{d.name} {lid}@{view} {dname}: moved unnamed "
                                        + ", ".join(f"{k} {m:.2f} mm" for k, m in quiet.items()))
    n = sum(counts.values())
    return {"n": n, "counts": counts, "along": along, "worst": worst, "silent": silent,
            "worst_silent": worst_silent, "failures": failures}


def min_px_per_mm(case: Case, res: SfmResult) -> float:
    """Smallest resolution (px per mm at the clicked landmarks, as stage 1 measures it)
    over the photos."""
    return min(px_per_mm(c, np.array([res.landmarks[k] for k in case.views[v].landmarks
                                      if k in res.landmarks]))
               for v, c in res.cameras.items())


def resolution_sweep(root: Path, seeds: list[int], sizes: list[int]) -> list[dict[str, float]]:
    rows = []
    for size in sizes:
        t1, rmse, ppmm, warned, directions = [], [], [], 0, 0
        for s in seeds:
            d = ensure_case(root / f"size-{size}" / f"case-{s:03d}", s, size)
            case = read_case(d)
            truth = read_reconstruction(d / "truth.json").landmarks
            try:
                res = bundle_adjust(case)
            except NaseviewError as e:
                print(f"  {size} px seed {s}: FAILED {e}")
                continue
            t1.append(table1_case(res.landmarks, truth)["mean_error_mm"])
            rmse.append(landmark_rmse_case(res.landmarks, truth)["rmse_mm"])
            ppmm.append(min_px_per_mm(case, res))
            warned += any("low photo resolution" in w for w in res.warnings)
            directions += any("similar directions" in w or "focal length" in w
                              or "looks like" in w or "rotated" in w for w in res.warnings)
        rows.append({"size": size, "t1": float(np.mean(t1)), "rmse": float(np.mean(rmse)),
                     "ppmm": float(np.mean(ppmm)), "warned": warned, "n": len(t1),
                     "directions": directions})
    return rows


def _off(counts: Counter[str], along: Counter[str], kind: str) -> str:
    """``k/n (p %)``: trials of ``kind`` among those whose move is off every epipolar
    line (where the clicks alone can tell which one is wrong)."""
    n = sum(counts.values()) - sum(along.values())
    k = counts[kind] - along[kind]
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "-"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1,2", help="synthetic case seeds")
    ap.add_argument("--px", default="15,30", help="bad-click offsets, px")
    ap.add_argument("--sizes", default="1024,768,640,512,256,200,120", help="photo sizes, px")
    ap.add_argument("--directions", default="right,down",
                    help=f"click move directions, of {','.join(DIRECTIONS)}")
    ap.add_argument("--photos", default="4,6",
                    help="one-bad-click rows: 4 (front, left, right, bottom) and/or 6 (and "
                         "both obliques)")
    ap.add_argument("--no-resolution", action="store_true")
    ap.add_argument("--verbose", action="store_true", help="list every trial not correct")
    ap.add_argument("--data", type=Path,
                    default=Path(tempfile.gettempdir()) / "naseview-bench-clicks")
    args = ap.parse_args(argv)
    directions = args.directions.split(",")
    if not set(directions) <= set(DIRECTIONS):
        ap.error(f"--directions: each of {', '.join(DIRECTIONS)}")
    seeds = [int(s) for s in args.seeds.split(",")]
    photos = [int(p) for p in args.photos.split(",")]
    if not set(photos) <= set(PHOTOS):
        ap.error("--photos: 4 and/or 6")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"One bad click, generic synthetic cases (seeds {args.seeds}), 1024 px; load "
          f"average {load:.1f}; directions {args.directions}")
    print(f"{'photos':>6} {'px':>4} {'trials':>6} {'correct':>8} {'wrong':>6} {'ambig':>6} "
          f"{'unflag':>7} {'error':>6} {'worst mm':>9} {'>1mm unnamed':>13} {'along epi':>10} "
          f"{'ambig along':>12} {'correct off-epi':>16} {'s/solve':>8}")
    verdict = {}
    for n_photos in photos:
        dirs = [ensure_case(case_folder(args.data, 1024, n_photos, s), s, 1024,
                            PHOTOS[n_photos]) for s in seeds]
        ok = True
        for px in [float(p) for p in args.px.split(",")]:
            t0 = time.perf_counter()
            r = click_sweep(dirs, px, directions)
            secs = (time.perf_counter() - t0) / max(1, int(r["n"]) + len(dirs))  # type: ignore[call-overload]
            c, a = r["counts"], r["along"]
            assert isinstance(c, Counter) and isinstance(a, Counter)
            print(f"{n_photos:>6} {px:>4g} {r['n']:>6} {c['correct']:>8} {c['wrong']:>6} "
                  f"{c['ambiguous']:>6} {c['unflagged']:>7} {c['error']:>6} "
                  f"{r['worst']:>9.2f} {r['silent']:>13} {sum(a.values()):>10} "
                  f"{a['ambiguous']:>12} {_off(c, a, 'correct'):>16} {secs:>8.2f}", flush=True)
            frac = c["correct"] / max(1, int(r["n"]))  # type: ignore[call-overload]
            need = TARGET_15 if px < 30 else 1.0
            ok &= frac >= need and c["wrong"] == 0 and r["silent"] == 0
            if args.verbose:
                for f in r["failures"]:  # type: ignore[attr-defined]
                    print("   ", f)
        verdict[n_photos] = ok
    print("targets: 15 px >= 98 % correct, 0 wrong; 30 px 100 % correct; no landmark "
          f"> {MOVE_LIMIT_MM:g} mm from its clean-click position unnamed: "
          + ", ".join(f"{n} photos {'PASS' if ok else 'FAIL'}" for n, ok in verdict.items()))
    print("s/solve: seconds per stage-1 solve (each trial's, with its leave-one-out "
          "re-solves, and each clean one), on this machine's load")
    print(f"along epi: trials whose move lies within {EPIPOLAR_DEG:g} deg of an epipolar line "
          "of its photo (only priors can then tell which click is wrong); ambig along: of "
          "those, the ambiguous ones; correct off-epi: correct blame among the others")
    if not args.no_resolution:
        rows = resolution_sweep(args.data, seeds, [int(s) for s in args.sizes.split(",")])
        print("\nPhoto resolution (same cases, 1.5 px click noise; px/mm: the mean over cases "
              "of the lowest photo's)")
        print(f"{'size px':>7} {'T1 mm':>7} {'x1024':>6} {'RMSE mm':>8} {'px/mm':>6} "
              f"{'res warned':>10} {'camera-blamed':>13}")
        for row in rows:
            print(f"{row['size']:>7} {row['t1']:>7.3f} {row['t1'] / rows[0]['t1']:>6.2f} "
                  f"{row['rmse']:>8.3f} {row['ppmm']:>6.2f} {row['warned']:>6}/{row['n']:<3} "
                  f"{row['directions']:>9}/{row['n']:<3}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
