"""Occluding contours of the photos as constraints on stage 3 (issue 11).

Where a photo shows the nose against a uniform background (the ``left`` and ``right``
profiles), the mesh's occluding contour must project onto the photo's silhouette. After
the ARAP solve of :func:`~naseview.stage3_mesh.solve.refine`, ICP-like rounds:

1. the occluding contour of the deformed nose w.r.t. each camera centre ``C``: vertices
   of edges between a front-facing and a back-facing triangle
   (``sign(n_f . (C - centroid_f))`` differs), kept only where the vertex projects onto
   the boundary of the mesh's own projected outline, holes filled (an outer contour,
   not an internal fold or a nostril), at most one per ``spacing_mm``. For an outline
   traced over the face (the alar rims seen from below, the alae seen from the front:
   pieces of stage 2's curves, :func:`silhouette_from_curve`) the mesh's outline is not
   the whole face's: there the contour vertices kept are those the camera sees, near
   the piece's landmarks, whose projected outward normal agrees with the outline's;
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

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import igl
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from naseview.camera import Camera
from naseview.geometry.mesh import face_normals
from naseview.measurements.section import topology
from naseview.render import rasterize, visible_points

SILHOUETTE_VIEWS: tuple[str, ...] = ("left", "right")
"""Views whose nose outline is against the background (the profiles)."""

OUTLINE_CURVES: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "bottom_l": ("bottom", "bottom", ("ac_l", "al_l", "alp_l")),
    "bottom_r": ("bottom", "bottom", ("ac_r", "al_r", "alp_r")),
    "bottom_tip": ("bottom", "bottom", ("alp_r", "prn", "alp_l")),
    "ala_l": ("ala_l", "front", ("ac_l", "al_l", "int_l")),
    "ala_r": ("ala_r", "front", ("ac_r", "al_r", "int_r")),
}
"""Pieces of stage-2 curves that trace an occluding contour of the nose over the face:
piece -> (the curve, the photo it is detected in, the landmarks along the piece: it runs
between the first and the last, the chord between them closes it on the nose's side,
and only mesh vertices within :data:`OUTLINE_REACH_MM` of the chain through them are
matched to it - seen from below, the sidewalls' contour projects next to the alar
rims'). ``bottom_l``/``bottom_r``: the
alar rims' outline over the lip and cheeks seen from below (ac-al-al'); ``bottom_tip``
the tip lobule's (al'-prn-al'); ``ala_l``/``ala_r``: the alar outlines over the cheeks
seen from the front (ac-al-int). ``RefineParams.outline_curves`` names its keys."""

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
        outline: the silhouette is the whole face's outline against the background (a
            profile photo): the contour matched is the mesh's outer outline. ``False``
            (an outline over the face, :func:`silhouette_from_curve`): the contour
            matched is the mesh's visible occluding contour whose outward normal agrees
            with the silhouette's.
        valid: (y1-y0, x1-x0) bool, the pixels a match may start from (None: all): for a
            curve, those nearer the curve than the chord that closes it.
        name: the handles' name (``"sil:<view>"``, ``"sil:<curve>"``).
        chain: (m, 3) mm, the landmarks along an outline piece: only vertices within
            :data:`OUTLINE_REACH_MM` of them are matched (None: any).
    """

    view: str
    camera: Camera
    box: tuple[int, int, int, int]
    sdf: np.ndarray
    normal: np.ndarray
    edge_px: int = 4
    outline: bool = True
    valid: np.ndarray | None = None
    name: str = ""
    chain: np.ndarray | None = None

    @property
    def label(self) -> str:
        """The handles' name: ``name`` or ``"sil:<view>"``."""
        return self.name or f"sil:{self.view}"

    def match(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k, 2) pixels -> ((k, 2) offset onto the silhouette along its normal,
        ``-sdf(u) n(u)`` bilinear, px; (k,) bool inside the box)."""
        x0, y0, x1, y1 = self.box
        e = self.edge_px
        q = uv - [x0, y0]
        h, w = self.sdf.shape
        ok = (q[:, 0] >= e) & (q[:, 0] <= w - 1 - e) & (q[:, 1] >= e) & (q[:, 1] <= h - 1 - e)
        if self.valid is not None and ok.any():
            p = np.round(q[ok]).astype(int)
            ok[np.flatnonzero(ok)] = self.valid[p[:, 1], p[:, 0]]
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


OUTLINE_REACH_MM = 5.0
"""How far (mm) from the landmark chain of an :data:`OUTLINE_CURVES` piece a mesh vertex
may lie and still be matched to it."""


def near_chain(V: np.ndarray, chain: np.ndarray, reach_mm: float) -> np.ndarray:
    """(n,) bool: the points ``V`` (n, 3) within ``reach_mm`` of the polyline ``chain``
    (m, 3), sampled every 0.5 mm."""
    chain = np.asarray(chain, float).reshape(-1, 3)
    pts = [chain[:1]]
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        k = max(int(np.ceil(np.linalg.norm(b - a) / 0.5)), 1)
        pts.append(a + np.linspace(0, 1, k + 1)[1:, None] * (b - a))
    d, _ = cKDTree(np.concatenate(pts)).query(V, distance_upper_bound=reach_mm)
    return np.asarray(np.isfinite(d))


def curve_piece(uv: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, 2) the part of the polyline ``uv`` (N, 2) between its points nearest ``a``
    and ``b`` (2,) px, in the polyline's order."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    i, j = (int(np.argmin(np.linalg.norm(uv - np.asarray(x, float), axis=1))) for x in (a, b))
    return uv[min(i, j):max(i, j) + 1]


def silhouette_from_curve(piece: str, camera: Camera, uv: np.ndarray, chain: np.ndarray,
                          end_px: float = 3.0, margin_px: int = 40) -> Silhouette | None:
    """:class:`Silhouette` of an outline traced over the face (a piece of a stage-2 curve
    in its photo, :data:`OUTLINE_CURVES`): ``uv`` (N, 2) px closed by the straight chord
    between its ends into a polygon whose inside is the nose's side; its signed distance
    field in a box ``margin_px`` around it. A match may start only where the curve, not
    the chord, is the nearest boundary, and not within ``end_px`` of the curve's ends
    (past them the outline is unknown or another piece's), from a vertex near the
    piece's landmark ``chain`` (m, 3) mm. None for fewer than 3 points or a box under
    16 px."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    if len(uv) < 3 or not np.isfinite(uv).all():
        return None
    x0, y0 = np.floor(uv.min(0)).astype(int) - margin_px
    x1, y1 = np.ceil(uv.max(0)).astype(int) + margin_px
    x0, y0 = max(int(x0), 0), max(int(y0), 0)
    x1, y1 = min(int(x1), camera.width), min(int(y1), camera.height)
    if x1 - x0 < 16 or y1 - y0 < 16:
        return None
    q = uv - [x0, y0]
    c = q[[-1, 0]]                                              # the chord
    shape = (y1 - y0, x1 - x0)
    fix = lambda P: np.round(P * 8).astype(np.int32).reshape(-1, 1, 2)  # noqa: E731
    poly = np.zeros(shape, np.uint8)
    cv2.fillPoly(poly, [fix(q)], 1, cv2.LINE_8, 3)             # closed by the chord
    line = np.ones(shape, np.uint8)
    cv2.polylines(line, [fix(q)], False, 0, 1, cv2.LINE_8, 3)
    cut = np.ones(shape, np.uint8)
    cv2.polylines(cut, [fix(c)], False, 0, 1, cv2.LINE_8, 3)
    d_curve = cv2.distanceTransform(line, cv2.DIST_L2, 5)
    d_chord = cv2.distanceTransform(cut, cv2.DIST_L2, 5)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    d_end = np.min([np.hypot(xx - e[0], yy - e[1]) for e in (q[0], q[-1])], axis=0)
    valid = (d_curve + 1.0 < d_chord) & (d_end > end_px + d_curve)
    s = silhouette_from_mask(OUTLINE_CURVES[piece][1], camera, poly.astype(bool),
                             (0, 0, shape[1], shape[0]))
    return dataclasses.replace(s, box=(x0, y0, x1, y1), outline=False, valid=valid,
                               name=f"sil:{piece}", chain=np.asarray(chain, float))


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
               ids: np.ndarray, normals: np.ndarray | None = None) -> np.ndarray:
    """(k, 3) the rim point nearest each vertex of ``ids`` on its contour edges: where
    ``g = n . (C - X)`` (vertex normals, linear along the edge) is zero. A contour vertex
    lies up to an edge off the rim and projects inside the outline; matching the vertex
    itself would inflate the mesh by that much. ``normals``: (n, 3) the vertex normals
    when the caller has them."""
    N = np.asarray(igl.per_vertex_normals(V, F), float) if normals is None else normals
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


