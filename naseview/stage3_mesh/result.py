"""What stage 3 (paper §3.4) returns: the refined face and how it was made.

Everything is in the SPEC frame (mm, origin g, +x subject's left, +y up, +z anterior);
vertex ids index the face model's mesh (``FaceModel.mean``), which the refined face shares.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from naseview.facemodel import FaceModel
from naseview.stage3_mesh.correspondences import Correspondences
from naseview.stage3_mesh.deform import DeformReport, NoseDeformer
from naseview.stage3_mesh.fit import BaseFit


@dataclass
class RefineResult:
    """Stage 3 output.

    Attributes:
        V: (V, 3) refined face, mm, SPEC frame.
        F: (F, 3) int64 triangles (the model's).
        nose_vertex_ids: (N,) the model's nose region (what ``nose.ply`` holds).
        nose_faces: (M, 3) triangles of ``F`` with all corners in the nose region.
        region_vertex_ids: (R,) vertices ARAP may move (nose region grown around handles);
            the rest of ``V`` equals ``base_V``.
        base_V: (V, 3) the base face ARAP starts from: the morphable-model fit
            (``fit.vertices``) after the smooth warp.
        coefficients: (K,) identity coefficients of the fit.
        fit: the :class:`~naseview.stage3_mesh.fit.BaseFit`.
        handles: the :class:`~naseview.stage3_mesh.correspondences.Correspondences` used as
            hard constraints (vertex ids, targets, names).
        released: names of the ad-landmarks left out of the hard constraints
            (``params.release_mm``).
        deformer: the :class:`~naseview.stage3_mesh.deform.NoseDeformer`, ready for
            re-solves with moved handles (``None`` without ARAP and smoothing).
        report: the :class:`~naseview.stage3_mesh.deform.DeformReport` of the solve
            (``None`` without ARAP and smoothing).
        warnings: one line each (fit, correspondences, deformation).
        seconds: {"fit", "warp", "correspondences", "precompute", "arap", "smooth"} -> s.
        model_name: the face model's name (``"ict"``, ``"generic"``...).
        credit: the face model's attribution line (show it with the mesh).
        model: the :class:`~naseview.facemodel.FaceModel` used.
    """

    V: np.ndarray
    F: np.ndarray
    nose_vertex_ids: np.ndarray
    nose_faces: np.ndarray
    region_vertex_ids: np.ndarray
    base_V: np.ndarray
    coefficients: np.ndarray
    fit: BaseFit
    handles: Correspondences
    released: list[str]
    deformer: NoseDeformer | None
    report: DeformReport | None
    warnings: list[str]
    seconds: dict[str, float]
    model_name: str = ""
    credit: str = ""
    model: FaceModel | None = None
