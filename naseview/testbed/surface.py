"""Nose surface error against a ground-truth mesh, and the stage-3 ablation (SPEC §6).

The paper reports landmark distances only; naseview also measures the refined surface of
stage 3 (paper §3.4) on synthetic cases whose true face is known (``truth_face.ply``):

- :func:`nose_surface_samples` - area-uniform points of the true external nose;
- :func:`surface_error` - their distances to the reconstructed mesh after rigid landmark
  alignment;
- :data:`ABLATION_ROWS` and :func:`ablation` - the same error for the paper's steps and
  naseview's additions, each a change of :class:`~naseview.stage3_mesh.RefineParams`.

Used by ``naseview evaluate`` (:mod:`naseview.testbed.evaluate`) and
``benchmarks/bench_stage3.py``. SPEC frame, mm.

Example
-------
    S = nose_surface_samples(truth_V, truth_F, truth_landmarks)
    surface_error(truth_V, truth_F, truth_landmarks, res.V, res.F,
                  rec.landmarks, samples=S)["mean_mm"]
    # -> 0.35
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from typing import Any

import igl
import numpy as np

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.geometry.alignment import umeyama
from naseview.geometry.mesh import face_normals
from naseview.geometry.occlusion import occlusion
from naseview.geometry.polygon import points_in_polygon
from naseview.landmarks import LANDMARK_IDS
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh import RefineParams, refine

NOSE_OUTLINE: tuple[str, ...] = ("mf_r", "mf_l", "int_l", "al_l", "ac_l", "sn", "ac_r",
                                 "al_r", "int_r")
"""Landmarks whose frontal (x, y) outline bounds the nose region of a ground-truth mesh."""


def _open_nose_triangles(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                         max_occlusion: float) -> tuple[np.ndarray, np.ndarray]:
    """Ids of the triangles inside the nose outline with ambient occlusion at most
    ``max_occlusion``, and the (m,) areas of all triangles (mm^2)."""
    poly = np.array([np.asarray(landmarks[k], float)[:2] for k in NOSE_OUTLINE])
    C = V[F].mean(1)
    N = face_normals(V, F)
    area = 0.5 * np.linalg.norm(N, axis=1)
    keep = np.flatnonzero(points_in_polygon(C[:, :2], poly) & (area > 0))
    if len(keep):
        Nu = N[keep] / (2 * area[keep])[:, None]
        keep = keep[occlusion(V, F, C[keep], Nu) <= max_occlusion]
    return keep, area


def nose_surface_samples(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                         n_samples: int = 20000, seed: int = 0,
                         max_occlusion: float = 0.6) -> np.ndarray:
    """Area-uniform random points of the external nose surface of a (ground-truth) face.

    The nose is the part of the surface whose frontal projection (x, y) lies inside the
    outline :data:`NOSE_OUTLINE` (mf_r, mf_l, int_l, al_l, ac_l, sn, ac_r, al_r, int_r);
    of it only the open surface counts: triangles whose ambient occlusion (libigl, embree,
    64 rays from the centroid) is at most ``max_occlusion``, which leaves out the nostril
    cavities (occlusion about 0.9) that no photo shows and no base face models alike.

    Args:
        V, F: (n, 3) mm / (m, 3) int, the mesh in the SPEC frame.
        landmarks: id -> (3,) on that mesh (all of :data:`NOSE_OUTLINE`).
        n_samples: number of points.
        seed: random seed (fixed: the same points every run).
        max_occlusion: largest ambient occlusion (0 open .. 1 enclosed) of a kept triangle.
    Returns:
        (n_samples, 3) points, mm.
    Raises:
        NaseviewError: an outline landmark is missing, or no triangle is inside it.
    """
    missing = [k for k in NOSE_OUTLINE if k not in landmarks]
    if missing:
        raise NaseviewError(f"truth.json: key 'landmarks' lacks {', '.join(missing)}, needed "
                            "to outline the nose for the surface error")
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    keep, area = _open_nose_triangles(V, F, landmarks, max_occlusion)
    if not len(keep):
        raise NaseviewError("truth_face.ply: no open triangle inside the nose outline of the "
                            "truth landmarks; is the mesh in the SPEC frame?")
    rng = np.random.default_rng(seed)
    pick = keep[rng.choice(len(keep), n_samples, p=area[keep] / area[keep].sum())]
    r1, r2 = rng.random(n_samples), rng.random(n_samples)
    s = np.sqrt(r1)
    bary = np.c_[1 - s, s * (1 - r2), s * r2]
    return np.asarray(np.einsum("ij,ijk->ik", bary, V[F[pick]]))


def surface_error(truth_V: np.ndarray, truth_F: np.ndarray,
                  truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray, F: np.ndarray,
                  landmarks: Mapping[str, np.ndarray], n_samples: int = 20000,
                  samples: np.ndarray | None = None) -> dict[str, float]:
    """Nose surface error (SPEC §6): truth nose samples to the reconstructed mesh.

    The reconstruction is first moved rigidly (Kabsch on the landmarks both have) onto the
    truth; then the distance from each ground-truth nose sample
    (:func:`nose_surface_samples`) to the nearest point of the reconstructed mesh
    (``igl.point_mesh_squared_distance``).

    Args:
        truth_V, truth_F: ground-truth face mesh (SPEC frame, mm).
        truth_landmarks: id -> (3,) true landmarks.
        V, F: reconstructed face mesh (mm).
        landmarks: id -> (3,) reconstructed landmarks (same frame as V).
        n_samples: ground-truth samples (when ``samples`` is not given).
        samples: optional precomputed (k, 3) truth samples.
    Returns:
        ``{"mean_mm", "p95_mm", "max_mm", "rigid_rmse_mm"}``.
    Raises:
        NaseviewError: fewer than 3 landmarks in common.
    """
    common = [k for k in LANDMARK_IDS if k in truth_landmarks and k in landmarks]
    if len(common) < 3:
        raise NaseviewError("surface error: fewer than 3 landmarks shared by the "
                            "reconstruction and truth.json")
    X = np.array([np.asarray(landmarks[k], float) for k in common])
    Y = np.array([np.asarray(truth_landmarks[k], float) for k in common])
    s, R, t = umeyama(X, Y, with_scale=False)
    rmse = float(np.sqrt(np.mean(np.sum((X @ R.T + t - Y) ** 2, axis=1))))
    Va = np.ascontiguousarray(np.asarray(V, float) @ R.T + t)
    P = samples if samples is not None else nose_surface_samples(
        truth_V, truth_F, truth_landmarks, n_samples)
    d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(P, dtype=np.float64), Va,
                                               np.ascontiguousarray(F, dtype=np.int64))
    d = np.sqrt(d2)
    return {"mean_mm": float(d.mean()), "p95_mm": float(np.percentile(d, 95)),
            "max_mm": float(d.max()), "rigid_rmse_mm": rmse}


_PAPER: dict[str, Any] = {"use_warp": False, "release_mm": float("inf"),
                          "sub_landmark_curves": None, "smooth_displacement": False}

# field name -> value keyword arguments of dataclasses.replace (RefineParams checks them)
ABLATION_ROWS: dict[str, dict[str, Any]] = {
    "fit": {**_PAPER, "use_arap": False, "use_smoothing": False, "use_sublandmarks": False},
    "arap21": {**_PAPER, "use_smoothing": False, "use_sublandmarks": False},
    "arap76": {**_PAPER, "use_smoothing": False},
    "arap76+smooth": {**_PAPER},
    "fit+warp": {"use_arap": False, "use_smoothing": False},
    "naseview-all76": {"sub_landmark_curves": None},
    "naseview": {},
}
"""The issue-5 comparison, each a change of :class:`~naseview.stage3_mesh.RefineParams`.
The paper's steps: morphable-model fit only (21 landmarks); + ARAP with the 21 landmarks;
+ ARAP with all 76 ad-landmarks; + cotangent smoothing of the positions. Then naseview's:
the fit bent smoothly towards the ad-landmarks (no ARAP); the default pipeline with all 76
ad-landmarks; and the default pipeline (warp, ARAP with the consistent handles of the
mid- and ala-curves, smoothing of the displacement)."""


def ablation(model: FaceModel, reconstruction: Reconstruction, truth_V: np.ndarray,
             truth_F: np.ndarray, truth_landmarks: Mapping[str, np.ndarray],
             params: RefineParams | None = None,
             samples: np.ndarray | None = None) -> dict[str, dict[str, float]]:
    """Surface error of each :data:`ABLATION_ROWS` variant of stage 3 on one case.

    Args:
        model: base face model.
        reconstruction: stage 1(-2) result (landmarks, ad-landmarks).
        truth_V, truth_F, truth_landmarks: ground truth (``truth_face.ply``, ``truth.json``).
        params: the other stage-3 parameters (default :class:`RefineParams`).
        samples: optional precomputed truth nose samples (:func:`nose_surface_samples`).
    Returns:
        row name -> :func:`surface_error` dict plus ``"seconds"``.
    """
    params = params or RefineParams()
    if samples is None:
        samples = nose_surface_samples(truth_V, truth_F, truth_landmarks)
    out: dict[str, dict[str, float]] = {}
    for row, kw in ABLATION_ROWS.items():
        t = time.perf_counter()
        res = refine(model, reconstruction, dataclasses.replace(params, **kw))
        e = surface_error(truth_V, truth_F, truth_landmarks, res.V, res.F,
                          reconstruction.landmarks, samples=samples)
        e["seconds"] = time.perf_counter() - t
        out[row] = e
    return out
