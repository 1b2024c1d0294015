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

Run: ``python benchmarks/bench_annotation.py [--cases N]`` (about 4 s per case).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from naseview.case import read_case
from naseview.facemodel import load_face_model
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.landmarks import ALL_IDS
from naseview.testbed.synth import synthesize_case

FITTS_A, FITTS_B, TARGET_WIDTH = 0.2, 0.15, 0.01


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
    n = ap.parse_args().cases
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