def contour_edges(V: np.ndarray, F: np.ndarray, cam: Camera, edges: np.ndarray,
                  edge_faces: np.ndarray) -> np.ndarray:
    """(c, 2) the ``edges`` of (V, F) between a front- and a back-facing triangle seen
    from ``cam`` (``sign(n_f . (C - centroid_f))`` differs across the edge):
    the occluding contour generator."""
    facing = np.einsum("ij,ij->i", face_normals(V, F), cam.center - V[F].mean(1)) > 0
    return edges[facing[edge_faces[:, 0]] != facing[edge_faces[:, 1]]]


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
    cont = contour_edges(V, F, cam, edges, edge_faces)
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


def visible_contour(V: np.ndarray, F: np.ndarray, s: Silhouette, edges: np.ndarray,
                    edge_faces: np.ndarray, candidates: np.ndarray, depth_tol_mm: float = 0.3
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Vertices of ``candidates`` (bool (n,)) on the occluding contour of (V, F) seen from
    ``s.camera`` that the camera sees (depth test in ``s.box``) and whose outward normal,
    projected into the photo, points the way of the silhouette's outward normal (cosine
    above 0.5: the outline of the nose over the face, not the rim of a nostril or a
    fold): ((k,) ids, (k, 3) their :func:`rim_points`)."""
    cam = s.camera
    cont = contour_edges(V, F, cam, edges, edge_faces)
    ids = np.unique(cont)
    ids = ids[candidates[ids]]
    if s.chain is not None:
        ids = ids[near_chain(V[ids], s.chain, OUTLINE_REACH_MM)]
    none = (np.zeros(0, np.int64), np.zeros((0, 3)))
    if not len(ids):
        return none
    x0, y0, x1, y1 = s.box
    K = cam.K.copy()
    K[0, 2] -= x0
    K[1, 2] -= y0
    crop = Camera(K, cam.R, cam.t, x1 - x0, y1 - y0)
    seen = visible_points(V[ids], crop, rasterize(V, F, crop).depth, tol_mm=depth_tol_mm)
    ids = ids[seen]
    if not len(ids):
        return none
    q = cam.project(V[ids]) - [x0, y0]
    h, w = s.sdf.shape
    inside = (q[:, 0] >= 0) & (q[:, 0] <= w - 1) & (q[:, 1] >= 0) & (q[:, 1] <= h - 1)
    ids, q = ids[inside], q[inside]
    NV = np.asarray(igl.per_vertex_normals(V, F), float)
    N = NV[ids]
    n2 = np.stack([N @ cam.R[0], N @ cam.R[1]], 1)
    n2 /= np.maximum(np.linalg.norm(n2, axis=1, keepdims=True), 1e-9)
    c = [q[:, 1], q[:, 0]]
    g = np.stack([ndimage.map_coordinates(s.normal[i], c, order=1) for i in range(2)], 1)
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-9)
    ids = ids[np.einsum("ij,ij->i", n2, g) > 0.5]
    keep = np.isin(cont, ids).any(1)
    return ids, rim_points(V, F, cam, cont[keep], ids, NV)


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


@dataclass
class _Matches:
    """One silhouette's contour points and their matches (module docstring, step 2)."""

    s: Silhouette
    ids: np.ndarray        # (k,) contour vertices
    uv: np.ndarray         # (k, 2) their rim points' projections, px
    z: np.ndarray          # (k,) the rim points' depths, mm
    off: np.ndarray        # (k, 2) offsets onto the silhouette, px
    inside: np.ndarray     # (k,) bool: matched inside the silhouette's box

    def rematch(self, t: np.ndarray) -> None:
        """Offsets measured from ``uv + t``."""
        self.off, self.inside = self.s.match(self.uv + t)

    def near(self, max_mm: float) -> np.ndarray:
        """(k,) bool: matched within ``max_mm`` (perpendicular to the line of sight)."""
        return self.inside & (np.linalg.norm(self.off, axis=1) * self.z
                              / self.s.camera.focal_px <= max_mm)


