"""Rendered views of the nose for the report: front, left profile and base (from below).

Each view is a portrait-lens camera 600 mm from the nose
(:func:`naseview.camera.standard_camera`), rendered with
:func:`naseview.render.render_mesh`; the face's eye and mouth holes are closed first
(:func:`naseview.geometry.closing.cap_holes`) and the "after" profile carries the
"before" silhouette as a blue outline (:data:`OUTLINE_VIEWS`).

The de-identified ("nose only") renders show the whole face in neutral grey, faded to
white outside a soft vignette around the nose (:func:`nose_vignette`): a clean, smooth
boundary instead of the ragged edge of the nose region's triangles, and no eyes, skin
or face outline.
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

_PATIENT_TITLES = {"front": "From the front", "left": "From the side (left profile)",
                   "base": "From below"}
RENDER_VIEWS: dict[str, tuple[str, tuple[float, float, float]]] = {
    v: (_PATIENT_TITLES[v], STANDARD_VIEWS[v][1]) for v in ("front", "left", "base")}
"""The report's views, in page order: a subset of :data:`naseview.camera.STANDARD_VIEWS`
(name -> (patient title, direction from the nose towards the camera))."""

SKIN_BGR = (168, 192, 226)
NEUTRAL_BGR = (200, 200, 200)
"""Neutral grey of the de-identified renders (never the patient's skin)."""
NOSE_ONLY_FIELD = 1.2
"""Field of the de-identified views, in nose extents (the full views: 1.9)."""
OUTLINE_BGR = (200, 110, 30)
"""Blue outline of the silhouette before the simulation, drawn on the "after" renders."""
OUTLINE_VIEWS = ("left",)
"""The views whose "before" silhouette outlines the nose: the profile. From the front and
from below the face's silhouette is the head's edge (the top of the head in the base
view), not the nose, so no line is drawn there (issue 27)."""


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


def nose_vignette(nose_mask: np.ndarray, sigma_frac: float = 0.04) -> np.ndarray:
    """Soft vignette around the nose: (H, W) float32 alpha in [0, 1].

    ``a = smoothstep(0.06, 0.5, G_sigma * m)``: the nose-region mask ``m`` (H, W) bool
    blurred by a Gaussian of ``sigma = sigma_frac * W`` px, 1 inside the smoothed nose
    outline (the blur's 0.5 level), fading smoothly to 0 about two sigmas outside it;
    the blur removes the ragged triangle edges of the region.
    """
    m = np.asarray(nose_mask, np.float32)
    g = cv2.GaussianBlur(m, (0, 0), max(sigma_frac * m.shape[1], 0.5))
    t = np.clip((g - 0.06) / (0.5 - 0.06), 0.0, 1.0)
    return (t * t * (3.0 - 2.0 * t)).astype(np.float32)


def _faded(img: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``img`` (H, W, 3) BGR blended to white where ``alpha`` (H, W) is 0."""
    a = alpha[:, :, None]
    return np.clip(img * a + 255.0 * (1.0 - a) + 0.5, 0, 255).astype(np.uint8)


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
        nose_only: the de-identified views: the face (holes closed,
            :func:`~naseview.geometry.closing.cap_holes`) in :data:`NEUTRAL_BGR`, faded
            outside :func:`nose_vignette` of the nose region (of ``V`` and of ``framing``,
            so before and after share the region); otherwise the face with its holes
            closed, in skin colour or ``texture``.
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
    inside = np.zeros(len(V), dtype=bool)
    inside[nose_ids] = True
    F_nose = F[inside[F].all(axis=1)]
    if texture is None or nose_only:
        V, F = cap_holes(V, F)
    colors = np.tile(np.asarray(NEUTRAL_BGR if nose_only else SKIN_BGR, np.uint8),
                     (len(V), 1))
    images, masks = {}, {}
    for view in RENDER_VIEWS:
        cam = standard_camera(frame_V, view, size, nose_ids,
                              NOSE_ONLY_FIELD if nose_only else 1.9)
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
        if nose_only and len(F_nose):
            region = np.isfinite(rasterize(V[: len(inside)], F_nose, cam).depth)
            if framing is not None:
                region |= np.isfinite(rasterize(frame_V, F_nose, cam).depth)
            img = _faded(img, nose_vignette(region))
        images[view] = img
    return images, masks
