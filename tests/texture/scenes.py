"""Small synthetic scenes for the texture tests: a dome or a bumped sheet seen by pinhole
cameras, photographed with flat (albedo-only) shading on a distinctive backdrop."""

from __future__ import annotations

import numpy as np

from naseview.camera import Camera, look_at
from naseview.render import render_mesh

BACKDROP_BGR = (0, 255, 0)
"""Pure green: a colour no test surface has."""


def grid(n: int = 31, half: float = 50.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y) grid vertices (n*n, 2) mm, triangles (counter-clockwise from +z), index grid."""
    g = np.linspace(-half, half, n)
    gx, gy = np.meshgrid(g, g)
    idx = np.arange(n * n).reshape(n, n)
    F = np.concatenate([
        np.c_[idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()],
        np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()]])
    return np.c_[gx.ravel(), gy.ravel()], F, idx


def dome(radius: float = 50.0, n: int = 31) -> tuple[np.ndarray, np.ndarray]:
    """An open spherical cap (n*n vertices), pole towards +z, mm."""
    xy, F, _ = grid(n, radius * 0.95)
    r2 = np.minimum((xy ** 2).sum(axis=1), (radius * 0.95) ** 2)
    z = np.sqrt(radius ** 2 - r2) - radius * 0.3
    return np.c_[xy, z], F


def bumped_sheet(n: int = 41, half: float = 60.0, height: float = 35.0, sigma: float = 9.0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """A flat sheet (z = 0) with a tall round bump at the centre, mm."""
    xy, F, _ = grid(n, half)
    z = height * np.exp(-(xy ** 2).sum(axis=1) / (2 * sigma ** 2))
    return np.c_[xy, z], F


def pattern_rgb(V: np.ndarray) -> np.ndarray:
    """(n, 3) uint8 RGB: smooth stripes in red and blue, green kept low (never backdrop)."""
    r = 140 + 90 * np.sin(V[:, 0] / 9.0)
    b = 140 + 90 * np.cos(V[:, 1] / 11.0)
    g = 60 + 20 * np.sin((V[:, 0] + V[:, 1]) / 15.0)
    return np.clip(np.c_[r, g, b], 0, 255).astype(np.uint8)


def camera_towards(direction: tuple[float, float, float], size: int = 256,
                   distance: float = 400.0, focal: float = 700.0) -> Camera:
    d = np.asarray(direction, dtype=np.float64)
    d /= np.linalg.norm(d)
    up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    return look_at(d * distance, [0.0, 0.0, 0.0], up, focal, size, size)


def photograph(V: np.ndarray, F: np.ndarray, rgb: np.ndarray, cam: Camera) -> np.ndarray:
    """(H, W, 3) uint8 BGR photo of the albedo (no lighting) on the green backdrop."""
    bgr = rgb[:, ::-1].astype(np.float64) / 255.0
    return render_mesh(V, F, cam, vertex_colors=bgr, light_intensities=(0.0, 0.0),
                       ambient=1.0, specular=0.0, background=BACKDROP_BGR,
                       supersample=2).image
