"""Scharr edges (paper eq. 11) and least-cost paths between landmarks (eq. 12).

Where the edge of the nose is faint (alar and cheek skin look alike), a least-cost path
between two consecutive landmarks bridges it: the cost of stepping onto a pixel is low on
strong edges and high on flat skin. The search is a Dijkstra restricted to a corridor
around the straight segment between the two landmarks, which keeps it fast and stops it
from wandering to another edge.

Example
-------
>>> import numpy as np
>>> img = np.zeros((60, 80), np.uint8); img[:, 40:] = 200       # one vertical edge
>>> em = edge_map(img, (0, 0, 80, 60))
>>> path = least_cost_path(edge_cost(em.strength), (40, 5), (40, 55), corridor=15)
>>> bool(np.all(np.abs(path[:, 0] - 39.5) <= 0.5))
True
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from naseview.geometry.polyline import polyline_length, resample_by_count


@dataclass(frozen=True)
class EdgeMap:
    """Scharr edges of a region of one photo.

    Attributes:
        strength: (h, w) float32 edge strength in 0..1 (1 = at or above the reference
            percentile of the region).
        display: (h, w) uint8 eq. 11 (min-max normalised magnitude, 0..255).
        origin: (x0, y0) of the region in the photo (px).
    """

    strength: np.ndarray
    display: np.ndarray
    origin: tuple[int, int]


def to_gray(image: np.ndarray) -> np.ndarray:
    """(H, W) uint8 grey image from BGR (or pass through a grey image)."""
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def scharr_magnitude(gray: np.ndarray, blur_sigma: float = 0.0) -> np.ndarray:
    """(H, W) float32 gradient magnitude K = sqrt((I*Gx)^2 + (I*Gy)^2) (eq. 11)."""
    g: np.ndarray = gray.astype(np.float32)
    if blur_sigma > 0:
        g = cv2.GaussianBlur(g, (0, 0), blur_sigma)
    gx = cv2.Scharr(g, cv2.CV_32F, 1, 0)
    gy = cv2.Scharr(g, cv2.CV_32F, 0, 1)
    return cv2.magnitude(gx, gy)


def normalize_edges(K: np.ndarray) -> np.ndarray:
    """Eq. 11: ``255 (K - min M) / (max M - min M)`` as uint8."""
    lo, hi = float(K.min()), float(K.max())
    if hi <= lo:
        return np.zeros(K.shape, np.uint8)
    return np.clip(255.0 * (K - lo) / (hi - lo), 0, 255).astype(np.uint8)


def roi_around(points: ArrayLike, margin: int, width: int,
               height: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) box around (N, 2) pixels grown by ``margin``, inside the photo."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    x0 = int(max(0, np.floor(p[:, 0].min()) - margin))
    y0 = int(max(0, np.floor(p[:, 1].min()) - margin))
    x1 = int(min(width, np.ceil(p[:, 0].max()) + margin + 1))
    y1 = int(min(height, np.ceil(p[:, 1].max()) + margin + 1))
    return x0, y0, x1, y1


def edge_map(image: np.ndarray, roi: tuple[int, int, int, int], blur_sigma: float = 1.0,
             ref_percentile: float = 98.0) -> EdgeMap:
    """Scharr edge strength in ``roi`` = (x0, y0, x1, y1) of a BGR or grey photo."""
    x0, y0, x1, y1 = roi
    pad = 4
    px0, py0 = max(0, x0 - pad), max(0, y0 - pad)
    px1, py1 = min(image.shape[1], x1 + pad), min(image.shape[0], y1 + pad)
    gray = to_gray(image[py0:py1, px0:px1])
    K = scharr_magnitude(gray, blur_sigma)[y0 - py0:y1 - py0, x0 - px0:x1 - px0]
    ref = float(np.percentile(K[::2, ::2], ref_percentile)) if K.size else 0.0
    strength = np.clip(K / ref, 0.0, 1.0).astype(np.float32) if ref > 0 else \
        np.zeros(K.shape, np.float32)
    return EdgeMap(strength, normalize_edges(K), (x0, y0))


def edge_cost(strength: np.ndarray, exponent: float = 2.0, floor: float = 0.02) -> np.ndarray:
    """Per-pixel cost ``floor + (1 - E)^exponent`` of eq. 12 (E = edge strength 0..1)."""
    return (floor + (1.0 - strength) ** exponent).astype(np.float64)


_OFFSETS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])
_STEP_LEN = np.hypot(_OFFSETS[:, 0], _OFFSETS[:, 1])


def least_cost_path(cost: np.ndarray, start: ArrayLike, end: ArrayLike,
                    corridor: float, penalty: np.ndarray | None = None,
                    penalty_weight: float = 0.0) -> np.ndarray | None:
    """Least-cost 8-connected pixel path from ``start`` to ``end`` (eq. 12).

    Stepping from pixel p to a neighbour q costs ``|p - q| * cost[q]``. Only pixels within
    ``corridor`` px of the straight segment start-end are searched, and the Dijkstra
    search stops at the cost of the straight route (an upper bound of the optimum).

    Args:
        cost: (H, W) positive cost per pixel (coordinates of the array, px).
        start, end: (2,) ``[x, y]`` in the same coordinates.
        corridor: half-width of the search corridor (px).
        penalty: optional (H, W) extra per-pixel cost, added times ``penalty_weight``
            (e.g. the squared distance to a prior curve).
    Returns:
        (N, 2) float pixels ``[x, y]`` from start to end (the first and last are the given
        points), or None when the points are outside ``cost`` or not connected.
    """
    H, W = cost.shape
    s = np.asarray(start, dtype=np.float64)
    e = np.asarray(end, dtype=np.float64)
    si = np.clip(np.round(s).astype(int), 0, [W - 1, H - 1])
    ei = np.clip(np.round(e).astype(int), 0, [W - 1, H - 1])
    if np.any(np.abs(si - s) > 2) or np.any(np.abs(ei - e) > 2):
        return None
    x0 = int(max(0, min(si[0], ei[0]) - corridor))
    x1 = int(min(W, max(si[0], ei[0]) + corridor + 1))
    y0 = int(max(0, min(si[1], ei[1]) - corridor))
    y1 = int(min(H, max(si[1], ei[1]) + corridor + 1))
    h, w = y1 - y0, x1 - x0
    cl = cost[y0:y1, x0:x1]
    if penalty is not None and penalty_weight:
        cl = cl + penalty_weight * penalty[y0:y1, x0:x1]
    ys = np.arange(y0, y1, dtype=np.float64)[:, None]
    xs = np.arange(x0, x1, dtype=np.float64)[None, :]
    d = e - s
    L2 = float(d @ d)
    tt = np.clip(((xs - s[0]) * d[0] + (ys - s[1]) * d[1]) / L2, 0, 1) if L2 > 0 else \
        np.zeros((h, w))
    inside = np.hypot(xs - (s[0] + tt * d[0]), ys - (s[1] + tt * d[1])) <= corridor
    inside[si[1] - y0, si[0] - x0] = True
    inside[ei[1] - y0, ei[0] - x0] = True
    # graph on the corridor pixels only: 8 CSR entries per node, missing neighbours weigh inf
    n = int(inside.sum())
    ids = np.full((h + 2, w + 2), n, dtype=np.int32)
    ids[1:-1, 1:-1][inside] = np.arange(n, dtype=np.int32)
    c_ext = np.append(cl[inside], np.inf)
    nb = np.stack([ids[1 + dy:h + 1 + dy, 1 + dx:w + 1 + dx][inside]
                   for dy, dx in _OFFSETS], axis=1)
    wgt = _STEP_LEN * c_ext[nb]
    nb[nb == n] = 0
    G = csr_matrix((wgt.ravel(), nb.ravel(), np.arange(0, 8 * n + 1, 8, dtype=np.int32)),
                   shape=(n, n))
    src = int(ids[si[1] - y0 + 1, si[0] - x0 + 1])
    dst = int(ids[ei[1] - y0 + 1, ei[0] - x0 + 1])
    # upper bound: cost of the straight route
    m = max(2, int(np.ceil(np.sqrt(L2))) + 1)
    line = np.round(s + np.linspace(0, 1, m)[:, None] * d).astype(int)
    line = np.clip(line, [x0, y0], [x1 - 1, y1 - 1])
    bound = float(np.sum(np.hypot(*np.diff(line, axis=0).T)
                         * cl[line[1:, 1] - y0, line[1:, 0] - x0]))
    dist, pred = dijkstra(G, directed=True, indices=src, return_predecessors=True,
                          limit=bound * (1 + 1e-9) + 1e-9)
    if src != dst and not np.isfinite(dist[dst]):
        return None
    chain = [dst]
    while chain[-1] != src:
        chain.append(int(pred[chain[-1]]))
    chain.reverse()
    yy, xx = np.nonzero(inside)  # row-major order == node numbering
    path = np.column_stack([xx[chain] + x0, yy[chain] + y0]).astype(np.float64)
    path[0], path[-1] = s, e
    return path


def smooth_polyline(P: ArrayLike, sigma: float) -> np.ndarray:
    """Gaussian smoothing of an open (N, D) polyline along its arc length, ends fixed.

    Args:
        P: (N, D) points; sigma: standard deviation in units of P (px).
    """
    P = np.asarray(P, dtype=np.float64)
    if sigma <= 0 or len(P) < 3:
        return P.copy()
    Q = resample_by_count(P, max(2, int(np.ceil(polyline_length(P) / 0.5)) + 1))
    k = int(np.ceil(3 * sigma / 0.5))
    x = np.arange(-k, k + 1) * 0.5
    g = np.exp(-0.5 * (x / sigma) ** 2)
    g /= g.sum()
    # reflect about the end points (odd extension) so the ends stay put
    pad_a = 2 * Q[0] - Q[1:k + 1][::-1]
    pad_b = 2 * Q[-1] - Q[-k - 1:-1][::-1]
    ext = np.concatenate([pad_a, Q, pad_b]) if len(Q) > k + 1 else Q
    if len(ext) == len(Q):
        return Q
    out = np.stack([np.convolve(ext[:, j], g, mode="valid") for j in range(Q.shape[1])], 1)
    out[0], out[-1] = Q[0], Q[-1]
    return out
