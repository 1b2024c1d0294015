"""A small software rasteriser (numpy only): z-buffer, smooth shading, depth tests.

Renders triangle meshes through a :class:`~naseview.camera.Camera` (SPEC §4: ``x_cam = R X
+ t``, pixel ``[0, 0]`` is the centre of the top-left pixel) into a BGR photo, a depth map
(mm along the optical axis) and a triangle-id map. Used to make synthetic photos with
exact ground truth (:mod:`naseview.testbed.synth`) and to test visibility.

How it works: for every row of every triangle's screen box the three edge functions give
the exact pixel span inside the triangle (vectorised over all rows); the spans are
expanded into fragments with ``np.repeat`` (in chunks to bound memory); ``1/z`` is affine
in screen space, so each fragment's depth is one multiply-add; ``np.minimum.at``
resolves the z-buffer and the winners get perspective-correct barycentrics. Shading is
Gouraud (lit vertex colours interpolated) with lights fixed in the camera frame, like a
photographer's key and fill lights.

Example
-------
>>> import numpy as np
>>> from naseview.camera import look_at
>>> V = np.array([[-50.0, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]])
>>> F = np.array([[0, 1, 2], [0, 2, 3]])
>>> cam = look_at([0, 0, 300.0], [0, 0, 0], [0, 1, 0], 500.0, 64, 64)
>>> res = render_mesh(V, F, cam, supersample=1)
>>> float(res.depth[32, 32])
300.0
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera
from naseview.geometry.mesh import vertex_normals

__all__ = ["DEFAULT_LIGHTS", "DEFAULT_LIGHT_INTENSITIES", "Raster", "RenderResult",
           "rasterize", "rasterize_screen", "render_mesh", "shade_vertices", "visible_points"]

DEFAULT_LIGHTS: tuple[tuple[float, float, float], ...] = (
    (-0.45, -0.55, -1.0),   # key light: above and left of the camera
    (0.6, -0.1, -1.0),      # fill light: right of the camera
)
"""Directions towards the lights in the camera frame (x right, y down, z forward)."""

DEFAULT_LIGHT_INTENSITIES: tuple[float, ...] = (0.62, 0.28)

_CHUNK_FRAGMENTS = 2_000_000


@dataclass
class Raster:
    """Visibility of a mesh in one camera, per pixel.

    Attributes:
        depth: (H, W) float64 depth along the optical axis (mm); ``inf`` = background.
        face_id: (H, W) int64 index of the visible triangle; ``-1`` = background.
        pixels: (M,) int64 flat indices (``y * W + x``) of the covered pixels, ascending.
        bary: (M, 3) float32 perspective-correct barycentric weights, at those pixels'
            centres, of the vertices ``F[face_id]`` of the visible triangle.
    """

    depth: np.ndarray
    face_id: np.ndarray
    pixels: np.ndarray
    bary: np.ndarray

    def interpolate(self, F: np.ndarray, values: np.ndarray) -> np.ndarray:
        """(M, C) per-vertex ``values`` (V, C) interpolated at :attr:`pixels`."""
        tv = np.asarray(F)[self.face_id.reshape(-1)[self.pixels]].T      # (3, M)
        vals = np.asarray(values)
        vals = vals.reshape(len(vals), -1)
        b = self.bary.T.astype(np.result_type(vals.dtype, np.float32))     # (3, M)
        out = np.empty((vals.shape[1], len(self.pixels)), dtype=b.dtype)
        for c in range(vals.shape[1]):
            col = np.ascontiguousarray(vals[:, c], dtype=b.dtype)
            out[c] = col[tv[0]] * b[0] + col[tv[1]] * b[1] + col[tv[2]] * b[2]
        return out.T if np.ndim(values) > 1 else out[0]


@dataclass
class RenderResult:
    """A rendered photo.

    Attributes:
        image: (H, W, 3) uint8 BGR.
        depth: (H, W) float64 depth along the optical axis (mm), ``inf`` = background.
        face_id: (H, W) int64 visible triangle per pixel, ``-1`` = background.
    """

    image: np.ndarray
    depth: np.ndarray
    face_id: np.ndarray


def rasterize(V: ArrayLike, F: ArrayLike, camera: Camera, supersample: int = 1,
              cull_backfaces: bool = False, near_mm: float = 1.0) -> Raster:
    """Z-buffer rasterisation of a triangle mesh.

    Args:
        V: (V, 3) vertices, world frame (mm).
        F: (F, 3) triangles (vertex indices).
        camera: pinhole camera; the raster is ``supersample`` times its size.
        supersample: integer factor; pixel ``i`` of the raster has its centre at
            ``(i + 0.5) / s - 0.5`` in the camera's pixel coordinates.
        cull_backfaces: drop triangles whose outer side faces away from the camera.
        near_mm: triangles with a vertex closer than this to the camera plane are dropped.
    Returns:
        :class:`Raster` of shape ``(s H, s W)``.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64).reshape(-1, 3)
    s = int(supersample)
    xc = camera.to_camera(V)
    z = xc[:, 2]
    K = camera.K
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (K[0, 0] * xc[:, 0] + K[0, 1] * xc[:, 1]) / z + K[0, 2]
        v = K[1, 1] * xc[:, 1] / z + K[1, 2]
    keep = np.all(z[F] > near_mm, axis=1) if len(F) else np.zeros(0, dtype=bool)
    if cull_backfaces and len(F):
        fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        keep &= np.einsum("ij,ij->i", fn, camera.center - V[F[:, 0]]) > 0
    return rasterize_screen(np.column_stack([(u + 0.5) * s - 0.5, (v + 0.5) * s - 0.5]),
                            z, F[keep], camera.width * s, camera.height * s,
                            face_ids=np.flatnonzero(keep))


