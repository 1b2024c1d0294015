"""The clinical viewer of a tab: standard views of the nose, a 10 mm scale bar, a PNG of
the view.

Views come from the ONE table the report and the view PNGs use
(:data:`naseview.camera.STANDARD_VIEWS`, :func:`naseview.camera.standard_camera`), framed
so the nose fills :data:`NOSE_FILL` of the view height, centred on it. SPEC frame (mm,
+x subject's left, +y up, +z anterior): "Left profile" puts the camera at +x.

The scale bar is a 10 mm segment with end ticks and a "10 mm" label *in the scene*,
in the plane facing the chosen view through the nose, beside the face: clear of the
face's projected outline (:func:`scale_bar_segments`). Being geometry at the nose's
depth, it is foreshortened and zoomed exactly like the nose, so it stays true at any
zoom; it is re-placed (facing the camera) whenever a standard view is chosen, and hidden
in patient mode (the turntable would carry it across the face).

"Save view as PNG" renders the face with the software rasteriser
(:func:`naseview.texture.views.render_textured`) through the tab's current viser camera
(position, look-at, field of view, aspect), textured when photos exist: it needs no
browser round trip (``get_render`` depends on the page's WebGL and fails headless).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import DISTANCE_MM, STANDARD_VIEWS, Camera, look_at, standard_camera
from naseview.errors import NaseviewError
from naseview.imagefile import image_bytes
from naseview.render import rasterize
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


SCALE_BAR_MARGIN_PX = 0.03
"""Clearance of the scale bar (its ticks and label) from the face's outline and from the
image border, as a share of the image height."""


def view_camera(V: ArrayLike, nose_ids: ArrayLike, view: str, aspect: float = 1.0,
                height: int = 800) -> Camera:
    """The camera of a standard view as :func:`view_pose` frames it, ``height`` px high
    and ``aspect`` (width / height) as wide as the tab's window (same vertical field)."""
    cam = standard_camera(V, view, height, nose_ids, field_factor=1.0 / NOSE_FILL)
    w = max(16, int(round(height * max(float(aspect), 0.1))))
    K = cam.K.copy()
    K[0, 2] += 0.5 * (w - cam.width)
    return Camera(K, cam.R, cam.t, w, cam.height)


def scale_bar_segments(V: ArrayLike, F: ArrayLike, nose_ids: ArrayLike, camera: Camera,
                       length_mm: float = SCALE_BAR_MM) -> tuple[np.ndarray, np.ndarray]:
    """``(segments (3, 2, 3), label position (3,))`` of a scale bar of ``length_mm``
    upright in the image of ``camera`` (its plane facing the camera, through the nose's
    centre, so it is foreshortened like the nose), placed *beside the face*: the bar,
    its end ticks and its label clear of the face's projected outline (``V`` (n, 3),
    ``F``, mm) by :data:`SCALE_BAR_MARGIN_PX`, as close to the nose as that allows
    (issue 27: in the Base view a bar 6 mm beside the nose lay half in the cheek). A
    place inside the image is taken when there is one; else the nearest one outside it
    (a face filling the whole view leaves no room beside it in the picture)."""
    V = np.asarray(V, np.float64)
    ids = np.asarray(nose_ids, np.int64)
    P = V[ids] if len(ids) else V
    c = 0.5 * (P.min(axis=0) + P.max(axis=0))
    R = camera.R
    right, up = R[0], -R[1]
    z = float(camera.depth(c[None])[0])
    W, H = camera.width, camera.height
    s = min(1.0, 240.0 / max(W, H))               # the outline at <= 240 px: fast, enough
    small = Camera(np.diag([s, s, 1.0]) @ camera.K, R, camera.t,
                   max(8, int(round(W * s))), max(8, int(round(H * s))))
    face = np.isfinite(rasterize(V, np.asarray(F, np.int64), small).depth)
    m = max(1, int(round(SCALE_BAR_MARGIN_PX * small.height)))
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * m + 1, 2 * m + 1))
    blocked = cv2.dilate(face.astype(np.uint8), k) > 0
    f = float(small.K[1, 1])
    L = f * length_mm / max(z, 1e-6)              # bar length (small px)
    tick = max(1, int(round(f * 1.2 / max(z, 1e-6))))
    label_w = max(2, int(round(0.9 * L)))          # "10 mm" beside the bar
    nose_xy = small.project(P)
    lo, hi = nose_xy.min(axis=0), nose_xy.max(axis=0)
    mid = 0.5 * (lo + hi)
    pad = 4 * small.width                          # room beyond the image
    grid = np.zeros((small.height + 2 * pad, small.width + 2 * pad), bool)
    grid[pad:pad + small.height, pad:pad + small.width] = blocked
    best: tuple[float, float, float, int] | None = None
    step = max(1.0, L / 6.0)
    for side in (1, -1):
        for dy in np.arange(-3 * L, 3 * L + step, step):
            for dx in np.arange(0.0, 2.5 * small.width, step):
                x = mid[0] + side * dx
                y1 = mid[1] + dy + 0.5 * L                 # the foot (image y down)
                y0 = y1 - L
                lx0, lx1 = (x + tick, x + tick + label_w) if side > 0 else \
                    (x - tick - label_w, x - tick)
                x0, x1 = min(x - tick, lx0), max(x + tick, lx1)
                inside = x0 >= m and x1 <= small.width - m and y0 >= m \
                    and y1 <= small.height - m
                r0, r1 = int(np.floor(y0)) + pad, int(np.ceil(y1)) + pad + 1
                c0, c1 = int(np.floor(x0)) + pad, int(np.ceil(x1)) + pad + 1
                if r0 < 0 or c0 < 0 or r1 > grid.shape[0] or c1 > grid.shape[1]:
                    continue
                if grid[r0:r1, c0:c1].any():
                    continue
                cost = (0.0 if inside else 1e6) + float(np.hypot(dx, dy))
                if best is None or cost < best[0]:
                    best = (cost, x, y1, side)
                break                    # farther along this row is only farther away
    depth_at = z
    if best is None or best[0] >= 1e6:
        # no room beside the face in the picture (the Front view in a window narrower
        # than about 16:9 shows nothing but face around the nose): at the picture's
        # lower right corner, in front of the face (never buried), shrunk so that it
        # still shows 10 mm at the nose's depth
        depth = rasterize(V, np.asarray(F, np.int64), small).depth
        x = float(small.width - m - tick - 1)      # the label on the bar's left
        y1 = float(small.height - m - 1)
        r0, c0 = max(0, int(y1 - L) - tick), max(0, int(x) - label_w - 2 * tick)
        under = depth[r0:int(y1) + 2, c0:int(x) + tick + 2]
        near = float(np.min(under)) if under.size else np.inf
        if np.isfinite(near):
            depth_at = max(1.0, min(z, near - 5.0))
        best = (0.0, x, y1, -1)
    _, x, y1, side = best
    ray = np.linalg.solve(small.K, np.array([x, y1, 1.0]))
    foot = R.T @ (depth_at * ray - camera.t)
    g = depth_at / z                               # 1 beside the face
    top = foot + g * length_mm * up
    t3 = g * 1.2 * right
    segs = np.stack([np.stack([foot, top]), np.stack([foot - t3, foot + t3]),
                     np.stack([top - t3, top + t3])])
    label = 0.5 * (foot + top) + side * g * 2.0 * right
    return segs, label


