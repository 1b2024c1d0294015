"""The SPEC §4 anatomical frame of stage 1 (paper §3.2): gauge, axes and millimetre scale.

The bundle adjustment (eq. 1) fixes the landmarks only up to a similarity (7 gauge
degrees of freedom). The result is expressed in the SPEC §4 frame: origin at ``g``, +x to
the subject's left (sum of the ``_r`` -> ``_l`` pair vectors), +y up (``sn`` -> ``g``
orthogonalised against x), +z = x cross y (anterior), and millimetres from
``case.scale_mm`` (least squares over all given distances).

Example
-------
>>> import numpy as np
>>> pts = {"g": np.zeros(3), "sn": np.array([0.0, -50.0, 0.0]),
...        "al_l": np.array([15.0, -45.0, -5.0]), "al_r": np.array([-15.0, -45.0, -5.0])}
>>> origin, R = anatomical_frame(pts)
>>> origin.tolist(), R.round(6).tolist()
([0.0, 0.0, 0.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from naseview.camera import Camera
from naseview.landmarks import LANDMARK_IDS

PAIR_BASES: tuple[str, ...] = tuple(lid[:-2] for lid in LANDMARK_IDS if lid.endswith("_l"))
"""Names of the left/right landmark pairs without the side suffix (``"al"`` for al_l/al_r)."""

ScaleDistances = dict[tuple[str, str], float]
"""(id, id) -> distance (mm): ``case.scale_mm``."""


@dataclass(frozen=True)
class Gauge:
    """Landmark indices that define the SPEC frame of N points.

    Attributes:
        origin: index of g (of n when g is not among the points: a provisional origin
            while g is placed from one photo).
        left, right: (P,) indices of the ``_l`` members of the pairs and their partners.
        low: index of sn, else c, else prn (the lower end of the +y axis).
        scale_a, scale_b: (S,) endpoints of the scale distances among the points.
        scale_mm: (S,) their lengths (mm).
    """

    origin: int
    left: np.ndarray
    right: np.ndarray
    low: int
    scale_a: np.ndarray
    scale_b: np.ndarray
    scale_mm: np.ndarray

    @staticmethod
    def build(point_ids: Sequence[str], scale_mm: ScaleDistances | None = None) -> Gauge:
        """The gauge of the points ``point_ids`` (in this order).

        Raises:
            ValueError: naming what is missing (origin, pair or lower midline landmark).
        """
        idx = {lid: j for j, lid in enumerate(point_ids)}
        origin, pairs, low = _origin(idx), _pairs(idx), _low(idx)  # checked in this order
        scales = [(idx[a], idx[b], d) for (a, b), d in (scale_mm or {}).items()
                  if a in idx and b in idx]
        return Gauge(origin, np.array([p[0] for p in pairs]),
                     np.array([p[1] for p in pairs]), low,
                     np.array([c[0] for c in scales], dtype=np.int64),
                     np.array([c[1] for c in scales], dtype=np.int64),
                     np.array([c[2] for c in scales], dtype=np.float64))

    def frames(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, N, 3) points -> origins (B, 3) and rotations (B, 3, 3) (rows x, y, z)."""
        x = (X[:, self.left] - X[:, self.right]).sum(1)
        x /= np.linalg.norm(x, axis=1, keepdims=True)
        y = X[:, self.origin] - X[:, self.low]
        y -= (y * x).sum(1, keepdims=True) * x
        y /= np.linalg.norm(y, axis=1, keepdims=True)
        return X[:, self.origin], np.stack([x, y, np.cross(x, y)], axis=1)

    def scales(self, X: np.ndarray) -> np.ndarray:
        """(B, N, 3) -> (B,) least-squares scale to millimetres; without a usable distance,
        the scale making the RMS distance from the origin 1 (so the gauge stays fixed)."""
        if not len(self.scale_mm):
            r = X - X[:, self.origin][:, None]
            return 1.0 / np.sqrt((r * r).sum(2).mean(1))
        d = np.linalg.norm(X[:, self.scale_a] - X[:, self.scale_b], axis=2)
        return (d * self.scale_mm).sum(1) / (d * d).sum(1)

    def apply(self, X: np.ndarray) -> np.ndarray:
        """(B, N, 3) points in any similarity frame -> (B, N, 3) SPEC-frame points (mm)."""
        o, R = self.frames(X)
        return self.scales(X)[:, None, None] * np.einsum("bij,bnj->bni", R, X - o[:, None])


def _origin(idx: dict[str, int]) -> int:
    """Index of g, else of n (provisional origin while g is placed)."""
    origin = "g" if "g" in idx else "n"
    if origin not in idx:
        raise ValueError("g (or n) is needed for the origin")
    return idx[origin]


def _pairs(idx: dict[str, int]) -> list[tuple[int, int]]:
    """(left, right) indices of every pair with both members among the points."""
    pairs = [(idx[b + "_l"], idx[b + "_r"]) for b in PAIR_BASES
             if b + "_l" in idx and b + "_r" in idx]
    if not pairs:
        raise ValueError("no left/right landmark pair")
    return pairs


def _low(idx: dict[str, int]) -> int:
    """Index of sn, else c, else prn."""
    low = next((idx[i] for i in ("sn", "c", "prn") if i in idx), None)
    if low is None:
        raise ValueError("no lower midline landmark (sn, c or prn)")
    return low


def anatomical_frame(points: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Origin and axes of the SPEC §4 frame from landmark positions (any similarity frame).

    +x: sum of the ``_r`` -> ``_l`` pair vectors; +y: from ``sn`` (else ``c``, else
    ``prn``) towards ``g``, orthogonalised against x; +z = x cross y.

    Args:
        points: id -> (3,) positions; must hold ``g``, a lower midline landmark and at
            least one left/right pair.
    Returns:
        origin (3,) (= g) and (3, 3) rotation whose rows are the x, y, z axes, so that
        ``Rg @ (X - origin)`` are SPEC coordinates (before scaling).
    Raises:
        ValueError: the landmarks needed are missing.
    """
    ids = list(points)
    gauge = Gauge.build(ids)
    X = np.array([points[i] for i in ids], dtype=np.float64)[None]
    o, R = gauge.frames(X)
    return o[0], R[0]


def similarity_camera(cam: Camera, origin: np.ndarray, R: np.ndarray, s: float) -> Camera:
    """The same camera after the world change ``X' = s R (X - origin)`` (pixels unchanged).

    Args:
        origin: (3,) old coordinates of the new origin; R: (3, 3) rotation; s: scale.
    """
    return Camera(cam.K, cam.R @ R.T, s * (cam.R @ origin + cam.t), cam.width, cam.height)


def scale_from(scale_mm: ScaleDistances, pts: dict[str, np.ndarray]) -> float | None:
    """Least-squares factor s minimising sum (s d_i - D_i)^2; None without a usable pair.

    Args:
        scale_mm: (a, b) -> D_i, the given distances (mm).
        pts: id -> (3,) positions; d_i = |pts[a] - pts[b]| over the pairs present.
    """
    num = den = 0.0
    for (a, b), D in scale_mm.items():
        if a in pts and b in pts:
            d = float(np.linalg.norm(pts[a] - pts[b]))
            num += d * D
            den += d * d
    return num / den if den > 0 else None
