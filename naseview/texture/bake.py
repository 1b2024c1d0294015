"""Projective texturing: the patient's own skin on the reconstructed face, from the photos.

Every texel of the face's texture (:mod:`naseview.texture.uv`) is a point on the mesh ``V``
(n, 3) mm (SPEC frame). Each photo (its stage-1 camera, SPEC §4) that sees the point
offers the colour it shows there, weighted by

- **visibility**: the point is not behind the rendered face (z-buffer of
  :func:`naseview.render.rasterize`, ``tol_mm`` tolerance), so the nose never lends its
  colour to the cheek it hides;
- **view angle**: ``((cos - cos_min) / (1 - cos_min)) ** angle_power`` of the angle between
  the surface normal and the direction to the camera, zero at grazing angles, and zero
  where the photo sees the back of the texel's triangle (a fold);
- **distance to an edge**: a ramp over ``feather_px`` pixels from the image border, the
  rendered silhouette, depth discontinuities and the backdrop (the uniform background that
  stage 2 removes, :mod:`naseview.stage2_curves.mask`), so seams between photos blend and
  the backdrop is never sampled.

Photos differ in exposure: a per-view, per-channel gain (least squares over texels that
two views both see well, the front view fixed at 1) equalises them before the weighted
blend. Texels no photo sees (the back of the head, deep inside the nostrils) are filled
from their neighbours by push-pull (Gortler et al. 1996), so the texture has no black holes
and no stripes; the eye and mouth openings are baked on flat caps (their photo content), so
a renderer that caps them (:func:`naseview.geometry.closing.cap_holes`) shows the eyes.

Precompute / solve: :func:`texel_plan` rasterises the chart once per topology and size;
:func:`bake_texture` projects the texels of one face into the photos.

Example
-------
>>> tex = bake_texture(V, F, rec.cameras, photos)          # doctest: +SKIP
>>> import numpy as np                     # the hole filling on its own:
>>> img = np.full((4, 4, 3), 100.0, np.float32); w = np.ones((4, 4), np.float32)
>>> w[1:3, 1:3] = 0.0
>>> float(push_pull(img * w[:, :, None], w)[1, 1, 0])
100.0
"""

from __future__ import annotations

import hashlib
import logging
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.camera import Camera
from naseview.case import Case
from naseview.errors import NaseviewError
from naseview.geometry.closing import cap_holes, cap_values
from naseview.geometry.mesh import face_normals, vertex_normals
from naseview.render import rasterize, rasterize_screen, visible_points
from naseview.stage2_curves.mask import estimate_background, foreground_mask
from naseview.texture.uv import face_uv, uv_to_pixels

log = logging.getLogger(__name__)

__all__ = ["BakeParams", "FaceTexture", "TexelPlan", "bake_texture", "skin_texture", "push_pull",
           "multiband_blend", "sample_image", "texel_plan", "view_weights"]

REFERENCE_VIEW = "front"
"""The view whose exposure the others are matched to (gain 1)."""


@dataclass(frozen=True)
class BakeParams:
    """Settings of :func:`bake_texture`.

    Attributes:
        size: texture width = height (texels).
        tol_mm: visibility tolerance behind the z-buffer (mm).
        cos_min: cosine of the grazing angle at which a view's weight reaches 0.
        angle_power: exponent of the view-angle weight (higher = sharper preference for
            the photo facing the surface).
        feather_px: width of the ramp from an edge (photo pixels) over which a view's
            weight rises from 0 to 1.
        jump_mm: depth step between neighbouring pixels that counts as a discontinuity.
        min_pair_weight: both views' weights above this for a texel to enter the gains.
        mask_backdrop: remove the uniform backdrop of each photo (stage 2's mask).
        bands: levels of the multi-band blend (:func:`multiband_blend`).
        border_feather: width of the weight ramp at the image border, as a fraction of
            the photo's larger side (a crop is an arbitrary cut, so it fades widely).
        full_weight: total blend weight at which a texel is taken from the photos alone;
            below it the photo colour fades into the colour filled from the neighbours
            (so the edge of what the photos cover does not show).
    """

    size: int = 1024
    tol_mm: float = 1.5
    cos_min: float = 0.15
    angle_power: float = 3.0
    feather_px: float = 12.0
    jump_mm: float = 6.0
    min_pair_weight: float = 0.1
    mask_backdrop: bool = True
    full_weight: float = 0.25
    bands: int = 6
    border_feather: float = 0.06


