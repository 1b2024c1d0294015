"""How uncertain a measurement is, from its landmarks' stated uncertainties.

Stage 1 states an uncertainty for every landmark (``reconstruction.json``
``landmark_uncertainty_mm``: the root of the covariance trace for a triangulated
landmark); a landmark clicked in one photo only is placed by stage 3 where its line of
sight meets the fitted face, with the uncertainty of that depth along the ray (the
pipeline also records the ray's direction, ``landmark_sight_direction``). The medial
orbital rims mf are often hidden in the profile photos, so they are clicked in the front
photo only, and their depth along the front ray is the face model's (measured 5-6 mm off
on a real face where the fit states 3.3-4.2 mm).

Propagation (first order, landmarks independent). A measurement that is a linear
combination ``m = (sum_i c_i p_i) . a`` of landmark positions ``p_i`` along a unit axis
``a`` of the facial frame (:mod:`.frame`) has

    sd(m)^2 = sum_i c_i^2 s_i^2,

with ``s_i`` the sd of landmark ``i`` along ``a``. Assumed: a landmark's stated value
``u_i`` bounds its sd along any axis (true for the root of the covariance trace, and for
an sd along a ray, where ``s_i = u_i |d_i . a|`` for the ray direction ``d_i``); where the
ray is recorded it is used, else ``s_i = u_i`` (the bound). The frame's axes are taken as
exact (their own uncertainty is second order here). So

- ``radix_height = (n - (mf_l + mf_r) / 2) . anterior``:
  ``sd^2 = s_n^2 + (s_mf_l^2 + s_mf_r^2) / 4`` along the anterior axis;
- ``radix_level``: the same along the facial vertical (a front ray barely moves it).

A measurement is *estimated* when its sd exceeds :data:`ESTIMATED_SD_MM`: the app and
the report show it as an estimate with its uncertainty, never as a plain finding.

Example
-------
>>> import numpy as np
>>> lm = {"n": np.array([0.0, -15, -3]), "mf_l": np.array([9.0, -15, -12]),
...       "mf_r": np.array([-9.0, -15, -12])}
>>> sd = measurement_uncertainty(lm, {"n": 0.3, "mf_l": 3.6, "mf_r": 3.2})
>>> {k: round(v, 2) for k, v in sd.items()}
{'radix_height': 2.43, 'radix_level': 2.43}
>>> d = {"mf_l": [0.0, 0.0, -1.0], "mf_r": [0.0, 0.0, -1.0]}     # front rays
>>> {k: round(v, 2) for k, v in measurement_uncertainty(lm, {"n": 0.3, "mf_l": 3.6,
...                                                         "mf_r": 3.2}, d).items()}
{'radix_height': 2.43, 'radix_level': 0.3}
>>> est = estimated_measurements(lm, {"landmark_uncertainty_mm": {"n": 0.3, "mf_l": 3.6,
...     "mf_r": 3.2}, "landmarks_one_photo": {"mf_l": "line of sight", "mf_r": "line of sight"}})
>>> est["radix_height"].reason, est["radix_height"].points
('mf seen in one photo', ('mf',))
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from naseview.measurements.frame import clean_landmarks, midline_plane

ESTIMATED_SD_MM = 1.0
"""A measurement whose sd (mm) from its landmarks' uncertainty exceeds this is shown as
an estimate with its uncertainty (issue 23: 'uncertain by more than 1 mm')."""

UNCERTAINTY_KEY = "landmark_uncertainty_mm"
"""``reconstruction.json`` key: landmark id -> stated uncertainty (mm)."""

DIRECTION_KEY = "landmark_sight_direction"
"""``reconstruction.json`` key: landmark id -> (3,) unit direction of the line of sight a
one-photo landmark was placed on (SPEC frame)."""

ONE_PHOTO_KEY = "landmarks_one_photo"
"""``reconstruction.json`` key: landmark id -> how a one-photo landmark was placed."""

LINEAR_MEASUREMENTS: dict[str, tuple[dict[str, float], str]] = {
    "radix_height": ({"n": 1.0, "mf_l": -0.5, "mf_r": -0.5}, "anterior"),
    "radix_level": ({"n": 1.0, "mf_l": -0.5, "mf_r": -0.5}, "up"),
}
"""Measurements that are ``(sum_i c_i p_i) . axis``: name -> (landmark -> c_i, axis of
the facial frame, ``"anterior"`` or ``"up"``)."""


def measurement_uncertainty(landmarks: Mapping[str, Any],
                            uncertainty_mm: Mapping[str, float],
                            directions: Mapping[str, Any] | None = None) -> dict[str, float]:
    """The sd (mm) of each measurement of :data:`LINEAR_MEASUREMENTS` from its
    landmarks' stated uncertainties (module docstring: what is assumed).

    Args:
        landmarks: id -> (3,) position, mm (SPEC frame); the facial frame is built from
            them (:func:`~naseview.measurements.frame.midline_plane`).
        uncertainty_mm: id -> stated uncertainty, mm (``landmark_uncertainty_mm``); a
            landmark without one counts as exact.
        directions: id -> (3,) direction of the line of sight the stated uncertainty is
            along (normalised here), or None: the uncertainty then bounds every axis.
    Returns:
        measurement name -> sd, mm. No entry when a landmark of the measurement is
        missing (or not finite), or when none of its landmarks states an uncertainty.
    """
    clean = clean_landmarks(landmarks)
    plane = midline_plane(clean)
    axes = {"anterior": plane.anterior, "up": plane.up}
    out: dict[str, float] = {}
    for name, (coef, axis) in LINEAR_MEASUREMENTS.items():
        if any(k not in clean for k in coef):
            continue
        var, stated = 0.0, False
        for k, c in coef.items():
            u = _finite(uncertainty_mm.get(k))
            if u is None:
                continue
            stated = True
            var += (c * u * _along(directions, k, axes[axis])) ** 2
        if stated:
            out[name] = math.sqrt(var)
    return out


def _finite(v: Any) -> float | None:
    """``abs(float(v))``, or None when missing or not a finite number."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return abs(f) if math.isfinite(f) else None


