"""Nose surface error against a ground-truth mesh, and the stage-3 ablation (SPEC §6).

The paper reports landmark distances only; naseview also measures the refined surface of
stage 3 (paper §3.4) on synthetic cases whose true face is known (``truth_face.ply``):

- :func:`nose_region` - the nose region of a truth mesh (SPEC §6: a box from the truth
  landmarks, forward-facing triangles, their ambient occlusion); the one definition of
  the nose that the surface error and the region figures (:mod:`.regions`) share;
- :func:`nose_surface_samples` - area-uniform points of its open part (the true
  external nose; works on a whole-head truth mesh);
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
from dataclasses import dataclass
from typing import Any

import igl
import numpy as np

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.geometry.alignment import umeyama
from naseview.geometry.mesh import face_normals
from naseview.geometry.occlusion import occlusion
from naseview.landmarks import LANDMARK_IDS
from naseview.reconstruction import Reconstruction
from naseview.stage3_mesh import RefineParams, refine

NOSE_REGION_LANDMARKS: tuple[str, ...] = ("n", "sn", "al_l", "al_r", "ac_l", "ac_r")
"""The truth landmarks that bound the nose region (:func:`nose_region`)."""

REGION_MARGIN_MM = 3.0
"""How far the nose region reaches past its landmarks (SPEC §6), mm."""

FORWARD_MIN_NZ = -0.2
"""Smallest z of a kept triangle's unit normal (SPEC §6: facing forward)."""

MAX_OCCLUSION = 0.6
"""Largest ambient occlusion of an open (headline) nose triangle (SPEC §6)."""

OCCLUSION_RAYS = 64
"""Rays of the ambient occlusion at each triangle's centroid."""


@dataclass(frozen=True)
class NoseRegion:
    """The nose region of a (ground-truth) mesh, SPEC §6, before the openness test.

    Attributes:
        triangles: (k,) ids of the triangles in the box, facing forward, area > 0.
        area: (k,) their areas, mm^2.
        normals: (k, 3) their unit normals.
        occlusion: (k,) ambient occlusion at their centroids (0 open .. 1 enclosed).
    """

    triangles: np.ndarray
    area: np.ndarray
    normals: np.ndarray
    occlusion: np.ndarray

    @property
    def open(self) -> np.ndarray:
        """(k,) bool: the triangles of the SPEC §6 region (occlusion <= 0.6)."""
        return np.asarray(self.occlusion <= MAX_OCCLUSION)