@dataclass(frozen=True)
class FaceTexture:
    """A face's texture baked from photos.

    Attributes:
        uv: (n, 2) float64 texture coordinates of the face vertices, in [0, 1], origin at
            the image's top-left, v down (glTF convention; OBJ's ``vt`` is ``(u, 1 - v)``).
        image: (H, W, 3) uint8 **RGB** texture.
        coverage: (H, W) bool, texels some photo saw (the rest is filled from neighbours).
        vertex_colors: (n, 3) uint8 RGB, the texture at each vertex (a cheap fallback for
            vertex-coloured displays).
        gains: view -> (3,) RGB gain applied to that photo (reference view: 1).
        view_share: view -> fraction of the total blend weight it contributed.
    """

    uv: np.ndarray
    image: np.ndarray
    coverage: np.ndarray
    vertex_colors: np.ndarray
    gains: dict[str, np.ndarray] = field(default_factory=dict)
    view_share: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class TexelPlan:
    """The texels of a chart: which capped triangle covers each, and where in it.

    Attributes:
        size: texture width = height.
        uv: (n, 2) chart of the open mesh (:func:`naseview.texture.uv.face_uv`).
        faces: (m', 3) triangles of the hole-capped mesh (``F`` first, then the caps).
        texels: (T,) flat indices ``y * size + x`` of the texels inside the chart.
        tri: (T,) index into ``faces`` of each texel's triangle.
        bary: (T, 3) float32 barycentric weights of the texel centre in it.
        chart: (size, size) bool, the texels inside the chart.
    """

    size: int
    uv: np.ndarray
    faces: np.ndarray
    texels: np.ndarray
    tri: np.ndarray
    bary: np.ndarray
    chart: np.ndarray


_PLANS: dict[tuple[str, int], TexelPlan] = {}
_PLAN_LOCK = threading.Lock()


def texel_plan(V: ArrayLike, F: ArrayLike, size: int = 1024) -> TexelPlan:
    """Rasterise the chart of ``(V, F)`` into a ``size`` x ``size`` texture (cached per
    topology and size, like the chart itself).

    Args:
        V: (n, 3) vertices (mm); F: (m, 3) triangles.
        size: texture width = height (texels, 16..8192).
    """
    F = np.asarray(F, dtype=np.int64)
    V = np.asarray(V, dtype=np.float64)
    size = int(size)
    if not 16 <= size <= 8192:
        raise NaseviewError(f"texture: size {size} must be between 16 and 8192 texels")
    key = (hashlib.sha1(F.tobytes()).hexdigest(), size)
    with _PLAN_LOCK:
        hit = _PLANS.get(key)
    if hit is not None and len(hit.uv) == len(V):
        return hit
    uv = face_uv(V, F)
    Vc, Fc = cap_holes(V, F)
    uvc = cap_values(uv, F, V)
    ras = rasterize_screen(uv_to_pixels(uvc, size, size), np.ones(len(Vc)), Fc, size, size)
    chart = np.zeros(size * size, dtype=bool)
    chart[ras.pixels] = True
    plan = TexelPlan(size, uv, Fc, ras.pixels, ras.face_id.reshape(-1)[ras.pixels],
                     ras.bary, chart.reshape(size, size))
    with _PLAN_LOCK:
        _PLANS[key] = plan
    return plan


