"""Plausibility warnings of stage 1 (paper §3.2): what a good fit of eq. 1 cannot see.

A bundle adjustment can fit the clicks well and still be wrong, or rest on a finding the
surgeon should confirm. After the solve, in the SPEC §4 frame (mm, origin ``g``, +x the
subject's left, +y up, +z anterior):

- :func:`symmetry_warnings`: a midline landmark off the midsagittal plane, or a left/right
  pair that is not a mirror image, by more than ``max_asymmetry_mm`` beyond its
  uncertainty (a sideways front-photo click moves a midline landmark only in x, which no
  other photo sees; a deviated nose looks the same, so it is worded as a finding);
- :func:`resolution_warnings`: a photo with fewer than ``min_px_per_mm`` pixels per mm at
  the nose (focal length / depth of its landmarks), below which the landmark error grows
  (``benchmarks/bench_clicks.py``);
- :func:`view_warnings`: a camera whose viewing direction fits another view's slot better
  than its own (photos swapped), or that is rolled by about 90 or 180 degrees (an EXIF
  orientation tag on pixels that were already upright, or none where one was needed).

Example
-------
>>> import numpy as np
>>> from naseview.camera import look_at
>>> cam = look_at(eye=[0, 0, 400.0], target=[0, 0, 0], up=[0, 1, 0], focal_px=1000.0,
...               width=1024, height=1024)
>>> round(px_per_mm(cam, np.zeros((1, 3))), 2)
2.5
>>> roll_deg(cam), viewing_angle_deg(cam, "front", 50.0)
(0.0, 0.0)
"""

from __future__ import annotations

import math

import numpy as np
import scipy.stats

from naseview.camera import Camera
from naseview.landmarks import MIDLINE_IDS
from naseview.stage1_landmarks.frame import PAIR_BASES
from naseview.stage1_landmarks.params import SfmParams
from naseview.stage1_landmarks.symmetry import midsagittal_plane, mirror_points
from naseview.stage1_landmarks.uncertainty import GAUGE_SD_MM

_MIN_PLANE_POINTS = 4
"""Midline landmarks and pair midpoints needed (besides the one tested) to fit the plane."""

_MIN_UP_IN_IMAGE = 0.3
"""Below this length of the projected +y axis in a photo (a camera looking almost straight
up or down), its roll is not judged."""


def nominal_direction(view: str, bottom_elevation_deg: float) -> np.ndarray:
    """(3,) unit direction a ``view`` camera looks along in the SPEC frame: front along
    -z (from +z), left along -x (from +x), right along +x, bottom up and back (from below
    and in front, ``bottom_elevation_deg`` below the front camera); the obliques halfway
    between the front and the left / right profile."""
    e = math.radians(bottom_elevation_deg)
    h = math.sqrt(0.5)
    return {"front": np.array([0.0, 0.0, -1.0]), "left": np.array([-1.0, 0.0, 0.0]),
            "right": np.array([1.0, 0.0, 0.0]),
            "bottom": np.array([0.0, math.sin(e), -math.cos(e)]),
            "oblique_left": np.array([-h, 0.0, -h]),
            "oblique_right": np.array([h, 0.0, -h])}[view]


def viewing_angle_deg(cam: Camera, view: str, bottom_elevation_deg: float) -> float:
    """Angle (deg) between the optical axis of ``cam`` and the direction of ``view``."""
    c = float(np.clip(cam.R[2] @ nominal_direction(view, bottom_elevation_deg), -1.0, 1.0))
    return round(math.degrees(math.acos(c)), 9)


def roll_deg(cam: Camera) -> float | None:
    """Clockwise angle (deg, (-180, 180]) from the image's up to the subject's up (+y)
    as the photo shows it; None when +y points almost along the optical axis."""
    a, b = cam.R[0, 1], cam.R[1, 1]  # image x (right) and y (down) of the world +y axis
    if math.hypot(a, b) < _MIN_UP_IN_IMAGE:
        return None
    return round(math.degrees(math.atan2(a, -b)), 9) + 0.0


