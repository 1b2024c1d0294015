"""Time to open a case in the app, split into its phases (issue 27 item 6).

Opens a photo case the way ``naseview serve CASE_DIR`` does
(:func:`naseview.app.serve.start_app` on port 0, one headless tab connected, then
:meth:`NaseviewApp.wait_ready`) and prints one row per phase: the pipeline's stages (as
the pipeline reports them), then what the app does after them ("building the editor…"):
keeping the reconstruction in the patient folder, the baseline, the stage-3 solver, the
controller, the photo thumbnails, the texture bake, the tab's scene, the autosave. The
phases are timed by wrapping the functions the app calls (no change to the app).

Target (issue 27): the whole within 1.5x of the pipeline's stage time.

Usage: ``python benchmarks/bench_open.py [CASE_DIR] [--repeat 2] [--profile out.prof]``
(default case ``../shared/data/scan-cases/james-a``). Needs the ICT model.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _shared import use_shared_ict

DEFAULT_CASE = (Path(__file__).resolve().parents[2] / "shared" / "data" / "scan-cases"
                / "james-a")


class Phases:
    """Seconds spent per named phase (summed over calls, any thread)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.order: list[str] = []
        self.first_end: dict[str, float] = {}      # perf_counter at a phase's first end
        self._lock = threading.Lock()

    def add(self, name: str, dt: float) -> None:
        with self._lock:
            if name not in self.seconds:
                self.order.append(name)
            self.seconds[name] += dt
            self.first_end.setdefault(name, time.perf_counter())

    def wrap(self, owner: Any, attr: str, name: str) -> Callable[[], None]:
        """Time every call of ``owner.attr`` as ``name``; returns the undo."""
        original = getattr(owner, attr)

        def timed(*args: Any, **kwargs: Any) -> Any:
            t = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.add(name, time.perf_counter() - t)

        setattr(owner, attr, timed)
        return lambda: setattr(owner, attr, original)


def open_once(case_dir: Path, model: str | None, profile: cProfile.Profile | None
              ) -> tuple[float, Phases, dict[str, float]]:
    """Open ``case_dir`` once; (wall seconds, phases, pipeline stage seconds)."""
    import naseview.app.face_look as face_look_module
    import naseview.app.naseview_app as naseview_app
    import naseview.app.serve as serve
    from naseview.app.headless_tab import HeadlessTab
    from naseview.app.patient_work import PatientWork
    from naseview.app.screen import Screen

    phases = Phases()
    stages: dict[str, float] = {}
    undo = [phases.wrap(naseview_app, "baseline_from_pipeline", "baseline from pipeline"),
            phases.wrap(face_look_module, "make_look", "texture bake"),
            phases.wrap(naseview_app, "photo_thumbnails", "photo thumbnails"),
            phases.wrap(naseview_app.NaseviewApp, "_controller_for", "controller"),
            phases.wrap(Screen, "show_case", "tab scene"),
            phases.wrap(PatientWork, "reconstructed", "save reconstruction"),
            phases.wrap(PatientWork, "attach", "autosave attach")]
    original_reconstruct = naseview_app.reconstruct

    def reconstruct(*args: Any, **kwargs: Any) -> Any:
        report = args[4] if len(args) > 4 else kwargs.get("progress")

        def progress(stage: str, seconds: float) -> None:
            stages[stage] = seconds
            if report is not None:
                report(stage, seconds)
        args = args[:4] + (progress,) + args[5:] if len(args) > 4 else args
        if "progress" in kwargs:
            kwargs["progress"] = progress
        t = time.perf_counter()
        try:
            return original_reconstruct(*args, **kwargs)
        finally:
            phases.add("pipeline (stages 1-3)", time.perf_counter() - t)

    naseview_app.reconstruct = reconstruct
    original_install = naseview_app.NaseviewApp._install
    if profile is not None:              # the job thread's work after the pipeline
        def install(self: Any, *args: Any, **kwargs: Any) -> Any:
            assert profile is not None
            return profile.runcall(original_install, self, *args, **kwargs)
        naseview_app.NaseviewApp._install = install  # type: ignore[method-assign]
    original_factory = naseview_app._default_solver_factory
    try:
        t0 = time.perf_counter()
        server, app = serve.start_app(case_dir, port=0, model=model)
        app.solver_factory = _timed_factory(phases, app.solver_factory)
        tab = HeadlessTab(server)
        ok = app.wait_ready(120.0)
        # the tab's scene is built on the job thread after the install; wait for it
        for screen in list(app.screens.values()):
            screen.shown.wait(30.0)
        wall = time.perf_counter() - t0
        if not ok:
            raise SystemExit("the case did not open within 120 s")
        tab.close()
        server.stop()
    finally:
        naseview_app.reconstruct = original_reconstruct
        naseview_app.NaseviewApp._install = original_install  # type: ignore[method-assign]
        naseview_app._default_solver_factory = original_factory
        for u in undo:
            u()
    phases.first_end = {k: v - t0 for k, v in phases.first_end.items()}
    return wall, phases, stages


def _timed_factory(phases: Phases, factory: Callable[..., Any]) -> Callable[..., Any]:
    def timed(*args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return factory(*args, **kwargs)
        finally:
            phases.add("editor solver build", time.perf_counter() - t)
    return timed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", type=Path, default=DEFAULT_CASE)
    ap.add_argument("--model", default=None)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--profile", type=Path, default=None,
                    help="write a cProfile of the last opening's work after the pipeline "
                         "(job thread) here and print its top")
    args = ap.parse_args()
    use_shared_ict()
    for i in range(args.repeat):
        # a fresh patient store each time: the case is reconstructed, not reopened
        os.environ["NASEVIEW_WORK_DIR"] = tempfile.mkdtemp(prefix="naseview-bench-")
        prof = cProfile.Profile() if args.profile and i == args.repeat - 1 else None
        wall, phases, stages = open_once(args.case, args.model, prof)
        pipe = phases.seconds.get("pipeline (stages 1-3)", 0.0)
        stage_sum = sum(stages.values())
        print(f"\nopening {args.case.name} (run {i + 1}/{args.repeat})")
        print(f"  {'phase':34s} {'s':>7s}")
        for name, dt in stages.items():
            print(f"  {'  stage: ' + name:34s} {dt:7.2f}")
        for name in phases.order:
            print(f"  {name:34s} {phases.seconds[name]:7.2f}")
        other = wall - pipe
        shown = phases.first_end.get("tab scene")
        if shown is not None:
            print(f"  {'editor shown in the tab (at)':34s} {shown:7.2f}   "
                  f"= {shown / max(stage_sum, 1e-9):.2f} x stage time")
        print(f"  {'(after the pipeline, all)':34s} {other:7.2f}")
        print(f"  {'total (start_app -> ready)':34s} {wall:7.2f}")
        print(f"  total / stage time = {wall / max(stage_sum, 1e-9):.2f} "
              f"(target <= 1.5; stages {stage_sum:.2f} s)")
        if prof is not None:
            prof.dump_stats(str(args.profile))
            pstats.Stats(prof).sort_stats("cumulative").print_stats(45)


if __name__ == "__main__":
    main()
