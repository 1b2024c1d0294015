"""Does a multi-view photo-consistency term know the true nose? (issue 23, deliver 3)

Issue 23 asks to measure a photo-consistency term inside the base-face fit ("one texture
must reproject consistently into all photos") and to keep it only if it helps both real
faces. Before building it into the fit, this asks whether the term can tell a better
surface from a worse one at all, on james-a,b and lps-a,b (``../shared/data/scan-cases``).

The term, for a surface (V, F) and cameras: area-uniform points P of the SPEC §6 nose
region with their normals N; in each photo v that sees P (depth test against the
rendered surface, 0.5 mm; ``N . (C_v - P) / |C_v - P| > 0.3``) the colour c_v(P)
(bilinear); each photo's colours scaled per channel to the front photo's mean over the
points both see (lighting differs by view); the inconsistency of P is the standard
deviation of its colours over the photos that see it (0-255), the figure the mean over
the points seen at least twice:

    E(V) = mean_P  sd_v { g_v * c_v(project_v(P)) }

Columns (the same photos throughout):

- ``truth, true cams``: the true face with the renderer's cameras (the floor: what the
  shading differences between views leave even for the right surface);
- ``recon``: naseview's reconstruction (ICT base) with stage 1's cameras;
- ``truth, est. cams``: the true face, rigidly aligned to the reconstruction's landmarks,
  with stage 1's cameras: what the term would score if the fit found the truth;
- ``recon -1 .. +1``: the reconstruction moved along its vertex normals by that many mm
  (negative: inwards);
- ``rho``: Spearman correlation over the reconstruction's points between their
  inconsistency and their distance to the aligned truth (a term that knows where the
  surface is wrong has rho well above 0).

A term worth fitting scores ``truth, est. cams`` below ``recon`` and has its minimum of
the offsets at 0 on every case. Measured (2026-12-04): it scores the true surface worse
than the reconstruction on both lps cases, prefers the nose shrunk by 1 mm on all four,
and rho is -0.27 .. +0.10: the term is not built into the fit.

    PYTHONPATH=. python benchmarks/bench_photo_consistency.py
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping
from pathlib import Path

import igl
import numpy as np
from _shared import use_shared_ict
from bench_real import REAL_CASES, SHARED, Runner
from scipy.stats import spearmanr

from naseview.camera import Camera
from naseview.case import read_case
from naseview.geometry.alignment import umeyama
from naseview.pipeline import PipelineParams
from naseview.reconstruction import read_reconstruction
from naseview.render import rasterize, visible_points
from naseview.testbed.surface import nose_surface_samples
from naseview.texture.bake import sample_image

OFFSETS_MM = (-1.0, -0.5, 0.5, 1.0)
FACING_COS = 0.3
DEPTH_TOL_MM = 0.5


def point_normals(V: np.ndarray, F: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(k, 3) unit normals of the triangles of (V, F) nearest the points P (k, 3)."""
    _, fi, _ = igl.point_mesh_squared_distance(P, V, F)
    return np.asarray(igl.per_face_normals(V, F, np.array([0.0, 0.0, 1.0])))[fi]


