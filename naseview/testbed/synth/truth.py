"""Ground truth of a synthetic case: true curves, 2D boundaries, helper points (SPEC §7).

- true curves: ``model.curve_vertices`` on the true mesh (vertex paths; sills closed loops
  without the repeated first vertex);
- ``truth_boundaries.json``: per curve, per view (:data:`naseview.landmarks.CURVE_VIEWS`),
  the 2D ground-truth boundary points in that photo's pixels: the true 3D curve resampled
  every 0.5 mm, projected with the true camera, keeping only the points that pass the
  depth test (1 mm) against the rendered scene and lie inside the image;
- the helper ``add_x``: the point halfway (2D arc length) between alp_x and prn along the
  projection of the true bottom curve in the bottom view.
"""

from __future__ import annotations

import numpy as np

from naseview.camera import Camera
from naseview.facemodel import FaceModel
from naseview.geometry.polyline import cumulative_length, resample_by_spacing
from naseview.landmarks import CURVE_VIEWS
from naseview.render import visible_points

CLOSED_CURVES: tuple[str, ...] = ("sill_l", "sill_r")
"""Curves that are closed loops."""

BOUNDARY_STEP_MM = 0.5
"""Spacing of the true 3D curve points before projection (mm)."""


def truth_curves(model: FaceModel, V: np.ndarray) -> dict[str, np.ndarray]:
    """SPEC §5 curve name -> (L, 3) true polyline (vertex path on the true mesh)."""
    return {name: V[np.asarray(path, dtype=np.int64)]
            for name, path in model.curve_vertices.items()}


def boundary_points(curve: np.ndarray, closed: bool, camera: Camera,
                    depth: np.ndarray) -> np.ndarray:
    """(M, 2) visible pixels of a 3D curve (L, 3) resampled every 0.5 mm (module doc)."""
    P = resample_by_spacing(curve, BOUNDARY_STEP_MM, closed)
    vis = visible_points(P, camera, depth, tol_mm=1.0)
    return camera.project(P[vis]) if vis.any() else np.zeros((0, 2))


def view_boundaries(curves: dict[str, np.ndarray], view: str, camera: Camera,
                    depth: np.ndarray) -> dict[str, list[list[float]]]:
    """Curve name -> its ground-truth points (px, 3 decimals) in ``view``, for the curves
    whose truth that photo gives."""
    return {name: np.round(boundary_points(curves[name], name in CLOSED_CURVES, camera,
                                           depth), 3).tolist()
            for name, vlist in CURVE_VIEWS.items() if view in vlist and name in curves}


def arc_midpoint(uv: np.ndarray) -> tuple[np.ndarray, int, float]:
    """Point halfway along a 2D polyline (N, 2) by length: (2,), segment index, fraction."""
    seg = np.linalg.norm(np.diff(uv, axis=0), axis=1)
    s = cumulative_length(uv)
    half = 0.5 * s[-1]
    i = int(np.clip(np.searchsorted(s, half) - 1, 0, len(seg) - 1))
    f = (half - s[i]) / seg[i] if seg[i] > 0 else 0.0
    return uv[i] + f * (uv[i + 1] - uv[i]), i, float(f)


def helper_points(model: FaceModel, V: np.ndarray) -> dict[str, np.ndarray]:
    """Helper id ``add_x`` -> (K, 3) the true bottom curve's vertex path from alp_x to prn."""
    path = np.asarray(model.curve_vertices["bottom"], dtype=np.int64)
    lv = model.landmark_vertices
    out = {}
    for side in ("l", "r"):
        a = np.flatnonzero(path == lv[f"alp_{side}"])
        b = np.flatnonzero(path == lv["prn"])
        if a.size == 0 or b.size == 0:
            continue
        i, j = sorted((int(a[0]), int(b[0])))
        out[f"add_{side}"] = V[path[i:j + 1]]
    return out


def helper_position(P3: np.ndarray, camera: Camera) -> np.ndarray:
    """(3,) point of the piece P3 (K, 3) halfway along its projection in ``camera``."""
    if len(P3) < 2:
        return np.asarray(P3[0])
    _, i, f = arc_midpoint(camera.project(P3))
    return np.asarray(P3[i] + f * (P3[i + 1] - P3[i]))
