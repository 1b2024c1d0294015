"""Editable baselines: what the editor starts from, built from a pipeline result, a face
model's shape or a ``naseview reconstruct`` output folder (SPEC §5). No viser here."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from naseview.editing.state import Baseline
from naseview.errors import NaseviewError
from naseview.measurements import clinical_measurements
from naseview.meshio import read_mesh
from naseview.reconstruction import Reconstruction, read_reconstruction
from naseview.stage2_curves.params import DEFAULT_SUB_LANDMARKS


def baseline_from_pipeline(result: Any) -> Baseline:
    """A :class:`Baseline` from a :class:`naseview.pipeline.PipelineResult`.

    Raises:
        NaseviewError: the result has no face mesh (stage 3 did not run).
    """
    rec: Reconstruction = result.reconstruction
    if getattr(result, "face_vertices", None) is None or getattr(result, "faces", None) is None:
        raise NaseviewError("reconstruction: stage 3 produced no face mesh; run all three "
                            "stages (--stages 1,2,3)")
    V = np.asarray(result.face_vertices, np.float64)
    F = np.asarray(result.faces, np.int64)
    nose = np.asarray(result.nose_vertex_ids, np.int64)
    meas = dict(rec.measurements) or clinical_measurements(rec.landmarks, rec.curves or None,
                                                           V, F)
    return Baseline(V, F, nose, {k: np.asarray(v, np.float64) for k, v in
                                 rec.landmarks.items()},
                    {k: np.asarray(c, np.float64).reshape(-1, 3) for k, c in
                     rec.curves.items()},
                    np.asarray(rec.ad_landmarks, np.float64).reshape(-1, 3), meas, rec)


def baseline_from_face_model(model: Any, coeffs: np.ndarray | None = None) -> Baseline:
    """A face model's shape as an editable :class:`Baseline` (no photos needed).

    The face ``model.shape(coeffs)`` is moved so that glabella ``g`` is the origin (SPEC
    frame); landmarks are its annotated vertices, curves its annotated vertex paths, and
    the ad-landmarks the 21 landmarks plus points at even arc-length fractions of each
    curve (stage 2's default counts).
    """
    V = model.shape(coeffs)
    V = V - V[model.landmark_vertices["g"]]
    F = np.asarray(model.faces, np.int64)
    lms = {k: V[i].copy() for k, i in model.landmark_vertices.items()}
    curves: dict[str, np.ndarray] = {}
    for name, path in model.curve_vertices.items():
        P = V[np.asarray(path, np.int64)]
        curves[name] = np.concatenate([P, P[:1]]) if name.startswith("sill") else P
    counts = DEFAULT_SUB_LANDMARKS
    ad = [lms[k] for k in lms]
    for name, P in curves.items():
        n = int(counts.get(name, 3))
        seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
        cum = np.r_[0.0, np.cumsum(seg)]
        if cum[-1] <= 0 or n <= 0:
            continue
        t = cum[-1] * (np.arange(1, n + 1) / (n + 1))
        ad += list(np.column_stack([np.interp(t, cum, P[:, k]) for k in range(3)]))
    return Baseline(V, F, np.asarray(model.nose_vertices, np.int64), lms, curves,
                    np.array(ad), clinical_measurements(lms, curves, V, F))


def baseline_from_output_dir(out_dir: Path) -> Baseline:
    """A :class:`Baseline` from ``naseview reconstruct`` output (SPEC §5).

    Raises:
        NaseviewError: a file is missing or the nose mesh does not match the face mesh.
    """

    rec = read_reconstruction(out_dir / "reconstruction.json")
    for name in ("face.ply", "nose.ply"):
        if not (out_dir / name).is_file():
            raise NaseviewError(f"{out_dir / name}: file not found; re-run `naseview "
                                f"reconstruct CASE -o {out_dir}` (stage 3 writes it)")
    V, F = read_mesh(out_dir / "face.ply")
    Vn, _ = read_mesh(out_dir / "nose.ply")
    d, ids = cKDTree(V).query(Vn)
    if len(d) and float(d.max()) > 1e-4:
        raise NaseviewError(f"{out_dir / 'nose.ply'}: its vertices are not vertices of "
                            "face.ply; re-run `naseview reconstruct` to write both")
    meas = dict(rec.measurements) or clinical_measurements(rec.landmarks, rec.curves or None,
                                                           V, F)
    return Baseline(V, F, np.unique(ids).astype(np.int64),
                    {k: np.asarray(v, np.float64) for k, v in rec.landmarks.items()},
                    {k: np.asarray(c, np.float64).reshape(-1, 3) for k, c in rec.curves.items()},
                    np.asarray(rec.ad_landmarks, np.float64).reshape(-1, 3), meas, rec)