def _detrend(view: Sequence[_Matches], max_mm: float, iterations: int = 10) -> None:
    """Take out of the offsets of one photo's silhouettes ``view`` the shift ``t`` of the
    whole image that explains them best (the camera's own pose error), in place: ``t``
    by point-to-line ICP over all of them (a normal offset sees only part of a shift, so
    one mean is not enough), then each offset measured from ``u + t``. A rotation is not
    taken out: on a base far from the nose (the generic face) a dorsum at the wrong angle
    looks like one (measured: worse on the generic base)."""
    t = np.zeros(2)
    for _ in range(iterations):
        near = [m.off[m.near(max_mm)] for m in view]
        if sum(len(n) for n in near) < 6:
            break
        step = np.concatenate(near).mean(0)
        t = t + step
        for m in view:
            m.rematch(t)
        if np.abs(step).max() < 0.02:
            break


FIXED_POINT_MM = 1e-3
"""Silhouette rounds (the fit's and the deformation's) stop once a round's contour
matches are those of the round before, their targets within this (mm)."""


def same_matches(ids: np.ndarray, targets: np.ndarray,
                 last: tuple[np.ndarray, np.ndarray] | None) -> bool:
    """Whether the matches (ids (k,), targets (k, 3) mm) are the round before's ``last``:
    the same vertices, targets within :data:`FIXED_POINT_MM` (the rounds' fixed point)."""
    return (last is not None and np.array_equal(ids, last[0])
            and float(np.abs(targets - last[1]).max(initial=0.0)) <= FIXED_POINT_MM)


