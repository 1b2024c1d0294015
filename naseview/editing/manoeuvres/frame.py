"""The nasal frame and the smooth weights every manoeuvre field is built from.

Frame (SPEC frame, mm), the one of :mod:`naseview.measurements` (its facial midline
plane and lateral projection):

- ``e = unit(mf_l - mf_r)`` (else +x): the lateral direction (the subject's left); the
  *midline plane* passes through g (else the origin) with normal ``e``;
- ``u``: the direction of n -> prn in that plane (``prn - n`` with its ``e`` part
  removed), ``L`` that length (the nasal length in the lateral projection);
- ``a``: the in-plane normal of ``u`` pointing anteriorly (+z side): the anterior normal
  of the n-prn line, as the dorsal hump depth uses;
- ``W``: the nose's width, |al_l - al_r| (else |ac_l - ac_r|, else 0.8 L).

Every radius of every field is a multiple of ``L`` or ``W`` (or of a distance between two
landmarks), so a field scales with the nose it is applied to.

Weights (all C1, values in [0, 1]):

- ``smoothstep(t) = 3 t^2 - 2 t^3`` on [0, 1], 0 below, 1 above; its slope is at most
  1.5, so a fade of an amount ``A`` over a band ``D`` mm has gradient <= 1.5 A / D;
- ``fade(d, r0, r1) = 1 - smoothstep((d - r0) / (r1 - r0))``: 1 for d <= r0, 0 for
  d >= r1;
- :func:`bump`: an ellipsoidal bump around a centre ``c`` in a local orthonormal frame
  ``(b_0, b_1, b_2)``, with a radius per half-axis: with ``q_k = (p - c) . b_k`` and
  ``R_k = R_k+`` for ``q_k >= 0`` else ``R_k-``, ``rho^2 = sum_k (q_k / R_k)^2`` and the
  weight ``fade(rho, rho0, 1)`` (1 on the plateau ``rho <= rho0``, 0 for ``rho >= 1``).
  Across ``q_k = 0`` the two radii meet with zero slope of ``q_k^2``, so the bump is C1.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


def smoothstep(t: np.ndarray | float) -> np.ndarray:
    """``3 t^2 - 2 t^3`` of ``t`` clipped to [0, 1] (C1; 0 at 0, 1 at 1, slope <= 1.5)."""
    t = np.clip(np.asarray(t, np.float64), 0.0, 1.0)
    return np.asarray(t * t * (3.0 - 2.0 * t))


def fade(d: np.ndarray | float, r0: float, r1: float) -> np.ndarray:
    """1 for ``d <= r0``, 0 for ``d >= r1``, ``1 - smoothstep`` between (C1); r1 > r0."""
    return np.asarray(1.0 - smoothstep((np.asarray(d, np.float64) - r0) / (r1 - r0)))


def bump(P: np.ndarray, centre: np.ndarray, axes: np.ndarray,
         radii: tuple[tuple[float, float], tuple[float, float], tuple[float, float]],
         plateau: float = 0.0) -> np.ndarray:
    """(K,) ellipsoidal C1 bump weight of points ``P`` (K, 3), mm (module docstring).

    Args:
        P: (K, 3) points. centre: (3,). axes: (3, 3) orthonormal rows ``b_0, b_1, b_2``.
        radii: per axis ``(R_minus, R_plus)`` mm, the radius on the negative / positive
            side of the centre along that axis (all > 0).
        plateau: ``rho0`` in [0, 1): the weight is 1 for ``rho <= rho0``.
    """
    Q = (np.asarray(P, np.float64) - centre) @ np.asarray(axes, np.float64).T
    rho2 = np.zeros(len(Q))
    for k, (rm, rp) in enumerate(radii):
        q = Q[:, k]
        rho2 += (q / np.where(q >= 0.0, rp, rm)) ** 2
    return fade(np.sqrt(rho2), plateau, 1.0)


def unit(v: np.ndarray) -> np.ndarray:
    """``v / |v|`` of a (3,) vector (zero stays zero)."""
    v = np.asarray(v, np.float64)
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else v * 0.0


@dataclass(frozen=True)
class NasalFrame:
    """The nose's own frame and size (module docstring), SPEC frame, mm.

    Attributes:
        landmarks: id -> (3,) rest positions (the 21 or a subset).
        origin: (3,) a point of the midline plane (g, else the SPEC origin).
        n, prn: (3,) nasion and pronasale.
        u, a, e: (3,) unit dorsal-line, anterior and lateral directions.
        length: L = |prn - n| (mm). width: W, the nose's width (mm).
    """

    landmarks: Mapping[str, np.ndarray]
    origin: np.ndarray
    n: np.ndarray
    prn: np.ndarray
    u: np.ndarray
    a: np.ndarray
    e: np.ndarray
    length: float
    width: float

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) rows ``u, a, e``."""
        return np.stack([self.u, self.a, self.e])

    def has(self, *ids: str) -> bool:
        """True when every landmark of ``ids`` is present."""
        return all(i in self.landmarks for i in ids)

    def lateral(self, P: np.ndarray) -> np.ndarray:
        """(K,) signed distance (mm) of points (K, 3) from the midline plane (+ = left)."""
        return np.asarray((np.asarray(P, np.float64) - self.origin) @ self.e)


def nasal_frame(landmarks: Mapping[str, np.ndarray]) -> NasalFrame | None:
    """The :class:`NasalFrame` of the landmarks, or None without n and prn (or when n->prn
    is perpendicular to the midline plane)."""
    lms = {k: np.asarray(v, np.float64).reshape(3) for k, v in landmarks.items()
           if np.all(np.isfinite(np.asarray(v, np.float64)))}
    if "n" not in lms or "prn" not in lms:
        return None
    e = np.array([1.0, 0.0, 0.0])
    if "mf_l" in lms and "mf_r" in lms and np.linalg.norm(lms["mf_l"] - lms["mf_r"]) > 1e-6:
        e = unit(lms["mf_l"] - lms["mf_r"])
    origin = lms.get("g", np.zeros(3))
    n, prn = lms["n"], lms["prn"]
    d = (prn - n) - ((prn - n) @ e) * e
    length = float(np.linalg.norm(d))
    if length < 1e-6:
        return None
    u = d / length
    a = unit(np.cross(u, e))
    if a[2] < 0.0:
        a = -a
    width = 0.8 * length
    for p, q in (("al_l", "al_r"), ("ac_l", "ac_r")):
        if p in lms and q in lms and np.linalg.norm(lms[p] - lms[q]) > 1e-6:
            width = float(np.linalg.norm(lms[p] - lms[q]))
            break
    return NasalFrame(lms, origin, n, prn, u, a, e, length, width)
