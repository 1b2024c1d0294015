"""What stage 2 (paper section 3.3) hands on: :class:`CurvesResult`.

Stage 3 reads ``curves``, ``ad_landmarks`` and ``ad_landmark_tags``; the app shows
``curves_2d``, ``flags``, ``warnings`` and ``evidence``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np

from naseview.stage2_curves.edges import EdgeMap
from naseview.stage2_curves.mask import Background


class ViewEvidence(TypedDict, total=False):
    """What one photo showed stage 2, for display (keys present when computed).

    Keys:
        background: :class:`~naseview.stage2_curves.mask.Background` of a side photo.
        mask: (H, W) bool foreground mask of a side photo (eq. 2).
        edges: :class:`~naseview.stage2_curves.edges.EdgeMap` of the nose region (eq. 11).
        nostril_threshold: value threshold (0..255) of the dark nostrils (bottom photo).
    """

    background: Background
    mask: np.ndarray
    edges: EdgeMap
    nostril_threshold: float


@dataclass
class CurvesResult:
    """Stage-2 result.

    Attributes:
        curves: SPEC §5 curve name -> (N, 3) polyline (mm), spacing ``curve_spacing_mm``;
            sills are closed loops starting at al'' (first point not repeated).
        curves_2d: curve name -> view -> (N, 2) the curve in that photo (px): the
            detected path, or the projection of the fallback where detection failed.
        anchors: curve name -> [(landmark id, index into ``curves[name]``)].
        ad_landmarks: (M, 3) the 21 landmarks then the sub-landmarks (M = 76 by default).
        ad_landmark_tags: M dicts ``{"id", "curve", "t", "between", "s"}``
            (:mod:`~naseview.stage2_curves.sublandmarks`; the ``reconstruction.json``
            record, SPEC §5).
        flags: curve name -> ``"image"`` (from the photos), ``"circle"`` (side-curve
            regression), ``"estimated"`` (one of its landmarks was not placed by stage 1
            and stands on its line of sight at an estimated depth), ``"partial"`` (some
            segments interpolated), ``"fallback"`` (interpolated) or ``"missing"`` (left
            out).
        warnings: one-line messages naming the curve and the photo.
        evidence: view -> :class:`ViewEvidence` for display.
        seconds: step name -> wall time (s) of this call.
    """

    curves: dict[str, np.ndarray] = field(default_factory=dict)
    curves_2d: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    anchors: dict[str, list[tuple[str, int]]] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ad_landmark_tags: list[dict[str, Any]] = field(default_factory=list)
    flags: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    evidence: dict[str, ViewEvidence] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