@dataclass
class _Triangles:
    """Screen-space set-up of the triangles that cover at least one pixel centre.

    Attributes:
        tri: (T,) indices into ``F`` of these triangles.
        bx0, by0, bw, bh: (T,) int64 pixel box (first column / row, width, height).
        edges: (T, 6) ``a1, b1, c1, a2, b2, c2``: barycentric weight ``l_k = a_k x + b_k y
            + c_k`` of vertices 1 and 2 (``l_0 = 1 - l_1 - l_2``).
        iz: (T, 3) ``1/z`` of the three vertices; inv_z: (T, 3) ``ai, bi, ci``, the plane
            ``1/z = ai x + bi y + ci`` (affine in screen space).
    """

    tri: np.ndarray
    bx0: np.ndarray
    by0: np.ndarray
    bw: np.ndarray
    bh: np.ndarray
    edges: np.ndarray
    iz: np.ndarray
    inv_z: np.ndarray


def _setup_triangles(u: np.ndarray, v: np.ndarray, z: np.ndarray, F: np.ndarray, W: int,
                     H: int) -> _Triangles | None:
    """Boxes, edge functions and the 1/z plane of the front, non-degenerate triangles
    whose box holds a pixel centre; None when there is none."""
    zt = z[F]
    keep = np.all(zt > 0, axis=1)
    ut, vt = u[F], v[F]
    area = (ut[:, 1] - ut[:, 0]) * (vt[:, 2] - vt[:, 0]) \
        - (ut[:, 2] - ut[:, 0]) * (vt[:, 1] - vt[:, 0])
    keep &= np.abs(area) > 1e-10
    x0 = np.ceil(ut.min(axis=1))
    x1 = np.floor(ut.max(axis=1))
    y0 = np.ceil(vt.min(axis=1))
    y1 = np.floor(vt.max(axis=1))
    with np.errstate(invalid="ignore"):
        x0 = np.clip(x0, 0, W - 1)
        x1 = np.clip(x1, -1, W - 1)
        y0 = np.clip(y0, 0, H - 1)
        y1 = np.clip(y1, -1, H - 1)
    keep &= np.isfinite(x0) & np.isfinite(y0) & (x1 >= x0) & (y1 >= y0)
    tri = np.flatnonzero(keep)
    if tri.size == 0:
        return None
    ut, vt, zt, area = ut[tri], vt[tri], zt[tri], area[tri]
    bx0 = x0[tri].astype(np.int64)
    by0 = y0[tri].astype(np.int64)
    bw = x1[tri].astype(np.int64) - bx0 + 1
    bh = y1[tri].astype(np.int64) - by0 + 1
    # Edge functions: l1 = a1 x + b1 y + c1 (weight of vertex 1), l2 likewise; l0 = 1-l1-l2.
    inv = 1.0 / area
    a1 = (vt[:, 2] - vt[:, 0]) * inv
    b1 = -(ut[:, 2] - ut[:, 0]) * inv
    c1 = -(a1 * ut[:, 0] + b1 * vt[:, 0])
    a2 = -(vt[:, 1] - vt[:, 0]) * inv
    b2 = (ut[:, 1] - ut[:, 0]) * inv
    c2 = -(a2 * ut[:, 0] + b2 * vt[:, 0])
    # 1/z is affine in screen space: iz = l0/z0 + l1/z1 + l2/z2.
    iz0, iz1, iz2 = 1.0 / zt[:, 0], 1.0 / zt[:, 1], 1.0 / zt[:, 2]
    ai = a1 * (iz1 - iz0) + a2 * (iz2 - iz0)
    bi = b1 * (iz1 - iz0) + b2 * (iz2 - iz0)
    ci = iz0 + c1 * (iz1 - iz0) + c2 * (iz2 - iz0)
    return _Triangles(tri, bx0, by0, bw, bh, np.stack([a1, b1, c1, a2, b2, c2], axis=1),
                      np.stack([iz0, iz1, iz2], axis=1), np.stack([ai, bi, ci], axis=1))


