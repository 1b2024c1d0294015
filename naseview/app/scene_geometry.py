"""The geometry behind a tab's 3D scene, without viser handles: the nose region split
off the face (two meshes, so a live update sends only the nose), its outline and the
outline's display smoothing, the before/after blend, camera poses for viser, curve
segments and where the landmark labels go in a view (SPEC frame, mm, +y up).

:class:`naseview.app.scene.FaceScene` and :class:`naseview.app.face_glb.FaceGlb` build on
these; nothing here draws.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from viser import transforms as vtf

from naseview.camera import Camera


def split_region(F: np.ndarray, region: np.ndarray, n_vertices: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Split a face mesh into the triangles touching a region and the rest.

    Args:
        F: (M, 3) triangles.
        region: (K,) vertex ids of the region (e.g. the nose).
        n_vertices: number of vertices of the mesh.
    Returns:
        ``(part_ids, part_F, rest_ids, rest_F)``: vertex ids of each part (sorted, into the
        full mesh) and its triangles re-indexed to those ids. A triangle with at least one
        region vertex belongs to the part, so vertices shared by both parts lie outside
        the region.
    """
    F = np.asarray(F, dtype=np.int64)
    in_region = np.zeros(n_vertices, dtype=bool)
    in_region[np.asarray(region, dtype=np.int64)] = True
    touch = in_region[F].any(axis=1)

    def compact(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ids = np.unique(faces)
        remap = np.full(n_vertices, -1, dtype=np.int64)
        remap[ids] = np.arange(len(ids))
        return ids, remap[faces]

    part_ids, part_F = compact(F[touch])
    rest_ids, rest_F = compact(F[~touch])
    return part_ids, part_F, rest_ids, rest_F


def region_outline(F: np.ndarray, region: np.ndarray, n_vertices: int) -> np.ndarray:
    """(E, 2) vertex pairs of the border of a region: edges of exactly one triangle whose
    three corners lie in ``region`` (an outline drawn instead of tinting the region)."""
    F = np.asarray(F, dtype=np.int64)
    inside = np.zeros(n_vertices, dtype=bool)
    inside[np.asarray(region, dtype=np.int64)] = True
    Fr = F[inside[F].all(axis=1)]
    if len(Fr) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    E = np.sort(np.concatenate([Fr[:, [0, 1]], Fr[:, [1, 2]], Fr[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(E, axis=0, return_counts=True)
    return uniq[count == 1]


def outline_smoother(edges: np.ndarray, iterations: int = 4) -> tuple[np.ndarray,
                                                                     np.ndarray]:
    """Display smoothing of a region outline (mesh-edge zig-zags become a soft curve).

    Args:
        edges: (E, 2) vertex pairs (:func:`region_outline`).
        iterations: rounds of "half self, half mean of outline neighbours".
    Returns:
        ``(vertex_ids (n,), S (n, n))``: the outline's vertices and the smoothing matrix;
        the smoothed points are ``S @ V[vertex_ids]`` and the segments
        ``np.searchsorted(vertex_ids, edges)`` index them.
    """
    ids = np.unique(edges)
    n = len(ids)
    loc = np.searchsorted(ids, edges)
    A = np.zeros((n, n))
    A[loc[:, 0], loc[:, 1]] = 1.0
    A[loc[:, 1], loc[:, 0]] = 1.0
    deg = A.sum(axis=1, keepdims=True)
    step = 0.5 * np.eye(n) + 0.5 * A / np.where(deg > 0, deg, 1.0)
    step[deg[:, 0] == 0] = np.eye(n)[deg[:, 0] == 0]
    return ids, np.linalg.matrix_power(step, max(0, int(iterations)))


def blend(V0: np.ndarray, V1: np.ndarray, t: float) -> np.ndarray:
    """(N, 3) vertices ``(1 - t) V0 + t V1`` (mm; before -> after, t in [0, 1])."""
    t = float(np.clip(t, 0.0, 1.0))
    return (1.0 - t) * np.asarray(V0, np.float64) + t * np.asarray(V1, np.float64)


def camera_pose(cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(wxyz (4,), position (3,)) of a SPEC camera for viser (OpenCV axes, camera to
    world)."""
    return vtf.SO3.from_matrix(cam.R.T).wxyz, cam.center


def curve_segments(points: np.ndarray, closed: bool) -> np.ndarray:
    """(N, 3) polyline -> (S, 2, 3) segments (closing the loop when ``closed``)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(P) < 2:
        return np.zeros((0, 2, 3))
    Q = np.concatenate([P, P[:1]]) if closed else P
    return np.stack([Q[:-1], Q[1:]], axis=1)


LABEL_PX = (8.0, 18.0)
"""Approximate (width of a character, height) of a landmark label on screen (px)."""


def label_layout(anchors: Mapping[str, np.ndarray], landmarks: Mapping[str, np.ndarray],
                 texts: Mapping[str, str], V: np.ndarray, F: np.ndarray, camera: Camera,
                 tol_mm: float = 1.5) -> dict[str, np.ndarray | None]:
    """Where each landmark label goes in the view of ``camera``: None for a landmark the
    camera cannot see (behind the face ``V``, ``F``: its label would name a hidden point),
    else its anchor (3,), moved up or down on screen (at its own depth) until its box
    (:data:`LABEL_PX` per character, ``bottom-center`` anchored) overlaps no label placed
    before it (placed top to bottom). Issue 27: labels overlapped and named hidden
    landmarks."""
    from naseview.render import rasterize, visible_points

    ids = [k for k in anchors if k in landmarks]
    out: dict[str, np.ndarray | None] = dict.fromkeys(anchors)
    if not ids:
        return out
    s = min(1.0, 320.0 / max(camera.width, camera.height))
    small = Camera(np.diag([s, s, 1.0]) @ camera.K, camera.R, camera.t,
                   max(8, int(round(camera.width * s))), max(8, int(round(camera.height * s))))
    depth = rasterize(V, F, small).depth
    P = np.array([landmarks[k] for k in ids], np.float64)
    seen = visible_points(P, small, depth, tol_mm=tol_mm, radius_px=1)
    A = np.array([anchors[k] for k in ids], np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = camera.project(A)
    z = camera.depth(A)
    cw, ch = LABEL_PX
    boxes: list[tuple[float, float, float, float]] = []
    order = sorted((j for j in range(len(ids)) if seen[j] and z[j] > 0), key=lambda j: uv[j, 1])
    for j in order:
        w = cw * len(texts.get(ids[j], ids[j])) + 6.0
        x0, x1 = uv[j, 0] - w / 2, uv[j, 0] + w / 2
        y = float(uv[j, 1])

        def hits(y: float, x0: float = x0, x1: float = x1) -> bool:
            return any(x0 < b[2] and b[0] < x1 and y - ch < b[3] and b[1] < y
                       for b in boxes)

        best = y
        for step in range(1, 40):
            if not hits(best):
                break
            up, down = y - step * 0.5 * ch, y + step * 0.5 * ch
            best = up if not hits(up) else down if not hits(down) else best
        if hits(best):
            best = y
        boxes.append((x0, best - ch, x1, best))
        ray = np.linalg.solve(camera.K, np.array([uv[j, 0], best, 1.0]))
        out[ids[j]] = camera.R.T @ (z[j] * ray - camera.t)
    return out


__all__ = ["LABEL_PX", "blend", "camera_pose", "curve_segments", "label_layout",
           "outline_smoother", "region_outline", "split_region"]
