"""Real-face accuracy (issue 11): nose surface and landmarks on faces the model never saw.

Sets (each case rendered once into ``--data``, default ``$TMPDIR/naseview-bench-real``):

- ``james-a``, ``james-b``: the photo cases of ``../shared/data/scan-cases`` (a real face
  scan, rendered by a renderer that is not naseview's);
- ``scan-james``: ``naseview synth --scan`` of ``../shared/data/scans/james`` (menpo3d,
  BSD-3), ``--scans`` seeds at 1.5 px click noise; ``scan-3px`` the same at 3 px
  (about the click noise of ``james-b``: its reprojection RMSE is 2.2 px, james-a's 1.35);
- ``generic->ict``: generic-face truth (``synth --model generic``) reconstructed on the
  ICT base; ``ict->generic``: ICT truth on the generic base (``--cases`` each way);
- ``in-model``: the same ICT truth on the ICT base (with paper Table 1).

Each case runs stages 1-2 once; stage 3 (with the one-photo sight lines,
``naseview.pipeline.run_stage3``) then runs on a copy for each base and each ablation
variant. Figures: nose surface mean / p95 (SPEC §6, ``naseview.testbed.surface``),
landmark RMSE and the worst landmark after rigid alignment, Table 1 mean error, seconds
per case (stages 1-3). The issue-11 targets are printed beside each figure
(``<=`` target; ``*`` marks a miss).

    python benchmarks/bench_real.py [--ablation] [--scans 3] [--cases 5] [--sets a,b]

Runs on older code too (``PYTHONPATH=<checkout>``): variants a checkout's
``RefineParams`` lacks are left out, and without ``run_stage3`` each base runs the whole
pipeline.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from _shared import use_shared_ict

from naseview.case import Case, read_case
from naseview.facemodel import FaceModel, load_face_model
from naseview.meshio import read_mesh
from naseview.pipeline import PipelineParams, PipelineResult, reconstruct
from naseview.reconstruction import read_reconstruction
from naseview.stage3_mesh import RefineParams
from naseview.testbed.evaluate import landmark_rmse_case, table1_case
from naseview.testbed.surface import nose_surface_samples, surface_error

try:  # the current pipeline; older checkouts run every stage per base
    from naseview.pipeline import run_stage3
except ImportError:  # pragma: no cover - older code
    run_stage3 = None  # type: ignore[assignment]

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
JAMES = SHARED / "scans" / "james"

TARGETS: dict[str, dict[str, float]] = {
    "real": {"ict_mean": 0.7, "ict_p95": 1.8, "generic_mean": 1.0, "rmse": 0.8, "worst": 2.0},
    "cross": {"mean": 0.8},
    "in-model": {"mean": 0.31, "table1": 0.21},
    "real-3px": {},
}
"""Issue 11's "must reach" figures (mm); seconds per case <= 2 everywhere. The targets
hold at 1.5 px clicks; ``real-3px`` (james at 3 px, the click noise of ``james-b``) is
printed for reference, without targets."""

ABLATION: dict[str, dict[str, Any]] = {
    "default": {},
    "no sight lines": {"sight_iterations": 0},
    "no landmark keep": {"keep_landmarks": False},
    "no landmark slide": {"slide_landmarks": False},
    "warp no carry": {"warp_carries_landmarks": False},
    "no silhouettes": {"silhouette_rounds": 0, "mid_handles": True},
    "2 silh. rounds": {"silhouette_rounds": 2},
    "silh. keep mid": {"mid_handles": True},
    "silh. drop mid": {"mid_handles": False},
    "silh. no detrend": {"silhouette_detrend": False},
    "alar outlines": {"outline_curves": ("bottom_l", "bottom_r", "ala_l", "ala_r")},
    "outline + tip": {"outline_curves": ("bottom_l", "bottom_r", "bottom_tip", "ala_l",
                                         "ala_r")},
}
"""Ablation rows: each a change of RefineParams (rows whose fields a checkout lacks are
skipped). The silhouette rows: the profile photos' occluding contours as stage-3 handles
(:mod:`naseview.stage3_mesh.silhouette`) off, kept beside the mid-curve sub-landmark
handles on every face model or dropped on every one (by default kept on a model with
fewer modes than landmarks, the generic face: ``RefineParams.mid_handles``), or without
the per-photo rigid detrend. The outline
rows: the alar outlines over the face (bottom and front photos) on (off by default, for
speed), and with the tip lobule's outline in the bottom photo added."""


@dataclass
class SetSpec:
    """One benchmark set: its cases, the bases it is reconstructed on, its targets."""

    name: str
    cases: list[Path]
    bases: tuple[str, ...]
    kind: str


@dataclass
class Row:
    """Figures of one (set, base): per-case lists."""

    mean: list[float] = field(default_factory=list)
    p95: list[float] = field(default_factory=list)
    rmse: list[float] = field(default_factory=list)
    worst: list[tuple[float, str]] = field(default_factory=list)
    table1: list[float] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)