@dataclass
class _Spans:
    """One scanline span per row of every triangle's box.

    Attributes:
        row_t: (R,) local triangle of the row; counts: (R,) pixels inside (>= 0);
        ends: (R,) cumulative ``counts``; row_pix: (R,) flat index of the first pixel;
        row_iz: (R,) ``1/z`` at the first pixel; row_dz: (R,) its step per pixel.
    """

    row_t: np.ndarray
    counts: np.ndarray
    ends: np.ndarray
    row_pix: np.ndarray
    row_iz: np.ndarray
    row_dz: np.ndarray


def _scanline_spans(t: _Triangles, W: int) -> _Spans:
    """For every triangle row, the pixel interval where all three edge functions are
    >= 0 (a small tolerance closes cracks between neighbours)."""
    a1, b1, c1, a2, b2, c2 = t.edges.T
    ai, bi, ci = t.inv_z.T
    eps = 1e-7
    row_t = np.repeat(np.arange(len(t.tri)), t.bh)
    row_y = (np.arange(len(row_t)) - np.repeat(np.cumsum(t.bh) - t.bh, t.bh)
             + t.by0[row_t]).astype(np.float64)
    lo = t.bx0[row_t].astype(np.float64)
    hi = (t.bx0 + t.bw - 1)[row_t].astype(np.float64)
    a0 = -(a1 + a2)
    b0 = -(b1 + b2)
    c0 = 1.0 - c1 - c2
    for ea, eb, ec in ((a0, b0, c0), (a1, b1, c1), (a2, b2, c2)):
        ar = ea[row_t]
        rest = eb[row_t] * row_y + ec[row_t] + eps     # edge >= 0  <=>  ar * x + rest >= 0
        with np.errstate(divide="ignore", invalid="ignore"):
            xb = -rest / ar
        pos = ar > 0
        neg = ar < 0
        lo = np.where(pos, np.maximum(lo, np.ceil(xb)), lo)
        hi = np.where(neg, np.minimum(hi, np.floor(xb)), hi)
        hi = np.where((ar == 0) & (rest < 0), lo - 1, hi)
    counts = np.maximum(hi - lo + 1, 0).astype(np.int64)
    row_pix = row_y.astype(np.int64) * W + np.where(counts > 0, lo, 0).astype(np.int64)
    row_iz = ai[row_t] * lo + bi[row_t] * row_y + ci[row_t]   # 1/z at the span start
    return _Spans(row_t, counts, np.cumsum(counts), row_pix, row_iz, ai[row_t])


