"""The clinical viewer of a tab: standard views of the nose, a 10 mm scale bar, a PNG of
the view.

Views come from the ONE table the report and the view PNGs use
(:data:`naseview.camera.STANDARD_VIEWS`, :func:`naseview.camera.standard_camera`), framed
so the nose fills :data:`NOSE_FILL` of the view height, centred on it. SPEC frame (mm,
+x subject's left, +y up, +z anterior): "Left profile" puts the camera at +x.

The scale bar is a 10 mm segment with end ticks and a "10 mm" label *in the scene*,
placed beside the nose in the plane facing the chosen view. Being geometry at the
nose's depth, it is foreshortened and zoomed exactly like the nose, so it stays true at
any zoom; it is re-placed (facing the camera) whenever a standard view is chosen.

"Save view as PNG" renders the face with the software rasteriser
(:func:`naseview.texture.views.render_textured`) through the tab's current viser camera
(position, look-at, field of view, aspect), textured when photos exist: it needs no
browser round trip (``get_render`` depends on the page's WebGL and fails headless).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import DISTANCE_MM, STANDARD_VIEWS, Camera, look_at, standard_camera
from naseview.errors import NaseviewError
from naseview.fileio import image_bytes
from naseview.texture.bake import FaceTexture
from naseview.texture.views import render_textured

NOSE_FILL = 0.6
"""Share of the view height the nose fills in a standard view."""

DEFAULT_VIEW = "three_quarter_left"
"""The view a tab starts with."""

SCALE_BAR_MM = 10.0
"""Length of the scale bar (mm)."""


def view_pose(V: ArrayLike, nose_ids: ArrayLike, view: str
              ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``(look_at (3,), eye (3,), vertical fov rad, camera rotation R (3, 3))`` of a
    standard view framing the nose (SPEC frame, mm); R's rows are the camera's x (right),
    y (down) and z (forward) axes in the SPEC frame.

    Raises:
        NaseviewError: unknown view name.
    """
    cam = standard_camera(V, view, 800, nose_ids, field_factor=1.0 / NOSE_FILL)
    eye = cam.center
    target = eye + DISTANCE_MM * cam.R[2]
    fov = 2.0 * math.atan2(cam.height / 2.0, float(cam.K[1, 1]))
    return target, eye, fov, cam.R


def scale_bar_segments(V: ArrayLike, nose_ids: ArrayLike, R: np.ndarray,
                       length_mm: float = SCALE_BAR_MM) -> tuple[np.ndarray, np.ndarray]:
    """``(segments (3, 2, 3), label position (3,))`` of a vertical scale bar of
    ``length_mm`` in the plane facing the camera rotation ``R`` (rows: right, down,
    forward) through the nose's centre, 6 mm beside the nose, its foot at the nose's
    lowest point in the image (mm, SPEC frame). Of the two sides of the nose, the one
    where less of the face ``V`` (n, 3) lies in front of the bar is taken (in profile:
    in front of the face, not behind the cheek)."""
    V = np.asarray(V, np.float64)
    ids = np.asarray(nose_ids, np.int64)
    P = V[ids] if len(ids) else V
    right, up, fwd = R[0], -R[1], R[2]
    c = 0.5 * (P.min(axis=0) + P.max(axis=0))
    d = P - c
    y = float((d @ up).min())
    D = V - c
    sx, sy, sz = D @ right, D @ up, D @ fwd
    best: tuple[int, float] | None = None
    for side in (1.0, -1.0):
        x = side * (float((side * (d @ right)).max()) + 6.0)
        near = (np.abs(sx - x) < 3.0) & (sy > y - 1.0) & (sy < y + length_mm + 1.0)
        hidden = int(np.count_nonzero(near & (sz < 0.0)))     # face closer than the bar
        if best is None or hidden < best[0]:
            best = (hidden, x)
    assert best is not None
    x = best[1]
    foot = c + x * right + y * up
    top = foot + length_mm * up
    tick = 1.2 * right
    segs = np.stack([np.stack([foot, top]), np.stack([foot - tick, foot + tick]),
                     np.stack([top - tick, top + tick])])
    label = 0.5 * (foot + top) + (2.0 if x > 0 else -2.0) * right
    return segs, label


def camera_of_view(position: ArrayLike, target: ArrayLike, up: ArrayLike, fov: float,
                   aspect: float, height: int) -> Camera:
    """A SPEC camera of a viser view (eye ``position``, ``target``, ``up``, vertical
    ``fov`` rad, width / height ``aspect``), ``height`` px high."""
    h = int(height)
    w = max(16, int(round(h * max(float(aspect), 0.1))))
    focal = (h / 2.0) / math.tan(max(float(fov), 1e-3) / 2.0)
    up = np.asarray(up, np.float64)
    fwd = np.asarray(target, np.float64) - np.asarray(position, np.float64)
    if float(np.linalg.norm(np.cross(fwd, up))) < 1e-9 * max(float(np.linalg.norm(fwd)), 1e-9):
        up = np.array([0.0, 0.0, 1.0])
    return look_at(position, target, up, focal, w, h)


def view_png(V: ArrayLike, F: ArrayLike, camera: Camera,
             texture: FaceTexture | None = None) -> bytes:
    """PNG bytes of the face ``V`` (n, 3) mm, ``F`` through ``camera`` (textured when
    ``texture`` is given, else skin-coloured), white background."""
    V = np.asarray(V, np.float64)
    if texture is not None and len(texture.uv) != len(V):
        raise NaseviewError("view PNG: the texture was baked for another mesh; reopen the "
                            "case to bake it again")
    skin = np.tile(np.array([[226, 192, 168]], np.uint8), (len(V), 1))
    img = render_textured(V, F, camera, texture=texture,
                          vertex_colors=None if texture is not None else skin,
                          shading=0.35 if texture is not None else 0.8)
    return image_bytes(np.ascontiguousarray(img[:, :, ::-1]), ".png", where="view PNG")


VIEW_BUTTONS: tuple[tuple[str, str], ...] = (
    ("Front", "front"), ("Left", "left"), ("Right", "right"), ("Base", "base"),
    ("¾ left", "three_quarter_left"), ("¾ right", "three_quarter_right"))
"""(button text, :data:`STANDARD_VIEWS` key) of the view buttons (titles in the hints)."""
assert all(k in STANDARD_VIEWS for _, k in VIEW_BUTTONS)


__all__ = ["DEFAULT_VIEW", "NOSE_FILL", "SCALE_BAR_MM", "VIEW_BUTTONS", "camera_of_view",
           "scale_bar_segments", "view_png", "view_pose"]
