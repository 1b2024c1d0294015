"""Textured renders of the face from the standard clinical views, and PNGs for the chart.

A face ``V`` (n, 3) mm (SPEC frame: +x subject's left, +y up, +z anterior), ``F`` (m, 3), with
a :class:`~naseview.texture.bake.FaceTexture` (or plain per-vertex colours) is rendered by
the software rasteriser (:func:`naseview.render.rasterize`) through a portrait-lens camera
600 mm away (:func:`naseview.camera.orbit_camera`): per pixel the texture is looked up at
the interpolated ``uv`` and lightly shaded (the photos already carry their light, so only
``shading`` of the key/fill lighting of :func:`naseview.render.shade_vertices` is added,
enough to read the shape). Eye and mouth openings are capped (their texture is the photo's
eye and mouth, see :mod:`naseview.texture.bake`).

Example (``tex`` baked for the face ``V``, ``F``; ``ids`` its nose vertices)::

    png = render_view_png(V, F, tex, "left", size=800, nose_ids=ids)
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera, standard_camera
from naseview.errors import NaseviewError
from naseview.geometry.closing import cap_holes, cap_values
from naseview.geometry.mesh import vertex_normals
from naseview.imagefile import image_bytes
from naseview.render import rasterize, shade_vertices
from naseview.texture.bake import FaceTexture, sample_image
from naseview.texture.uv import uv_to_pixels

__all__ = ["render_textured", "render_view_png"]

def render_textured(V: ArrayLike, F: ArrayLike, camera: Camera,
                    texture: FaceTexture | None = None,
                    vertex_colors: ArrayLike | None = None,
                    background: tuple[int, int, int] = (255, 255, 255),
                    shading: float = 0.35, supersample: int = 2,
                    cap: bool = True) -> np.ndarray:
    """Render the face with its texture (or RGB vertex colours) through ``camera``.

    Args:
        V: (n, 3) vertices (mm); F: (m, 3) triangles (those the texture was baked for).
        camera: the camera (image of its size).
        texture: the baked texture; or
        vertex_colors: (n, 3) uint8 RGB per vertex (default light skin grey).
        background: RGB of empty pixels.
        shading: share of the rendered lighting mixed in (0 = the texture as it is).
        supersample: anti-aliasing factor.
        cap: close the eye and mouth openings first.
    Returns:
        (H, W, 3) uint8 **RGB** image.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if texture is not None and len(texture.uv) != len(V):
        raise NaseviewError(f"texture: it has {len(texture.uv)} vertices, the mesh {len(V)}; "
                            "bake it for this mesh")
    if cap:
        Vc, Fc = cap_holes(V, F)
    else:
        Vc, Fc = V, F
    s = max(1, int(supersample))
    ras = rasterize(Vc, Fc, camera, supersample=s)
    Hs, Ws = ras.depth.shape
    out = np.empty((Hs * Ws, 3), np.float32)
    out[:] = np.asarray(background, np.float32)
    if ras.pixels.size:
        if texture is not None:
            uv = cap_values(texture.uv, F, V) if cap else texture.uv
            th, tw = texture.image.shape[:2]
            xy = ras.interpolate(Fc, uv_to_pixels(uv, tw, th))
            col = sample_image(texture.image, xy)
        else:
            vc = (np.full((len(V), 3), 200.0) if vertex_colors is None
                  else np.asarray(vertex_colors, dtype=np.float64))
            if len(vc) != len(V):
                raise NaseviewError(f"vertex colours: {len(vc)} for {len(V)} vertices")
            col = ras.interpolate(Fc, cap_values(vc, F, V) if cap else vc)
        N = vertex_normals(Vc, Fc)
        lit = shade_vertices(Vc, N, np.ones((len(Vc), 3)), camera, specular=0.05)[:, 0]
        k = float(np.clip(shading, 0.0, 1.0))
        light = ras.interpolate(Fc, (1.0 - k) + k * lit / 1.1)
        out[ras.pixels] = col * light[:, None]
    img: np.ndarray = np.clip(out + 0.5, 0, 255).astype(np.uint8).reshape(Hs, Ws, 3)
    if s > 1:
        img = np.asarray(cv2.resize(img, (camera.width, camera.height),
                                    interpolation=cv2.INTER_AREA))
    return img


def render_view_png(V: ArrayLike, F: ArrayLike, texture: FaceTexture | ArrayLike | None,
                    view_name: str, size: int = 800, nose_ids: ArrayLike | None = None
                    ) -> bytes:
    """PNG of the face from a standard view, for the patient's chart.

    Args:
        V: (n, 3) vertices (mm); F: (m, 3) triangles.
        texture: a :class:`FaceTexture`, or (n, 3) uint8 RGB vertex colours, or None
            (plain skin grey).
        view_name: a key of :data:`naseview.camera.STANDARD_VIEWS` (front, left, right, base,
            three_quarter_left, three_quarter_right).
        size: width = height (px, 64..4096).
        nose_ids: frame the nose (see :func:`naseview.camera.standard_camera`);
            default the whole face.
    Returns:
        PNG bytes (RGB image, white background).
    Raises:
        NaseviewError: unknown view, bad size, or a texture of another mesh.
    """
    if not 64 <= int(size) <= 4096:
        raise NaseviewError(f"view PNG: size {size} must be between 64 and 4096 px")
    cam = standard_camera(V, view_name, int(size), nose_ids)
    if isinstance(texture, FaceTexture):
        img = render_textured(V, F, cam, texture=texture)
    else:
        img = render_textured(V, F, cam, vertex_colors=texture)
    return image_bytes(np.ascontiguousarray(img[:, :, ::-1]), ".png")