def _fragments(sp: _Spans) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Every covered pixel of every span: (M,) flat pixel, depth z and local triangle,
    expanded in chunks of about ``_CHUNK_FRAGMENTS`` to bound memory; None if empty."""
    frags_pix, frags_z, frags_t = [], [], []
    r_start = 0
    n_rows = len(sp.row_t)
    while r_start < n_rows:
        base = int(sp.ends[r_start - 1]) if r_start else 0
        r_stop = int(np.searchsorted(sp.ends, base + _CHUNK_FRAGMENTS, side="right"))
        r_stop = min(max(r_stop, r_start + 1), n_rows)
        cnt = sp.counts[r_start:r_stop]
        total = int(cnt.sum())
        if total:
            rows = np.repeat(np.arange(r_start, r_stop), cnt)
            off = np.arange(total) - np.repeat(sp.ends[r_start:r_stop] - cnt - base, cnt)
            frags_t.append(sp.row_t[rows])
            frags_pix.append(sp.row_pix[rows] + off)
            frags_z.append(1.0 / (sp.row_iz[rows] + sp.row_dz[rows] * off))
        r_start = r_stop
    if not frags_pix:
        return None
    return np.concatenate(frags_pix), np.concatenate(frags_z), np.concatenate(frags_t)


def _barycentrics(t: _Triangles, pixels: np.ndarray, wt: np.ndarray, depth: np.ndarray,
                  W: int) -> np.ndarray:
    """(M, 3) float32 perspective-correct barycentrics of the visible triangles ``wt``
    (local ids) at the centres of ``pixels``, from the resolved ``depth``."""
    ys, xs = np.divmod(pixels, W)
    cw = np.concatenate([t.edges, t.iz], axis=1)[wt]   # (M, 9)
    l1 = cw[:, 0] * xs + cw[:, 1] * ys + cw[:, 2]
    l2 = cw[:, 3] * xs + cw[:, 4] * ys + cw[:, 5]
    dz = depth[pixels]
    bary = np.empty((len(pixels), 3), dtype=np.float32)
    bary[:, 1] = l1 * cw[:, 7] * dz
    bary[:, 2] = l2 * cw[:, 8] * dz
    bary[:, 0] = 1.0 - bary[:, 1] - bary[:, 2]
    return bary


def rasterize_screen(uv: ArrayLike, z: ArrayLike, F: ArrayLike, width: int, height: int,
                     face_ids: ArrayLike | None = None) -> Raster:
    """Z-buffer rasterisation of triangles already in screen space.

    Steps: triangle set-up (boxes, edge functions, the 1/z plane), scanline spans,
    fragments, z-buffer (``np.minimum.at``), barycentrics of the winners.

    Args:
        uv: (V, 2) pixel coordinates of the vertices (pixel centres at integers).
        z: (V,) positive depth of the vertices; ``1/z`` is interpolated affinely (the
            perspective-correct rule), the smallest ``z`` wins.
        F: (F, 3) triangles.
        width, height: raster size in pixels.
        face_ids: (F,) ids written to ``face_id`` (default ``arange(F)``).
    Returns:
        :class:`Raster` of shape ``(height, width)``.
    """
    uvz = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    zs = np.asarray(z, dtype=np.float64).reshape(-1)
    F = np.asarray(F, dtype=np.int64).reshape(-1, 3)
    ids = np.arange(len(F)) if face_ids is None else np.asarray(face_ids, dtype=np.int64)
    W, H = int(width), int(height)
    depth = np.full(H * W, np.inf)
    face_id = np.full(H * W, -1, dtype=np.int64)
    empty = Raster(depth.reshape(H, W), face_id.reshape(H, W), np.zeros(0, dtype=np.int64),
                   np.zeros((0, 3), dtype=np.float32))
    t = _setup_triangles(uvz[:, 0], uvz[:, 1], zs, F, W, H) if len(F) else None
    frags = _fragments(_scanline_spans(t, W)) if t is not None else None
    if t is None or frags is None:
        return empty
    pix, fz, ft = frags
    np.minimum.at(depth, pix, fz)
    win = fz <= depth[pix]
    local = np.full(H * W, -1, dtype=np.int64)
    local[pix[win]] = ft[win]
    pixels = np.flatnonzero(local >= 0)
    wt = local[pixels]
    face_id[pixels] = ids[t.tri[wt]]
    return Raster(depth.reshape(H, W), face_id.reshape(H, W), pixels,
                  _barycentrics(t, pixels, wt, depth, W))


def _downsample(raster: Raster, image: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray,
                                                                    np.ndarray]:
    """Box-filter the image; per output pixel keep the nearest sub-sample's depth and id."""
    H, W = raster.depth.shape[0] // s, raster.depth.shape[1] // s
    img = cv2.resize(image, (W, H), interpolation=cv2.INTER_AREA)
    d = raster.depth.reshape(H, s, W, s).transpose(0, 2, 1, 3).reshape(H, W, s * s)
    f = raster.face_id.reshape(H, s, W, s).transpose(0, 2, 1, 3).reshape(H, W, s * s)
    k = np.argmin(d, axis=2)[..., None]
    return img, np.take_along_axis(d, k, 2)[..., 0], np.take_along_axis(f, k, 2)[..., 0]


