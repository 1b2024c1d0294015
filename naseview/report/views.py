"""Rendered views of the nose for the report: front, profile, three-quarter and bottom.

Each view is a portrait-lens camera 600 mm from the nose (:func:`view_camera`, placed with
:func:`naseview.camera.orbit_camera`), rendered with :func:`naseview.render.render_mesh`;
the face's eye and mouth holes are closed first (:func:`cap_holes`) and the "after" images
carry the "before" silhouette as a blue outline.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import cv2
import numpy as np

from naseview.camera import Camera, orbit_camera
from naseview.facemodel.meshcurves import region_boundary_loops
from naseview.render import render_mesh

RENDER_VIEWS: dict[str, tuple[str, tuple[float, float, float]]] = {
    "front": ("Front", (0.0, 0.0, 1.0)),
    "profile": ("Profile (right)", (-1.0, 0.0, 0.0)),
    "three_quarter": ("Three-quarter (right)", (-math.sin(math.radians(45.0)), 0.0,
                                               math.cos(math.radians(45.0)))),
    "bottom": ("Bottom (basal)", (0.0, -math.sin(math.radians(60.0)),
                                  math.cos(math.radians(60.0)))),
}
"""Rendered views: name -> (title, direction from the nose towards the camera, SPEC
frame: +x subject's left, +y up, +z anterior)."""

SKIN_BGR = (168, 192, 226)
NOSE_ONLY_BGR = (150, 172, 222)
OUTLINE_BGR = (200, 110, 30)
"""Blue outline of the silhouette before the simulation, drawn on the "after" renders."""


def view_camera(V: np.ndarray, nose_ids: np.ndarray, view: str, size: int = 480,
                field_factor: float = 2.3) -> Camera:
    """Camera looking at the nose from ``view`` (:data:`RENDER_VIEWS`).

    Args:
        V: (N, 3) mesh (mm).
        nose_ids: (K,) nose-region vertices (centre and extent of the framing).
        view: key of :data:`RENDER_VIEWS`.
        size: image width = height (px).
        field_factor: field of view width as a multiple of the nose extent.
    Returns:
        a :class:`~naseview.camera.Camera` 600 mm away (a portrait-lens perspective).
    """
    P = V[nose_ids] if len(nose_ids) else V
    centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
    extent = float(np.ptp(P, axis=0).max()) if len(P) else 60.0
    if view == "bottom":  # aim at the nasal base, not at the middle of the dorsum
        low = P[P[:, 1] <= np.quantile(P[:, 1], 0.4)]
        centre = 0.5 * (low.min(axis=0) + low.max(axis=0))
    return orbit_camera(centre, RENDER_VIEWS[view][1], 600.0,
                        max(field_factor * extent, 1.0), size)


def cap_holes(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Close the inner holes of an open face mesh (eyes, mouth) with triangle fans.

    Every boundary loop but the longest (the outline of the face) gets a vertex at its
    centroid and one triangle per loop edge, oriented like the mesh. A face model with
    open eyes then renders with closed lids instead of see-through holes.

    Args:
        V: (N, 3) vertices; F: (M, 3) triangles.
    Returns:
        (N + H, 3) vertices and (M + sum of loop lengths, 3) triangles.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    loops = region_boundary_loops(F, np.arange(len(V)))[1:]
    if not loops:
        return V, F
    extra_V: list[np.ndarray] = []
    extra_F: list[np.ndarray] = []
    for loop in loops:
        c = len(V) + len(extra_V)
        extra_V.append(V[loop].mean(axis=0))
        a, b = loop, np.roll(loop, -1)
        extra_F.append(np.column_stack([b, a, np.full(len(loop), c)]))
    return np.vstack([V, np.array(extra_V)]), np.vstack([F, *extra_F])


def _draw_outline(img: np.ndarray, silhouette: np.ndarray) -> np.ndarray:
    """``img`` (H, W, 3) BGR with the outer contour of ``silhouette`` (H, W) bool drawn
    in :data:`OUTLINE_BGR` (antialiased, 2 px, not along the image frame)."""
    cs, _ = cv2.findContours(silhouette.astype(np.uint8), cv2.RETR_EXTERNAL,
                             cv2.CHAIN_APPROX_NONE)
    layer = np.zeros(img.shape[:2], np.uint8)
    cv2.drawContours(layer, cs, -1, 255, 2, cv2.LINE_AA)
    layer[:3], layer[-3:], layer[:, :3], layer[:, -3:] = 0, 0, 0, 0  # not the frame
    a = (layer.astype(np.float32) / 255.0)[:, :, None]
    return (img * (1 - a) + np.asarray(OUTLINE_BGR, np.float32) * a).astype(np.uint8)


def render_views(V: np.ndarray, F: np.ndarray, nose_ids: np.ndarray, size: int = 480,
                 nose_only: bool = False, framing: np.ndarray | None = None,
                 outline_of: Mapping[str, np.ndarray] | None = None
                 ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Shaded renders of a face (or nose-only) mesh from every :data:`RENDER_VIEWS` view.

    Args:
        V: (N, 3) vertices (mm).
        F: (M, 3) triangles.
        nose_ids: (K,) nose region.
        size: image size (px).
        nose_only: render only the triangles whose three vertices are in the region;
            otherwise eye and mouth holes are closed (:func:`cap_holes`).
        framing: (N, 3) vertices that fix the cameras (so before and after share them);
            default ``V``.
        outline_of: view -> (size, size) bool silhouette to draw as a blue outline
            (the "before" silhouette on the "after" images).
    Returns:
        view -> (size, size, 3) uint8 BGR, and view -> (size, size) bool silhouette.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    nose_ids = np.asarray(nose_ids, dtype=np.int64)
    frame_V = V if framing is None else np.asarray(framing, dtype=np.float64)
    if nose_only and len(nose_ids):
        inside = np.zeros(len(V), dtype=bool)
        inside[nose_ids] = True
        F = F[inside[F].all(axis=1)]
    else:
        V, F = cap_holes(V, F)
    colors = np.tile(np.asarray(NOSE_ONLY_BGR if nose_only else SKIN_BGR, np.uint8),
                     (len(V), 1))
    images, masks = {}, {}
    for view in RENDER_VIEWS:
        cam = view_camera(frame_V, nose_ids, view, size, 1.5 if nose_only else 1.9)
        res = render_mesh(V, F, cam, vertex_colors=colors, supersample=2,
                          background=(255, 255, 255))
        img = res.image.copy()
        masks[view] = np.isfinite(res.depth)
        if outline_of is not None and view in outline_of:
            img = _draw_outline(img, outline_of[view])
        images[view] = img
    return images, masks
