"""Texture baking and the photo composite: time, coverage and colour accuracy.

    python benchmarks/bench_texture.py [--size 1024] [--seed 1] [--work DIR]

Rows:

- ``ict synth (truth)``: a synthetic ICT case (``naseview synth --model ict``), baked on
  the true face with the true cameras; colour error = mean |baked - true albedo| (RGB grey
  levels) over the vertices some photo sees (cos > 0.5 to a camera and not hidden). The
  photos are lit, so the figure includes the studio shading, not just the baking.
- ``ict synth (reconstructed)``: the same photos baked on the reconstructed face with the
  stage-1 cameras (what the app does); colour error against the albedo of the nearest true
  vertex.
- ``james-a (reconstructed)``: the scan case rendered from ``scans/james`` (a real skin
  texture), reconstructed and baked like the app does; error against the scan's own texture
  at the nearest scan vertex (within 2 mm).

``err`` is the mean absolute RGB error (grey levels); ``err/gain`` the same after the best
per-channel gain, which removes a uniform exposure / average shading difference.

Composite: the reconstructed ICT face with the tip pushed back 4 mm and up 1.5 mm,
composited into each photo; time per photo.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _shared import use_shared_ict
from scipy.spatial import cKDTree

from naseview.camera import Camera
from naseview.case import read_case
from naseview.geometry.mesh import vertex_normals
from naseview.meshio import read_mesh
from naseview.reconstruction import read_reconstruction
from naseview.render import rasterize, visible_points
from naseview.texture.bake import BakeParams, FaceTexture, bake_texture
from naseview.texture.composite import composite_photo

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def seen_vertices(V: np.ndarray, F: np.ndarray, cams: dict[str, Camera]) -> np.ndarray:
    """(n,) bool: vertices some camera sees squarely (cos > 0.5) and unoccluded."""
    N = vertex_normals(V, F)
    ok = np.zeros(len(V), bool)
    for cam in cams.values():
        d = cam.center - V
        cos = np.einsum("ij,ij->i", N, d) / np.linalg.norm(d, axis=1)
        ok |= (cos > 0.5) & visible_points(V, cam, rasterize(V, F, cam).depth, 1.0)
    return ok


def colour_errors(baked: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """Mean |baked - truth| (grey levels) as it is, and after the best per-channel gain
    (which removes a uniform exposure / average shading difference)."""
    b = baked.astype(np.float64)
    t = truth.astype(np.float64)
    g = (b * t).sum(axis=0) / np.maximum((b * b).sum(axis=0), 1e-9)
    return float(np.abs(b - t).mean()), float(np.abs(b * g - t).mean())


def bake(V: np.ndarray, F: np.ndarray, cams: dict[str, Camera], photos: dict[str, np.ndarray],
         size: int) -> tuple[FaceTexture, float]:
    bake_texture(V, F, cams, photos, BakeParams(size=size))      # warm the per-topology cache
    t = time.perf_counter()
    tex = bake_texture(V, F, cams, photos, BakeParams(size=size))
    return tex, time.perf_counter() - t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--work", type=Path, default=None)
    a = ap.parse_args()
    use_shared_ict()
    work = a.work or Path(tempfile.mkdtemp(prefix="bench_texture_"))
    case_dir, out_dir = work / "case", work / "out"
    from naseview.cli import main as cli

    if not (case_dir / "case.json").is_file():
        cli(["synth", str(case_dir), "--model", "ict", "--seed", str(a.seed)])
    if not (out_dir / "reconstruction.json").is_file():
        cli(["reconstruct", str(case_dir), "-o", str(out_dir)])
    rows: list[tuple[str, float, int, float, float, float]] = []
    nan = float("nan")
    case = read_case(case_dir)
    photos = {v: case.load_image(v) for v in case.views}
    truth = read_reconstruction(case_dir / "truth.json")
    Vt, Ft = read_mesh(case_dir / "truth_face.ply")
    albedo = _albedo(case_dir, a.seed, len(Vt))
    tex, dt = bake(Vt, Ft, truth.cameras, photos, a.size)
    seen = seen_vertices(Vt, Ft, truth.cameras)
    e, eg = colour_errors(tex.vertex_colors[seen], albedo[seen]) if albedo is not None \
        else (nan, nan)
    rows.append(("ict synth (truth)", dt, a.size, 100 * tex.coverage.mean(), e, eg))
    rec = read_reconstruction(out_dir / "reconstruction.json")
    V, F = read_mesh(out_dir / "face.ply")
    tex_r, dt = bake(V, F, rec.cameras, photos, a.size)
    e, eg = nan, nan
    if albedo is not None:
        seen_r = seen_vertices(V, F, rec.cameras)
        nearest = cKDTree(Vt).query(V[seen_r])[1]
        e, eg = colour_errors(tex_r.vertex_colors[seen_r], albedo[nearest])
    rows.append(("ict synth (reconstructed)", dt, a.size, 100 * tex_r.coverage.mean(), e, eg))
    james = DATA / "scan-cases" / "james-a"
    if (james / "case.json").is_file():
        rows.append(_james_row(james, work, a.size))
    print(f"{'case':26s} {'bake s':>7s} {'texels':>7s} {'cover %':>8s} {'err':>6s} "
          f"{'err/gain':>9s}")
    for name, t, s, cov, e, eg in rows:
        print(f"{name:26s} {t:7.2f} {s:7d} {cov:8.1f} {e:6.1f} {eg:9.1f}")
    # the composite at the end of a drag
    prn = rec.landmarks["prn"]
    fall = np.clip(1 - np.linalg.norm(V - prn, axis=1) / 30.0, 0, 1) ** 2
    V1 = V + fall[:, None] * np.array([0.0, 1.5, -4.0])
    print(f"\n{'composite photo':28s} {'px':>7s} {'s':>7s}")
    for view, img in photos.items():
        composite_photo(img, rec.cameras[view], V, V1, F)
        t = time.perf_counter()
        composite_photo(img, rec.cameras[view], V, V1, F)
        print(f"{view:28s} {img.shape[1]:7d} {time.perf_counter() - t:7.3f}")
    return 0


def _albedo(case_dir: Path, seed: int, n: int) -> np.ndarray | None:
    """The true albedo (n, 3) RGB of a synthetic ICT case, or None if it cannot be redrawn."""
    try:
        from naseview.facemodel import load_face_model
        from naseview.testbed.synth import rig, scene
        from naseview.testbed.synth import synthesize as syn

        model = load_face_model("ict")
        rs = syn.random_streams(seed)
        V, _ = rig.sample_identity(model, rs["identity"])
        sc, _ = scene.build_scene(model, V, rs["appearance"])
    except (ImportError, AttributeError, KeyError) as e:
        print(f"(albedo of {case_dir} not redrawn: {e})", file=sys.stderr)
        return None
    if len(V) != n:
        return None
    return np.asarray(sc.colors[:n, ::-1] * 255.0)


def _james_row(case_dir: Path, work: Path, size: int) -> tuple[str, float, int, float,
                                                              float, float]:
    """The scan case: reconstructed as the app would, baked, compared with the scan's own
    texture at the nearest scan vertex."""
    from naseview.cli import main as cli
    from naseview.testbed.synth.scan import read_scan

    out = work / "james-out"
    if not (out / "reconstruction.json").is_file():
        cli(["reconstruct", str(case_dir), "-o", str(out)])
    scan_dir = DATA / "scans" / "james"
    scan = read_scan(scan_dir / "james.obj", scan_dir / "landmarks.json")
    case = read_case(case_dir)
    photos = {v: case.load_image(v) for v in case.views}
    rec = read_reconstruction(out / "reconstruction.json")
    V, F = read_mesh(out / "face.ply")
    tex, dt = bake(V, F, rec.cameras, photos, size)
    nan = float("nan")
    if scan.texture is None or scan.uv is None:
        return ("james-a (reconstructed)", dt, size, 100 * tex.coverage.mean(), nan, nan)
    H, W = scan.texture.shape[:2]
    uv = scan.uv.reshape(-1, 2)
    x = np.clip((uv[:, 0] % 1.0) * (W - 1), 0, W - 1).astype(int)
    y = np.clip((1.0 - uv[:, 1] % 1.0) * (H - 1), 0, H - 1).astype(int)
    corner = scan.texture[y, x][:, ::-1].astype(float)
    acc = np.zeros((len(scan.V), 3))
    cnt = np.zeros(len(scan.V))
    np.add.at(acc, scan.F.reshape(-1), corner)
    np.add.at(cnt, scan.F.reshape(-1), 1)
    scan_rgb = acc / np.maximum(cnt, 1)[:, None]
    d, nearest = cKDTree(scan.V).query(V)
    seen = seen_vertices(V, F, rec.cameras) & (d < 2.0)
    e, eg = colour_errors(tex.vertex_colors[seen], scan_rgb[nearest[seen]])
    return ("james-a (reconstructed)", dt, size, 100 * tex.coverage.mean(), e, eg)


if __name__ == "__main__":
    sys.exit(main())