def inconsistency(V: np.ndarray, F: np.ndarray, cameras: Mapping[str, Camera],
                  photos: Mapping[str, np.ndarray], P: np.ndarray, N: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Per point of P (k, 3) with normals N (k, 3) on the surface (V, F): ((k,) colour
    standard deviation over the photos that see it, 0-255 after the per-view gains;
    (k,) bool seen by at least two photos). Module docstring."""
    cols, seen = [], []
    for v, cam in cameras.items():
        ok = visible_points(P, cam, rasterize(V, F, cam).depth, tol_mm=DEPTH_TOL_MM)
        ray = cam.center - P
        ray /= np.linalg.norm(ray, axis=1, keepdims=True)
        ok &= np.einsum("ij,ij->i", ray, N) > FACING_COS
        cols.append(sample_image(photos[v], cam.project(P)).astype(np.float64))
        seen.append(ok)
    C, S = np.array(cols), np.array(seen)                 # (v, k, 3), (v, k)
    for i in range(1, len(C)):                            # gains to the first (front) photo
        both = S[i] & S[0]
        if both.sum() > 20:
            C[i] *= C[0][both].mean(0) / np.maximum(C[i][both].mean(0), 1e-6)
    n = S.sum(0)
    mu = (C * S[..., None]).sum(0) / np.maximum(n, 1)[:, None]
    var = (((C - mu) ** 2).sum(2) * S).sum(0) / np.maximum(n - 1, 1)
    return np.sqrt(var), n >= 2


def figure(V: np.ndarray, F: np.ndarray, cameras: Mapping[str, Camera],
           photos: Mapping[str, np.ndarray], P: np.ndarray, N: np.ndarray) -> float:
    """E(V): the mean inconsistency over the points seen twice (module docstring)."""
    sd, two = inconsistency(V, F, cameras, photos, P, N)
    return float(sd[two].mean())


def measure_case(runner: Runner, d: Path) -> dict[str, float]:
    """The columns of the module docstring for the case folder ``d``."""
    res, _, truth = runner.run(d, "ict", PipelineParams())
    rec, case = res.reconstruction, read_case(d)
    true_cams = read_reconstruction(d / "truth.json").cameras
    cams = {v: rec.cameras[v] for v in rec.cameras if v in true_cams}
    photos = {v: case.load_image(v) for v in cams}
    assert res.face_vertices is not None and res.faces is not None
    V, F = res.face_vertices, res.faces
    Pt = truth.samples[::4]
    Nt = point_normals(truth.V, truth.F, Pt)
    out = {"truth, true cams": figure(truth.V, truth.F, {v: true_cams[v] for v in cams},
                                      photos, Pt, Nt)}
    Pr = nose_surface_samples(V, F, rec.landmarks, n_samples=5000)
    Nr = point_normals(V, F, Pr)
    out["recon"] = figure(V, F, cams, photos, Pr, Nr)
    ids = [k for k in rec.landmarks if k in truth.landmarks]
    _, R, t = umeyama(np.array([truth.landmarks[k] for k in ids]),
                      np.array([rec.landmarks[k] for k in ids]), with_scale=False)
    Vt = truth.V @ R.T + t
    out["truth, est. cams"] = figure(Vt, truth.F, cams, photos, Pt @ R.T + t, Nt @ R.T)
    Nv = np.asarray(igl.per_vertex_normals(V, F))
    for dl in OFFSETS_MM:
        out[f"recon {dl:+.1f}"] = figure(V + dl * Nv, F, cams, photos, Pr + dl * Nr, Nr)
    sd, two = inconsistency(V, F, cams, photos, Pr, Nr)
    dist = np.sqrt(igl.point_mesh_squared_distance(Pr, Vt, truth.F)[0])
    out["rho"] = float(spearmanr(sd[two], dist[two]).correlation)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--cases", default=",".join(REAL_CASES),
                    help="comma list of ../shared/data/scan-cases folders")
    args = ap.parse_args(argv)
    use_shared_ict()
    os.environ.setdefault("OMP_NUM_THREADS", "2")
    runner = Runner()
    rows = {c: measure_case(runner, SHARED / "scan-cases" / c)
            for c in args.cases.split(",") if c}
    cols = list(next(iter(rows.values())))
    print(f"{'case':10s}" + "".join(f"{c:>18s}" for c in cols))
    print("-" * (10 + 18 * len(cols)))
    for c, r in rows.items():
        print(f"{c:10s}" + "".join(f"{r[k]:>18.2f}" if k != "rho" else f"{r[k]:>+18.2f}"
                                   for k in cols))
    print("colour standard deviation over the photos seeing each nose point (0-255, mean); "
          "rho: Spearman(inconsistency, distance to the truth) over the reconstruction's "
          "points")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