def _along(directions: Mapping[str, Any] | None, k: str, axis: np.ndarray) -> float:
    """|d_k . axis| for landmark k's recorded ray direction, 1 (the bound) without one."""
    d = None if directions is None else directions.get(k)
    if d is None:
        return 1.0
    try:
        v = np.asarray(d, np.float64).reshape(3)
    except (TypeError, ValueError):
        return 1.0
    n = float(np.linalg.norm(v))
    if not math.isfinite(n) or n < 1e-9:
        return 1.0
    return min(1.0, abs(float(v @ axis)) / n)


@dataclass(frozen=True)
class Estimate:
    """A measurement shown as an estimate.

    Attributes:
        sd_mm: its standard deviation, mm (:func:`measurement_uncertainty`).
        points: the landmarks behind it, without the side (``("mf",)``): those clicked in
            one photo only, else those whose stated uncertainty exceeds
            :data:`ESTIMATED_SD_MM`.
        one_photo: the ``points`` are one-photo landmarks.
    """

    sd_mm: float
    points: tuple[str, ...] = ()
    one_photo: bool = False

    @property
    def reason(self) -> str:
        """Why, for the surgeon: ``"mf seen in one photo"``, ``"mf poorly determined"``."""
        if not self.points:
            return "landmarks poorly determined"
        what = ", ".join(self.points)
        return f"{what} seen in one photo" if self.one_photo else f"{what} poorly determined"

    def text(self, value: float, unit: str = " mm") -> str:
        """``"10.2 ± 2.4 mm (estimated: mf seen in one photo)"``."""
        return f"{value:.1f} ± {self.sd_mm:.1f}{unit} (estimated: {self.reason})"


def _base(k: str) -> str:
    """``"mf_l"`` -> ``"mf"``."""
    return k[:-2] if k.endswith(("_l", "_r")) else k


def estimated_measurements(landmarks: Mapping[str, Any], extra: Mapping[str, Any] | None
                           ) -> dict[str, Estimate]:
    """The measurements of a reconstruction to show as estimates: those whose sd
    (:func:`measurement_uncertainty` on ``extra``'s :data:`UNCERTAINTY_KEY` and
    :data:`DIRECTION_KEY`) exceeds :data:`ESTIMATED_SD_MM`.

    Args:
        landmarks: id -> (3,) mm (``Reconstruction.landmarks``).
        extra: ``Reconstruction.extra`` (or None: nothing is estimated).
    Returns:
        name -> :class:`Estimate`.
    """
    extra = extra or {}
    unc = extra.get(UNCERTAINTY_KEY)
    if not isinstance(unc, Mapping):
        return {}
    dirs = extra.get(DIRECTION_KEY)
    one = extra.get(ONE_PHOTO_KEY)
    one_photo: Collection[str] = one if isinstance(one, (Mapping, list, tuple)) else ()
    sds = measurement_uncertainty(landmarks, unc, dirs if isinstance(dirs, Mapping) else None)
    out = {}
    for name, sd in sds.items():
        if sd <= ESTIMATED_SD_MM:
            continue
        ids = LINEAR_MEASUREMENTS[name][0]
        seen_once = [k for k in ids if k in one_photo and (_finite(unc.get(k)) or 0) > 0]
        poor = [k for k in ids if (_finite(unc.get(k)) or 0) > ESTIMATED_SD_MM]
        pts = seen_once or poor
        out[name] = Estimate(sd, tuple(dict.fromkeys(_base(k) for k in pts)),
                             bool(seen_once))
    return out