def shade_vertices(V: ArrayLike, N: ArrayLike, C: ArrayLike, camera: Camera,
                   light_dirs: ArrayLike = DEFAULT_LIGHTS,
                   light_intensities: ArrayLike = DEFAULT_LIGHT_INTENSITIES,
                   ambient: float = 0.32, specular: float = 0.12, shininess: float = 24.0,
                   vertex_specular: ArrayLike | None = None) -> np.ndarray:
    """Lit colour of every vertex seen from ``camera`` (Blinn-Phong, lights in camera frame).

    ``colour * (ambient + sum_i I_i * wrap(n . l_i)) + specular * s_v * sum_i I_i
    (n . h_i)^shininess``; ``wrap`` is a soft Lambert (light reaches slightly past the
    terminator, like a large diffuse photo light); ``n`` is turned towards the camera
    (two-sided lighting); ``h_i`` is the half vector of light ``i`` and the view direction.

    Args:
        V: (V, 3) vertices (mm, world); N: (V, 3) unit normals (world); C: (V, 3) albedo
            in [0, 1] (any channel order).
        camera: gives the view direction and the camera frame of the lights.
        light_dirs: (L, 3) directions towards the lights, camera frame (x right, y down,
            z forward).
        light_intensities: (L,) strengths.
        vertex_specular: (V,) multiplier of the highlight per vertex (default 1).
    Returns:
        (V, 3) colours (may exceed 1 in highlights; clip when converting).
    """
    V = np.asarray(V, dtype=np.float64)
    n = np.asarray(N, dtype=np.float64) @ camera.R.T
    view = -camera.to_camera(V)
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-9)
    n = np.where((np.einsum("ij,ij->i", n, view) < 0)[:, None], -n, n)
    L = np.asarray(light_dirs, dtype=np.float64).reshape(-1, 3)
    L = L / np.linalg.norm(L, axis=1, keepdims=True)
    Li = np.asarray(light_intensities, dtype=np.float64).reshape(-1)
    diff = np.zeros(len(V))
    spec = np.zeros(len(V))
    for li, inten in zip(L, Li, strict=True):
        diff += inten * np.clip((n @ li + 0.15) / 1.15, 0.0, None)
        h = li[None, :] + view
        h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-9)
        spec += inten * np.clip(np.einsum("ij,ij->i", n, h), 0.0, None) ** shininess
    sv = np.ones(len(V)) if vertex_specular is None else np.asarray(vertex_specular, float)
    return np.asarray(C, dtype=np.float64) * (ambient + diff)[:, None] \
        + (specular * spec * sv)[:, None]


