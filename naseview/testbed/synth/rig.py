"""The random face and the four phone cameras of a synthetic case (SPEC §2-§4).

- :func:`sample_identity`: ``w ~ N(0, I)`` over all modes of the face model, moved so that
  landmark ``g`` is the origin (the model axes are the SPEC axes: +x subject's left, +y
  up, +z anterior).
- :func:`sample_rig`: four cameras, each aimed at the bounding-box centre of the
  landmarks marked in its view (jittered +-4 mm): ``front`` on +z, ``left`` on +x (the
  subject's left side, 90 degrees yaw), ``right`` on -x, ``bottom`` below the nose looking
  up at 45-60 degrees elevation. Each view gets yaw and pitch jitter of up to +-8 degrees
  (profile views: up to 8 degrees towards the face but at most 2 behind the true profile,
  where the brow would hide g), roll up to +-6 degrees and its own distance (the case's
  base distance, 300-450 mm, +-15 %). The optional oblique views (``oblique_left``,
  ``oblique_right``: 45 degrees from the front towards the subject's left / right, level
  with the nose) get the same jitter; they are drawn after the four from the same stream,
  so the four cameras of a case do not depend on whether its obliques are rendered, and
  an oblique that would put a landmark near a border steps back instead of zooming the
  others out. One focal length per case (one phone), chosen so
  that the alar width al_l-al_r spans 26-34 % of the frame width (the nose region about a
  third of the frame: surgeons frame the nose), reduced if a marked landmark would fall
  within 8 % of a border. That is ``f`` of about 1.8-4.6 times the image width: a phone
  photo zoomed or cropped to the face (roughly 50-120 mm full-frame equivalent; an
  uncropped 26 mm phone lens at 30-45 cm would show the nose at only ~8 % of the width).

Example
-------
>>> import numpy as np
>>> from naseview.facemodel import load_face_model
>>> model = load_face_model("generic")
>>> V, w = sample_identity(model, np.random.default_rng(0))
>>> cams, info = sample_rig(V, model, np.random.default_rng(1), size=256)
>>> sorted(cams), bool(np.allclose(V[model.landmark_vertices["g"]], 0.0))
(['bottom', 'front', 'left', 'right'], True)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from naseview.camera import Camera, look_at, rodrigues
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.landmarks import ALL_VIEWS, OBLIQUE_VIEWS, VIEW_LANDMARKS, VIEWS

DEFAULT_SIZE = 1024
"""Photo width = height (px)."""

SIZE_RANGE = (64, 4096)
"""Smallest and largest photo size (px) a synthetic case is made at: below 64 px no nose
is left to click; above 4096 px a case costs gigabytes and tells nothing 4096 does not."""


def check_synth_arguments(size: int, seed: int, noise_px: float, image_noise: float) -> None:
    """One-line errors for ``naseview synth`` arguments no case can be made with: the
    photo size outside :data:`SIZE_RANGE`, a negative seed, a negative or infinite noise."""
    lo, hi = SIZE_RANGE
    if not lo <= size <= hi:
        raise NaseviewError(f"--size {size}: photos are {lo} to {hi} px")
    if seed < 0:
        raise NaseviewError(f"--seed {seed}: the seed is an integer >= 0")
    if not (noise_px >= 0 and image_noise >= 0 and math.isfinite(noise_px + image_noise)):
        raise NaseviewError("--noise-px and --image-noise must be finite and >= 0")

def parse_views(text: str) -> tuple[str, ...]:
    """``--views front,left,right,bottom,oblique_left`` -> the views in
    :data:`~naseview.landmarks.ALL_VIEWS` order.

    Raises:
        NaseviewError: an unknown view, or one of the four required views missing.
    """
    names = [v.strip() for v in text.split(",") if v.strip()]
    unknown = [v for v in names if v not in ALL_VIEWS]
    if unknown:
        raise NaseviewError(f"--views: unknown view {unknown[0]!r}; use the four "
                            f"{', '.join(VIEWS)} and optionally {', '.join(OBLIQUE_VIEWS)}")
    missing = [v for v in VIEWS if v not in names]
    if missing:
        raise NaseviewError(f"--views: {', '.join(missing)} missing; every case has the four "
                            f"views {', '.join(VIEWS)} (the obliques are optional)")
    return tuple(v for v in ALL_VIEWS if v in names)


SIDE_YAW_BEHIND = 2.0
"""Degrees a profile camera may stand behind the true profile."""

ViewDraw = tuple[np.ndarray, float, float, np.ndarray]
"""One view's draw: (yaw, pitch) degrees (2,), roll degrees, distance mm, target (3,) mm."""