def px_per_mm(cam: Camera, points: np.ndarray) -> float:
    """Pixels per millimetre at ``points`` (N, 3) in the photo of ``cam``: focal length
    (px) / median depth (mm)."""
    return cam.focal_px / float(np.median(cam.depth(points)))


def resolution_warnings(cameras: dict[str, Camera], landmarks: dict[str, np.ndarray],
                        clicked: dict[str, list[str]], params: SfmParams
                        ) -> tuple[list[str], frozenset[str], frozenset[str]]:
    """One warning naming the photos below ``params.min_px_per_mm`` at their clicked
    landmarks; those photos; and those below half of it, whose fitted cameras are too
    unreliable to be judged (at 1 px per mm, 120-px photos, the bundle adjustment can land
    on a near-orthographic rig with wrong directions).

    Args:
        cameras: view -> camera; landmarks: id -> (3,) mm, same frame.
        clicked: view -> ids clicked in that photo.
    """
    low: dict[str, float] = {}
    for v, cam in cameras.items():
        ids = [i for i in clicked[v] if i in landmarks]
        if ids:
            r = px_per_mm(cam, np.array([landmarks[i] for i in ids]))
            if r < params.min_px_per_mm:
                low[v] = r
    if not low:
        return [], frozenset(), frozenset()
    which = ", ".join(f"{v!r} {r:.1f}" for v, r in low.items())
    return [f"low photo resolution: {which} px per mm at the nose; stage 1 is accurate from "
            f"{params.min_px_per_mm:g} px per mm (below, the landmark error grows and the "
            "cameras fitted to those photos are unreliable): use the full-size photos or "
            "take them closer"], frozenset(low), frozenset(
            v for v, r in low.items() if r < 0.5 * params.min_px_per_mm)


def slot_message(view: str, looks_like: str, why: str) -> str:
    """The one line for a photo that does not look like its slot (here after stage 1,
    and at upload by :mod:`naseview.intake.photo_check`).

    >>> slot_message("bottom", "a profile", "not symmetric")[:60]
    "the 'bottom' photo looks like a profile (not symmetric): che"
    """
    return (f"the {view!r} photo looks like {looks_like} ({why}): check that each photo "
            "is in its slot")


def view_warnings(cameras: dict[str, Camera], params: SfmParams,
                  unreliable: frozenset[str] = frozenset()) -> list[str]:
    """Photos that look like another view's photo (swapped), and photos rolled by about
    90 or 180 degrees (EXIF orientation); photos whose camera is ``unreliable`` (low
    resolution: the resolution warning names them) are not judged."""
    elev = params.bottom_elevation_deg
    looks_like: dict[str, str] = {}
    for v, cam in cameras.items():
        if v in unreliable:
            continue
        own = viewing_angle_deg(cam, v, elev)
        best = min(cameras, key=lambda u: viewing_angle_deg(cam, u, elev))
        if own > params.max_view_angle_deg and best != v:
            looks_like[v] = best
    out = []
    for v, u in looks_like.items():
        if looks_like.get(u) == v:
            if v < u:
                continue  # one message per swapped pair
            out.append(f"the {v!r} photo looks like a {u!r} photo and the {u!r} photo like "
                       f"a {v!r} photo: swap them (photos and clicks)")
        else:
            angle = viewing_angle_deg(cameras[v], v, elev)
            out.append(slot_message(v, f"a {u!r} photo", f"{angle:.0f} deg from a {v!r} view"))
    for v, cam in cameras.items():
        roll = None if v in unreliable else roll_deg(cam)
        if roll is None or abs(roll) <= params.max_roll_deg:
            continue
        turn = round(roll / 90.0) * 90
        how = {90: "90 deg clockwise", -90: "90 deg counter-clockwise"}.get(
            turn, "180 deg")
        out.append(f"photo {v!r} appears rotated by {how}: check its EXIF orientation "
                   "(the pixels may already be upright)")
    return out


