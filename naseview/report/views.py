"""Rendered views of the nose for the report: front, profile, three-quarter and bottom.

Each view is a portrait-lens camera 600 mm from the nose
(:func:`naseview.camera.standard_camera`), rendered with
:func:`naseview.render.render_mesh`; the face's eye and mouth holes are closed first
(:func:`naseview.geometry.closing.cap_holes`) and the "after" images
carry the "before" silhouette as a blue outline.
"""

from __future__ import annotations

from collections.abc import Mapping

import cv2
import numpy as np

from naseview.camera import STANDARD_VIEWS, standard_camera
from naseview.geometry.closing import cap_holes
from naseview.render import rasterize, render_mesh
from naseview.texture.bake import FaceTexture
from naseview.texture.views import render_textured

RENDER_VIEWS: dict[str, tuple[str, tuple[float, float, float]]] = {
    v: STANDARD_VIEWS[v] for v in ("front", "right", "three_quarter_right", "base")}
"""The report's views, in page order: a subset of :data:`naseview.camera.STANDARD_VIEWS`
(name -> (title, direction from the nose towards the camera))."""

SKIN_BGR = (168, 192, 226)
NOSE_ONLY_BGR = (150, 172, 222)
OUTLINE_BGR = (200, 110, 30)
"""Blue outline of the silhouette before the simulation, drawn on the "after" renders."""


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
                 outline_of: Mapping[str, np.ndarray] | None = None,
                 texture: FaceTexture | None = None
                 ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Shaded renders of a face (or nose-only) mesh from every :data:`RENDER_VIEWS` view.

    Args:
        V: (N, 3) vertices (mm).
        F: (M, 3) triangles.
        nose_ids: (K,) nose region.
        size: image size (px).
        nose_only: render only the triangles whose three vertices are in the region;
            otherwise eye and mouth holes are closed (:func:`~naseview.geometry.closing.cap_holes`).
        framing: (N, 3) vertices that fix the cameras (so before and after share them);
            default ``V``.
        outline_of: view -> (size, size) bool silhouette to draw as a blue outline
            (the "before" silhouette on the "after" images).
        texture: the patient's skin for this mesh (the face, not ``nose_only``): the
            renders show it (:func:`naseview.texture.views.render_textured`).
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
    elif texture is None:
        V, F = cap_holes(V, F)
    colors = np.tile(np.asarray(NOSE_ONLY_BGR if nose_only else SKIN_BGR, np.uint8),
                     (len(V), 1))
    images, masks = {}, {}
    for view in RENDER_VIEWS:
        cam = standard_camera(frame_V, view, size, nose_ids, 1.5 if nose_only else 1.9)
        if texture is not None and not nose_only:
            img = cv2.cvtColor(render_textured(V, F, cam, texture=texture,
                                               background=(255, 255, 255)),
                               cv2.COLOR_RGB2BGR)
            masks[view] = np.isfinite(rasterize(*cap_holes(V, F), cam).depth)
        else:
            res = render_mesh(V, F, cam, vertex_colors=colors, supersample=2,
                              background=(255, 255, 255))
            img = res.image.copy()
            masks[view] = np.isfinite(res.depth)
        if outline_of is not None and view in outline_of:
            img = _draw_outline(img, outline_of[view])
        images[view] = img
    return images, masks
