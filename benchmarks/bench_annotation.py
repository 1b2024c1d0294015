"""Pointer travel of the guided click order (naseview.intake.click_order) on synthetic cases.

For each synthetic case (generic face model, noise-free clicks) the landmarks a surgeon
marks in each photo are visited in three orders: the guided order of
:data:`naseview.intake.click_order.CLICK_ORDER`, the SPEC table order (g n k r prn c sn mf int al
alp alpp ac md ...) and a random order. The table prints, per order, the number of clicks
and skips, the pointer travel in photo widths (the distance between consecutive clicks
in a photo, divided by the photo width; switching photos is free) and a Fitts'-law
estimate of the pointing time, MT = a + b log2(1 + D / W) per click with a = 0.2 s,
b = 0.15 s/bit and W = 1 % of the photo width (a click ring). The estimate leaves out
reading the instructions and looking for the landmark, so it is a lower bound.

Prediction (``--predict``): the guided flow is replayed click by click; before each click
the page's pre-placed marker (:func:`naseview.intake.predict.predict_next`: the template
fit of the photo's clicks so far, or the guidance reprojection once the photos are
related) is compared with the true click, in px and in % of the nose's size in that photo
(the diagonal of the bounding box of its true clicks). Person time: a marker within
``--accept`` % of the nose's size is confirmed (``CONFIRM_S``), otherwise the landmark is
found and clicked (``CORRECT_S``, the ~5 s a person needs). Cases: synthetic ones
(generic model, 1.5 px click noise) and ``../shared/data/scan-cases`` (real photos,
clicked by hand).

Run: ``python benchmarks/bench_annotation.py [--cases N] [--predict]`` (about 4 s per case).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from naseview.case import read_case
from naseview.facemodel import load_face_model
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.intake.guidance import quick_stage1
from naseview.intake.predict import predict_next
from naseview.landmarks import ALL_IDS
from naseview.testbed.synth import synthesize_case

FITTS_A, FITTS_B, TARGET_WIDTH = 0.2, 0.15, 0.01
CONFIRM_S, CORRECT_S = 1.5, 5.0
"""Person time of confirming a pre-placed marker (look, one click) and of finding and
clicking a landmark without one (issue 27: about 5 s)."""
SCAN_CASES = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "scan-cases"


def replay(case_dir: Path) -> list[tuple[str, str, float | None, float | None]]:
    """(view, id, error px, error % of the nose) of the pre-placed marker before each
    click of the guided flow (None: no marker yet)."""
    case = read_case(case_dir)
    sizes = {v: (x.width, x.height) for v, x in case.views.items()}
    clicks: dict[str, dict[str, np.ndarray]] = {v: {} for v in VIEW_ORDER}
    out: list[tuple[str, str, float | None, float | None]] = []
    for v in VIEW_ORDER:
        true = case.views[v].landmarks
        P = np.array(list(true.values()))
        nose = float(np.linalg.norm(P.max(0) - P.min(0)))
        for lid in CLICK_ORDER[v]:
            if lid not in true:
                continue
            g = quick_stage1(clicks, sizes, dict(case.scale_mm))
            pred = predict_next(v, clicks, g.hints(v, set(clicks[v])))
            if lid in pred:
                e = float(np.linalg.norm(pred[lid] - true[lid]))
                out.append((v, lid, e, 100.0 * e / nose))
            else:
                out.append((v, lid, None, None))
            clicks[v][lid] = np.asarray(true[lid], np.float64)
    return out


def predict_table(name: str, rows: list[tuple[str, str, float | None, float | None]],
                  accept: float, cases: int = 1) -> None:
    """One line per case group (counts and time per case): markers shown, error
    percentiles, confirmations, corrections, person time."""
    e = np.array([r[2] for r in rows if r[2] is not None])
    pc = np.array([r[3] for r in rows if r[3] is not None])
    n = round(len(rows) / cases)
    ok = round(int((pc <= accept).sum()) / cases)
    secs = ok * CONFIRM_S + (n - ok) * CORRECT_S
    shown = round(len(e) / cases)
    print(f"{name:24s} {n:6d} {shown:7d} {np.median(e):8.1f} {np.percentile(e, 90):8.1f} "
          f"{np.median(pc):7.1f} {np.percentile(pc, 90):7.1f} {ok:6d} {n - ok:6d} "
          f"{secs:8.0f}")
    for v in VIEW_ORDER:
        pv = np.array([r[3] for r in rows if r[0] == v and r[3] is not None])
        if len(pv):
            print(f"  {v:22s} median {np.median(pv):5.1f} %, within {accept:g} %: "
                  f"{int((pv <= accept).sum())} of {sum(1 for r in rows if r[0] == v)}")


def predict_main(n: int, accept: float) -> None:
    model = load_face_model("generic")
    groups: dict[str, list[Path]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(n):
            d = Path(tmp) / f"case{seed}"
            synthesize_case(d, model, seed=seed, noise_px=1.5)
            groups.setdefault(f"synthetic x{n} (per case)", []).append(d)
        if SCAN_CASES.is_dir():
            for d in sorted(SCAN_CASES.iterdir()):
                if (d / "case.json").is_file():
                    groups[d.name] = [d]
        print(f"pre-placed marker vs the true click; confirmed within {accept:g} % of "
              f"the nose ({CONFIRM_S:g} s), else found and clicked ({CORRECT_S:g} s)")
        print(f"{'case':24s} {'clicks':>6s} {'markers':>7s} {'med px':>8s} {'p90 px':>8s} "
              f"{'med %':>7s} {'p90 %':>7s} {'conf.':>6s} {'corr.':>6s} {'time s':>8s}")
        for name, dirs in groups.items():
            predict_table(name, [r for d in dirs for r in replay(d)], accept, len(dirs))


def travel(points: list[np.ndarray], width: float) -> tuple[float, float]:
    """(travel in photo widths, Fitts time in s) of clicking ``points`` in order."""
    d = [float(np.linalg.norm(b - a)) / width for a, b in zip(points[:-1], points[1:], strict=True)]
    t = FITTS_A * len(points) + sum(FITTS_B * np.log2(1.0 + x / TARGET_WIDTH) for x in d)
    return sum(d), t


def measure(case_dir: Path, orders: dict[str, dict[str, tuple[str, ...]]]
            ) -> dict[str, tuple[int, int, float, float]]:
    case = read_case(case_dir)
    out = {}
    for name, order in orders.items():
        clicks = skips = 0
        dist = secs = 0.0
        for view in VIEW_ORDER:
            v = case.views[view]
            pts = [v.landmarks[i] for i in order[view] if i in v.landmarks]
            skips += sum(1 for i in order[view] if i not in v.landmarks)
            clicks += len(pts)
            dd, tt = travel(pts, float(v.width))
            dist += dd
            secs += tt
        out[name] = (clicks, skips, dist, secs)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--cases", type=int, default=3, help="synthetic cases to measure")
    ap.add_argument("--predict", action="store_true",
                    help="measure the pre-placed markers instead of the pointer travel")
    ap.add_argument("--accept", type=float, default=3.0,
                    help="a marker within this %% of the nose's size is confirmed")
    args = ap.parse_args()
    n = args.cases
    if args.predict:
        predict_main(n, args.accept)
        return
    model = load_face_model("generic")
    rng = np.random.default_rng(0)
    spec = {v: tuple(i for i in ALL_IDS if i in CLICK_ORDER[v]) for v in CLICK_ORDER}
    rows: dict[str, list[tuple[int, int, float, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(n):
            d = Path(tmp) / f"case{seed}"
            synthesize_case(d, model, seed=seed, noise_px=0.0)
            shuffled = {v: tuple(rng.permutation(ids)) for v, ids in CLICK_ORDER.items()}
            res = measure(d, {"guided (curves)": CLICK_ORDER, "SPEC table order": spec,
                              "random": shuffled})
            for k, r in res.items():
                rows.setdefault(k, []).append(r)
    print(f"{n} synthetic cases (generic model), photos {VIEW_ORDER}")
    print(f"{'order':20s} {'clicks':>7s} {'skips':>6s} {'travel (photo widths)':>22s} "
          f"{'Fitts pointing time (s)':>24s}")
    for k, rs in rows.items():
        a = np.array(rs, dtype=float)
        print(f"{k:20s} {a[:, 0].mean():7.1f} {a[:, 1].mean():6.1f} "
              f"{a[:, 2].mean():16.2f} ± {a[:, 2].std():4.2f} {a[:, 3].mean():18.1f}")


if __name__ == "__main__":
    main()