def region_box(landmarks: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The nose box of SPEC §6 as ``(lo, hi)`` (3,) each, mm: x within ``|al_l.x - al_r.x|
    / 2 + 3`` of ``(al_l.x + al_r.x) / 2``, y from ``sn.y - 3`` to ``n.y + 3``, z in front
    of ``min(ac_l.z, ac_r.z) - 3`` (``hi.z`` is +inf). ``landmarks`` holds
    :data:`NOSE_REGION_LANDMARKS`."""
    lm = {k: np.asarray(landmarks[k], float) for k in NOSE_REGION_LANDMARKS}
    m = REGION_MARGIN_MM
    cx = 0.5 * (lm["al_l"][0] + lm["al_r"][0])
    hw = 0.5 * abs(lm["al_l"][0] - lm["al_r"][0]) + m
    lo = np.array([cx - hw, lm["sn"][1] - m, min(lm["ac_l"][2], lm["ac_r"][2]) - m])
    hi = np.array([cx + hw, lm["n"][1] + m, np.inf])
    return lo, hi


def in_region_box(P: np.ndarray, landmarks: Mapping[str, np.ndarray]) -> np.ndarray:
    """(n,) bool: points ``P`` (n, 3) inside :func:`region_box`."""
    lo, hi = region_box(landmarks)
    P = np.asarray(P, float).reshape(-1, 3)
    return np.asarray(((P >= lo) & (P <= hi)).all(axis=1))


def nose_region(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                source: str = "truth.json") -> NoseRegion:
    """The triangles of the nose region of SPEC §6, with their occlusion.

    A triangle belongs when its centroid is in :func:`region_box` (between ``sn.y - 3``
    and ``n.y + 3`` in height, within ``|al_l.x - al_r.x| / 2 + 3`` of the alae's middle
    across, in front of ``min(ac_l.z, ac_r.z) - 3``) and its unit normal faces forward
    (``z > -0.2``). So it holds the radix up to nasion, the alar-facial grooves and the
    nostril sills, and a truth mesh that is a whole head gives nothing from its back.
    The ambient occlusion at each centroid (:func:`naseview.geometry.occlusion.occlusion`,
    64 rays) tells the open surface (SPEC §6: at most 0.6, :attr:`NoseRegion.open`) from
    the nostril cavities. The one definition of the nose of a truth mesh: the surface
    error (:func:`nose_surface_samples`) and the region figures
    (:mod:`naseview.testbed.regions`) both use it.

    Args:
        V, F: (n, 3) mm / (m, 3) int, the mesh in the SPEC frame.
        landmarks: id -> (3,) on that mesh (all of :data:`NOSE_REGION_LANDMARKS`).
        source: the file the landmarks come from, named in the error.
    Raises:
        NaseviewError: a landmark of :data:`NOSE_REGION_LANDMARKS` is missing.
    """
    missing = [k for k in NOSE_REGION_LANDMARKS if k not in landmarks]
    if missing:
        raise NaseviewError(f"{source}: key 'landmarks' lacks {', '.join(missing)}, needed "
                            "to bound the nose region for the surface error (SPEC §6)")
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    C = V[F].mean(1)
    N = face_normals(V, F)
    area = 0.5 * np.linalg.norm(N, axis=1)
    keep = np.flatnonzero(in_region_box(C, landmarks) & (area > 0))
    Nu = N[keep] / (2 * area[keep])[:, None]
    fwd = Nu[:, 2] > FORWARD_MIN_NZ
    keep, Nu = keep[fwd], Nu[fwd]
    ao = occlusion(V, F, C[keep], Nu, OCCLUSION_RAYS) if len(keep) else np.zeros(0)
    return NoseRegion(keep, area[keep], Nu, ao)


def sample_triangles(V: np.ndarray, F: np.ndarray, triangles: np.ndarray, area: np.ndarray,
                     n_samples: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Area-uniform random points on the ``triangles`` (k,) of (V, F) with ``area`` (k,):
    ``((n_samples, 3) points, (n_samples,) index into triangles)``; fixed ``seed``."""
    rng = np.random.default_rng(seed)
    k = rng.choice(len(triangles), n_samples, p=area / area.sum())
    r1, r2 = rng.random(n_samples), rng.random(n_samples)
    s = np.sqrt(r1)
    bary = np.c_[1 - s, s * (1 - r2), s * r2]
    P = np.einsum("ij,ijk->ik", bary, np.asarray(V, float)[np.asarray(F)[triangles[k]]])
    return np.asarray(P), k


def nose_surface_samples(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                         n_samples: int = 20000, seed: int = 0,
                         source: str = "truth.json",
                         mesh_source: str = "truth_face.ply") -> np.ndarray:
    """Area-uniform random points of the external nose surface of a (ground-truth) face.

    The open triangles of :func:`nose_region` (SPEC §6): in the nose box, facing forward,
    ambient occlusion at most 0.6 (the nostril cavities, about 0.9, that no photo shows
    and no base face models alike are left out).

    Args:
        V, F: (n, 3) mm / (m, 3) int, the mesh in the SPEC frame.
        landmarks: id -> (3,) on that mesh (all of :data:`NOSE_REGION_LANDMARKS`).
        n_samples: number of points.
        seed: random seed (fixed: the same points every run).
        source, mesh_source: the files of the landmarks and the mesh, named in errors.
    Returns:
        (n_samples, 3) points, mm.
    Raises:
        NaseviewError: a region landmark is missing, or no open triangle is in the region.
    """
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    reg = nose_region(V, F, landmarks, source)
    ok = reg.open
    if not ok.any():
        raise NaseviewError(f"{mesh_source}: no open forward-facing triangle in the nose "
                            f"region of the landmarks of {source}; is the mesh in the SPEC "
                            "frame?")
    return sample_triangles(V, F, reg.triangles[ok], reg.area[ok], n_samples, seed)[0]


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
