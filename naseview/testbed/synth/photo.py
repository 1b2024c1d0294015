"""The synthetic phone photo: backdrop, lights, shading, blur, sensor noise (SPEC §3).

Gouraud-shaded render (:func:`naseview.render.render_mesh`) with a soft key light
above-left of the camera and a fill light on the right, a uniform backdrop colour (light
blue, blue, green, grey or white, jittered), a light optical blur (sigma 0.6 px) and
Gaussian sensor noise of ``image_noise`` grey levels. The photos are written as JPEG
quality 92 (:func:`naseview.imagefile.write_image`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera
from naseview.render import DEFAULT_LIGHTS, render_mesh
from naseview.testbed.synth.scene import Scene

BACKDROPS_BGR: tuple[tuple[int, int, int], ...] = (
    (225, 205, 170),   # light blue
    (170, 120, 60),    # clinic blue
    (130, 165, 110),   # muted green
    (175, 175, 172),   # mid grey
    (238, 238, 236),   # white
)
"""Uniform backdrop colours clinics use (BGR), jittered per case."""


@dataclass(frozen=True)
class Studio:
    """Backdrop and lights of a case (the same for its four photos).

    Attributes:
        background: BGR uint8 backdrop colour.
        light_dirs: (2, 3) directions towards the key and the fill light, camera frame.
    """

    background: tuple[int, int, int]
    light_dirs: np.ndarray


def draw_studio(rng: np.random.Generator) -> Studio:
    """A backdrop from :data:`BACKDROPS_BGR` jittered by +-8 per channel, and the key
    (above-left) and fill (right) light directions, from the appearance stream."""
    base = np.array(BACKDROPS_BGR[int(rng.integers(len(BACKDROPS_BGR)))], dtype=float)
    b, g, r = (int(v) for v in np.clip(base + rng.uniform(-8, 8, size=3), 0, 255))
    key = np.array([rng.uniform(-0.6, -0.3), rng.uniform(-0.7, -0.4), -1.0])
    fill = np.array([rng.uniform(0.4, 0.8), rng.uniform(-0.2, 0.1), -1.0])
    return Studio((b, g, r), np.stack([key, fill]))


def render_photo(scene: Scene, camera: Camera, background: tuple[int, int, int],
                 rng: np.random.Generator, image_noise: float = 2.0,
                 light_dirs: ArrayLike = DEFAULT_LIGHTS) -> tuple[np.ndarray, np.ndarray]:
    """One synthetic photo of ``scene``.

    Args:
        scene: what is rendered; camera: the view's camera (its size is the photo's).
        background: BGR uint8 backdrop colour.
        rng: the sensor-noise stream.
        image_noise: sensor noise, standard deviation in grey levels (0 = none).
        light_dirs: (L, 3) directions towards the lights, camera frame.
    Returns:
        (H, W, 3) uint8 BGR photo (blurred, noisy) and the (H, W) depth map (mm).
    """
    res = render_mesh(scene.V, scene.F, camera, vertex_colors=scene.colors,
                      background=background, supersample=1, cull_backfaces=True,
                      normals=scene.normals, vertex_specular=scene.specular,
                      ambient=0.26, specular=0.08, shininess=20.0,
                      light_intensities=(0.55, 0.24), light_dirs=light_dirs)
    img = cv2.GaussianBlur(res.image, (0, 0), 0.6)
    if image_noise > 0:
        noise = rng.standard_normal(size=img.shape, dtype=np.float32)
        noise *= np.float32(image_noise)
        noise += img
        noise += np.float32(0.5)
        img = np.clip(noise, 0, 255, out=noise).astype(np.uint8)
    return img, res.depth
