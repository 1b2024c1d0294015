"""Speed of the synthetic-case generator and of the rasteriser.

Prints, per face model, the median wall time over N runs of:

- ``synthesize_case`` at 1024 px (four photos, clicks, truth files);
- one 1024 px photo render (``render_mesh``: z-buffer + Gouraud shading) of the front
  view of that case's scene.

Usage::

    python benchmarks/bench_synth.py [--n 5] [--size 1024] [--models ict,generic]

Targets: one 1024 px case < 2 s; one 1024 px render of a ~20k-triangle face well under
1 s (single core).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from _shared import use_shared_ict

from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.render import render_mesh
from naseview.testbed.synth import (
    build_scene,
    random_streams,
    sample_identity,
    sample_rig,
    synthesize_case,
)

use_shared_ict()


def bench(model_name: str, n: int, size: int) -> dict[str, float | int | str]:
    model = load_face_model(model_name)
    synthesize_case(Path(tempfile.mkdtemp()) / "warm", model, seed=0, size=size)  # imports
    case_t, case_cpu = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(n):
            t0, c0 = time.perf_counter(), time.process_time()
            synthesize_case(Path(tmp) / f"c{i}", model, seed=i, size=size)
            case_t.append(time.perf_counter() - t0)
            case_cpu.append(time.process_time() - c0)
    rs = random_streams(0)
    V, _ = sample_identity(model, rs["identity"])
    cams, _ = sample_rig(V, model, rs["rig"], size)
    scene, _ = build_scene(model, V, rs["appearance"])
    render_t = []
    for _ in range(n):
        t0 = time.perf_counter()
        res = render_mesh(scene.V, scene.F, cams["front"], vertex_colors=scene.colors,
                          normals=scene.normals, supersample=1, cull_backfaces=True)
        render_t.append(time.perf_counter() - t0)
    return {"model": model_name, "vertices": len(scene.V), "triangles": len(scene.F),
            "covered_px": int((res.face_id >= 0).sum()),
            "case_s": statistics.median(case_t), "case_cpu_s": statistics.median(case_cpu),
            "render_s": statistics.median(render_t)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=5)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--models", default="ict,generic")
    args = ap.parse_args()
    rows = []
    for name in args.models.split(","):
        try:
            rows.append(bench(name, args.n, args.size))
        except NaseviewError as e:
            print(f"{name}: skipped ({e})")
    print(f"\nsynthetic case at {args.size} px, median of {args.n} (s; wall and CPU time of "
          "this process, which differ when other jobs share the cores)")
    print(f"{'model':<9} {'verts':>7} {'tris':>7} {'front px':>9} {'case wall':>10} "
          f"{'case cpu':>9} {'render wall':>12}")
    for r in rows:
        print(f"{r['model']:<9} {r['vertices']:>7} {r['triangles']:>7} {r['covered_px']:>9} "
              f"{r['case_s']:>10.2f} {r['case_cpu_s']:>9.2f} {r['render_s']:>12.3f}")


if __name__ == "__main__":
    main()
