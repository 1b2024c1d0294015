"""Where the browsers look while a photo is annotated: straight at the photo plane.

The camera stays :data:`~naseview.app.photo_plane.CAMERA_DISTANCE` in front of the photo
(+z), looking along -z with +y up, so the photo is never tilted; framing changes only the
point looked at and the field of view. Pixel boxes are SPEC §2 pixels of the photo.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import viser
from viser import transforms as vtf

from naseview.app.photo_plane import CAMERA_DISTANCE, PhotoPlane

DEFAULT_ASPECT = 16 / 10
"""Window aspect (width / height) assumed before a browser reports its size."""


def _aspect(camera: viser.CameraHandle) -> float:
    return camera.image_width / camera.image_height if camera.image_height else DEFAULT_ASPECT


def fit_photo(server: viser.ViserServer | None, plane: PhotoPlane,
              clients: Iterable[viser.ClientHandle]) -> None:
    """The whole photo, fitted to each window of ``clients``; with ``server``, also new
    browsers' initial view (and every tab's "Reset View"): a page on the server scope
    only. A page in one tab passes ``None`` and leaves the other tabs' views alone."""
    eye = plane.centre + np.array([0.0, 0.0, CAMERA_DISTANCE])
    if server is not None:
        cam0 = server.initial_camera
        cam0.position = tuple(eye)
        cam0.look_at = tuple(plane.centre)
        cam0.up = (0.0, 1.0, 0.0)
        cam0.fov = plane.fov_for(DEFAULT_ASPECT)
        cam0.near = 1.0
        cam0.far = 4.0 * CAMERA_DISTANCE
    for client in clients:
        c = client.camera
        aspect = _aspect(c)
        with client.atomic():
            c.fov = plane.fov_for(aspect)
            c.near = 1.0
            c.far = 4.0 * CAMERA_DISTANCE
            c.up_direction = (0.0, 1.0, 0.0)
            c.position = tuple(eye)
            c.look_at = tuple(plane.centre)


def frame_pixels(plane: PhotoPlane, lo: np.ndarray, hi: np.ndarray,
                 clients: Iterable[viser.ClientHandle]) -> None:
    """Look straight at the pixel box [lo, hi] (2,) of the photo, filling each view."""
    target = plane.to_world(0.5 * (lo + hi))[0]
    scale = plane.size / max(plane.width_px, plane.height_px)
    eye = target + np.array([0.0, 0.0, CAMERA_DISTANCE])
    for client in clients:
        c = client.camera
        need = max((hi - lo)[1], (hi - lo)[0] / _aspect(c)) * scale * 1.05
        with client.atomic():
            c.fov = float(2.0 * np.arctan(0.5 * need / CAMERA_DISTANCE))
            c.up_direction = (0.0, 1.0, 0.0)
            c.position = tuple(eye)
            c.look_at = tuple(target)


def nose_box(plane: PhotoPlane, points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Pixel box (lo, hi) around the clicks and hints ``points`` (2,) with a margin;
    with fewer than three points, the central 60 % of the photo."""
    if len(points) >= 3:
        P = np.array(points)
        lo, hi = P.min(axis=0), P.max(axis=0)
        pad = 0.18 * max(hi - lo) + 0.03 * max(plane.width_px, plane.height_px)
        return lo - pad, hi + pad
    c = np.array([plane.width_px, plane.height_px]) / 2.0
    return c * 0.4, c * 1.6


def screen_box_pixels(camera: viser.CameraHandle, plane: PhotoPlane,
                      screen_min: tuple[float, float], screen_max: tuple[float, float]
                      ) -> tuple[np.ndarray, np.ndarray] | None:
    """Pixel box (lo, hi) of the photo under a rectangle drawn on the screen (corners in
    0..1 of the window); None when a corner misses the photo plane or the box is a slip
    (under 2 % of the photo)."""
    R = vtf.SO3(np.asarray(camera.wxyz)).as_matrix()          # camera -> world (OpenCV)
    th = np.tan(camera.fov / 2.0)
    aspect = _aspect(camera)
    corners = []
    for u, v in ((screen_min[0], screen_min[1]), (screen_max[0], screen_max[1])):
        d = R @ np.array([(2 * u - 1) * th * aspect, (2 * v - 1) * th, 1.0])
        uv = plane.intersect(camera.position, d)
        if uv is None:
            return None
        corners.append(uv)
    lo, hi = np.minimum(*corners), np.maximum(*corners)
    if max(hi - lo) < 0.02 * max(plane.width_px, plane.height_px):
        return None
    return lo, hi
