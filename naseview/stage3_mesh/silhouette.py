"""Occluding contours of the photos as constraints on stage 3 (issue 11).

Where a photo shows the nose against a uniform background (the ``left`` and ``right``
profiles), the mesh's occluding contour must project onto the photo's silhouette. After
the ARAP solve of :func:`~naseview.stage3_mesh.solve.refine`, ICP-like rounds:

1. the occluding contour of the deformed nose w.r.t. each camera centre ``C``: vertices
   of edges between a front-facing and a back-facing triangle
   (``sign(n_f . (C - centroid_f))`` differs), kept only where the vertex projects onto
   the boundary of the mesh's own projected outline, holes filled (an outer contour,
   not an internal fold or a nostril), at most one per ``spacing_mm``;
2. each such vertex ``X`` represented by the rim point ``P`` nearest it on its contour
   edges (where ``n . (C - X)`` interpolated along the edge is zero; projected ``u``,
   depth ``z`` mm), ``u`` moved onto the photo's silhouette along its normal (the zero
   level ``b`` of the foreground mask's signed distance, sub-pixel; the mask is stage
   2's, :mod:`naseview.stage2_curves.mask`, made in :func:`naseview.pipeline.run_stage3`);
   the 2D offset ``o = b - u`` (px) becomes the 3D displacement perpendicular to the
   line of sight at that depth

       dX = (z / f) * (o_x * r_x + o_y * r_y)        (mm)

   (``f`` the focal length in px, ``r_x``, ``r_y`` the camera's image axes in the world,
   rows 0 and 1 of ``R``); matches with ``|dX|`` above ``max_mm`` or next to the
   boundary of the searched box are rejected. With ``detrend`` a shift ``t`` of the
   whole photo (the camera's pose error, by 2D ICP) is taken out first: ``o = b - (u + t)``;
3. the matched vertices added as extra hard ARAP handles at ``X + dX`` (depth along the
   ray kept where it was) and the deformation solved again from the base; the contour
   is found again on the result for the next round.

Shapes: V (n, 3) mm SPEC frame; masks (H, W) bool; pixels ``[x, y]``.

Measured (``benchmarks/bench_real.py --ablation``): the reconstructed profile already
lies within 0.1-0.2 mm (mean) of the photos' silhouettes (the mid-curve handles are
that silhouette); these handles fill between them and take out the camera's shift.
Off the midline (sidewalls, alae: most of the error) a profile photo says nothing.

Example
-------
    box = nose_box(cam, rec.landmarks)
    sils = [silhouette_from_mask("left", cam, foreground_mask, box)]  # stage 2's mask
    ids, targets, names = contour_targets(V, F, sils, movable, held.targets, 1.0, 3.0,
                                          detrend=True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import igl
import numpy as np
from scipy import ndimage

from naseview.camera import Camera
from naseview.geometry.mesh import face_normals
from naseview.measurements.section import topology

SILHOUETTE_VIEWS: tuple[str, ...] = ("left", "right")
"""Views whose nose outline is against the background (the profiles)."""

_NOSE_IDS: tuple[str, ...] = ("n", "k", "r", "prn", "c", "sn", "al_l", "al_r")


@dataclass(frozen=True)
class Silhouette:
    """One photo's silhouette near the nose, as a signed distance field.

    Attributes:
        view: the view name.
        camera: its :class:`~naseview.camera.Camera` (the reconstruction's frame).
        box: (x0, y0, x1, y1) px, the searched box.
        sdf: (y1-y0, x1-x0) float signed distance (px) of each pixel centre to the
            silhouette: ``edt(background) - edt(foreground)``, negative inside; the edge
            (the zero level) lies half-way between the last foreground and the first
            background pixel.
        normal: (2, y1-y0, x1-x0) unit gradient of ``sdf`` (x, y): the outward normal.
        edge_px: points within this of the box's edge are not matched (the mask is cut
            there).
    """

    view: str
    camera: Camera
    box: tuple[int, int, int, int]
    sdf: np.ndarray
    normal: np.ndarray
    edge_px: int = 4

    def match(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k, 2) pixels -> ((k, 2) offset onto the silhouette along its normal,
        ``-sdf(u) n(u)`` bilinear, px; (k,) bool inside the box)."""
        x0, y0, x1, y1 = self.box
        e = self.edge_px
        q = uv - [x0, y0]
        h, w = self.sdf.shape
        ok = (q[:, 0] >= e) & (q[:, 0] <= w - 1 - e) & (q[:, 1] >= e) & (q[:, 1] <= h - 1 - e)
        off = np.zeros_like(uv, dtype=np.float64)
        if ok.any():
            c = [q[ok, 1], q[ok, 0]]
            d = ndimage.map_coordinates(self.sdf, c, order=1)
            n = np.stack([ndimage.map_coordinates(self.normal[i], c, order=1)
                          for i in range(2)], 1)
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)
            off[ok] = -d[:, None] * n
        return off, ok


