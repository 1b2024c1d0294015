"""The photo shown in the 3D view of the "new patient" page, and its click markers.

A photo is a scene image on a plane far away from the face (:data:`PLANE_CENTRE`), seen
straight on by a camera the page places; a click anywhere in the view is a ray that
:meth:`PhotoPlane.intersect` turns into pixels (SPEC §2: ``[0, 0]`` is the centre of the
top-left pixel). The markers are flat meshes in the plane (:func:`ring_mesh`,
:func:`disc_mesh`).

Example
-------
>>> import numpy as np
>>> plane = PhotoPlane(800, 600)
>>> uv = plane.intersect(plane.centre + [0.0, 0.0, 400.0], [0.0, 0.0, -1.0])
>>> uv.round(2).tolist()
[399.5, 299.5]
>>> plane.to_pixel(plane.to_world(np.array([[10.0, 20.0]]))[0]).round(6).tolist()
[10.0, 20.0]
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

PLANE_CENTRE = np.array([0.0, 100_000.0, 0.0])
"""Where the photo plane lives: 100 m above the face, so the face is never in view."""

PLANE_SIZE = 200.0
"""Longest side of the photo plane (scene units)."""

CAMERA_DISTANCE = 400.0
"""Distance of the page's camera from the photo plane (scene units)."""


@dataclass(frozen=True)
class PhotoPlane:
    """A photo of ``width_px`` x ``height_px`` shown as a scene image.

    The image node sits at ``centre`` rotated 180 degrees about x, so that seen from +z
    with +y up its pixel ``[0, 0]`` is at the top left; its longest side is ``size``
    scene units. Pixel coordinates follow SPEC §2 (``[0, 0]`` = centre of the top-left
    pixel).
    """

    width_px: int
    height_px: int
    centre: np.ndarray = field(default_factory=lambda: PLANE_CENTRE.copy())
    size: float = PLANE_SIZE

    @property
    def width_u(self) -> float:
        return self.size * self.width_px / max(self.width_px, self.height_px)

    @property
    def height_u(self) -> float:
        return self.size * self.height_px / max(self.width_px, self.height_px)

    @property
    def wxyz(self) -> tuple[float, float, float, float]:
        return (0.0, 1.0, 0.0, 0.0)

    def to_pixel(self, point: np.ndarray) -> np.ndarray:
        """(3,) world point on the plane -> (2,) pixel ``[x, y]``."""
        d = np.asarray(point, dtype=np.float64) - self.centre
        u = (d[0] / self.width_u + 0.5) * self.width_px - 0.5
        v = (-d[1] / self.height_u + 0.5) * self.height_px - 0.5
        return np.array([u, v])

    def to_world(self, uv: np.ndarray, lift: float = 0.0) -> np.ndarray:
        """(N, 2) pixels -> (N, 3) world points ``lift`` units in front of the photo."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        x = ((uv[:, 0] + 0.5) / self.width_px - 0.5) * self.width_u
        y = -((uv[:, 1] + 0.5) / self.height_px - 0.5) * self.height_u
        return self.centre + np.column_stack([x, y, np.full(len(uv), lift)])

    def intersect(self, origin: ArrayLike, direction: ArrayLike) -> np.ndarray | None:
        """Pixel where a view ray meets the photo plane (``None``: parallel or behind)."""
        o = np.asarray(origin, dtype=np.float64)
        d = np.asarray(direction, dtype=np.float64)
        if abs(d[2]) < 1e-12:
            return None
        t = (self.centre[2] - o[2]) / d[2]
        if t <= 0:
            return None
        return self.to_pixel(o + t * d)

    def inside(self, uv: np.ndarray) -> bool:
        return bool(-0.5 <= uv[0] <= self.width_px - 0.5
                    and -0.5 <= uv[1] <= self.height_px - 0.5)

    def fov_for(self, aspect: float, distance: float = CAMERA_DISTANCE,
                margin: float = 1.03) -> float:
        """Vertical field of view (rad) that fits the photo in a view of ``aspect``
        (width / height) from ``distance``."""
        need = max(self.height_u, self.width_u / max(aspect, 1e-3)) * margin
        return float(2.0 * np.arctan(0.5 * need / distance))

    def marker_radius(self) -> float:
        """Radius of a click ring (scene units): ~1 % of the photo's longest side."""
        return 0.0105 * self.size


def ring_mesh(r_in: float, r_out: float, n: int = 28) -> tuple[np.ndarray, np.ndarray]:
    """A flat annulus in the z = 0 plane, normal +z: (2n, 3) vertices, (2n, 3) faces."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    V = np.concatenate([np.column_stack([r_in * c, r_in * s, np.zeros(n)]),
                        np.column_stack([r_out * c, r_out * s, np.zeros(n)])])
    i = np.arange(n)
    j = (i + 1) % n
    F = np.concatenate([np.column_stack([i, n + i, n + j]), np.column_stack([i, n + j, j])])
    return V, F.astype(np.int64)


def disc_mesh(r: float, n: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """A flat disc in the z = 0 plane, normal +z."""
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    V = np.vstack([[0.0, 0.0, 0.0], np.column_stack([r * np.cos(a), r * np.sin(a),
                                                     np.zeros(n)])])
    i = np.arange(n)
    F = np.column_stack([np.zeros(n, np.int64), 1 + i, 1 + (i + 1) % n])
    return V, F
