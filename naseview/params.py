"""Checks shared by every params dataclass (``SfmParams``, ``CurveParams``, ``RefineParams``).

One convention for the package: a params object is a frozen dataclass that checks every
field in ``__post_init__`` with these helpers, so a bad value fails where it is made, in
one line naming the class, the field, the value and the allowed range (scikit-image's
``check_nD`` style); an unknown field name fails as for any dataclass.

Example
-------
>>> r = Range(0.0, 1.0, low_open=True)
>>> str(r), 0.5 in r, 0.0 in r
('(0, 1]', True, False)
>>> str(Range(1.0))
'[1, inf)'
>>> check_number("RefineParams", "smooth_step", 2.0, Range(0.0, 1.0, low_open=True),
...              "the smoothing step (unitless)")
Traceback (most recent call last):
...
naseview.errors.NaseviewError: RefineParams.smooth_step: 2.0 is outside (0, 1]; the smoothing step (unitless)
"""  # noqa: E501

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np

from naseview.errors import NaseviewError

ErrorType = Callable[[str], Exception]


@dataclass(frozen=True)
class Range:
    """Allowed interval of a numeric field: ``[low, high]``, each end open on request.

    ``high_open=None`` (the default) leaves an infinite ``high`` open and a finite one
    closed; ``high_open=False`` with ``high=inf`` admits ``inf`` itself (a field where
    ``inf`` means "no limit"). NaN is in no range.
    """

    low: float
    high: float = math.inf
    low_open: bool = False
    high_open: bool | None = None
    integer: bool = False

    @property
    def _high_open(self) -> bool:
        return math.isinf(self.high) if self.high_open is None else self.high_open

    def __contains__(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self._high_open else value <= self.high
        return bool(above and below)

    def __str__(self) -> str:
        def num(x: float) -> str:
            return "inf" if math.isinf(x) else f"{x:g}"

        return (f"{'(' if self.low_open else '['}{num(self.low)}, "
                f"{num(self.high)}{')' if self._high_open else ']'}")


def check_number(owner: str, name: str, value: object, allowed: Range, meaning: str,
                 error: ErrorType = NaseviewError) -> None:
    """Raise ``error`` unless ``value`` is a number (an integer if ``allowed.integer``;
    never a bool) inside ``allowed``; the message names ``owner.name`` and the range."""
    kind = Integral if allowed.integer else Real
    if isinstance(value, bool) or not isinstance(value, kind):
        what = "an integer" if allowed.integer else "a number"
        raise error(f"{owner}.{name}: {value!r} is not {what} in {allowed}; {meaning}")
    if float(value) not in allowed:
        raise error(f"{owner}.{name}: {value!r} is outside {allowed}; {meaning}")


def check_choice(owner: str, name: str, value: object, choices: tuple[str, ...],
                 error: ErrorType = NaseviewError) -> None:
    """Raise ``error`` unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise error(f"{owner}.{name}: {value!r} is not one of "
                    f"{', '.join(repr(c) for c in choices)}")


def check_flag(owner: str, name: str, value: object,
               error: ErrorType = NaseviewError) -> None:
    """Raise ``error`` unless ``value`` is ``True`` or ``False``."""
    if not isinstance(value, bool):
        raise error(f"{owner}.{name}: {value!r} is not True or False")


def check_names(owner: str, name: str, value: object, allowed: tuple[str, ...],
                error: ErrorType = NaseviewError) -> None:
    """Raise ``error`` unless ``value`` is a tuple of names, each one of ``allowed``."""
    if not isinstance(value, tuple) or any(v not in allowed for v in value):
        raise error(f"{owner}.{name}: {value!r} is not a tuple of names from "
                    f"{', '.join(allowed)}")


# Physical ranges of the numbers naseview reads from files (case.json, reconstruction.json,
# session and simulation files). One place, used by every reader: a number outside its
# range is a damaged or hostile file, refused at the boundary naming the key, never passed
# on to overflow in numpy (1e308 mm) or to divide by a focal length of 1e-300 px.

POSITION_MM = Range(-1000.0, 1000.0)
"""Coordinates of a point of the face (landmark, curve, mesh vertex), mm in the face's
frame (SPEC §2): within a metre of the origin."""

CAMERA_POSITION_MM = Range(-100_000.0, 100_000.0)
"""A camera's translation ``t`` (mm): within 100 m of the face."""

ROTATION_ENTRY = Range(-1.001, 1.001)
"""An entry of a rotation matrix (unitless; |R_ij| <= 1)."""

FOCAL_PER_SIDE = Range(0.05, 100.0)
"""A focal length in pixels divided by the photo's longest side: from a 170-degree fisheye
(0.05) to a 2500 mm telephoto (100); see :func:`focal_range`."""

PHOTO_SIDE_PX = Range(1, 100_000, integer=True)
"""A photo's width or height (px)."""

PIXEL_ERROR_PX = Range(0.0, 1e6)
"""A reprojection error (px)."""

MEASUREMENT_VALUE = Range(-1e6, 1e6)
"""A stored measurement (mm, degrees, mm^2 or a ratio): no facial measure is near 1e6."""


def focal_range(width: float, height: float) -> Range:
    """The focal lengths (px) accepted for a ``width`` x ``height`` photo
    (:data:`FOCAL_PER_SIDE` times its longest side).

    >>> str(focal_range(1000, 800))
    '[50, 100000]'
    """
    side = max(float(width), float(height), 1.0)
    return Range(FOCAL_PER_SIDE.low * side, FOCAL_PER_SIDE.high * side)


def first_outside(values: object, allowed: Range) -> float | None:
    """The first number of ``values`` (an array of floats) outside ``allowed`` (NaN and
    inf included), or None when all are inside.

    >>> first_outside([1.0, 2e300, -5.0], Range(-10.0, 10.0))
    2e+300
    >>> first_outside([], Range(0.0)) is None
    True
    """
    arr = np.asarray(values, dtype=np.float64).ravel()
    with np.errstate(invalid="ignore"):
        low = arr > allowed.low if allowed.low_open else arr >= allowed.low
        high = arr < allowed.high if allowed._high_open else arr <= allowed.high
    bad = np.flatnonzero(~(low & high))
    return float(arr[bad[0]]) if bad.size else None
