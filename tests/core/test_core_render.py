"""The software rasteriser: depth, coverage, occlusion, perspective-correct interpolation."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from naseview.camera import look_at
from naseview.geometry.mesh import vertex_normals
from naseview.render import rasterize, rasterize_screen, render_mesh, visible_points


def grid_plane(n: int, half: float, z: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(n+1)^2 vertices on the square [-half, half]^2 at height z, facing +z."""
    t = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(t, t)
    V = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    F = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return V, F


def cube(half: float) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned cube centred at 0, triangles counter-clockwise seen from outside."""
    V = np.array([[x, y, z] for x in (-half, half) for y in (-half, half)
                  for z in (-half, half)], dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
             (1, 5, 7, 3)]
    F = []
    for a, b, c, d in quads:
        F += [(a, b, c), (a, c, d)]
    F = np.array(F)
    # orient outwards
    cen = V[F].mean(axis=1)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ij,ij->i", n, cen) < 0
    F[flip] = F[flip][:, ::-1]
    return V, F


def test_plane_depth_and_coverage() -> None:
    V, F = grid_plane(1, 50.0)
    cam = look_at([0, 0, 300.0], [0, 0, 0], [0, 1, 0], 500.0, 400, 300)
    ras = rasterize(V, F, cam)
    assert ras.depth.shape == (300, 400)
    inside = np.isfinite(ras.depth)
    assert np.allclose(ras.depth[inside], 300.0, atol=1e-9)
    # the square spans 100 mm at 300 mm with f = 500: 166.7 px wide, centred
    xs = np.flatnonzero(inside.any(axis=0))
    ys = np.flatnonzero(inside.any(axis=1))
    assert abs((xs[-1] - xs[0] + 1) - 500 * 100 / 300) <= 1.0
    assert abs((ys[-1] - ys[0] + 1) - 500 * 100 / 300) <= 1.0
    assert abs(0.5 * (xs[0] + xs[-1]) - 199.5) <= 0.5
    assert np.all(ras.face_id[~inside] == -1) and np.all(ras.face_id[inside] >= 0)


def test_no_cracks_between_many_triangles() -> None:
    V, F = grid_plane(40, 50.0)
    cam = look_at([30, 20, 250.0], [0, 0, 0], [0, 1, 0], 700.0, 256, 256)
    ras = rasterize(V, F, cam)
    uv = cam.project(V[[0, 40, 41 * 41 - 1, 41 * 40]])   # the square's four corners
    poly = np.zeros((256, 256), np.uint8)
    cv2.fillConvexPoly(poly, np.round(uv * 16).astype(np.int32), 1, shift=4)
    interior = cv2.erode(poly, np.ones((3, 3), np.uint8)).astype(bool)
    assert interior.sum() > 10000
    assert np.isfinite(ras.depth[interior]).all()


def test_tilted_plane_depth_and_perspective_correct_interpolation() -> None:
    V, F = grid_plane(3, 60.0)
    R = np.array([[1, 0, 0], [0, np.cos(1.0), -np.sin(1.0)], [0, np.sin(1.0), np.cos(1.0)]])
    V = V @ R.T
    cam = look_at([10, -20, 220.0], [0, 0, 0], [0, 1, 0], 400.0, 200, 200)
    ras = rasterize(V, F, cam)
    ys, xs = np.divmod(ras.pixels, 200)
    origin, d = cam.rays(np.column_stack([xs, ys]).astype(float))
    normal = R @ np.array([0.0, 0.0, 1.0])
    s = -(origin @ normal) / (d @ normal)
    P = origin + s[:, None] * d                      # exact ray-plane intersections
    assert np.allclose(ras.depth.reshape(-1)[ras.pixels], cam.depth(P), atol=1e-6)
    # the world position interpolated with the barycentrics is the intersection point
    assert np.allclose(ras.interpolate(F, V), P, atol=1e-3)


def test_cube_occlusion_and_visible_points() -> None:
    V, F = cube(20.0)
    cam = look_at([0, 0, 200.0], [0, 0, 0], [0, 1, 0], 600.0, 256, 256)
    res = render_mesh(V, F, cam, background=(10, 20, 30), supersample=1)
    hit = res.face_id >= 0
    front = np.flatnonzero(np.all(V[F][:, :, 2] > 19.9, axis=1))
    assert set(np.unique(res.face_id[hit])) <= set(front.tolist())
    assert np.allclose(res.depth[hit], 180.0, atol=1e-6)
    assert np.all(res.image[~hit] == (10, 20, 30))
    pts = np.array([[0, 0, 20.0],      # centre of the front face: visible
                    [0, 0, -20.0],     # centre of the back face: hidden
                    [5, 5, 0.0],       # inside the cube: hidden
                    [200, 0, 0.0],     # outside the image
                    [0, 0, 250.0]])    # behind the camera
    assert visible_points(pts, cam, res.depth).tolist() == [True, False, False, False, False]
    # a point just behind the surface is visible only within the tolerance
    assert visible_points([[0, 0, 19.5]], cam, res.depth, tol_mm=1.0)[0]
    assert not visible_points([[0, 0, 18.0]], cam, res.depth, tol_mm=1.0)[0]


def test_backface_culling() -> None:
    V = np.array([[-10.0, -10, 0], [10, -10, 0], [0, 10, 0]])
    cam = look_at([0, 0, 100.0], [0, 0, 0], [0, 1, 0], 300.0, 64, 64)
    toward = np.array([[0, 1, 2]])            # counter-clockwise seen from +z: faces camera
    away = toward[:, ::-1]
    assert (rasterize(V, toward, cam, cull_backfaces=True).face_id >= 0).sum() > 100
    assert (rasterize(V, away, cam, cull_backfaces=True).face_id >= 0).sum() == 0
    assert (rasterize(V, away, cam).face_id >= 0).sum() > 100


def test_shading_lights_surfaces_facing_the_key_light() -> None:
    V, F = grid_plane(20, 40.0)
    cam = look_at([0, 0, 300.0], [0, 0, 0], [0, 1, 0], 800.0, 128, 128)
    colors = np.full((len(V), 3), 0.6)
    facing = render_mesh(V, F, cam, vertex_colors=colors, light_dirs=[(0, 0, -1)],
                         light_intensities=[0.6], specular=0.0, supersample=1)
    grazing = render_mesh(V, F, cam, vertex_colors=colors, light_dirs=[(1, 0, -0.05)],
                          light_intensities=[0.6], specular=0.0, supersample=1)
    assert facing.image[64, 64].mean() > grazing.image[64, 64].mean() + 40
    n = vertex_normals(V, F)
    assert np.allclose(n, [0, 0, 1])


def test_supersampling_keeps_geometry() -> None:
    V, F = cube(20.0)
    cam = look_at([60, 50, 150.0], [0, 0, 0], [0, 1, 0], 300.0, 96, 80)
    r1 = render_mesh(V, F, cam, supersample=1)
    r2 = render_mesh(V, F, cam, supersample=2)
    assert r2.image.shape == (80, 96, 3) and r2.depth.shape == (80, 96)
    both = np.isfinite(r1.depth) & np.isfinite(r2.depth)
    assert np.mean(both) > 0.1
    assert np.median(np.abs(r1.depth[both] - r2.depth[both])) < 0.5
    # coverage differs only along the silhouette
    assert np.sum(np.isfinite(r1.depth) != np.isfinite(r2.depth)) < 0.1 * both.sum()


def test_rasterize_screen_keeps_nearest() -> None:
    uv = np.array([[0, 0], [30, 0], [0, 30], [0, 0], [30, 0], [0, 30]], dtype=float)
    z = np.array([5.0, 5, 5, 2, 2, 2])
    F = np.array([[0, 1, 2], [3, 4, 5]])
    ras = rasterize_screen(uv, z, F, 32, 32)
    assert np.all(ras.face_id[ras.face_id >= 0] == 1)
    assert ras.depth[3, 3] == pytest.approx(2.0)
