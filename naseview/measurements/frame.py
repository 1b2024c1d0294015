"""The facial midline plane and the lateral (profile) projection every measurement shares.

Definition (SPEC frame, mm: origin glabella g, +x subject's left, +y up, +z anterior).
The *facial midline plane* passes through g (the origin when g is missing) with the unit
normal ``e = (mf_l - mf_r) / |mf_l - mf_r|`` (the medial orbital rims are the most
reliable bilateral landmarks beside the nasal root); without both mf landmarks (or with
coincident ones) ``e = +x``, i.e. the plane x = 0 of the SPEC frame. In the plane:

- ``up = unit(y - (y . e) e)``, the facial vertical (+y made orthogonal to ``e``);
- ``anterior = e x up`` (≈ +z, right-handed with e ≈ +x and up ≈ +y).

The *lateral projection* of a point ``p`` is ``(t, h) = ((p - o) . anterior,
(p - o) . up)`` (what a lateral photograph shows); its *lateral offset* is ``(p - o) . e``
(signed, + towards the subject's left).

Example
-------
>>> import numpy as np
>>> plane = midline_plane({"mf_l": np.array([9.0, -15, -8]), "mf_r": np.array([-9.0, -15, -8])})
>>> plane.to_2d(np.array([[0.0, -45, 25]])).tolist(), float(plane.lateral(np.array([3.0, 0, 0]))[0])
([[25.0, -45.0]], 3.0)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


class CleanLandmarks(dict[str, np.ndarray]):
    """Landmarks already checked: every value a finite (3,) float64 array (looked up
    without re-checking; the measurements run on every drag)."""


def clean_landmarks(landmarks: Mapping[str, np.ndarray]) -> CleanLandmarks:
    """The landmarks as (3,) float64 arrays, those missing or not finite left out."""
    out = CleanLandmarks()
    for k in landmarks:
        p = landmark(landmarks, k)
        if p is not None:
            out[k] = p
    return out


def landmark(landmarks: Mapping[str, np.ndarray], name: str) -> np.ndarray | None:
    """(3,) float64 position of landmark ``name``, or None when missing or not finite."""
    p = landmarks.get(name)
    if p is None or type(landmarks) is CleanLandmarks:
        return p
    if type(p) is np.ndarray and p.dtype == np.float64 and p.shape == (3,):
        q = p
    else:
        try:
            q = np.asarray(p, dtype=np.float64).reshape(3)
        except (TypeError, ValueError):
            return None
    return q if np.isfinite(q).all() else None


def landmarks_of(landmarks: Mapping[str, np.ndarray], *names: str) -> list[np.ndarray] | None:
    """(3,) positions of ``names``, or None when any is missing or not finite."""
    out = [landmark(landmarks, n) for n in names]
    return None if any(p is None for p in out) else [p for p in out if p is not None]


def mean_landmark(landmarks: Mapping[str, np.ndarray], *names: str) -> np.ndarray | None:
    """(3,) mean of those of ``names`` that exist (e.g. ac_l, ac_r), None when none does."""
    ps = [p for p in (landmark(landmarks, n) for n in names) if p is not None]
    return np.mean(ps, axis=0) if ps else None


def angle_deg(a: np.ndarray, vertex: np.ndarray, b: np.ndarray) -> float:
    """Angle a-vertex-b in degrees (0..180) between the rays vertex->a and vertex->b
    (points of any dimension, 2D or 3D; 0 for a zero-length ray)."""
    u = np.asarray(a, float) - vertex
    v = np.asarray(b, float) - vertex
    c = float(np.dot(u, v) / max(float(np.linalg.norm(u) * np.linalg.norm(v)), 1e-12))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def direction_angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    """Angle in degrees (0..180) between direction vectors ``u`` and ``v``."""
    return angle_deg(np.asarray(u, float), np.zeros_like(np.asarray(u, float)), v)


@dataclass(frozen=True)
class MidlinePlane:
    """The facial midline plane (module docstring), SPEC frame.

    Attributes:
        origin: (3,) a point of the plane (g), mm.
        normal: (3,) unit lateral direction ``e`` (≈ +x, the subject's left).
        up: (3,) unit facial vertical in the plane (≈ +y).
        anterior: (3,) unit anterior direction in the plane (≈ +z).
    """

    origin: np.ndarray
    normal: np.ndarray
    up: np.ndarray
    anterior: np.ndarray

    def to_2d(self, P: np.ndarray) -> np.ndarray:
        """(K, 2) lateral projection ``(anterior, up)`` mm of points ``P`` (K, 3) or (3,)."""
        d = np.asarray(P, np.float64).reshape(-1, 3) - self.origin
        return np.stack([d @ self.anterior, d @ self.up], axis=1)

    def lateral(self, P: np.ndarray) -> np.ndarray:
        """(K,) signed distance mm of points ``P`` (K, 3) from the plane (+ subject's left)."""
        return (np.asarray(P, np.float64).reshape(-1, 3) - self.origin) @ self.normal


def midline_plane(landmarks: Mapping[str, np.ndarray]) -> MidlinePlane:
    """The facial midline plane of ``landmarks`` (module docstring); never raises.

    Args:
        landmarks: id -> (3,) mm; uses g, mf_l, mf_r when present.
    """
    g = landmark(landmarks, "g")
    origin = np.zeros(3) if g is None else g
    e = np.array([1.0, 0.0, 0.0])
    mf = landmarks_of(landmarks, "mf_l", "mf_r")
    if mf is not None:
        d = mf[0] - mf[1]
        nd = float(np.linalg.norm(d))
        if nd > 1e-6 and abs(d[1]) < 0.9 * nd:    # a usable, roughly lateral direction
            e = d / nd
    y = np.array([0.0, 1.0, 0.0])
    up = y - (y @ e) * e
    up /= np.linalg.norm(up)
    return MidlinePlane(origin, e, up, np.cross(e, up))