def render_mesh(V: ArrayLike, F: ArrayLike, camera: Camera,
                vertex_colors: ArrayLike | None = None,
                light_dirs: ArrayLike = DEFAULT_LIGHTS,
                light_intensities: ArrayLike = DEFAULT_LIGHT_INTENSITIES,
                ambient: float = 0.32, specular: float = 0.12, shininess: float = 24.0,
                background: tuple[int, int, int] = (255, 255, 255),
                supersample: int = 2, cull_backfaces: bool = False,
                normals: ArrayLike | None = None,
                vertex_specular: ArrayLike | None = None) -> RenderResult:
    """Render a shaded mesh into a photo, a depth map and a triangle-id map.

    Gouraud shading: every vertex is lit by :func:`shade_vertices` (soft key and fill
    lights fixed in the camera frame, Blinn-Phong highlight) and the lit colours are
    interpolated perspective-correctly across the triangles.

    Args:
        V: (V, 3) vertices, world frame (mm).
        F: (F, 3) triangles, counter-clockwise seen from outside.
        camera: the camera; the image has its width and height.
        vertex_colors: (V, 3) BGR in [0, 1] (floats) or [0, 255] (uint8); default light grey.
        light_dirs: (L, 3) directions towards the lights, camera frame (x right, y down,
            z forward), normalised internally.
        light_intensities: (L,) light strengths.
        ambient: ambient term (fraction of the colour).
        specular: strength of the white highlight (0 for matte).
        shininess: Blinn-Phong exponent.
        background: BGR uint8 colour of empty pixels.
        supersample: anti-aliasing factor (2 = 4 samples per pixel, box filtered).
        cull_backfaces: hide triangles seen from inside (the inner side of open shells).
        normals: (V, 3) vertex normals; default :func:`vertex_normals`.
        vertex_specular: (V,) per-vertex multiplier of ``specular`` (e.g. 0 on hair).
    Returns:
        :class:`RenderResult`; depth and face id are those of the nearest sub-sample.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64).reshape(-1, 3)
    s = max(1, int(supersample))
    if vertex_colors is None:
        C = np.full((len(V), 3), 0.8)
    else:
        C = np.asarray(vertex_colors)
        C = C.astype(np.float64) / 255.0 if C.dtype == np.uint8 else C.astype(np.float64)
    N = vertex_normals(V, F) if normals is None else np.asarray(normals, dtype=np.float64)
    lit = shade_vertices(V, N, C, camera, light_dirs=light_dirs,
                         light_intensities=light_intensities, ambient=ambient,
                         specular=specular, shininess=shininess,
                         vertex_specular=vertex_specular).astype(np.float32)
    ras = rasterize(V, F, camera, supersample=s, cull_backfaces=cull_backfaces)
    Hs, Ws = ras.depth.shape
    out = np.empty((Hs * Ws, 3), dtype=np.uint8)
    out[:] = np.asarray(background, dtype=np.uint8)
    if ras.pixels.size:
        col = ras.interpolate(F, lit)
        np.clip(col * 255.0 + 0.5, 0.0, 255.0, out=col)
        out[ras.pixels] = col.astype(np.uint8)
    out = out.reshape(Hs, Ws, 3)
    if s == 1:
        return RenderResult(out, ras.depth, ras.face_id)
    image, depth, face_id = _downsample(ras, out, s)
    return RenderResult(image, depth, face_id)


def visible_points(P: ArrayLike, camera: Camera, depth: np.ndarray, tol_mm: float = 1.0,
                   radius_px: int = 0) -> np.ndarray:
    """Depth test of 3D points against a rendered depth map.

    A point is visible when it projects inside the image, lies in front of the camera and
    is not farther than ``tol_mm`` behind the rendered surface somewhere near its pixel:
    the largest depth over the pixels within ``radius_px`` of the 2 x 2 pixels around
    its sub-pixel position is used. ``radius_px = 0`` is the plain depth test (the 2 x 2
    neighbourhood keeps points on steep surfaces and right at a silhouette visible); a
    few pixels also accept points just behind an occluding contour (a landmark a person
    would still click at that contour).

    Args:
        P: (N, 3) world points (mm).
        camera: the camera that produced ``depth``.
        depth: (H, W) depth map (mm along the optical axis, ``inf`` = background).
        tol_mm: depth tolerance (mm).
        radius_px: extra neighbourhood radius (px, square window).
    Returns:
        (N,) bool.
    """
    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    H, W = depth.shape
    z = camera.depth(P)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = camera.project(P)
    ok = (z > 0) & np.all(np.isfinite(uv), axis=1)
    ok &= (uv[:, 0] >= -0.5) & (uv[:, 0] <= W - 0.5) & (uv[:, 1] >= -0.5) & (uv[:, 1] <= H - 0.5)
    out = np.zeros(len(P), dtype=bool)
    if not ok.any():
        return out
    r = max(int(radius_px), 0)
    win = np.arange(-r, r + 2)
    rows = np.clip(np.floor(uv[ok, 1]).astype(np.int64)[:, None] + win, 0, H - 1)
    cols = np.clip(np.floor(uv[ok, 0]).astype(np.int64)[:, None] + win, 0, W - 1)
    dmax = depth[rows[:, :, None], cols[:, None, :]].max(axis=(1, 2))
    out[ok] = z[ok] <= dmax + tol_mm
    return out