def scale_bar_pixels(segs: np.ndarray, camera: Camera) -> np.ndarray:
    """(3, 2, 2) image positions (px) of the scale bar's segments through ``camera``."""
    return camera.project(np.asarray(segs, np.float64).reshape(-1, 3)).reshape(3, 2, 2)


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


PNG_SCALE_BAR_BGR = (40, 40, 40)
"""Colour of the scale bar drawn into a view PNG (the scene's)."""


def draw_scale_bar(img: np.ndarray, V: ArrayLike, F: ArrayLike, nose_ids: ArrayLike,
                   camera: Camera, length_mm: float = SCALE_BAR_MM) -> np.ndarray:
    """(3, 2, 2) pixels of the segments of the scale bar drawn into ``img`` (BGR, the
    picture of ``camera``): :func:`scale_bar_segments` placed for this camera (beside the
    face), so it is ``length_mm`` long at the nose's depth, with its "10 mm" label."""
    segs, label = scale_bar_segments(V, F, nose_ids, camera, length_mm)
    px = scale_bar_pixels(segs, camera)
    thick = max(2, int(round(img.shape[0] / 300)))
    for a, b in px:
        cv2.line(img, (int(round(a[0])), int(round(a[1]))), (int(round(b[0])), int(round(b[1]))),
                 PNG_SCALE_BAR_BGR, thick, cv2.LINE_AA)
    text = f"{length_mm:g} mm"
    scale = img.shape[0] / 900 * 0.8
    (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
    lab = camera.project(np.asarray(label, np.float64)[None])[0]
    left = lab[0] < px[0, 0, 0]
    x = int(round(lab[0] - tw if left else lab[0]))
    y = int(round(lab[1] + th / 2))
    cv2.putText(img, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, PNG_SCALE_BAR_BGR, thick,
                cv2.LINE_AA)
    return px


def view_png(V: ArrayLike, F: ArrayLike, camera: Camera,
             texture: FaceTexture | None = None,
             nose_ids: ArrayLike | None = None) -> bytes:
    """PNG bytes of the face ``V`` (n, 3) mm, ``F`` through ``camera`` (textured when
    ``texture`` is given, else skin-coloured), white background; with ``nose_ids`` the
    10 mm scale bar beside the face (:func:`draw_scale_bar`)."""
    V = np.asarray(V, np.float64)
    if texture is not None and len(texture.uv) != len(V):
        raise NaseviewError("view PNG: the texture was baked for another mesh; reopen the "
                            "case to bake it again")
    skin = np.tile(np.array([[226, 192, 168]], np.uint8), (len(V), 1))
    img = render_textured(V, F, camera, texture=texture,
                          vertex_colors=None if texture is not None else skin,
                          shading=0.35 if texture is not None else 0.8)
    bgr = np.ascontiguousarray(img[:, :, ::-1])
    if nose_ids is not None and len(np.asarray(nose_ids)):
        draw_scale_bar(bgr, V, F, nose_ids, camera)
    return image_bytes(bgr, ".png", where="view PNG")


VIEW_BUTTONS: tuple[tuple[str, str], ...] = (
    ("Front", "front"), ("Left", "left"), ("Right", "right"), ("Base", "base"),
    ("¾ left", "three_quarter_left"), ("¾ right", "three_quarter_right"))
"""(button text, :data:`STANDARD_VIEWS` key) of the view buttons (titles in the hints)."""
assert all(k in STANDARD_VIEWS for _, k in VIEW_BUTTONS)


__all__ = ["DEFAULT_VIEW", "NOSE_FILL", "PNG_SCALE_BAR_BGR", "SCALE_BAR_MARGIN_PX",
           "SCALE_BAR_MM", "VIEW_BUTTONS", "camera_of_view", "draw_scale_bar",
           "scale_bar_pixels", "scale_bar_segments", "view_camera", "view_png", "view_pose"]