def symmetry_warnings(landmarks: dict[str, np.ndarray], covariance: dict[str, np.ndarray],
                      clicked_in: dict[str, list[str]], params: SfmParams) -> list[str]:
    """Midline landmarks off the midsagittal plane and pairs that are not mirror images,
    by significantly more than ``params.max_asymmetry_mm``.

    The plane is fitted without the landmark (pair) tested, so it cannot pull the plane
    after itself. The part of the offset beyond ``max_asymmetry_mm`` is tested against
    its uncertainty: for a midline landmark, its sd across the plane (the distance must
    exceed ``max_asymmetry_mm`` + 1 sd: a sideways front-photo click of 15 px moves n by
    ~1.5 mm, within a 99 % interval); for a pair, chi-square with 3 degrees of freedom
    (left minus mirrored right, both uncertain) at ``params.outlier_alpha`` (a 1-sd rule
    in 3D fires on a third of clean pairs at 4-6 px per mm). The
    origin ``g`` has no covariance of its own (the gauge fixes it): it is given the median
    of the others' sd across the plane.

    Args:
        landmarks: id -> (3,) mm (SPEC frame); covariance: id -> (3, 3) mm^2.
        clicked_in: id -> the photos that show it.
    """
    a = params.max_asymmetry_mm
    out = []
    tests = []
    for lid in MIDLINE_IDS:
        rest = {k: p for k, p in landmarks.items() if k != lid}
        if lid in landmarks and _enough_for_plane(rest):
            c, n = midsagittal_plane(rest)
            tests.append((lid, float((landmarks[lid] - c) @ n),
                          math.sqrt(max(float(n @ covariance[lid] @ n), 0.0))))
    sds = [sd for _, _, sd in tests if sd >= GAUGE_SD_MM]
    floor = float(np.median(sds)) if sds else 0.0
    for lid, d, sd in tests:
        sd = sd if sd >= GAUGE_SD_MM else floor
        if abs(d) - a > sd:
            side = "left" if d > 0 else "right"
            photos = [v for v in clicked_in[lid] if v in ("front", "bottom")]
            where = (f"check its click in photo {' and '.join(repr(v) for v in photos)}"
                     if photos else "check its clicks")
            out.append(f"landmark {lid!r} lies {abs(d):.1f} mm (+-{sd:.1f}) to the patient's "
                       f"{side} of the midline: {where}, or note a deviated nose")
    q3 = float(scipy.stats.chi2.isf(params.outlier_alpha, 3))
    for base in PAIR_BASES:
        left, right = base + "_l", base + "_r"
        rest = {k: p for k, p in landmarks.items() if k not in (left, right)}
        if left not in landmarks or right not in landmarks or not _enough_for_plane(rest):
            continue
        c, n = midsagittal_plane(rest)
        e = landmarks[left] - mirror_points(landmarks[right], c, n)[0]
        dist = float(np.linalg.norm(e))
        if dist <= a:
            continue
        M = np.eye(3) - 2.0 * np.outer(n, n)
        C = covariance[left] + M @ covariance[right] @ M.T
        excess = e * (1.0 - a / dist)
        if float(excess @ np.linalg.pinv(C) @ excess) > q3:
            u = e / dist
            sd = math.sqrt(max(float(u @ C @ u), 0.0))
            out.append(f"landmarks {left!r} and {right!r} are not mirror images: {left!r} "
                       f"lies {dist:.1f} mm (+-{sd:.1f}) from the mirror image of {right!r} "
                       f"({_axis_words(e)}): check their clicks, or note an asymmetric nose")
    return out


def _enough_for_plane(points: dict[str, np.ndarray]) -> bool:
    """Enough midline landmarks and pairs to fit the midsagittal plane (and orient it)."""
    mids = sum(k in points for k in MIDLINE_IDS)
    pairs = sum(b + "_l" in points and b + "_r" in points for b in PAIR_BASES)
    return pairs >= 1 and mids + pairs >= _MIN_PLANE_POINTS


def _axis_words(e: np.ndarray) -> str:
    """The largest component of a left-minus-mirrored-right offset (3,) in words."""
    k = int(np.argmax(np.abs(e)))
    words = (("further out", "further in"), ("higher", "lower"),
             ("further forward", "further back"))[k]
    return f"mostly {words[0] if e[k] > 0 else words[1]}"