def _synth(out: Path, n: int, args: list[str]) -> None:
    """``naseview synth --batch n`` into ``out`` unless it holds ``n`` cases already (the
    cache); a smaller cache is rendered again whole, into a fresh folder."""
    if out.is_dir() and len(list(out.glob("case-*"))) >= n:
        return
    tmp = out.with_name(out.name + ".new")
    shutil.rmtree(tmp, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "naseview", "synth", str(tmp), "--batch", str(n),
                    *args], check=True, stdout=subprocess.DEVNULL)
    shutil.rmtree(out, ignore_errors=True)
    tmp.rename(out)


def build_sets(data: Path, n_scans: int, n_cases: int,
               only: frozenset[str] = frozenset()) -> list[SetSpec]:
    """The benchmark sets, rendering the missing synthetic cases into ``data`` (only those
    of the sets named in ``only``, when given)."""
    want = lambda name: not only or name in only  # noqa: E731
    if n_scans > 0:
        for sub, noise, name in (("scan", "1.5", "scan-james"), ("scan-3px", "3", "scan-3px")):
            if not want(name):
                continue
            _synth(data / sub, n_scans, ["--scan", str(JAMES / "james.obj"), "--landmarks",
                                         str(JAMES / "landmarks.json"), "--noise-px", noise])
    if n_cases > 0:
        _synth(data / "generic", n_cases, ["--model", "generic", "--seed", "100"])
        _synth(data / "ict", n_cases, ["--model", "ict", "--seed", "200"])
    pick = lambda d, n: sorted(d.glob("case-*"))[:n]  # noqa: E731
    specs = [
        SetSpec("james-a", [SHARED / "scan-cases" / "james-a"], ("ict", "generic"), "real"),
        SetSpec("james-b", [SHARED / "scan-cases" / "james-b"], ("ict", "generic"), "real"),
        SetSpec("scan-james", pick(data / "scan", n_scans), ("ict", "generic"), "real"),
        SetSpec("scan-3px", pick(data / "scan-3px", n_scans), ("ict", "generic"),
                "real-3px"),
        SetSpec("generic->ict", pick(data / "generic", n_cases), ("ict",), "cross"),
        SetSpec("ict->generic", pick(data / "ict", n_cases), ("generic",), "cross"),
        SetSpec("in-model", pick(data / "ict", n_cases), ("ict",), "in-model"),
    ]
    return [s for s in specs if s.cases]  # a set asked for with 0 cases is left out


@dataclass
class Truth:
    """A case's ground truth: landmarks, mesh and nose samples."""

    landmarks: dict[str, np.ndarray]
    V: np.ndarray
    F: np.ndarray
    samples: np.ndarray


def _truth(d: Path) -> Truth:
    t = read_reconstruction(d / "truth.json")
    V, F = read_mesh(d / "truth_face.ply")
    return Truth(t.landmarks, V, F, nose_surface_samples(V, F, t.landmarks))


def _params(kw: dict[str, Any]) -> PipelineParams | None:
    """Default pipeline params with the stage-3 change ``kw``; None when this checkout's
    RefineParams lacks one of its fields."""
    names = {f.name for f in dataclasses.fields(RefineParams)}
    if not set(kw) <= names:
        return None
    return dataclasses.replace(PipelineParams(),
                               refine=dataclasses.replace(RefineParams(), **kw))


class Runner:
    """Stages 1-2 once per case; stage 3 per base and variant on a copy."""

    def __init__(self) -> None:
        self.models: dict[str, FaceModel] = {}
        self.cache: dict[Path, tuple[Case, PipelineResult, float, Truth]] = {}

    def model(self, name: str) -> FaceModel:
        if name not in self.models:
            self.models[name] = load_face_model(name)
        return self.models[name]

    def run(self, d: Path, base: str, params: PipelineParams) -> tuple[PipelineResult, float,
                                                                        Truth]:
        """The result on ``base`` and the seconds of stages 1-3."""
        if run_stage3 is None:
            case = read_case(d)
            model = self.model(base)
            t = time.perf_counter()
            res = reconstruct(case, model, params=params)
            return res, time.perf_counter() - t, self._truth(d)
        if d not in self.cache:
            case = read_case(d)
            t = time.perf_counter()
            res12 = reconstruct(case, None, stages=(1, 2), params=params)
            self.cache[d] = (case, res12, time.perf_counter() - t, _truth(d))
        case, res12, s12, truth = self.cache[d]
        res = copy.deepcopy(res12)
        model = self.model(base)                 # loaded once per process, not per case
        t = time.perf_counter()
        run_stage3(res, case, model, params.refine)
        return res, s12 + time.perf_counter() - t, truth

    def _truth(self, d: Path) -> Truth:
        if d not in self.cache:
            self.cache[d] = (None, None, 0.0, _truth(d))  # type: ignore[assignment]
        return self.cache[d][3]


