"""A closed head behind the open face mask, so profile photos show a whole head.

In spherical coordinates about a point behind the face (``centre``), the mask's radius
map (first hit) is rasterised on a 360 x 180 longitude/latitude grid; holes in it (eyes,
mouth) are inpainted; outside the mask the radius blends into an ellipsoid fitted to the
mask's rim. The proxy is the radial surface 2 mm inside that radius (14 mm inside in the
holes, leaving room for eyeballs and a dark mouth), sampled on a coarser 120 x 60 grid.

Example
-------
>>> lon, lat, F = sphere_grid(8, 4)
>>> lon.shape, F.shape
((34,), (64, 3))
"""

from __future__ import annotations

import cv2
import numpy as np

from naseview.render import rasterize_screen

MAP_W, MAP_H = 360, 180
"""Longitude x latitude size of the radius maps (one sample per degree)."""

GRID_LON, GRID_LAT = 120, 60
"""Longitude x latitude size of the proxy mesh grid."""


def sphere_grid(n_lon: int, n_lat: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude/latitude grid with two poles: lon (N,), lat (N,), faces (M, 3) outward."""
    lons = -np.pi + (np.arange(n_lon) + 0.5) * 2 * np.pi / n_lon
    lats = np.pi / 2 - (np.arange(n_lat) + 0.5) * np.pi / n_lat
    LO, LA = np.meshgrid(lons, lats)                    # (n_lat, n_lon), row 0 at the top
    lon = np.concatenate([LO.ravel(), [0.0, 0.0]])
    lat = np.concatenate([LA.ravel(), [np.pi / 2, -np.pi / 2]])
    idx = np.arange(n_lat * n_lon).reshape(n_lat, n_lon)
    a = idx[:-1]
    b = np.roll(idx[:-1], -1, axis=1)
    c = np.roll(idx[1:], -1, axis=1)
    d = idx[1:]
    F = [np.column_stack([a.ravel(), d.ravel(), c.ravel()]),
         np.column_stack([a.ravel(), c.ravel(), b.ravel()])]
    top, bot = n_lat * n_lon, n_lat * n_lon + 1
    F.append(np.column_stack([np.full(n_lon, top), idx[0], np.roll(idx[0], -1)]))
    F.append(np.column_stack([np.full(n_lon, bot), np.roll(idx[-1], -1), idx[-1]]))
    return lon, lat, np.concatenate(F)


def _centre(s: float) -> np.ndarray:
    """(3,) centre of the spherical coordinates, behind the face (mm, ``s`` = face scale)."""
    return np.array([0.0, -20.0 * s, -85.0 * s])


def _radius_map(V: np.ndarray, F: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(MAP_H, MAP_W) float32 distance (mm) from ``c`` to the nearest mask triangle per
    direction; ``inf`` where no triangle is hit (triangles across the seam left out)."""
    W, H = MAP_W, MAP_H
    d = V - c
    r = np.linalg.norm(d, axis=1)
    lon = np.arctan2(d[:, 0], d[:, 2])
    lat = np.arcsin(np.clip(d[:, 1] / r, -1, 1))
    uv = np.column_stack([(lon + np.pi) * W / (2 * np.pi) - 0.5,
                          (np.pi / 2 - lat) * H / np.pi - 0.5])
    span = np.ptp(lon[F], axis=1) < np.pi
    ras = rasterize_screen(uv, r, F[span], W, H)
    return ras.depth.astype(np.float32)


def _outside_and_holes(covered: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) bool: uncovered and connected to the map border (outside the mask), and
    uncovered inside the mask (eyes, mouth)."""
    _, labels = cv2.connectedComponents((~covered).astype(np.uint8), connectivity=4)
    border = np.unique(np.concatenate([labels[:, 0], labels[:, -1], labels[0], labels[-1]]))
    outside = ~covered & np.isin(labels, border)
    return outside, ~covered & ~outside


def _inpaint(R: np.ndarray, covered: np.ndarray, s: float) -> np.ndarray:
    """The radius extended into holes and around the rim by normalised Gaussian averaging
    (median radius where nothing reaches)."""
    cov = covered.astype(np.float32)
    Rz = np.where(covered, R, 0).astype(np.float32)
    Rf = R.copy()
    for sigma in (2.0, 5.0, 12.0):
        num = cv2.GaussianBlur(Rz, (0, 0), sigma)
        den = cv2.GaussianBlur(cov, (0, 0), sigma)
        fill = ~np.isfinite(Rf) & (den > 1e-3)
        Rf[fill] = num[fill] / den[fill]
    Rf[~np.isfinite(Rf)] = float(np.median(R[covered])) if covered.any() else 90.0 * s
    return Rf


def _map_directions() -> np.ndarray:
    """(MAP_H, MAP_W, 3) unit direction of every radius-map pixel centre."""
    W, H = MAP_W, MAP_H
    g_lon = -np.pi + (np.arange(W) + 0.5) * 2 * np.pi / W
    g_lat = np.pi / 2 - (np.arange(H) + 0.5) * np.pi / H
    GL, GA = np.meshgrid(g_lon, g_lat)
    return np.stack([np.cos(GA) * np.sin(GL), np.sin(GA), np.cos(GA) * np.cos(GL)], axis=-1)


def _rim_ellipsoid(R: np.ndarray, covered: np.ndarray, outside: np.ndarray,
                   s: float) -> np.ndarray:
    """(H, W) radius of the axis-aligned ellipsoid ``1/r^2 = A dx^2 + B dy^2 + C dz^2``
    fitted to the rim of the covered region (semi-axes clipped to 60-140 mm x s)."""
    rim = covered & (cv2.dilate(outside.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0)
    ys, xs = np.nonzero(rim)
    dirs = _map_directions()
    if len(ys) >= 3:
        A = dirs[ys, xs] ** 2
        coef = np.linalg.lstsq(A, 1.0 / R[ys, xs].astype(float) ** 2, rcond=None)[0]
        coef = np.clip(coef, 1.0 / (140.0 * s) ** 2, 1.0 / (60.0 * s) ** 2)
    else:
        coef = 1.0 / (np.array([75.0, 110.0, 95.0]) * s) ** 2
    return np.asarray(1.0 / np.sqrt(np.einsum("hwk,k->hw", dirs ** 2, coef)))


def _proxy_radius(Rf: np.ndarray, Re: np.ndarray, covered: np.ndarray, outside: np.ndarray,
                  holes: np.ndarray, s: float) -> np.ndarray:
    """(H, W) radius of the proxy: the mask's blending into the ellipsoid outside it,
    moved inwards by 2 mm (14 mm in the holes)."""
    dist = cv2.distanceTransform((~covered | holes).astype(np.uint8), cv2.DIST_L2, 3)
    wgt = np.where(outside, np.exp(-dist / 12.0), 1.0)
    Rm = wgt * Rf + (1 - wgt) * Re
    inset = np.where(holes, 14.0 * s, 2.0 * s)
    inset = cv2.GaussianBlur(inset.astype(np.float32), (0, 0), 1.5)
    return np.asarray(Rm - inset)


def _on_grid(image: np.ndarray, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """Bilinear samples of an (H, W) map at the grid's map coordinates, (N,)."""
    return np.asarray(cv2.remap(image.astype(np.float32), mx, my, cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_REPLICATE).ravel())


def head_proxy(V: np.ndarray, F: np.ndarray, s: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A closed head surface behind an open face mask (module docstring).

    Args:
        V: (V, 3) face vertices (mm, SPEC frame); F: (F, 3) its triangles.
        s: face scale (alar width / 35 mm).
    Returns:
        vertices (P, 3), triangles (Q, 3) (outward), and (P,) hole weight in [0, 1].
    """
    c = _centre(s)
    R = _radius_map(V, F, c)
    covered = np.isfinite(R)
    outside, holes = _outside_and_holes(covered)
    Rm = _proxy_radius(_inpaint(R, covered, s), _rim_ellipsoid(R, covered, outside, s),
                       covered, outside, holes, s)
    hole_w = cv2.GaussianBlur(cv2.dilate(holes.astype(np.float32), np.ones((5, 5))),
                              (0, 0), 1.0)
    plon, plat, PF = sphere_grid(GRID_LON, GRID_LAT)
    mx = ((plon + np.pi) * MAP_W / (2 * np.pi) - 0.5).astype(np.float32).reshape(1, -1)
    my = ((np.pi / 2 - plat) * MAP_H / np.pi - 0.5).astype(np.float32).reshape(1, -1)
    rr = _on_grid(Rm, mx, my)
    hw = _on_grid(hole_w, mx, my)
    deep = _on_grid(cv2.distanceTransform(covered.astype(np.uint8), cv2.DIST_L2, 3), mx, my)
    pdir = np.column_stack([np.cos(plat) * np.sin(plon), np.sin(plat),
                            np.cos(plat) * np.cos(plon)])
    PV = c + rr[:, None] * pdir
    # triangles deep inside the mask (not in a hole) are never visible: drop them
    hidden = (deep > 6.0) & (hw < 0.01)
    PF = PF[~hidden[PF].all(axis=1)]
    return PV, PF, np.clip(hw, 0.0, 1.0)