def sample_identity(model: FaceModel, rng: np.random.Generator) -> tuple[np.ndarray,
                                                                          np.ndarray]:
    """A random face in the SPEC frame.

    Returns:
        V (V, 3) mm with landmark ``g`` at the origin, and the coefficients w (K,).
    """
    w = rng.standard_normal(model.n_modes)
    V = model.shape(w)
    V = V - V[model.landmark_vertices["g"]]
    return V, w


Points = Mapping[str, np.ndarray]
"""Landmark id -> (3,) position (mm, SPEC frame): all a rig needs of a face."""


def landmark_points(V: np.ndarray, model: FaceModel) -> dict[str, np.ndarray]:
    """Landmark id -> (3,) position of a face-model mesh ``V`` (its landmark vertices)."""
    return {k: V[i] for k, i in model.landmark_vertices.items()}


def view_aim(points: Points, view: str) -> np.ndarray:
    """(3,) aim point of a view: the bounding-box centre of the landmarks marked in it."""
    P = np.array([points[i] for i in VIEW_LANDMARKS[view] if i in points])
    return 0.5 * (P.min(axis=0) + P.max(axis=0))


def _rot_y(deg: float) -> np.ndarray:
    return rodrigues([0.0, math.radians(deg), 0.0])


def _nominal_directions(elev: float) -> dict[str, np.ndarray]:
    """View -> (3,) unit direction from the face towards the camera before jitter."""
    return {
        "front": np.array([0.0, 0.0, 1.0]),
        "left": np.array([1.0, 0.0, 0.0]),
        "right": np.array([-1.0, 0.0, 0.0]),
        "bottom": np.array([0.0, -math.sin(math.radians(elev)), math.cos(math.radians(elev))]),
        "oblique_left": np.array([math.sqrt(0.5), 0.0, math.sqrt(0.5)]),
        "oblique_right": np.array([-math.sqrt(0.5), 0.0, math.sqrt(0.5)]),
    }


def _draw_view(points: Points, rng: np.random.Generator, base: float, view: str) -> ViewDraw:
    """One view's jitter: yaw and pitch +-8 degrees, roll +-6, distance +-15 % of
    ``base`` (mm), aim +-4 mm from :func:`view_aim`."""
    return (rng.uniform(-8.0, 8.0, size=2), float(rng.uniform(-6.0, 6.0)),
            base * float(rng.uniform(0.85, 1.15)),
            view_aim(points, view) + rng.uniform(-4.0, 4.0, size=3))


def _draw_views(points: Points, rng: np.random.Generator, base: float) -> dict[str, ViewDraw]:
    """Per view, in :data:`~naseview.landmarks.VIEWS` order: angles, roll, distance, aim."""
    draws = {view: _draw_view(points, rng, base, view) for view in VIEWS}
    # profile photos: a photographer may stand up to 8 degrees in front of the true
    # profile but hardly behind it (then the brow hides g): yaw towards the face in
    # [-SIDE_YAW_BEHIND, 8] degrees (rotation about +y moves the left camera backwards)
    for view, sign in (("left", -1.0), ("right", 1.0)):
        (yaw, pitch), roll, dist, target = draws[view]
        towards_face = -SIDE_YAW_BEHIND + (yaw + 8.0) / 16.0 * (8.0 + SIDE_YAW_BEHIND)
        draws[view] = (np.array([sign * towards_face, pitch]), roll, dist, target)
    return draws


def _place_camera(draw: ViewDraw, nominal: np.ndarray, focal: float, size: int) -> Camera:
    """The camera of one view: nominal direction turned by yaw and pitch, at its distance
    from its target, rolled about its optical axis."""
    (yaw, pitch), roll, dist, target = draw
    side = np.cross([0.0, 1.0, 0.0], nominal)
    side /= np.linalg.norm(side)
    d = rodrigues(side * math.radians(pitch)) @ (_rot_y(yaw) @ nominal)
    cam = look_at(target + dist * d, target, [0.0, 1.0, 0.0], focal, size, size)
    Rr = rodrigues([0.0, 0.0, math.radians(roll)])
    return Camera(cam.K, Rr @ cam.R, Rr @ cam.t, size, size)