def silhouette_from_mask(view: str, camera: Camera, mask: np.ndarray,
                         box: tuple[int, int, int, int]) -> Silhouette:
    """:class:`Silhouette` from a (H, W) bool foreground ``mask`` inside ``box``."""
    x0, y0, x1, y1 = box
    m = mask[y0:y1, x0:x1]
    if m.all() or not m.any():
        sdf = np.full(m.shape, 1e6, np.float32)            # no edge: nothing matches
    else:
        sdf = (ndimage.distance_transform_edt(~m) - ndimage.distance_transform_edt(m))
        sdf = np.where(m, sdf + 0.5, sdf - 0.5)             # zero half-way between pixels
    g = np.stack(np.gradient(ndimage.gaussian_filter(sdf.astype(np.float64), 1.0))[::-1])
    return Silhouette(view, camera, box, sdf.astype(np.float32), g.astype(np.float32))


def nose_box(cam: Camera, landmarks: Mapping[str, np.ndarray], margin_px: int = 60
             ) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) px: the box around the projected nose landmarks grown by
    ``margin_px``, inside the image; None with fewer than 3 of them, or when they do not
    project to a box of at least 16 px in the photo (behind the camera, off the image)."""
    P = np.array([landmarks[k] for k in _NOSE_IDS if k in landmarks], float)
    if len(P) < 3 or not (cam.depth(P) > 0).all():
        return None
    uv = cam.project(P)
    if not np.isfinite(uv).all():
        return None
    x0, y0 = np.floor(uv.min(0)).astype(int) - margin_px
    x1, y1 = np.ceil(uv.max(0)).astype(int) + margin_px
    box = (max(int(x0), 0), max(int(y0), 0), min(int(x1), cam.width),
           min(int(y1), cam.height))
    return box if box[2] - box[0] >= 16 and box[3] - box[1] >= 16 else None


def edge_faces(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interior edges (e, 2) of ``F`` and their two faces (e, 2), from the mesh's cached
    :func:`~naseview.measurements.section.topology`."""
    topo = topology(F)
    two = topo.edge_faces[:, 1] >= 0
    return topo.edges[two], topo.edge_faces[two]


def rim_points(V: np.ndarray, F: np.ndarray, cam: Camera, contour_edges: np.ndarray,
               ids: np.ndarray) -> np.ndarray:
    """(k, 3) the rim point nearest each vertex of ``ids`` on its contour edges: where
    ``g = n . (C - X)`` (vertex normals, linear along the edge) is zero. A contour vertex
    lies up to an edge off the rim and projects inside the outline; matching the vertex
    itself would inflate the mesh by that much."""
    N = np.asarray(igl.per_vertex_normals(V, F), float)
    g = np.einsum("ij,ij->i", N, cam.center - V)
    a, b = contour_edges[:, 0], contour_edges[:, 1]
    den = g[a] - g[b]
    t = np.where(np.abs(den) > 1e-12, g[a] / np.where(np.abs(den) > 1e-12, den, 1.0), 0.5)
    t = np.clip(t, 0.0, 1.0)
    P = V[a] + t[:, None] * (V[b] - V[a])
    out = V[ids].copy()
    best = np.full(len(ids), np.inf)
    pos = {int(v): i for i, v in enumerate(ids)}
    for e in range(len(contour_edges)):
        for v in (int(a[e]), int(b[e])):
            i = pos.get(v)
            if i is not None:
                d = float(np.linalg.norm(P[e] - V[v]))
                if d < best[i]:
                    best[i], out[i] = d, P[e]
    return out