def contour_targets(V: np.ndarray, F: np.ndarray, silhouettes: Sequence[Silhouette],
                    movable: np.ndarray, avoid: np.ndarray, spacing_mm: float,
                    max_mm: float, edge_data: tuple[np.ndarray, np.ndarray] | None = None,
                    detrend: bool = False
                    ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Contour vertices of (V, F) in ``movable`` (bool (n,)) and their targets on the
    photos' silhouettes: ((k,) ids, (k, 3) targets mm, k names (:attr:`Silhouette.label`)).
    A vertex on two photos' contours takes the first photo's; handles of a later
    silhouette keep ``spacing_mm`` from the earlier ones' too.

    With ``detrend`` the part of each photo's offsets (over all its silhouettes) a shift
    of the whole image explains (``b ~ u + t``: the camera's own pose error, which the
    landmarks already pin) is taken out: the offset used is ``b - (u + t)``
    (:func:`_detrend`)."""
    E, EF = edge_data if edge_data is not None else edge_faces(F)
    ids_all: list[np.ndarray] = []
    tg_all: list[np.ndarray] = []
    names: list[str] = []
    used = np.zeros(len(V), bool)
    views = list(dict.fromkeys(s.view for s in silhouettes))
    for view in views:
        found: list[_Matches] = []
        for s in (s for s in silhouettes if s.view == view):
            if s.outline:
                ids, rim = occluding_contour(V, F, s.camera, E, EF, movable & ~used,
                                             with_rim=True)
            else:
                ids, rim = visible_contour(V, F, s, E, EF, movable & ~used)
            if len(ids):
                uv = s.camera.project(rim)
                found.append(_Matches(s, ids, uv, s.camera.depth(rim), *s.match(uv)))
        if detrend:
            _detrend(found, max_mm)
        for m in found:
            cam = m.s.camera
            dX = (m.z / cam.focal_px)[:, None] * (m.off[:, :1] * cam.R[0]
                                                  + m.off[:, 1:] * cam.R[1])
            ok = m.near(max_mm) & ~used[m.ids]
            ids, dX = m.ids[ok], dX[ok]
            keep = _spaced(V, ids, spacing_mm, np.concatenate(
                [np.asarray(avoid, float).reshape(-1, 3)] + [V[i] for i in ids_all]))
            pos = {int(i): j for j, i in enumerate(ids)}
            sel = np.array([pos[int(i)] for i in keep], np.int64)
            if not len(sel):
                continue
            ids_all.append(ids[sel])
            tg_all.append(V[ids[sel]] + dX[sel])
            names += [m.s.label] * len(sel)
            used[ids[sel]] = True
    if not ids_all:
        return np.zeros(0, np.int64), np.zeros((0, 3)), []
    return np.concatenate(ids_all), np.concatenate(tg_all), names