def sample_image(image: np.ndarray, xy: np.ndarray,
                 interpolation: int = cv2.INTER_LINEAR) -> np.ndarray:
    """Bilinear samples of ``image`` (H, W[, C]) at pixel positions ``xy`` (N, 2) -> (N[, C])
    float32 (``cv2.remap`` in rows of 4096, its size limit; outside: replicated border)."""
    xy = np.asarray(xy, dtype=np.float32).reshape(-1, 2)
    n = len(xy)
    cols = 4096
    rows = max(1, -(-n // cols))
    pad = np.zeros((rows * cols, 2), np.float32)
    pad[:n] = xy
    mx = pad[:, 0].reshape(rows, cols)
    my = pad[:, 1].reshape(rows, cols)
    src = image if image.dtype in (np.uint8, np.float32) else image.astype(np.float32)
    out = cv2.remap(src, mx, my, interpolation, borderMode=cv2.BORDER_REPLICATE)
    out = out.reshape(rows * cols, *image.shape[2:])[:n]
    return out.astype(np.float32)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def view_weights(photo: np.ndarray, depth: np.ndarray, params: BakeParams) -> np.ndarray:
    """(H, W) float32 in [0, 1]: how far each pixel is from an edge of what may be sampled.

    Zero on the backdrop (when the photo's border is a uniform colour), outside the
    rendered face (``depth`` inf), at depth discontinuities (a step over ``jump_mm``
    between neighbours) and on the image border; rising smoothly to 1 over
    ``feather_px`` pixels away from them (over ``border_feather`` of the image size from
    the image border). A pixel next to an invalid one has weight 0, so
    a bilinear sample with positive weight never touches the backdrop.

    Args:
        photo: (H, W, 3) uint8 BGR photo.
        depth: (H, W) depth map of the face in the photo's camera (mm, inf = none).
        params: :class:`BakeParams`.
    """
    valid = np.isfinite(depth)
    if params.mask_backdrop:
        bg = estimate_background(photo)
        if bg.uniform:
            valid &= foreground_mask(photo, bg, clean_px=3)
    big = np.where(np.isfinite(depth), depth, 1e6).astype(np.float32)
    k = np.ones((3, 3), np.uint8)
    step = cv2.dilate(big, k) - cv2.erode(big, k)
    valid &= step <= params.jump_mm
    valid[0, :] = valid[-1, :] = valid[:, 0] = valid[:, -1] = False
    dist = cv2.distanceTransform(valid.astype(np.uint8), cv2.DIST_L2, 5)
    H, W = depth.shape
    yy, xx = np.ogrid[:H, :W]
    frame = np.minimum(np.minimum(xx, W - 1 - xx), np.minimum(yy, H - 1 - yy))
    ramp = _smoothstep(frame / max(params.border_feather * max(H, W), 1.0))
    return (_smoothstep((dist - 1.5) / max(params.feather_px, 1e-6)) * ramp
            ).astype(np.float32)


def push_pull(image: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Fill an image where ``weight`` is low from its neighbourhood (push-pull pyramid).

    Args:
        image: (H, W, C) float32 values (anything where the weight is 0).
        weight: (H, W) float32 confidence in [0, 1] (0 = unknown).
    Returns:
        (H, W, C) float32: ``w * image + (1 - w) * coarse`` at every level, the coarse
        level being the weighted mean of the finer one; unknown regions get a smooth
        extension of the known colours, known ones are kept.
    """
    img = np.asarray(image, dtype=np.float32)
    w = np.clip(np.asarray(weight, dtype=np.float32), 0.0, 1.0)
    H, W = w.shape
    if H <= 1 and W <= 1 or not (w > 0).any():
        return img.copy()
    h2, w2 = (H + 1) // 2, (W + 1) // 2
    if (H, W) == (2 * h2, 2 * w2):
        pw, pc = w, img * w[:, :, None]
    else:
        pw = np.zeros((2 * h2, 2 * w2), np.float32)
        pc = np.zeros((2 * h2, 2 * w2, img.shape[2]), np.float32)
        pw[:H, :W] = w
        pc[:H, :W] = img * w[:, :, None]
    # 2 x 2 means (INTER_AREA on an exact halving); x4 gives the sums
    sw = 4.0 * cv2.resize(pw, (w2, h2), interpolation=cv2.INTER_AREA)
    sc = 4.0 * cv2.resize(pc, (w2, h2), interpolation=cv2.INTER_AREA).reshape(h2, w2, -1)
    coarse = sc / np.maximum(sw, 1e-12)[:, :, None]
    coarse = push_pull(coarse, np.minimum(sw, 1.0))
    up = cv2.resize(coarse, (2 * w2, 2 * h2), interpolation=cv2.INTER_LINEAR)
    up = up.reshape(2 * h2, 2 * w2, -1)[:H, :W]
    return w[:, :, None] * img + (1.0 - w[:, :, None]) * up


def multiband_blend(layers: list[np.ndarray], weights: list[np.ndarray], bands: int = 5
                    ) -> np.ndarray:
    """Blend images by their weights band by band (Burt and Adelson 1983).

    Each image's Laplacian pyramid is mixed with the Gaussian pyramid of its normalised
    weight, so coarse brightness differences between photos fade over a wide zone while
    fine detail switches over a narrow one: no visible seam, no ghosted detail.

    Args:
        layers: K images (H, W, 3) float32, defined everywhere (filled beyond their data).
        weights: K (H, W) float32 weights >= 0 (where all are 0, the images are averaged).
        bands: pyramid levels.
    Returns:
        (H, W, 3) float32.
    """
    total = np.sum(weights, axis=0)
    none = total <= 0
    norm = [np.where(none, 1.0 / len(layers), w / np.where(none, 1.0, total)).astype(np.float32)
            for w in weights]
    out: np.ndarray | None = None
    for img, w in zip(layers, norm, strict=True):
        g_img: list[np.ndarray] = [img]
        g_w: list[np.ndarray] = [w]
        for _ in range(bands - 1):
            if min(g_img[-1].shape[:2]) < 4:
                break
            g_img.append(cv2.pyrDown(g_img[-1]))
            g_w.append(cv2.pyrDown(g_w[-1]))
        acc = g_img[-1] * g_w[-1][:, :, None]
        for k in range(len(g_img) - 2, -1, -1):
            size = (g_img[k].shape[1], g_img[k].shape[0])
            lap = g_img[k] - cv2.pyrUp(g_img[k + 1], dstsize=size)
            acc = cv2.pyrUp(acc, dstsize=size) + lap * g_w[k][:, :, None]
        out = acc if out is None else out + acc
    assert out is not None
    return out


def _gains(samples: dict[str, np.ndarray], weights: dict[str, np.ndarray], ref: str,
           min_w: float) -> dict[str, np.ndarray]:
    """Per-view RGB gains by least squares over pairs of views (``ref`` fixed at 1).

    Minimises ``sum_pairs sum_texels min(w_a, w_b) (g_a c_a - g_b c_b)^2`` per channel
    (plus a small pull of every gain towards 1), over texels both views see with weight
    above ``min_w``; a view that shares no texel with another keeps gain 1.
    """
    views = list(samples)
    n = len(views)
    gains = {v: np.ones(3) for v in views}
    if n < 2:
        return gains
    M = np.zeros((3, n, n))
    for a in range(n):
        for b in range(a + 1, n):
            wa, wb = weights[views[a]], weights[views[b]]
            m = (wa > min_w) & (wb > min_w)
            if not m.any():
                continue
            ww = np.minimum(wa[m], wb[m])[:, None]
            ca, cb = samples[views[a]][m] / 255.0, samples[views[b]][m] / 255.0
            M[:, a, a] += (ww * ca * ca).sum(axis=0)
            M[:, b, b] += (ww * cb * cb).sum(axis=0)
            M[:, a, b] -= (ww * ca * cb).sum(axis=0)
            M[:, b, a] -= (ww * ca * cb).sum(axis=0)
    r = views.index(ref)
    free = [i for i in range(n) if i != r]
    for c in range(3):
        lam = 1e-3 * max(float(np.trace(M[c])) / n, 1e-9)
        A = M[c][np.ix_(free, free)] + lam * np.eye(len(free))
        rhs = -M[c][free, r] + lam
        g = np.linalg.solve(A, rhs)
        for i, gi in zip(free, g, strict=True):
            if M[c, i, i] > 0:
                gains[views[i]][c] = float(np.clip(gi, 0.5, 2.0))
    return gains


DEPTH_MAX_PX = 640
"""Largest side of the depth maps used for visibility (a larger photo's is rendered at
half, a quarter... of its size; the photo itself is sampled at full resolution)."""


def _depth_camera(cam: Camera) -> tuple[Camera, int]:
    """``cam`` reduced by an integer factor so that its larger side is at most
    :data:`DEPTH_MAX_PX` (pixel centres kept: ``x' = (x + 0.5) / s - 0.5``), and the
    factor."""
    s = max(1, -(-max(cam.width, cam.height) // DEPTH_MAX_PX))
    if s == 1:
        return cam, 1
    K = cam.K.copy()
    K[0, 0] /= s
    K[0, 1] /= s
    K[1, 1] /= s
    K[0, 2] = (K[0, 2] + 0.5) / s - 0.5
    K[1, 2] = (K[1, 2] + 0.5) / s - 0.5
    return Camera(K, cam.R, cam.t, -(-cam.width // s), -(-cam.height // s)), s


def _check_inputs(cameras: Mapping[str, Camera], photos: Mapping[str, np.ndarray]
                  ) -> list[str]:
    views = [v for v in photos if v in cameras]
    if not views:
        raise NaseviewError("texture: no photo has a camera; reconstruct the case first "
                            "(reconstruction.json key 'cameras')")
    for v in views:
        img, cam = photos[v], cameras[v]
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise NaseviewError(f"texture: photo '{v}' must be (H, W, 3) uint8 BGR, got "
                                f"{img.shape} {img.dtype}")
        if img.shape[:2] != (cam.height, cam.width):
            raise NaseviewError(f"texture: photo '{v}' is {img.shape[1]}x{img.shape[0]} px "
                                f"but its camera (reconstruction.json key 'cameras.{v}') is "
                                f"{cam.width}x{cam.height}; reconstruct the case again")
    return views


def bake_texture(V: ArrayLike, F: ArrayLike, cameras: Mapping[str, Camera],
                 photos: Mapping[str, np.ndarray], params: BakeParams | None = None
                 ) -> FaceTexture:
    """Texture a face mesh from calibrated photos (see the module doc).

    Args:
        V: (n, 3) face vertices (mm, SPEC frame), e.g. the reconstruction's ``face.ply``.
        F: (m, 3) triangles, counter-clockwise seen from outside.
        cameras: view -> stage-1 camera (``Reconstruction.cameras``).
        photos: view -> (H, W, 3) uint8 BGR photo (:meth:`naseview.case.Case.load_image`),
            of the size of its camera; views without a camera are ignored.
        params: :class:`BakeParams` (default: 1024 texels).
    Returns:
        :class:`FaceTexture` (RGB).
    Raises:
        NaseviewError: no photo with a camera, or a photo whose size is not its camera's.
    """
    p = params or BakeParams()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    views = _check_inputs(cameras, photos)
    plan = texel_plan(V, F, p.size)
    Vc = cap_holes(V, F)[0]
    Fc = plan.faces
    corners = Fc[plan.tri]                                           # (T, 3)
    b = plan.bary.astype(np.float64)
    P = np.einsum("tk,tkc->tc", b, Vc[corners])
    N = np.einsum("tk,tkc->tc", b, vertex_normals(Vc, Fc)[corners])
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-12)
    FN = face_normals(Vc, Fc)[plan.tri]          # the texel's own triangle (its true side)
    samples: dict[str, np.ndarray] = {}
    weights: dict[str, np.ndarray] = {}
    for v in views:
        cam, photo = cameras[v], photos[v]
        to_cam = cam.center - P
        cos = np.einsum("ij,ij->i", N, to_cam) / np.maximum(
            np.linalg.norm(to_cam, axis=1), 1e-12)
        # only these can get a weight: the smooth normal faces the photo, and so does the
        # triangle itself (a folded one's smooth normal may face it while the photo sees
        # its back, and lends it another place's colour; issue 27)
        facing = np.flatnonzero((cos > p.cos_min)
                                & (np.einsum("ij,ij->i", FN, to_cam) > 0.0))
        w_ang = ((cos[facing] - p.cos_min) / (1.0 - p.cos_min)) ** p.angle_power
        small, s = _depth_camera(cam)
        depth_small = rasterize(Vc, Fc, small).depth
        depth = depth_small if s == 1 else cv2.resize(
            depth_small, (cam.width, cam.height), interpolation=cv2.INTER_NEAREST)
        edge = view_weights(photo, depth, p)
        Pf = P[facing]
        vis = visible_points(Pf, small, depth_small, tol_mm=p.tol_mm)
        with np.errstate(divide="ignore", invalid="ignore"):
            xy = cam.project(Pf)
        xy = np.where(vis[:, None], xy, 0.0)
        w = np.zeros(len(P), np.float32)
        w[facing] = vis * w_ang * sample_image(edge, xy)
        col = np.zeros((len(P), 3), np.float32)
        col[facing] = sample_image(photo, xy)[:, ::-1]            # BGR -> RGB
        weights[v], samples[v] = w, col
    ref = REFERENCE_VIEW if REFERENCE_VIEW in views else max(
        views, key=lambda v: float(weights[v].sum()))
    gains = _gains(samples, weights, ref, p.min_pair_weight)
    S = p.size
    wsum = np.zeros(len(P), np.float64)
    layers, wmaps = [], []
    for v in views:
        wsum += weights[v]
        img = np.zeros((S * S, 3), np.float32)
        wm = np.zeros(S * S, np.float32)
        img[plan.texels] = samples[v] * gains[v][None, :].astype(np.float32)
        wm[plan.texels] = weights[v]
        layers.append(push_pull(img.reshape(S, S, 3), (wm > 0).reshape(S, S)))
        wmaps.append(wm.reshape(S, S))
    blended = multiband_blend(layers, wmaps, p.bands)
    flat_conf = np.zeros(S * S, np.float32)
    flat_conf[plan.texels] = _smoothstep(wsum / p.full_weight)
    conf = flat_conf.reshape(S, S)
    filled = push_pull(blended, conf)
    image = np.clip(filled + 0.5, 0, 255).astype(np.uint8)
    coverage = (conf > 0).reshape(S, S)
    vcol = np.clip(sample_image(image, uv_to_pixels(plan.uv, S, S)) + 0.5, 0, 255)
    total = max(float(wsum.sum()), 1e-12)
    return FaceTexture(plan.uv.copy(), image, coverage, vcol.astype(np.uint8), gains,
                       {v: float(weights[v].sum()) / total for v in views})


def case_photos(case: Case | None, cameras: Mapping[str, Camera]) -> dict[str, np.ndarray]:
    """view -> (H, W, 3) uint8 BGR photo of each view in ``cameras`` that ``case`` can
    load (those it cannot are left out and logged: the face is baked from the others);
    empty without a case."""
    out: dict[str, np.ndarray] = {}
    if case is None:
        return out
    for v in cameras:
        try:
            out[v] = case.load_image(v)
        except NaseviewError as e:
            log.warning("naseview: photo %s not shown on the face: %s", v, e)
    return out


def skin_texture(V: ArrayLike, F: ArrayLike, cameras: Mapping[str, Camera],
                 photos: Mapping[str, np.ndarray], params: BakeParams | None = None
                 ) -> FaceTexture | None:
    """:func:`bake_texture` of the photos that have a camera, or ``None`` when there is
    none or the bake refuses a photo (logged, never fatal): the face is then shown in
    plain skin colour. The one rule the app, the report and the exports follow."""
    usable = {v: p for v, p in photos.items() if v in cameras}
    if not usable:
        return None
    try:
        return bake_texture(V, F, cameras, usable, params)
    except NaseviewError as e:
        log.warning("naseview: face shown untextured: %s", e)
        return None