def measure(runner: Runner, spec: SetSpec, base: str, params: PipelineParams) -> Row:
    """Every figure of ``spec`` on ``base``."""
    row = Row()
    for d in spec.cases:
        res, secs, truth = runner.run(d, base, params)
        rec = res.reconstruction
        assert res.face_vertices is not None and res.faces is not None
        e = surface_error(truth.V, truth.F, truth.landmarks, res.face_vertices, res.faces,
                          rec.landmarks, samples=truth.samples)
        lm = landmark_rmse_case(rec.landmarks, truth.landmarks)
        per = lm["per_landmark_mm"]
        worst = max(per, key=per.get) if per else "-"
        row.mean.append(e["mean_mm"])
        row.p95.append(e["p95_mm"])
        row.rmse.append(lm["rmse_mm"])
        row.worst.append((float(per.get(worst, math.nan)), worst))
        row.table1.append(table1_case(rec.landmarks, truth.landmarks)["mean_error_mm"])
        row.seconds.append(secs)
    return row


def _cell(x: float, target: float | None) -> str:
    mark = "" if target is None or x <= target else "*"
    goal = "" if target is None else f" (<={target:g})"
    return f"{x:.3f}{mark}{goal}"


def main_table(runner: Runner, sets: list[SetSpec], progress: Callable[[str], None]) -> None:
    params = PipelineParams()
    head = (f"{'set':<14}{'n':>3}  {'ICT mean':<16}{'ICT p95':<16}{'generic mean':<16}"
            f"{'generic p95':<13}{'lm RMSE':<16}{'worst lm':<22}{'Table 1':<16}{'s/case':<12}")
    lines = [head, "-" * len(head)]
    for spec in sets:
        rows = {b: measure(runner, spec, b, params) for b in spec.bases}
        progress(f"  measured {spec.name}")
        tg = TARGETS[spec.kind]
        first = rows[spec.bases[0]]
        ict, gen = rows.get("ict"), rows.get("generic")
        ict_mean_t = tg.get("ict_mean", tg.get("mean"))
        gen_mean_t = tg.get("generic_mean", tg.get("mean"))
        cells = [
            _cell(float(np.mean(ict.mean)), ict_mean_t) if ict else "-",
            _cell(float(np.mean(ict.p95)), tg.get("ict_p95")) if ict else "-",
            _cell(float(np.mean(gen.mean)), gen_mean_t) if gen else "-",
            f"{np.mean(gen.p95):.3f}" if gen else "-",
            _cell(float(np.mean(first.rmse)), tg.get("rmse")),
        ]
        w, wn = max(first.worst)
        worst = _cell(w, tg.get("worst")) + f" {wn}"
        t1 = _cell(float(np.mean(first.table1)), tg.get("table1")) \
            if spec.kind == "in-model" else "-"
        secs = max(float(np.mean(r.seconds)) for r in rows.values())
        lines.append(f"{spec.name:<14}{len(spec.cases):>3}  {cells[0]:<16}{cells[1]:<16}"
                     f"{cells[2]:<16}{cells[3]:<13}{cells[4]:<16}{worst:<22}{t1:<16}"
                     f"{_cell(secs, 2.0):<12}")
    lines.append("surface mm: SPEC §6 nose surface after rigid landmark alignment; lm RMSE and "
                 "worst lm: landmarks after rigid alignment, on the set's first base (ICT for "
                 "the real sets); * = target missed")
    print("\n".join(lines), flush=True)


def ablation_table(runner: Runner, sets: list[SetSpec],
                   progress: Callable[[str], None]) -> None:
    cols = [(s, b) for s in sets for b in s.bases]
    names = [f"{s.name[:8]}/{b[:3]}" for s, b in cols]
    lines = [f"{'variant':<18}" + "".join(f"{n:>14}" for n in names)]
    for row, kw in ABLATION.items():
        params = _params(kw)
        if params is None:
            continue
        figs = [float(np.mean(measure(runner, s, b, params).mean)) for s, b in cols]
        progress(f"  ablation {row}")
        lines.append(f"{row:<18}" + "".join(f"{x:>14.3f}" for x in figs))
    lines.append("nose surface mean (mm) per set/base; each row one addition switched off "
                 "(RefineParams fields: " + "; ".join(
                     f"{r}: {kw}" for r, kw in ABLATION.items() if kw) + ")")
    print("\n".join(lines), flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path,
                    default=Path(tempfile.gettempdir()) / "naseview-bench-real")
    ap.add_argument("--scans", type=int, default=3, help="synth --scan cases of james")
    ap.add_argument("--cases", type=int, default=10, help="cross-model cases each way")
    ap.add_argument("--sets", default="", help="comma list of set names (default all)")
    ap.add_argument("--ablation", action="store_true", help="also print the ablation table")
    args = ap.parse_args(argv)
    use_shared_ict()
    os.environ.setdefault("OMP_NUM_THREADS", "2")
    keep = frozenset(args.sets.split(",")) if args.sets else frozenset()
    sets = build_sets(args.data, args.scans, args.cases, keep)
    if keep:
        sets = [s for s in sets if s.name in keep]
    runner = Runner()
    progress = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    main_table(runner, sets, progress)
    if args.ablation:
        print()
        ablation_table(runner, sets, progress)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
