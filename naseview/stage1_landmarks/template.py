"""The generic nose template that starts stage 1 (paper §3.2) and bounds one-photo depths.

A generic adult nose in the SPEC frame (mm, origin ``g``), written by hand from textbook
soft-tissue proportions (alar width 34 mm, nasal length n-prn ~ 44 mm, tip projection
~ 20 mm). It only starts the camera estimation (:mod:`.initial`) and gives a weak depth
prior to landmarks clicked in one photo (:mod:`.single_view`); it is never part of a
result.
"""

from __future__ import annotations

import numpy as np

from naseview.geometry.alignment import umeyama


def _with_right_side(half: dict[str, tuple[float, float, float]]
                     ) -> dict[str, tuple[float, float, float]]:
    """The midline and ``_l`` landmarks plus the ``_r`` ones mirrored across x = 0."""
    out = dict(half)
    for lid, (x, y, z) in half.items():
        if lid.endswith("_l"):
            out[lid[:-2] + "_r"] = (-x, y, z)
    return out


TEMPLATE_MM: dict[str, tuple[float, float, float]] = _with_right_side({
    "g": (0.0, 0.0, 0.0), "n": (0.0, -12.0, -6.0), "k": (0.0, -24.0, -1.0),
    "r": (0.0, -31.0, 3.0), "prn": (0.0, -47.0, 14.0), "c": (0.0, -53.0, 9.0),
    "sn": (0.0, -57.0, -3.0),
    "mf_l": (9.0, -10.0, -11.0), "int_l": (11.0, -40.0, 1.0), "al_l": (17.0, -48.0, -6.0),
    "alp_l": (7.0, -52.0, 7.0), "alpp_l": (5.0, -55.0, 3.0), "ac_l": (15.0, -52.0, -10.0),
    "md_l": (6.0, -51.0, 9.0),
})
"""id -> (x, y, z) mm of the 21 landmarks of the generic nose (SPEC frame)."""


PLAUSIBLE_FACTOR = 3.0
PLAUSIBLE_SLACK_MM = 5.0
PLAUSIBLE_MIN_MM = 0.5
"""A distance between two landmarks outside ``[typical / 3 - 5 mm, typical * 3 + 5 mm]``
(``typical``: the template's), or under 0.5 mm, is not a nose in millimetres: a wrong
unit (cm, m) or the wrong points. Long distances vary far less than 3x between noses
(alar width 25-50 mm against the template's 34); short ones (k-r, md_l-md_r, ac-al, a few
mm) vary by more than their own length, hence the slack."""


def typical_distance_mm(a: str, b: str) -> float:
    """The distance (mm) between landmarks ``a`` and ``b`` on the template."""
    return float(np.linalg.norm(np.subtract(TEMPLATE_MM[a], TEMPLATE_MM[b])))


def plausible_distance(a: str, b: str, d_mm: float) -> bool:
    """Whether ``d_mm`` can be the distance between landmarks ``a`` and ``b`` of a nose in
    millimetres (:data:`PLAUSIBLE_FACTOR`; True for ids the template lacks).

    >>> plausible_distance("al_l", "al_r", 34.5), plausible_distance("al_l", "al_r", 3.45)
    (True, False)
    >>> plausible_distance("k", "r", 2.2), plausible_distance("k", "r", 0.0022)
    (True, False)
    """
    if a not in TEMPLATE_MM or b not in TEMPLATE_MM:
        return d_mm >= PLAUSIBLE_MIN_MM
    typical = typical_distance_mm(a, b)
    low = max(PLAUSIBLE_MIN_MM, typical / PLAUSIBLE_FACTOR - PLAUSIBLE_SLACK_MM)
    return low <= d_mm <= typical * PLAUSIBLE_FACTOR + PLAUSIBLE_SLACK_MM


def aligned_template(landmarks: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], float]:
    """The generic nose template moved onto ``landmarks`` by a least-squares similarity.

    Args:
        landmarks: id -> (3,) positions in any frame (3+ template landmarks, not collinear).
    Returns:
        id -> (3,) template position in the frame of ``landmarks``, and the scale (frame
        units per template mm).
    """
    ids = [i for i in landmarks if i in TEMPLATE_MM]
    T = np.array([TEMPLATE_MM[i] for i in ids])
    P = np.array([landmarks[i] for i in ids])
    s, R, t = umeyama(T, P)
    return {k: s * R @ np.array(v) + t for k, v in TEMPLATE_MM.items()}, s