def occluding_contour(V: np.ndarray, F: np.ndarray, cam: Camera, edges: np.ndarray,
                      edge_faces: np.ndarray, candidates: np.ndarray,
                      outline_px: float = 1.5, margin_px: int = 40,
                      with_rim: bool = False
                      ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """(k,) vertices of ``candidates`` (bool (n,)) on the outer occluding contour of
    (V, F) seen from ``cam``: on an edge between a front- and a back-facing triangle, and
    projecting within ``outline_px`` of the boundary of the whole mesh's projected
    outline (rasterised in a box ``margin_px`` around them, holes filled). With
    ``with_rim`` also their (k, 3) :func:`rim_points`."""
    Fc = V[F].mean(1)
    facing = np.einsum("ij,ij->i", face_normals(V, F), cam.center - Fc) > 0
    cont = edges[facing[edge_faces[:, 0]] != facing[edge_faces[:, 1]]]
    ids = np.unique(cont)
    ids = ids[candidates[ids]]
    if not len(ids):
        return (ids, np.zeros((0, 3))) if with_rim else ids
    uv = cam.project(V)
    x0, y0 = np.floor(uv[ids].min(0)).astype(int) - margin_px
    x1, y1 = np.ceil(uv[ids].max(0)).astype(int) + margin_px
    w, h = int(x1 - x0), int(y1 - y0)
    img = np.zeros((h, w), np.uint8)
    q = uv[F] - [x0, y0]
    near = ((q[..., 0].max(1) >= 0) & (q[..., 0].min(1) < w) & (q[..., 1].max(1) >= 0)
            & (q[..., 1].min(1) < h))
    for tri in np.round(q[near] * 4).astype(np.int32):   # one by one: fillPoly of a list
        cv2.fillConvexPoly(img, tri, 1, cv2.LINE_8, 2)   # is even-odd, overlaps cancel
    ff = np.pad(img, 1)                                   # holes (nostrils seen through
    cv2.floodFill(ff, None, (0, 0), 2)                    # an open mesh) are not outline
    img = (ff[1:-1, 1:-1] != 2).astype(np.uint8)
    d_out = cv2.distanceTransform((img == 0).astype(np.uint8), cv2.DIST_L2, 3)
    d_in = cv2.distanceTransform(img, cv2.DIST_L2, 3)
    p = np.round(uv[ids] - [x0, y0]).astype(int)
    on = np.maximum(d_out[p[:, 1], p[:, 0]], d_in[p[:, 1], p[:, 0]]) <= outline_px
    ids = ids[on]
    if not with_rim:
        return ids
    keep = np.isin(cont, ids).any(1)
    return ids, rim_points(V, F, cam, cont[keep], ids)


def _spaced(V: np.ndarray, ids: np.ndarray, spacing_mm: float,
            avoid: np.ndarray) -> np.ndarray:
    """Greedy subset of ``ids`` at least ``spacing_mm`` from each other and from the
    points ``avoid`` (m, 3)."""
    keep: list[int] = []
    pts = [p for p in np.asarray(avoid, float).reshape(-1, 3)]
    for i in ids:
        if pts and np.min(np.linalg.norm(np.asarray(pts) - V[i], axis=1)) < spacing_mm:
            continue
        keep.append(int(i))
        pts.append(V[i])
    return np.asarray(keep, np.int64)


def _detrended(s: Silhouette, uv: np.ndarray, off: np.ndarray, inside: np.ndarray,
               z: np.ndarray, max_mm: float, iterations: int = 10
               ) -> tuple[np.ndarray, np.ndarray]:
    """The offsets left once a shift ``t`` of the whole image is taken out (the camera's
    own pose error): ``t`` by point-to-line ICP (a normal offset sees only part of a
    shift, so one mean is not enough), then each offset measured from ``u + t``. A
    rotation is not taken out: on a base far from the nose (the generic face) a
    dorsum at the wrong angle looks like one (measured: worse on the generic base)."""
    t = np.zeros(2)
    for _ in range(iterations):
        near = inside & (np.linalg.norm(off, axis=1) * z / s.camera.focal_px <= max_mm)
        if near.sum() < 6:
            break
        step = off[near].mean(0)
        t = t + step
        off, inside = s.match(uv + t)
        if np.abs(step).max() < 0.02:
            break
    return off, inside


def contour_targets(V: np.ndarray, F: np.ndarray, silhouettes: Sequence[Silhouette],
                    movable: np.ndarray, avoid: np.ndarray, spacing_mm: float,
                    max_mm: float, edge_data: tuple[np.ndarray, np.ndarray] | None = None,
                    detrend: bool = False
                    ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Contour vertices of (V, F) in ``movable`` (bool (n,)) and their targets on the
    photos' silhouettes: ((k,) ids, (k, 3) targets mm, k names ``"sil:<view>"``).
    A vertex on two views' contours takes the first; handles of a later view keep
    ``spacing_mm`` from the earlier views' too.

    With ``detrend`` the part of each view's offsets a shift of the whole image explains
    (``b ~ u + t``: the camera's own pose error, which the landmarks already pin) is
    taken out: the offset used is ``b - (u + t)`` (:func:`_detrended`)."""
    E, EF = edge_data if edge_data is not None else edge_faces(F)
    ids_all: list[np.ndarray] = []
    tg_all: list[np.ndarray] = []
    names: list[str] = []
    used = np.zeros(len(V), bool)
    for s in silhouettes:
        ids, rim = occluding_contour(V, F, s.camera, E, EF, movable & ~used,
                                     with_rim=True)
        if not len(ids):
            continue
        cam = s.camera
        uv = cam.project(rim)
        off, inside = s.match(uv)
        z = cam.depth(rim)
        if detrend:
            off, inside = _detrended(s, uv, off, inside, z, max_mm)
        dX = (z / cam.focal_px)[:, None] * (off[:, :1] * cam.R[0] + off[:, 1:] * cam.R[1])
        ok = inside & (np.linalg.norm(dX, axis=1) <= max_mm)
        ids, dX = ids[ok], dX[ok]
        keep = _spaced(V, ids, spacing_mm, np.concatenate(
            [np.asarray(avoid, float).reshape(-1, 3)] + [V[i] for i in ids_all]))
        pos = {int(i): j for j, i in enumerate(ids)}
        sel = np.array([pos[int(i)] for i in keep], np.int64)
        if not len(sel):
            continue
        ids_all.append(ids[sel])
        tg_all.append(V[ids[sel]] + dX[sel])
        names += [f"sil:{s.view}"] * len(sel)
        used[ids[sel]] = True
    if not ids_all:
        return np.zeros(0, np.int64), np.zeros((0, 3)), []
    return np.concatenate(ids_all), np.concatenate(tg_all), names
