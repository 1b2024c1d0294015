"""The generic face's external nose: a height field joined to the face (design step 1).

A dorsal ridge (profile, sidewall slope and roundness varying from radix to tip), the tip
lobule and the two alar lobules (soft-rimmed ellipsoid caps) joined by polynomial smooth
maxima, and cut from below by the nasal base (a plane rising forwards, higher beside the
columella). Small blend radii make the alar creases and grooves, larger ones the
nasofacial and supratip transitions (:func:`surface_height`). mm, the generic face's frame.

Example
-------
>>> import numpy as np
>>> x, y = np.array([0.0, 30.0]), np.array([-38.5, -38.5])
>>> (membership(np.c_[x, y, 0 * x]) > 0).tolist()        # the tip stands out, the cheek not
[True, False]
"""

from __future__ import annotations

import numpy as np

from naseview.facemodel.generic.face import face_height
from naseview.facemodel.generic.shapes import Profile, smax, smin, smoothstep

_RIDGE_Z = Profile([(14, -10.5), (6, -4.2), (0, 0.3), (-6, 4.7), (-12, 9.4), (-18, 13.9),
                    (-24, 18.3), (-29, 22.2), (-33, 25.3), (-38, 27.6), (-44, 28.2)])
"""Dorsal profile: midline height of the dorsal ridge (mm) at height y."""

_RIDGE_SLOPE = Profile([(14, 0.8), (0, 0.95), (-10, 1.35), (-20, 1.65), (-30, 1.75),
                        (-38, 2.1), (-46, 2.4)])
"""Slope of the nasal sidewalls (dz/dx)."""

_RIDGE_ROUND = Profile([(14, 10.0), (0, 8.0), (-10, 5.5), (-20, 4.6), (-30, 5.5),
                        (-45, 6.0)])
"""Roundness radius (mm) of the dorsal ridge cross-section."""

LOBULE = {"y": -38.5, "z0": 17.3, "rx": 9.5, "ry": 9.0, "ry_up": 10.5, "rz": 12.5,
          "flare": 2.5}
"""Tip lobule: cap of an ellipsoid centred at (0, y, z0) with semi-axes rx, ry (``ry_up``
above the centre), rz; its x semi-axis grows by ``flare`` below the centre."""

ALA = {"x": 11.0, "y": -41.5, "z0": 2.0, "rx": 5.6, "ry": 7.0, "rz": 12.0, "roll": 0.35}
"""Alar lobule (left; mirrored): ellipsoid cap, footprint rotated by ``roll`` rad."""

UNDERSIDE = {"y": -48.6, "z": 12.0, "slope": 0.27, "rim_rise": 1.2, "x_ala": 12.0}
"""Nasal base y = y0 + slope (z - z0) + rise(x): rises forwards, and by ``rim_rise``
beside the columella (the nostrils sit higher than the columella); beyond ``x_ala`` it
falls away so the alar lobules round off by themselves."""


def _cap(q2: np.ndarray, z0: float, rz: float, soft: float = 0.12) -> np.ndarray:
    """Ellipsoid cap ``z0 + rz sqrt(1 - q2)`` with a soft rim.

    Where ``1 - q2 < soft`` the square root continues along its tangent (C1), so the cap
    meets what it is blended with at a finite slope and keeps falling outside.
    """
    s = 1.0 - q2
    r = np.sqrt(soft)
    return z0 + rz * np.where(s > soft, np.sqrt(np.maximum(s, soft)), r + (s - soft) / (2 * r))


def _ridge(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dorsum and sidewalls; below the alar groove the sidewalls retreat behind the alae."""
    s = _RIDGE_SLOPE(y)
    rho = _RIDGE_ROUND(y)
    return _RIDGE_Z(y) - s * (np.sqrt(x * x + rho * rho) - rho)


def _lobule(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Tip lobule; its lower half widens into the soft triangles over the nostrils."""
    L = LOBULE
    rx = L["rx"] + L["flare"] * smoothstep((L["y"] - y) / 6.0)
    ry = np.where(y > L["y"], L["ry_up"], L["ry"])
    q2 = (x / rx) ** 2 + ((y - L["y"]) / ry) ** 2
    return _cap(q2, L["z0"], L["rz"])


def _ala(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Alar lobules (both sides): rotated ellipsoid caps with a wide soft rim."""
    A = ALA
    ax = np.abs(x) - A["x"]
    ay = y - A["y"]
    c, s = np.cos(A["roll"]), np.sin(A["roll"])
    u, v = c * ax + s * ay, -s * ax + c * ay
    q2 = (u / A["rx"]) ** 2 + (v / A["ry"]) ** 2
    return _cap(q2, A["z0"], A["rz"], soft=0.3)


def _rise(x: np.ndarray) -> np.ndarray:
    """How much the nasal base rises beside the columella, and falls beyond the alae."""
    U = UNDERSIDE
    ax = np.abs(x)
    return U["rim_rise"] * smoothstep((ax - 2.5) / 4.0) \
        - 15.0 * smoothstep((ax - U["x_ala"]) / 5.0)


def underside_y(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Height y of the nasal base below the point (x, z)."""
    U = UNDERSIDE
    return U["y"] + U["slope"] * (z - U["z"]) + _rise(x)


def _underside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The nasal base as a height field: z where the base passes height y."""
    U = UNDERSIDE
    return U["z"] + (y - U["y"] - _rise(x)) / U["slope"]


def nose_parts(x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """Height fields (mm) of the nose primitives at (x, y)."""
    return {"ridge": _ridge(x, y), "lobule": _lobule(x, y), "ala": _ala(x, y),
            "under": _underside(x, y)}


def _blend_k(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Blend radii (mm): ala/sidewall (alar groove), nose/face (crease near the alae)."""
    ax = np.abs(x)
    k_groove = 1.6 + 4.0 * smoothstep((10.0 - ax) / 4.0)
    near_ala = smoothstep((ax - 9.0) / 4.0) * smoothstep((-36.0 - y) / 4.0)
    k_face = 4.5 - 3.3 * near_ala
    return k_groove, k_face


def nose_height(x: np.ndarray, y: np.ndarray,
                parts: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """Depth z (mm) of the external nose alone at (x, y) (very low outside it)."""
    p = nose_parts(x, y) if parts is None else parts
    k_groove, _ = _blend_k(x, y)
    front = smax(p["ridge"], p["lobule"], 5.0)
    front = smax(front, p["ala"], k_groove)
    return smin(front, p["under"], 2.2)


def surface_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Depth z (mm) of the whole face, nose included (before carving the nostrils)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    _, k_face = _blend_k(x, y)
    return smax(face_height(x, y), nose_height(x, y), k_face)


def membership(X: np.ndarray) -> np.ndarray:
    """(N,) height (mm) of the nose above the face without it at the points' (x, y)."""
    return nose_height(X[:, 0], X[:, 1]) - face_height(X[:, 0], X[:, 1])