def _draw_info(draw: ViewDraw) -> dict[str, Any]:
    """JSON-able description of one view's draw."""
    (yaw, pitch), roll, dist, target = draw
    return {"yaw_deg": float(yaw), "pitch_deg": float(pitch), "roll_deg": roll,
            "distance_mm": dist, "target_mm": target.tolist()}


def _well_inside(cam: Camera, points: Points, view: str, size: int) -> bool:
    """Every landmark marked in ``view`` projects at least 8 % of the size from a border."""
    uv = cam.project(np.array([points[i] for i in VIEW_LANDMARKS[view] if i in points]))
    return bool(np.all((uv > 0.08 * size) & (uv < 0.92 * size)))


def sample_rig(V: np.ndarray, model: FaceModel, rng: np.random.Generator,
               size: int = DEFAULT_SIZE, views: tuple[str, ...] = VIEWS
               ) -> tuple[dict[str, Camera], dict[str, Any]]:
    """Four jittered phone cameras around the nose, and the obliques among ``views`` (see
    the module docstring).

    Args:
        V: (V, 3) face in the SPEC frame (mm).
        model: gives the landmark vertices.
        rng: random stream of the rig.
        size: image width = height (px).
        views: the four of :data:`~naseview.landmarks.VIEWS` and any obliques.
    Returns:
        ``{view: Camera}`` and a JSON-able description of the draw.
    """
    return sample_rig_points(landmark_points(V, model), rng, size, views)


def _oblique_cameras(points: Points, rng: np.random.Generator, base: float, focal: float,
                     size: int, views: tuple[str, ...]
                     ) -> tuple[dict[str, Camera], dict[str, dict[str, Any]]]:
    """The cameras of the obliques among ``views``, at the four's focal length (px).

    Both obliques are drawn whichever are asked for, so ``oblique_right`` is the same in a
    five- and a six-photo case; one that would put a landmark within 8 % of a border
    steps back by 7 % at a time (at most 20 times) instead of changing the focal length."""
    nominal = _nominal_directions(0.0)
    cams: dict[str, Camera] = {}
    info: dict[str, dict[str, Any]] = {}
    for view in OBLIQUE_VIEWS:
        (yaw, pitch), roll, dist, target = _draw_view(points, rng, base, view)
        if view not in views:
            continue
        for _ in range(20):
            draw: ViewDraw = (np.array([yaw, pitch]), roll, dist, target)
            cams[view] = _place_camera(draw, nominal[view], focal, size)
            if _well_inside(cams[view], points, view, size):
                break
            dist *= 1.07
        info[view] = _draw_info(draw)
    return cams, info


def sample_rig_points(points: Points, rng: np.random.Generator, size: int = DEFAULT_SIZE,
                      views: tuple[str, ...] = VIEWS
                      ) -> tuple[dict[str, Camera], dict[str, Any]]:
    """:func:`sample_rig` for any face given by its landmarks (e.g. a scan, SPEC §8).

    Args:
        points: landmark id -> (3,) position, SPEC frame, mm (at least al_l, al_r and
            the landmarks of each view).
        rng: random stream of the rig.
        size: image width = height (px).
        views: the four of :data:`~naseview.landmarks.VIEWS` and any obliques
            (:data:`~naseview.landmarks.OBLIQUE_VIEWS`), drawn after the four.
    Returns:
        ``{view: Camera}`` and a JSON-able description of the draw.
    """
    alar = float(np.linalg.norm(np.asarray(points["al_l"]) - np.asarray(points["al_r"])))
    base = float(rng.uniform(300.0, 450.0))
    frac = float(rng.uniform(0.26, 0.34))
    elev = float(rng.uniform(45.0, 60.0))
    nominal = _nominal_directions(elev)
    draws = _draw_views(points, rng, base)
    # one focal length (one phone); zoom out until every landmark is well inside each photo
    for _ in range(20):
        focal = frac * size * base / alar
        cams = {view: _place_camera(draws[view], nominal[view], focal, size) for view in VIEWS}
        info: dict[str, Any] = {"base_distance_mm": base, "alar_fraction": frac,
                                "focal_px": focal, "bottom_elevation_deg": elev,
                                "views": {view: _draw_info(draws[view]) for view in VIEWS}}
        if all(_well_inside(cams[view], points, view, size) for view in VIEWS):
            break
        frac *= 0.93
    if any(v in OBLIQUE_VIEWS for v in views):
        oblique, oblique_info = _oblique_cameras(points, rng, base, focal, size, views)
        cams.update(oblique)
        info["views"].update(oblique_info)
    return cams, info
