"""Pinhole cameras in the SPEC §4 convention (the projection in the reprojection error of
stage 1, paper §3.2, eq. 1).

``x_cam = R @ X + t``; ``[u*w, v*w, w] = K @ x_cam``; the camera looks along +z_cam and
image y points down. World frame: millimetres, origin at glabella ``g``, +x to the
subject's left, +y up, +z anterior.

Example
-------
>>> import numpy as np
>>> cam = look_at(eye=[0, 0, 400.0], target=[0, 0, 0], up=[0, 1, 0], focal_px=1000.0,
...               width=1024, height=1024)
>>> cam.project(np.array([[0.0, 0.0, 0.0]])).round(1).tolist()
[[511.5, 511.5]]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from naseview.errors import NaseviewError


@dataclass(frozen=True)
class Camera:
    """A calibrated pinhole camera.

    Attributes:
        K: (3, 3) intrinsics in pixels.
        R: (3, 3) world-to-camera rotation.
        t: (3,) world-to-camera translation (mm).
        width, height: image size in pixels.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int

    @property
    def center(self) -> np.ndarray:
        """(3,) camera centre in world coordinates (mm)."""
        return -self.R.T @ self.t

    @property
    def focal_px(self) -> float:
        return float(0.5 * (self.K[0, 0] + self.K[1, 1]))

    def to_camera(self, X: ArrayLike) -> np.ndarray:
        """(N, 3) world points -> (N, 3) camera coordinates."""
        X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
        return X @ self.R.T + self.t

    def project(self, X: ArrayLike) -> np.ndarray:
        """(N, 3) world points (mm) -> (N, 2) pixels ``[x, y]`` (SPEC §2)."""
        xc = self.to_camera(X)
        uvw = xc @ self.K.T
        return uvw[:, :2] / uvw[:, 2:3]

    def depth(self, X: ArrayLike) -> np.ndarray:
        """(N,) depth along the optical axis (mm) of world points."""
        return self.to_camera(X)[:, 2]

    def rays(self, uv: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Lines of sight through pixels.

        Args:
            uv: (N, 2) pixel coordinates.
        Returns:
            origin (3,) camera centre and (N, 3) unit directions in world coordinates.
        """
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        h = np.column_stack([uv, np.ones(len(uv))])
        d_cam = np.linalg.solve(self.K, h.T).T
        d = d_cam @ self.R
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return self.center, d

    def to_json(self) -> dict[str, Any]:
        return {"K": self.K.tolist(), "R": self.R.tolist(), "t": self.t.tolist(),
                "width": int(self.width), "height": int(self.height)}

    @staticmethod
    def from_json(obj: dict[str, Any], where: str = "camera") -> Camera:
        """Parse ``{"K", "R", "t", "width", "height"}``; ``where`` names it in errors."""
        try:
            K = np.asarray(obj["K"], dtype=np.float64)
            R = np.asarray(obj["R"], dtype=np.float64)
            t = np.asarray(obj["t"], dtype=np.float64)
            width, height = int(obj["width"]), int(obj["height"])
        except KeyError as e:
            raise NaseviewError(f"{where}: missing key {e.args[0]!r}") from None
        except (TypeError, ValueError):
            raise NaseviewError(f"{where}: K, R, t must be numeric arrays") from None
        if K.shape != (3, 3) or R.shape != (3, 3) or t.shape != (3,):
            raise NaseviewError(f"{where}: expected K (3x3), R (3x3), t (3)")
        return Camera(K, R, t, width, height)


def intrinsics(focal_px: float, width: int, height: int) -> np.ndarray:
    """(3, 3) K with square pixels and the principal point at the image centre.

    The centre of an image of width W is at x = (W - 1) / 2 because pixel [0, 0] is the
    centre of the top-left pixel (SPEC §2).
    """
    return np.array([[focal_px, 0.0, (width - 1) / 2.0],
                     [0.0, focal_px, (height - 1) / 2.0],
                     [0.0, 0.0, 1.0]])


def look_at(eye: ArrayLike, target: ArrayLike, up: ArrayLike, focal_px: float, width: int,
            height: int) -> Camera:
    """Camera at ``eye`` looking at ``target`` with image-up close to ``up`` (world, mm)."""
    eye = np.asarray(eye, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)  # image x: right; camera y points down, so x = z cross up
    nx = np.linalg.norm(x)
    if nx < 1e-9:
        raise ValueError("look_at: up is parallel to the viewing direction")
    x /= nx
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    t = -R @ eye
    return Camera(intrinsics(focal_px, width, height), R, t, int(width), int(height))


def orbit_camera(target: ArrayLike, direction: ArrayLike, distance_mm: float,
                 field_mm: float, size_px: int) -> Camera:
    """Square camera ``distance_mm`` from ``target`` along ``direction``, looking back at it.

    The focal length makes ``field_mm`` at the target span the image width; image-up is
    close to +y (the SPEC frame's up).

    Args:
        target: (3,) point the camera looks at (mm).
        direction: (3,) from ``target`` towards the camera (any length, not zero).
        distance_mm: camera distance from ``target`` (mm, > 0).
        field_mm: width of the field of view at ``target`` (mm, > 0).
        size_px: image width = height (px).
    Returns:
        the :class:`Camera`.
    """
    target = np.asarray(target, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    return look_at(target + distance_mm * d, target, (0.0, 1.0, 0.0),
                   size_px * distance_mm / field_mm, size_px, size_px)


def rodrigues(rvec: ArrayLike) -> np.ndarray:
    """(3,) axis-angle (radians) -> (3, 3) rotation matrix."""
    r = np.asarray(rvec, dtype=np.float64)
    theta = float(np.linalg.norm(r))
    if theta < 1e-12:
        k = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        return np.eye(3) + k
    k = r / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * (kx @ kx)


def rotation_to_rvec(R: ArrayLike) -> np.ndarray:
    """(3, 3) rotation -> (3,) axis-angle (radians)."""
    # lazy: scipy.spatial.transform adds ~0.3 s to `import naseview.camera` (0.06-0.1 s
    # without it, python -X importtime), and every module of the package imports this one
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.asarray(R, dtype=np.float64)).as_rotvec()


_S45 = math.sin(math.radians(45.0))
STANDARD_VIEWS: dict[str, tuple[str, tuple[float, float, float]]] = {
    "front": ("Front", (0.0, 0.0, 1.0)),
    "left": ("Left profile", (1.0, 0.0, 0.0)),
    "right": ("Right profile", (-1.0, 0.0, 0.0)),
    "base": ("Base (basal)", (0.0, -math.sin(math.radians(60.0)), math.cos(math.radians(60.0)))),
    "three_quarter_left": ("Three-quarter left", (_S45, 0.0, _S45)),
    "three_quarter_right": ("Three-quarter right", (-_S45, 0.0, _S45)),
}
"""The standard clinical views of the app, the report and the view PNGs (one table for all):
name -> (title, direction from the face towards the camera, SPEC frame). "left" is the
subject's left side (camera on +x), as in the photo views of SPEC §2.

>>> list(STANDARD_VIEWS)[:3]
['front', 'left', 'right']
"""

DISTANCE_MM = 600.0


def standard_camera(V: ArrayLike, view: str, size: int = 800,
                    nose_ids: ArrayLike | None = None, field_factor: float = 2.6
                    ) -> Camera:
    """Camera of a standard view (:data:`STANDARD_VIEWS`) framing the nose or the face.

    Args:
        V: (n, 3) vertices (mm).
        view: a key of :data:`STANDARD_VIEWS`.
        size: image width = height (px).
        nose_ids: (k,) nose vertices: frame the nose, ``field_factor`` times its extent;
            default: frame the face (the front 90 mm of the head).
        field_factor: see ``nose_ids``.
    Raises:
        NaseviewError: unknown view name.
    """
    if view not in STANDARD_VIEWS:
        raise NaseviewError(f"view {view!r}: unknown; use one of {', '.join(STANDARD_VIEWS)}")
    V = np.asarray(V, dtype=np.float64)
    if nose_ids is not None and len(np.asarray(nose_ids)):
        P = V[np.asarray(nose_ids, dtype=np.int64)]
        field = field_factor * float(np.ptp(P, axis=0).max())
    else:
        P = V[V[:, 2] >= V[:, 2].max() - 90.0]
        field = 1.1 * float(max(np.ptp(P[:, 0]), np.ptp(P[:, 1]), np.ptp(P[:, 2])))
    centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
    if view == "base" and nose_ids is not None and len(P):
        low = P[P[:, 1] <= np.quantile(P[:, 1], 0.4)]  # aim at the nasal base, not the
        centre = 0.5 * (low.min(axis=0) + low.max(axis=0))  # middle of the dorsum
    return orbit_camera(centre, STANDARD_VIEWS[view][1], DISTANCE_MM, max(field, 1.0),
                        int(size))
