"""The ARAP handles: each ad-landmark to a vertex of the base mesh (paper §3.4, eq. 19-20).

The paper deforms the base face so that its vertices at the ad-landmarks (the 21 landmarks
and stage 2's sub-landmarks on the boundary curves, §3.3) reach them. The 21 landmarks
name their vertex (``FaceModel.landmark_vertices``); a sub-landmark goes to the vertex of
the matching mesh curve at the same arc-length fraction
(:mod:`~naseview.stage3_mesh.curve_fractions`). SPEC frame, mm.

Example
-------
    handles, warnings = correspondences(model, fit.vertices, rec.landmarks,
                                        rec.ad_landmarks, rec.ad_landmark_tags)
    handles.vertex_ids.shape, handles.targets.shape
    # -> ((44,), (44, 3))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from naseview.facemodel import FaceModel
from naseview.stage3_mesh.curve_fractions import (
    AdLandmarkTag,
    SubRow,
    orient_loops,
    sub_positions,
    sub_rows,
)
from naseview.stage3_mesh.params import RefineParams


@dataclass
class Correspondences:
    """Handles: ad-landmark -> base-mesh vertex.

    Attributes:
        vertex_ids: (H,) int64 distinct vertex ids of the base mesh.
        targets: (H, 3) where those vertices must go, mm.
        names: H labels: a landmark id, or the sub-landmark's tag id (``"mid.03"``; else
            ``"<curve>@<fraction>"``).
        is_landmark: (H,) bool.
    """

    vertex_ids: np.ndarray
    targets: np.ndarray
    names: list[str]
    is_landmark: np.ndarray

    def subset(self, keep: np.ndarray) -> Correspondences:
        """The handles where ``keep`` (H,) bool is true, in order."""
        return Correspondences(self.vertex_ids[keep], self.targets[keep],
                               [n for n, k in zip(self.names, keep, strict=True) if k],
                               self.is_landmark[keep])


@dataclass
class _Handles:
    """Handles being collected (landmarks first); ``landmark_at``: vertex -> landmark."""

    ids: list[int] = field(default_factory=list)
    targets: list[np.ndarray] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    is_lm: list[bool] = field(default_factory=list)
    landmark_at: set[int] = field(default_factory=set)

    def add(self, v: int, target: np.ndarray, name: str, is_landmark: bool) -> None:
        self.ids.append(v)
        self.targets.append(target)
        self.names.append(name)
        self.is_lm.append(is_landmark)

    def result(self) -> Correspondences:
        return Correspondences(np.asarray(self.ids, np.int64),
                               np.asarray(self.targets, np.float64).reshape(-1, 3),
                               self.names, np.asarray(self.is_lm, bool))


@dataclass
class _Merged:
    """Sub-landmarks falling on one vertex: the sum of their targets, how many, the first
    one's name."""

    total: np.ndarray
    count: int
    name: str


def _landmark_handles(model: FaceModel, landmarks: Mapping[str, np.ndarray],
                      params: RefineParams, out: _Handles) -> None:
    """The landmarks of ``params.handle_landmarks`` at their model vertices (the first of
    two on one vertex wins)."""
    for lm in params.handle_landmarks:
        p = landmarks.get(lm)
        v = model.landmark_vertices.get(lm)
        if p is None or v is None or not np.isfinite(np.asarray(p, float)).all():
            continue
        if int(v) in out.landmark_at:
            continue
        out.landmark_at.add(int(v))
        out.add(int(v), np.asarray(p, np.float64).reshape(3), lm, True)


def _merge_on_vertices(model: FaceModel, V_base: np.ndarray, rows: list[SubRow],
                       landmark_at: set[int]) -> dict[int, _Merged]:
    """Each sub-landmark on the nearer of its two path vertices, averaged per vertex.

    Its target is the sub-landmark plus the vertex's offset from the exact curve point, so
    the vertex moves as that point does (no slip along the curve). Vertices of a landmark
    are skipped.
    """
    merged: dict[int, _Merged] = {}
    for r, (i, j, a) in zip(rows, sub_positions(model, V_base, rows), strict=True):
        v = i if a < 0.5 else j
        if v in landmark_at:
            continue
        if v not in merged:
            merged[v] = _Merged(np.zeros(3), 0, r.name)
        # the vertex moves as the curve point at the fraction does (no tangential slip)
        on_curve = (1 - a) * V_base[i] + a * V_base[j]
        merged[v].total = merged[v].total + r.target + (V_base[v] - on_curve)
        merged[v].count += 1
    return merged


def _sublandmark_handles(model: FaceModel, V_base: np.ndarray,
                         ad_landmarks: np.ndarray | None,
                         tags: Sequence[AdLandmarkTag] | None, params: RefineParams,
                         out: _Handles) -> list[str]:
    """Stage 2's sub-landmarks on ``params.sub_landmark_curves`` as handles, those closer
    than ``params.min_handle_spacing_mm`` to an earlier handle left out. Returns warnings."""
    rows, warnings = sub_rows(model, ad_landmarks, tags, params.sub_landmark_curves)
    orient_loops(model, V_base, rows)
    for v, m in _merge_on_vertices(model, V_base, rows, out.landmark_at).items():
        # sub-landmarks right beside another handle only add conflicting noise (and can
        # fold the triangles between the two): keep the first, a landmark first of all
        near = np.linalg.norm(V_base[out.ids] - V_base[v], axis=1) if out.ids else np.zeros(0)
        if len(near) and near.min() < params.min_handle_spacing_mm:
            continue
        out.add(v, m.total / m.count, m.name, False)
    return warnings


def correspondences(model: FaceModel, V_base: np.ndarray,
                    landmarks: Mapping[str, np.ndarray],
                    ad_landmarks: np.ndarray | None = None,
                    ad_landmark_tags: Sequence[AdLandmarkTag] | None = None,
                    params: RefineParams | None = None) -> tuple[Correspondences, list[str]]:
    """Each ad-landmark to a vertex of the base mesh (the ARAP handles).

    The 21 landmarks go to ``model.landmark_vertices``. A sub-landmark (stage 2 tag
    ``{"curve", "t", "between": [a, b], "s"}``) goes to the vertex of
    ``model.curve_vertices[curve]`` nearest to the same arc-length fraction ``s`` of the
    path between a's and b's vertices on ``V_base`` (without ``between``: fraction ``t`` of
    the whole curve). Its target is the sub-landmark plus the vertex's offset from the
    exact curve point at that fraction, so the vertex moves as that point does (no slip
    along the curve). Several ad-landmarks on one vertex: a landmark wins, sub-landmarks
    are averaged.

    Args:
        model: the face model (its annotations).
        V_base: (V, 3) fitted base face, mm.
        landmarks: id -> (3,) the 21 landmarks (any subset).
        ad_landmarks, ad_landmark_tags: stage 2's (M, 3) ad-landmarks and their M tags.
        params: :class:`RefineParams` (``handle_landmarks``, ``use_sublandmarks``).
    Returns:
        ``(Correspondences, warnings)``.
    """
    params = params or RefineParams()
    out = _Handles()
    _landmark_handles(model, landmarks, params, out)
    warnings: list[str] = []
    if params.use_sublandmarks:
        warnings = _sublandmark_handles(model, V_base, ad_landmarks, ad_landmark_tags, params,
                                        out)
    return out.result(), warnings
