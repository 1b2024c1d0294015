"""One call of stage 2: its inputs, timing, warnings and the assembly of an open curve.

:class:`CurveRun` holds what every curve reads (the photos and their cache keys, the 2D
landmark anchors per photo, the stage-1 landmarks and cameras, the parameters) and
collects what it produces into a :class:`~naseview.stage2_curves.result.CurvesResult`.
The curves themselves are made in :mod:`~naseview.stage2_curves.curve_mid`,
:mod:`~naseview.stage2_curves.curve_edges`, :mod:`~naseview.stage2_curves.curve_sills`
and :mod:`~naseview.stage2_curves.curve_side`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from itertools import pairwise

import numpy as np

from naseview.camera import Camera
from naseview.case import Case
from naseview.geometry.polyline import polyline_length, resample_by_count
from naseview.landmarks import ALL_IDS, CURVE_LANDMARKS, CURVE_VIEWS, HELPER_IDS
from naseview.stage2_curves.cache import StepCache, digest
from naseview.stage2_curves.fallback import catmull_rom_segments
from naseview.stage2_curves.params import CurveParams
from naseview.stage2_curves.result import CurvesResult

Segment = tuple[str, str, np.ndarray]
"""(landmark a, landmark b, (n, 3) polyline from a to b in mm)."""


def anchors_2d(case: Case, view: str, landmarks: Mapping[str, np.ndarray],
               camera: Camera | None) -> dict[str, np.ndarray]:
    """Landmark id -> (2,) px in ``view``: the click, else the reprojected 3D landmark."""
    out: dict[str, np.ndarray] = {}
    clicks = case.views[view].landmarks if view in case.views else {}
    for lid in ALL_IDS:
        if lid in clicks:
            out[lid] = np.asarray(clicks[lid], dtype=np.float64)
        elif camera is not None and lid in landmarks:
            out[lid] = camera.project(np.asarray(landmarks[lid]).reshape(1, 3))[0]
    return out


def photo_label(case: Case, view: str) -> str:
    """``photo 'front' (front.jpg)``: how warnings name a photo."""
    return f"photo {view!r} ({case.views[view].image})" if view in case.views else \
        f"photo {view!r}"


def _resample_segment(P: np.ndarray, spacing: float) -> np.ndarray:
    """(m, D) points at most ``spacing`` apart along P (N, D), at least its two ends."""
    n = max(2, int(np.ceil(polyline_length(P) / spacing)) + 1)
    return resample_by_count(P, n)


def assemble(segments: Sequence[Segment],
             spacing: float) -> tuple[np.ndarray, list[tuple[str, int]]]:
    """Join (a, b, (n, 3)) segments into one (N, 3) polyline with landmark indices.

    Returns:
        the polyline resampled every ``spacing`` mm per segment, and
        [(landmark id, index into the polyline)] of the segment ends in order.
    """
    pts: list[np.ndarray] = []
    anchors: list[tuple[str, int]] = []
    for i, (a, b, P) in enumerate(segments):
        Q = _resample_segment(P, spacing)
        if i == 0:
            anchors.append((a, 0))
            pts.append(Q)
        else:
            pts.append(Q[1:])
        anchors.append((b, sum(len(p) for p in pts) - 1))
    return (np.vstack(pts) if pts else np.zeros((0, 3))), anchors


class CurveRun:
    """The inputs and the growing result of one :func:`~naseview.stage2_curves.extract_curves`.

    Attributes:
        case: the case (clicks, photo names).
        params: the stage's tunables.
        cache: step cache shared between calls.
        L3: landmark id -> (3,) mm: stage 1's landmarks plus the ``estimated`` ones.
        estimated: landmarks stood on their line of sight (not placed by stage 1).
        cams: view -> stage-1 camera.
        res: the result being filled in.
    """

    def __init__(self, case: Case, images: Mapping[str, np.ndarray] | None,
                 landmarks: Mapping[str, np.ndarray], estimated: set[str],
                 cameras: Mapping[str, Camera], params: CurveParams,
                 cache: StepCache) -> None:
        self.case = case
        self.params = params
        self.cache = cache
        self.L3 = dict(landmarks)
        self.estimated = set(estimated)
        self.cams = dict(cameras)
        self.res = CurvesResult()
        self._images = dict(images) if images else {}
        self._img_keys: dict[str, str] = {}
        self._anchors: dict[str, dict[str, np.ndarray]] = {}

    # inputs, read once per call
    def image(self, view: str) -> np.ndarray:
        """(H, W, 3) uint8 BGR photo of ``view`` (read from the case on first use)."""
        if view not in self._images:
            self._images[view] = self.case.load_image(view)
        return self._images[view]

    def image_key(self, view: str) -> str:
        """Digest of the photo's pixels (part of every cache key reading it)."""
        if view not in self._img_keys:
            self._img_keys[view] = digest(self.image(view))
        return self._img_keys[view]

    def anchors(self, view: str) -> dict[str, np.ndarray]:
        """:func:`anchors_2d` of ``view`` (empty when the case has no such photo)."""
        if view not in self.case.views:
            return {}
        if view not in self._anchors:
            self._anchors[view] = anchors_2d(self.case, view, self.L3, self.cams.get(view))
        return self._anchors[view]

    # reporting
    def warn(self, curve: str, view: str, reason: str, consequence: str) -> None:
        """Add ``"<curve>: photo '<view>' (<file>): <reason>; <consequence>"``."""
        self.res.warnings.append(
            f"{curve}: {photo_label(self.case, view)}: {reason}; {consequence}")

    def timed(self, name: str, t0: float) -> None:
        """Add the wall time since ``t0`` to step ``name``."""
        self.res.seconds[name] = self.res.seconds.get(name, 0.0) + time.perf_counter() - t0

    # the landmarks of a curve and its interpolation
    def landmark_chain(self, curve: str) -> list[str]:
        """The curve's landmarks placed in 3D, in curve order (helpers left out)."""
        return [lid for lid in CURVE_LANDMARKS[curve] if lid not in HELPER_IDS and lid in self.L3]

    def left_out(self, curve: str) -> bool:
        """Flag and warn when fewer than two of the curve's landmarks could be placed."""
        chain = self.landmark_chain(curve)
        if len(chain) >= 2:
            return False
        lost = [i for i in CURVE_LANDMARKS[curve] if i not in HELPER_IDS and i not in self.L3]
        self.res.warnings.append(f"{curve}: landmarks {', '.join(lost)} could not be placed "
                                 "in 3D; the curve is left out")
        self.res.flags[curve] = "missing"
        return True

    def fallback_segments(self, curve: str) -> dict[tuple[str, str], np.ndarray]:
        """(a, b) -> (32, 3) Catmull-Rom segment through the curve's 3D landmarks."""
        chain = self.landmark_chain(curve)
        segs = catmull_rom_segments(np.array([self.L3[i] for i in chain]), 32)
        return {(a, b): s for (a, b), s in zip(pairwise(chain), segs, strict=True)}

    def finish_open(self, curve: str, segments: list[Segment],
                    paths_2d: dict[str, np.ndarray], ok_segments: int,
                    good_flag: str = "image") -> None:
        """Store an open curve: the joined polyline, its anchors, its flag and its 2D
        view in every photo of the curve (the projection where no path was found)."""
        P, anchors = assemble(segments, self.params.curve_spacing_mm)
        self.res.curves[curve] = P
        self.res.anchors[curve] = anchors
        total = len(segments)
        self.res.flags[curve] = (good_flag if ok_segments == total and total else
                                 "partial" if ok_segments else "fallback")
        if self.res.flags[curve] == good_flag and self.estimated & set(CURVE_LANDMARKS[curve]):
            self.res.flags[curve] = "estimated"
        views = dict(paths_2d)
        for view in CURVE_VIEWS[curve]:
            if view not in views and view in self.cams and len(P):
                views[view] = self.cams[view].project(P)
        self.res.curves_2d[curve] = views
