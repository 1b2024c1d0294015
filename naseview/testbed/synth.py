"""Synthetic cases with exact ground truth: ``naseview synth``.

A synthetic case is what a surgeon would bring (four phone photos of a face against a
clinic backdrop, the 21 landmark clicks, a calliper distance; SPEC §3) plus the truth
(SPEC §7). Everything is rendered by :mod:`naseview.render` from a random identity of a
:class:`~naseview.facemodel.FaceModel`, so every number in the truth is exact.

Per case (all random draws from ``seed``, one independent stream per part, so changing
``noise_px`` does not change the face or the rig):

- **Identity**: ``w ~ N(0, I)`` over all modes; the face is moved so that landmark ``g``
  is the origin (the model axes already are the SPEC axes: +x subject's left, +y up,
  +z anterior).
- **Scene**: the face mesh (back faces culled) closed by a head proxy behind it (a radial
  surface that follows the face mask 2 mm inside it and continues as an ellipsoid over
  the back of the head, with hair on top and at the back) and, when the mask has eye
  holes, two eyeballs (sclera, iris, pupil; a mesh that models the eyes, like the
  generic face, gets them painted on). Skin: a random tone from light to dark,
  smooth low-frequency tone variation, redder nose tip, cheeks and lips, darker eyebrows,
  creases darkened by a cavity term from the mean curvature, nostril vertices
  (``model.nostril_vertices``) nearly black.
- **Rig** (:func:`sample_rig`): four cameras, each aimed at the bounding-box centre of
  the landmarks marked in its view (jittered +-4 mm): ``front`` on +z, ``left`` on +x
  (the subject's left side, 90 degrees yaw), ``right`` on -x, ``bottom`` below the nose
  looking up at 45-60 degrees elevation. Each view gets yaw and pitch jitter of up to
  +-8 degrees (profile views: up to 8 degrees towards the face but at most 2 behind the
  true profile, where the brow would hide g), roll up to +-6 degrees and its own
  distance (the case's base distance, 300-450 mm, +-15 %). One focal length per case
  (one phone), chosen so that the alar width al_l-al_r spans 26-34 % of the frame width
  (the nose region about a third of the frame: surgeons frame the nose), reduced if a
  marked landmark would fall within 8 % of a border. That is ``f`` of about 1.8-4.6
  times the image width: a phone photo zoomed or cropped to the face (roughly 50-120 mm
  full-frame equivalent; an uncropped 26 mm phone lens at 30-45 cm would show the nose
  at only ~8 % of the width).
- **Photos**: Gouraud-shaded render with a soft key light above-left of the camera and a
  fill light on the right, a uniform backdrop colour (light blue, blue, green, grey or
  white, jittered), a light optical blur (sigma 0.6 px), Gaussian sensor noise of
  ``image_noise`` grey levels, JPEG quality 92.

Landmark policy (what a surgeon marks in each photo; a landmark is listed only if it is
visible and lies at least 3 px inside the image). Visible means: within 4 px (at 1024 px)
of its projection the rendered surface is nowhere more than 1.5 mm in front of it, so a
landmark right behind an occluding contour (g on a slightly turned profile, md behind the
alar rim) is still clicked there, as a surgeon would, while one hidden behind the nose or
the eye (al_r in the left view, mf in a true profile) is not:

- ``front``: all 21 landmarks;
- ``left``: the midline landmarks (g n k r prn c sn) and the subject's-left ones
  (``*_l``); ``right`` likewise with ``*_r``;
- ``bottom``: prn, c, sn and the alar/nostril landmarks al, alp, alpp, ac, md of both
  sides, plus the helpers ``add_l``/``add_r``.

A click is the exact projection of the landmark vertex plus Gaussian noise of standard
deviation ``noise_px`` per axis (so the mean click error is ``1.25 noise_px``). The
helper ``add_x`` is the point halfway (2D arc length) between alp_x and prn along the
projection of the true bottom curve in the bottom view, plus the same noise.
``scale_mm`` is the true distance al_l-al_r.

Ground truth written beside the case (written before ``case.json``, which comes last):

- ``truth.json`` (:class:`~naseview.reconstruction.Reconstruction` schema): true
  landmarks and curves (``model.curve_vertices`` on the true mesh; sills closed loops
  without the repeated first vertex), the four true cameras, the true clinical
  measurements; ``extra`` keys ``synth`` (seed, model, identity coefficients, rig and
  appearance parameters) and ``nose_vertex_ids`` (nose region of ``truth_face.ply``).
- ``truth_boundaries.json``: per curve, per view, the 2D ground-truth boundary points in
  that photo's pixels. Definition: the true 3D curve polyline (vertex path of
  ``model.curve_vertices[name]`` on the true mesh; sills closed) resampled every 0.5 mm,
  projected with the true camera, keeping only the points that pass the depth test (1 mm)
  against the rendered scene and lie inside the image. Views: ``mid`` in ``left`` and
  ``right``; ``bottom``, ``sill_l``, ``sill_r`` in ``bottom``; ``ala_l``, ``ala_r``,
  ``c``, ``side_l``, ``side_r`` in ``front``.
- ``truth_face.ply``: the true face mesh (face model vertices only, no proxies), SPEC
  frame, mm.

When the ICT model is used, credit "ICT Face Model (USC Institute for Creative
Technologies, MIT)" travels in ``truth.json`` (``synth.credit``).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> synthesize_case("/tmp/case", load_face_model("generic"), seed=7)   # doctest: +SKIP
PosixPath('/tmp/case/case.json')
"""

from __future__ import annotations

import argparse
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import Camera, look_at, rodrigues
from naseview.case import Case, View, write_case
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.fileio import atomic_write_json
from naseview.landmarks import LANDMARK_IDS, MIDLINE_IDS, VIEWS
from naseview.render import render_mesh, vertex_normals, visible_points

VIEW_LANDMARKS: dict[str, tuple[str, ...]] = {
    "front": LANDMARK_IDS,
    "left": MIDLINE_IDS + tuple(i for i in LANDMARK_IDS if i.endswith("_l")),
    "right": MIDLINE_IDS + tuple(i for i in LANDMARK_IDS if i.endswith("_r")),
    "bottom": ("prn", "c", "sn", "al_l", "al_r", "alp_l", "alp_r", "alpp_l", "alpp_r",
               "ac_l", "ac_r", "md_l", "md_r", "add_l", "add_r"),
}
"""Which ids a surgeon marks in each photo (listed only where visible)."""

TRUTH_CURVE_VIEWS: dict[str, tuple[str, ...]] = {
    "mid": ("left", "right"), "bottom": ("bottom",), "ala_l": ("front",),
    "ala_r": ("front",), "c": ("front",), "sill_l": ("bottom",), "sill_r": ("bottom",),
    "side_l": ("front",), "side_r": ("front",),
}
"""Views in which ``truth_boundaries.json`` gives each curve's 2D ground truth."""

CLOSED_CURVES: tuple[str, ...] = ("sill_l", "sill_r")

BACKDROPS_BGR: tuple[tuple[int, int, int], ...] = (
    (225, 205, 170),   # light blue
    (170, 120, 60),    # clinic blue
    (130, 165, 110),   # muted green
    (175, 175, 172),   # mid grey
    (238, 238, 236),   # white
)
"""Uniform backdrop colours clinics use (BGR), jittered per case."""

SKIN_TONES_RGB: tuple[tuple[float, float, float], ...] = (
    (243, 214, 196), (226, 185, 160), (205, 160, 128), (176, 128, 95), (141, 98, 70),
    (104, 70, 50), (78, 52, 38),
)
"""Skin albedo anchors from light to dark (RGB 0-255); a case picks a point between two."""

HAIR_RGB: tuple[tuple[float, float, float], ...] = (
    (22, 18, 16), (45, 32, 24), (80, 56, 38), (120, 90, 60), (170, 140, 95), (150, 145, 140),
)
IRIS_RGB: tuple[tuple[float, float, float], ...] = (
    (70, 45, 28), (105, 70, 40), (80, 110, 140), (95, 115, 80), (50, 35, 25),
)

GENERIC_EYES_MM = np.array([[31.0, -8.0], [-31.0, -8.0]])
"""Cornea centres (x, y) of the generic face's eyes in its model frame (its eye design)."""

DEFAULT_SIZE = 1024
JPEG_QUALITY = 92
CLICK_MARGIN_PX = 3.0
VISIBILITY_TOL_MM = 1.5
SIDE_YAW_BEHIND = 2.0          # degrees a profile camera may stand behind the true profile
CONTOUR_RADIUS_PX = 4          # at 1024 px; scaled with the photo size
BOUNDARY_STEP_MM = 0.5


@dataclass
class Scene:
    """Everything that is rendered: face mesh first, then proxies.

    Attributes:
        V: (N, 3) vertices (mm, SPEC frame); the first ``n_face`` belong to the face
            (the model's vertices first, then any added by local subdivision).
        F: (M, 3) triangles, counter-clockwise seen from outside.
        colors: (N, 3) albedo, BGR in [0, 1].
        specular: (N,) highlight multiplier.
        n_face: number of face-model vertices at the start of ``V``.
    """

    V: np.ndarray
    F: np.ndarray
    colors: np.ndarray
    specular: np.ndarray
    n_face: int
    normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


# --------------------------------------------------------------------------- identity


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


# --------------------------------------------------------------------------- rig


def view_aim(V: np.ndarray, model: FaceModel, view: str) -> np.ndarray:
    """(3,) aim point of a view: the bounding-box centre of the landmarks marked in it."""
    P = np.array([V[model.landmark_vertices[i]] for i in VIEW_LANDMARKS[view]
                  if i in model.landmark_vertices])
    return 0.5 * (P.min(axis=0) + P.max(axis=0))


def _rot_y(deg: float) -> np.ndarray:
    return rodrigues([0.0, math.radians(deg), 0.0])


def sample_rig(V: np.ndarray, model: FaceModel, rng: np.random.Generator,
               size: int = DEFAULT_SIZE) -> tuple[dict[str, Camera], dict[str, Any]]:
    """Four jittered phone cameras around the nose (see the module docstring).

    Args:
        V: (V, 3) face in the SPEC frame (mm).
        model: gives the landmark vertices.
        rng: random stream of the rig.
        size: image width = height (px).
    Returns:
        ``{view: Camera}`` and a JSON-able description of the draw.
    """
    lv = model.landmark_vertices
    alar = float(np.linalg.norm(V[lv["al_l"]] - V[lv["al_r"]]))
    base = float(rng.uniform(300.0, 450.0))
    frac = float(rng.uniform(0.26, 0.34))
    elev = float(rng.uniform(45.0, 60.0))
    nominal = {
        "front": np.array([0.0, 0.0, 1.0]),
        "left": np.array([1.0, 0.0, 0.0]),
        "right": np.array([-1.0, 0.0, 0.0]),
        "bottom": np.array([0.0, -math.sin(math.radians(elev)), math.cos(math.radians(elev))]),
    }
    draws = {view: (rng.uniform(-8.0, 8.0, size=2), float(rng.uniform(-6.0, 6.0)),
                    base * float(rng.uniform(0.85, 1.15)),
                    view_aim(V, model, view) + rng.uniform(-4.0, 4.0, size=3))
             for view in VIEWS}
    # profile photos: a photographer may stand up to 8 degrees in front of the true
    # profile but hardly behind it (then the brow hides g): yaw towards the face in
    # [-SIDE_YAW_BEHIND, 8] degrees (rotation about +y moves the left camera backwards)
    for view, sign in (("left", -1.0), ("right", 1.0)):
        (yaw, pitch), roll, dist, target = draws[view]
        towards_face = -SIDE_YAW_BEHIND + (yaw + 8.0) / 16.0 * (8.0 + SIDE_YAW_BEHIND)
        draws[view] = (np.array([sign * towards_face, pitch]), roll, dist, target)
    # one focal length (one phone); zoom out until every landmark is well inside each photo
    for _ in range(20):
        focal = frac * size * base / alar
        cams: dict[str, Camera] = {}
        info: dict[str, Any] = {"base_distance_mm": base, "alar_fraction": frac,
                                "focal_px": focal, "bottom_elevation_deg": elev, "views": {}}
        inside = True
        for view in VIEWS:
            (yaw, pitch), roll, dist, target = draws[view]
            d = nominal[view]
            side = np.cross([0.0, 1.0, 0.0], d)
            side /= np.linalg.norm(side)
            d = rodrigues(side * math.radians(pitch)) @ (_rot_y(yaw) @ d)
            cam = look_at(target + dist * d, target, [0.0, 1.0, 0.0], focal, size, size)
            Rr = rodrigues([0.0, 0.0, math.radians(roll)])
            cams[view] = Camera(cam.K, Rr @ cam.R, Rr @ cam.t, size, size)
            info["views"][view] = {"yaw_deg": float(yaw), "pitch_deg": float(pitch),
                                   "roll_deg": roll, "distance_mm": dist,
                                   "target_mm": target.tolist()}
            P = np.array([V[lv[i]] for i in VIEW_LANDMARKS[view] if i in lv])
            uv = cams[view].project(P)
            inside &= bool(np.all((uv > 0.08 * size) & (uv < 0.92 * size)))
        if inside:
            break
        frac *= 0.93
    return cams, info


# --------------------------------------------------------------------------- scene


def _smoothstep(x: np.ndarray) -> np.ndarray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _mesh_loops(F: np.ndarray, n_vertices: int) -> list[np.ndarray]:
    from naseview.facemodel.meshcurves import region_boundary_loops

    return region_boundary_loops(F, np.arange(n_vertices))


def _features(V: np.ndarray, F: np.ndarray, model: FaceModel) -> dict[str, Any]:
    """Eye and mouth positions: from the mesh's holes when it has them, else estimated."""
    from naseview.facemodel.meshcurves import mean_curvature

    lv = model.landmark_vertices
    P = {k: V[i] for k, i in lv.items()}
    scale = float(np.linalg.norm(P["al_l"] - P["al_r"])) / 35.0
    loops = _mesh_loops(F, len(V))[1:]
    eyes: dict[str, np.ndarray | None] = {"l": None, "r": None}
    eye_loops: dict[str, np.ndarray] = {}
    mouth = None
    for loop in loops:
        c = V[loop].mean(axis=0)
        if len(loop) < 8:
            continue
        if c[1] > P["prn"][1] and abs(c[0]) > 12.0 * scale:
            s = "l" if c[0] > 0 else "r"
            eyes[s] = c
            eye_loops[s] = loop
        elif c[1] < P["sn"][1] and abs(c[0]) < 10.0 * scale and mouth is None:
            mouth = loop
    est = {
        "l": np.array([31.0 * scale, P["n"][1] - 6.0 * scale, P["n"][2] - 14.0 * scale]),
        "r": np.array([-31.0 * scale, P["n"][1] - 6.0 * scale, P["n"][2] - 14.0 * scale]),
    }
    eye_weights = _modelled_eyes(model) if not eye_loops else {}
    for side in eye_weights:
        ind, r = eye_weights[side]
        est[side] = V[int(np.argmin(r))]
    eye_c = {s: (eyes[s] if eyes[s] is not None else est[s]) for s in ("l", "r")}
    H = mean_curvature(V, F, smooth_iterations=4)
    if mouth is not None:
        M = V[mouth]
        mouth_c = M.mean(axis=0)
        mouth_hw = 0.5 * float(M[:, 0].max() - M[:, 0].min())
    else:
        # the mouth line is the deepest crease on the midline about 21 mm below sn
        mouth_c = P["sn"] + np.array([0.0, -21.0, -2.0]) * scale
        near = np.flatnonzero((np.abs(V[:, 0] - P["sn"][0]) < 3.0 * scale)
                              & (np.abs(V[:, 1] - mouth_c[1]) < 7.0 * scale)
                              & (V[:, 2] > mouth_c[2] - 10.0 * scale))
        if near.size:
            mouth_c = V[near[np.argmin(H[near])]].copy()
        mouth_hw = 24.0 * scale
    return {"eye_center": eye_c, "eye_loops": eye_loops, "eye_weights": eye_weights,
            "mouth_loop": mouth, "mouth_center": mouth_c, "mouth_half_width": mouth_hw,
            "scale": scale, "mean_curvature": H}


def _modelled_eyes(model: FaceModel) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per side: (V,) palpebral-fissure indicator and (V,) distance (mm) to the cornea
    centre, on the model's mean, for a mesh that models the eyes (no eye holes).

    Only the built-in generic face does so; its eye design (fissure shape, cornea at
    x = +-31, y = -8 mm in its model frame) is read from :mod:`naseview.facemodel.generic`.
    The weights are attached to vertices, so they follow any identity.
    """
    if model.name != "generic":
        return {}
    from naseview.facemodel.generic import eye_fissure

    x, y = model.mean[:, 0], model.mean[:, 1]
    out = {}
    for (cx, cy), side, sign in zip(GENERIC_EYES_MM, ("l", "r"), (1.0, -1.0), strict=True):
        ind, _, _ = eye_fissure(x, y, sign)
        out[side] = (np.asarray(ind, dtype=float), np.hypot(x - cx, y - cy))
    return out


def _interp_rgb(table: tuple[tuple[float, float, float], ...], t: float) -> np.ndarray:
    """Piecewise-linear pick along ``table`` at ``t`` in [0, 1]; returned as BGR [0, 1]."""
    x = np.linspace(0.0, 1.0, len(table))
    rgb = np.array([np.interp(t, x, [c[k] for c in table]) for k in range(3)])
    return rgb[::-1] / 255.0


def _skin_colors(V: np.ndarray, N: np.ndarray, model: FaceModel, feats: dict[str, Any],
                 tone: np.ndarray, hair: np.ndarray, rng: np.random.Generator
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) BGR albedo and (V,) specular multiplier of the face-model vertices."""
    from naseview.facemodel.meshcurves import vertex_adjacency

    lv = model.landmark_vertices
    P = {k: V[i] for k, i in lv.items()}
    s = feats["scale"]
    C = np.tile(tone, (len(V), 1))
    # low-frequency tone variation: a few soft blobs, brightness and redness
    lo, hi = V.min(axis=0), V.max(axis=0)
    bright = np.zeros(len(V))
    for _ in range(8):
        c = rng.uniform(lo, hi)
        sig = rng.uniform(15.0, 40.0)
        bright += rng.uniform(-0.05, 0.05) * np.exp(-np.sum((V - c) ** 2, axis=1)
                                                    / (2 * sig * sig))
    C *= (1.0 + bright)[:, None]
    red = np.array([-0.03, -0.05, 0.05])            # BGR shift towards red
    redness = 1.0 * np.exp(-np.sum((V - P["prn"]) ** 2, axis=1) / (2 * (11.0 * s) ** 2))
    for side, sign in (("l", 1.0), ("r", -1.0)):
        cheek = P[f"ac_{side}"] + np.array([sign * 28.0, 10.0, -8.0]) * s
        redness += 0.9 * np.exp(-np.sum((V - cheek) ** 2, axis=1) / (2 * (17.0 * s) ** 2))
    C += rng.uniform(0.5, 1.0) * redness[:, None] * red * (0.4 + tone.mean())
    # lips: vermilion bands above and below the mouth line, soft edges
    m = feats["mouth_center"]
    hw = feats["mouth_half_width"]
    u = np.abs(V[:, 0] - m[0]) / max(hw, 1e-6)
    loop = feats["mouth_loop"]
    if loop is not None:
        L = V[loop]
        xs = np.linspace(L[:, 0].min(), L[:, 0].max(), 9)
        ys = [L[np.abs(L[:, 0] - x) <= 0.7 * (xs[1] - xs[0]), 1].mean() for x in xs]
        line = np.interp(V[:, 0], xs, ys)
    else:
        line = np.full(len(V), m[1])
    dy = (V[:, 1] - line) / s
    arc = np.sqrt(np.clip(1.0 - u ** 2, 0.0, 1.0))
    w_up = _smoothstep((8.0 * arc + 0.5 - dy) / 2.0) * (dy >= -0.5)
    w_lo = _smoothstep((10.0 * arc + 0.5 + dy) / 2.0) * (dy < -0.5)
    lip = np.maximum(w_up, w_lo) * _smoothstep((1.08 - u) / 0.2)
    lip *= _smoothstep((V[:, 2] - (m[2] - 14.0 * s)) / (4.0 * s))
    if loop is not None:
        from scipy.spatial import cKDTree

        d, _ = cKDTree(V[loop]).query(V)
        lip *= _smoothstep((15.0 * s - d) / (3.0 * s))
    A = vertex_adjacency(len(V), model.faces)
    deg = np.maximum(np.asarray(A.sum(axis=1)).ravel(), 1)
    for _ in range(2):                       # soften the vertex-sampled border
        lip = 0.5 * lip + 0.5 * (A @ lip) / deg
    lip_col = tone * np.array([0.72, 0.68, 0.88])
    C = C * (1 - 0.7 * lip[:, None]) + 0.7 * lip[:, None] * lip_col
    # eyebrows: an arched band above each eye, on front-facing skin, soft edges
    brow = np.zeros(len(V))
    for side, sign in (("l", 1.0), ("r", -1.0)):
        e = feats["eye_center"][side]
        uu = (V[:, 0] - e[0]) * sign / s                # lateral positive, mm
        vv = (V[:, 1] - e[1]) / s
        centre = 15.0 + 3.0 * np.exp(-((uu - 2.0) / 14.0) ** 2) - 0.01 * np.maximum(uu, 0) ** 2
        half = np.interp(uu, [-17.0, -10.0, 10.0, 24.0], [1.5, 4.0, 3.2, 0.8])
        along = _smoothstep((uu + 17.0) / 4.0) * _smoothstep((25.0 - uu) / 5.0)
        w = along * _smoothstep((half - np.abs(vv - centre)) / 3.0 + 0.5)
        brow = np.maximum(brow, w)
    brow *= _smoothstep((N[:, 2] - 0.1) / 0.3)
    C = C * (1 - 0.65 * brow[:, None]) + 0.65 * brow[:, None] * hair
    # hair on the scalp part of the mask
    hairw = _hair_weight(V, feats)
    C = C * (1 - hairw[:, None]) + hairw[:, None] * hair
    # creases (alar groove, nasolabial fold, lid creases) catch less light: baked cavity
    # occlusion from the mean curvature (1/mm, < 0 in creases)
    H = feats["mean_curvature"]
    C *= np.clip(1.0 + 1.5 * np.minimum(H, 0.0), 0.78, 1.0)[:, None]
    # nostrils: nearly black (their concavity darkens the shading too); the dark region
    # is rounded by one averaging step over the mesh edges
    dark = np.zeros(len(V))
    dark[model.nostril_vertices] = 1.0
    avg = (A @ dark) / deg
    dark = np.maximum(dark * _smoothstep((avg - 0.2) / 0.5), 0.0)
    C = C * (1 - dark[:, None]) + dark[:, None] * (tone * 0.07)
    spec = np.ones(len(V))
    spec += 0.6 * np.exp(-np.sum((V - P["prn"]) ** 2, axis=1) / (2 * (9.0 * s) ** 2))
    spec = spec * (1 - 0.7 * hairw) * (1 - 0.5 * brow) * (1 - dark)
    return np.clip(C, 0.0, 1.0), spec


def _hair_weight(P: np.ndarray, feats: dict[str, Any]) -> np.ndarray:
    """(N,) in [0, 1]: how much each point is hair (scalp above a hairline, SPEC frame)."""
    s = feats["scale"]
    lon = np.degrees(np.abs(np.arctan2(P[:, 0], P[:, 2] + 85.0 * s)))
    hairline = np.interp(lon, [0, 30, 55, 80, 105, 125, 180],
                         [0.0, -2.0, -12.0, -18.0, -20.0, -100.0, -125.0]) * s
    return _smoothstep((P[:, 1] - hairline - feats.get("hairline_mm", 0.0)) / (6.0 * s))


def _sphere_grid(n_lon: int, n_lat: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude/latitude grid with two poles: lon (N,), lat (N,), faces (M, 3) outward."""
    lons = -np.pi + (np.arange(n_lon) + 0.5) * 2 * np.pi / n_lon
    lats = np.pi / 2 - (np.arange(n_lat) + 0.5) * np.pi / n_lat
    LO, LA = np.meshgrid(lons, lats)                    # (n_lat, n_lon), row 0 at the top
    lon = np.concatenate([LO.ravel(), [0.0, 0.0]])
    lat = np.concatenate([LA.ravel(), [np.pi / 2, -np.pi / 2]])
    idx = np.arange(n_lat * n_lon).reshape(n_lat, n_lon)
    a = idx[:-1]
    b = np.roll(idx[:-1], -1, axis=1)
    c = np.roll(idx[1:], -1, axis=1)
    d = idx[1:]
    F = [np.column_stack([a.ravel(), d.ravel(), c.ravel()]),
         np.column_stack([a.ravel(), c.ravel(), b.ravel()])]
    top, bot = n_lat * n_lon, n_lat * n_lon + 1
    F.append(np.column_stack([np.full(n_lon, top), idx[0], np.roll(idx[0], -1)]))
    F.append(np.column_stack([np.full(n_lon, bot), np.roll(idx[-1], -1), idx[-1]]))
    return lon, lat, np.concatenate(F)


def _head_proxy(V: np.ndarray, F: np.ndarray, feats: dict[str, Any]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A closed head surface behind an open face mask.

    In spherical coordinates about a point behind the face, the mask's radius map (first
    hit) is rasterised; holes in it (eyes, mouth) are inpainted; outside the mask the
    radius blends into an ellipsoid fitted to the mask's rim. The proxy is the radial
    surface 2 mm inside that radius (14 mm inside in the holes, leaving room for eyeballs
    and a dark mouth).

    Returns:
        vertices (P, 3), triangles (Q, 3) (outward), and (P,) hole weight in [0, 1].
    """
    import cv2

    from naseview.render import rasterize_screen

    s = feats["scale"]
    c = np.array([0.0, -20.0 * s, -85.0 * s])
    W, H = 360, 180
    d = V - c
    r = np.linalg.norm(d, axis=1)
    lon = np.arctan2(d[:, 0], d[:, 2])
    lat = np.arcsin(np.clip(d[:, 1] / r, -1, 1))
    uv = np.column_stack([(lon + np.pi) * W / (2 * np.pi) - 0.5,
                          (np.pi / 2 - lat) * H / np.pi - 0.5])
    span = np.ptp(lon[F], axis=1) < np.pi
    ras = rasterize_screen(uv, r, F[span], W, H)
    R = ras.depth.astype(np.float32)
    covered = np.isfinite(R)
    n_lab, labels = cv2.connectedComponents((~covered).astype(np.uint8), connectivity=4)
    border = np.unique(np.concatenate([labels[:, 0], labels[:, -1], labels[0], labels[-1]]))
    outside = ~covered & np.isin(labels, border)
    holes = ~covered & ~outside
    # extend the radius into holes and around the rim: normalised Gaussian averaging
    cov = covered.astype(np.float32)
    Rz = np.where(covered, R, 0).astype(np.float32)
    Rf = R.copy()
    for sigma in (2.0, 5.0, 12.0):
        num = cv2.GaussianBlur(Rz, (0, 0), sigma)
        den = cv2.GaussianBlur(cov, (0, 0), sigma)
        fill = ~np.isfinite(Rf) & (den > 1e-3)
        Rf[fill] = num[fill] / den[fill]
    Rf[~np.isfinite(Rf)] = float(np.median(R[covered])) if covered.any() else 90.0 * s
    # ellipsoid 1/r^2 = A dx^2 + B dy^2 + C dz^2 through the rim of the covered region
    rim = covered & (cv2.dilate(outside.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0)
    ys, xs = np.nonzero(rim)
    g_lon = -np.pi + (np.arange(W) + 0.5) * 2 * np.pi / W
    g_lat = np.pi / 2 - (np.arange(H) + 0.5) * np.pi / H
    GL, GA = np.meshgrid(g_lon, g_lat)
    dirs = np.stack([np.cos(GA) * np.sin(GL), np.sin(GA), np.cos(GA) * np.cos(GL)], axis=-1)
    if len(ys) >= 3:
        A = dirs[ys, xs] ** 2
        coef = np.linalg.lstsq(A, 1.0 / R[ys, xs].astype(float) ** 2, rcond=None)[0]
        coef = np.clip(coef, 1.0 / (140.0 * s) ** 2, 1.0 / (60.0 * s) ** 2)
    else:
        coef = 1.0 / (np.array([75.0, 110.0, 95.0]) * s) ** 2
    Re = 1.0 / np.sqrt(np.einsum("hwk,k->hw", dirs ** 2, coef))
    dist = cv2.distanceTransform((~covered | holes).astype(np.uint8), cv2.DIST_L2, 3)
    wgt = np.where(outside, np.exp(-dist / 12.0), 1.0)
    Rm = wgt * Rf + (1 - wgt) * Re
    inset = np.where(holes, 14.0 * s, 2.0 * s)
    inset = cv2.GaussianBlur(inset.astype(np.float32), (0, 0), 1.5)
    Rm = Rm - inset
    hole_w = cv2.GaussianBlur(cv2.dilate(holes.astype(np.float32), np.ones((5, 5))),
                              (0, 0), 1.0)
    # sample the maps on a coarser lon/lat grid
    n_lon, n_lat = 120, 60
    plon, plat, PF = _sphere_grid(n_lon, n_lat)
    px = (plon + np.pi) * W / (2 * np.pi) - 0.5
    py = (np.pi / 2 - plat) * H / np.pi - 0.5
    mx = px.astype(np.float32).reshape(1, -1)
    my = py.astype(np.float32).reshape(1, -1)
    rr = cv2.remap(Rm.astype(np.float32), mx, my, cv2.INTER_LINEAR,
                   borderMode=cv2.BORDER_REPLICATE).ravel()
    hw = cv2.remap(hole_w, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).ravel()
    deep = cv2.remap((cv2.distanceTransform(covered.astype(np.uint8), cv2.DIST_L2, 3)
                      ).astype(np.float32), mx, my, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE).ravel()
    pdir = np.column_stack([np.cos(plat) * np.sin(plon), np.sin(plat),
                            np.cos(plat) * np.cos(plon)])
    PV = c + rr[:, None] * pdir
    # triangles deep inside the mask (not in a hole) are never visible: drop them
    hidden = (deep > 6.0) & (hw < 0.01)
    PF = PF[~hidden[PF].all(axis=1)]
    return PV, PF, np.clip(hw, 0.0, 1.0)


def _eyeball(loop_pts: np.ndarray, iris_bgr: np.ndarray, s: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """An eyeball sphere fitted behind an eye-hole loop, looking along +z.

    Returns vertices, triangles, BGR colours, specular multipliers.
    """
    R = 12.0 * s
    m = loop_pts.mean(axis=0)
    cen = m - np.array([0.0, 0.0, R * 0.75])
    for _ in range(10):                               # fit |p - c| = R (Gauss-Newton)
        d = loop_pts - cen
        n = np.linalg.norm(d, axis=1)
        J = -d / n[:, None]
        res = n - R
        cen = cen - np.linalg.lstsq(J, res, rcond=None)[0]
    if np.linalg.norm(cen[:2] - m[:2]) > 5 * s:       # degenerate fit: sit behind the hole
        cen = m - np.array([0.0, 0.0, R * 0.75])
    # lon/lat sphere whose pole looks forwards (+z): iris and pupil are latitude rings
    lon, lat, EF = _sphere_grid(48, 36)
    ang = 90.0 - np.degrees(lat)                       # angle from the gaze direction
    dirs = np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon),
                            np.sin(lat)])
    EV = cen + R * dirs
    sclera = np.array([0.80, 0.82, 0.88])
    col = np.tile(sclera, (len(EV), 1))
    col[ang < 29.0] = iris_bgr
    col[(ang > 24.0) & (ang < 29.0)] *= 0.55           # limbal ring
    col[ang < 9.0] = 0.03
    spec = np.full(len(EV), 2.0)
    return EV, EF, col, spec


def _paint_modelled_eyes(mean_xy: np.ndarray, N: np.ndarray, C: np.ndarray,
                         spec: np.ndarray, iris_bgr: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Sclera, iris, pupil and lash line painted on a mesh that models the eyes.

    Args:
        mean_xy: (P, 2) positions of the points on the model's mean (model frame, mm).
        N: (P, 3) normals; C: (P, 3) albedo; spec: (P,) highlight multipliers.
    Returns:
        the new albedo and highlight multipliers.
    """
    from naseview.facemodel.generic import eye_fissure

    x, y = mean_xy[:, 0], mean_xy[:, 1]
    C = C.copy()
    spec = spec.copy()
    for (cx, cy), sign in zip(GENERIC_EYES_MM, (1.0, -1.0), strict=True):
        ind, _, _ = eye_fissure(x, y, sign)
        r = np.hypot(x - cx, y - cy)
        iris_w = _smoothstep((5.6 - r) / 0.5)
        pupil_w = _smoothstep((2.2 - r) / 0.4)
        ec = np.array([0.74, 0.77, 0.84]) * (1 - iris_w[:, None]) + iris_w[:, None] * iris_bgr
        ec = ec * (1 - pupil_w[:, None]) + pupil_w[:, None] * 0.03
        ec = ec * (1 - 0.45 * _smoothstep((r - 4.8) / 0.5) * iris_w)[:, None]
        w = ind * _smoothstep((N[:, 2] - 0.1) / 0.3)
        C = C * (1 - w[:, None]) + w[:, None] * ec
        C *= (1.0 - 0.7 * 4.0 * ind * (1.0 - ind))[:, None]       # lash line
        spec = spec + 1.0 * w
    return C, spec


def _subdivide(F: np.ndarray, select: np.ndarray, attrs: list[np.ndarray]
               ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Split the selected triangles 1 -> 4 at their edge midpoints (flat: the surface is
    unchanged), interpolating every per-vertex attribute linearly.

    Args:
        F: (F, 3) triangles; select: (F,) bool.
        attrs: per-vertex arrays (V, ...) (positions, colours, normals...).
    Returns:
        new triangles (old vertex ids kept, midpoints appended) and the new attributes.
    """
    Fs = F[select]
    e = np.concatenate([Fs[:, [1, 2]], Fs[:, [2, 0]], Fs[:, [0, 1]]])
    key, inv = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True)
    n = len(attrs[0])
    mid = n + inv.reshape(3, -1).T                         # (S, 3): midpoint opposite k
    a, b, c = Fs[:, 0], Fs[:, 1], Fs[:, 2]
    ma, mb, mc = mid[:, 0], mid[:, 1], mid[:, 2]
    new_F = np.concatenate([F[~select], np.column_stack([a, mc, mb]),
                            np.column_stack([mc, b, ma]), np.column_stack([mb, ma, c]),
                            np.column_stack([ma, mb, mc])])
    new_attrs = [np.concatenate([x, 0.5 * (x[key[:, 0]] + x[key[:, 1]])]) for x in attrs]
    return new_F, new_attrs


def build_scene(model: FaceModel, V: np.ndarray, rng: np.random.Generator
                ) -> tuple[Scene, dict[str, Any]]:
    """The face plus head proxy and eyeballs, with albedo and highlight per vertex.

    Args:
        model: the face model (faces, landmarks, nostrils).
        V: (V, 3) the true face in the SPEC frame (mm).
        rng: random stream of the appearance.
    Returns:
        the :class:`Scene` and a JSON-able description of the appearance draw.
    """
    F = np.asarray(model.faces, dtype=np.int64)
    N = vertex_normals(V, F)
    feats = _features(V, F, model)
    feats["hairline_mm"] = float(rng.uniform(42.0, 60.0)) * feats["scale"]
    t_skin = float(rng.uniform(0.0, 1.0))
    tone = _interp_rgb(SKIN_TONES_RGB, t_skin) * rng.uniform(0.96, 1.04, size=3)
    hair = _interp_rgb(HAIR_RGB, float(rng.uniform(0, 1))) if t_skin < 0.5 else \
        _interp_rgb(HAIR_RGB[:3], float(rng.uniform(0, 1)))
    iris = _interp_rgb(IRIS_RGB, float(rng.uniform(0, 1))) if t_skin < 0.45 else \
        _interp_rgb(IRIS_RGB[:2], float(rng.uniform(0, 1)))
    feats["iris_bgr"] = iris
    C, spec = _skin_colors(V, N, model, feats, tone, hair, rng)

    if feats["eye_weights"]:
        # paint the eyes on a locally 16x finer mesh so the lid margins are crisp
        Fv = F
        attrs = [V, np.asarray(model.mean, dtype=float), N, C, spec[:, None]]
        for _ in range(2):
            sel = attrs[1][Fv][:, :, :2].mean(axis=1)[:, None, :] - GENERIC_EYES_MM
            sel = np.any((np.abs(sel[:, :, 0]) < 18.0) & (np.abs(sel[:, :, 1]) < 10.0),
                         axis=1)
            Fv, attrs = _subdivide(Fv, sel, attrs)
        Vf, Mf, Nf, Cf, Sf = attrs
        Nf = Nf / np.linalg.norm(Nf, axis=1, keepdims=True)
        Cf, Sf1 = _paint_modelled_eyes(Mf[:, :2], Nf, Cf, Sf[:, 0], iris)
        V_face, F_face, N_face, C, spec = Vf, Fv, Nf, Cf, Sf1
    else:
        V_face, F_face, N_face = V, F, N
    PV, PF, hole_w = _head_proxy(V, F, feats)
    hw = _hair_weight(PV, feats)
    pc = np.tile(tone, (len(PV), 1))
    pc = pc * (1 - hw[:, None]) + hw[:, None] * hair
    mouth_dark = np.array([0.10, 0.10, 0.22]) * (0.5 + tone.mean())
    pc = pc * (1 - hole_w[:, None]) + hole_w[:, None] * mouth_dark
    pspec = (1 - 0.7 * hw) * (1 - hole_w)

    parts_V = [V_face, PV]
    parts_F = [F_face, PF + len(V_face)]
    parts_C = [C, pc]
    parts_S = [spec, pspec]
    parts_N = [N_face, vertex_normals(PV, PF)]
    n = len(V_face) + len(PV)
    for side in ("l", "r"):
        loop = feats["eye_loops"].get(side)
        if loop is None:
            continue
        EV, EF, EC, ES = _eyeball(V[loop], iris, feats["scale"])
        parts_V.append(EV)
        parts_F.append(EF + n)
        parts_C.append(EC)
        parts_S.append(ES)
        parts_N.append(vertex_normals(EV, EF))
        n += len(EV)
    scene = Scene(np.concatenate(parts_V), np.concatenate(parts_F), np.concatenate(parts_C),
                  np.concatenate(parts_S), len(V_face), np.concatenate(parts_N))
    info = {"skin_tone": float(t_skin), "hairline_mm": feats["hairline_mm"],
            "skin_bgr": tone.tolist(), "hair_bgr": hair.tolist(), "iris_bgr": iris.tolist()}
    return scene, info


# --------------------------------------------------------------------------- photos


def render_photo(scene: Scene, camera: Camera, background: tuple[int, int, int],
                 rng: np.random.Generator, image_noise: float = 2.0,
                 light_dirs: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One synthetic photo of ``scene``.

    Returns:
        (H, W, 3) uint8 BGR photo (blurred, noisy) and the (H, W) depth map (mm).
    """
    import cv2

    kw: dict[str, Any] = {}
    if light_dirs is not None:
        kw["light_dirs"] = light_dirs
    res = render_mesh(scene.V, scene.F, camera, vertex_colors=scene.colors,
                      background=background, supersample=1, cull_backfaces=True,
                      normals=scene.normals, vertex_specular=scene.specular,
                      ambient=0.26, specular=0.08, shininess=20.0,
                      light_intensities=(0.55, 0.24), **kw)
    img = cv2.GaussianBlur(res.image, (0, 0), 0.6)
    if image_noise > 0:
        noise = rng.standard_normal(size=img.shape, dtype=np.float32)
        noise *= np.float32(image_noise)
        noise += img
        noise += np.float32(0.5)
        img = np.clip(noise, 0, 255, out=noise).astype(np.uint8)
    return img, res.depth


# --------------------------------------------------------------------------- truth


def resample_polyline(P: np.ndarray, step: float, closed: bool = False) -> np.ndarray:
    """(M, 3) points every ``step`` mm along the polyline ``P`` (N, 3), ends included."""
    P = np.asarray(P, dtype=np.float64)
    if closed:
        P = np.vstack([P, P[:1]])
    if len(P) < 2:
        return P.copy()
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(int(math.ceil(s[-1] / step)), 1)
    t = np.linspace(0.0, s[-1], n + 1)
    if closed:
        t = t[:-1]
    return np.column_stack([np.interp(t, s, P[:, k]) for k in range(3)])


def truth_curves(model: FaceModel, V: np.ndarray) -> dict[str, np.ndarray]:
    """SPEC §5 curve name -> (L, 3) true polyline (vertex path on the true mesh)."""
    return {name: V[np.asarray(path, dtype=np.int64)]
            for name, path in model.curve_vertices.items()}


def boundary_points(curve: np.ndarray, closed: bool, camera: Camera,
                    depth: np.ndarray) -> np.ndarray:
    """(M, 2) visible pixels of a 3D curve resampled every 0.5 mm (module docstring)."""
    P = resample_polyline(curve, BOUNDARY_STEP_MM, closed)
    vis = visible_points(P, camera, depth, tol_mm=1.0)
    return camera.project(P[vis]) if vis.any() else np.zeros((0, 2))


def _arc_midpoint(uv: np.ndarray) -> tuple[np.ndarray, int, float]:
    """Point halfway along a 2D polyline (by length): (2,), segment index, fraction."""
    seg = np.linalg.norm(np.diff(uv, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    half = 0.5 * s[-1]
    i = int(np.clip(np.searchsorted(s, half) - 1, 0, len(seg) - 1))
    f = (half - s[i]) / seg[i] if seg[i] > 0 else 0.0
    return uv[i] + f * (uv[i + 1] - uv[i]), i, f


def helper_points(model: FaceModel, V: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The true 3D polyline pieces of the bottom curve from alp_x to prn, per helper id."""
    path = np.asarray(model.curve_vertices["bottom"], dtype=np.int64)
    lv = model.landmark_vertices
    out = {}
    for side in ("l", "r"):
        a = np.flatnonzero(path == lv[f"alp_{side}"])
        b = np.flatnonzero(path == lv["prn"])
        if a.size == 0 or b.size == 0:
            continue
        i, j = sorted((int(a[0]), int(b[0])))
        out[f"add_{side}"] = (V[path[i:j + 1]], path[i:j + 1])
    return out


# --------------------------------------------------------------------------- case


def _streams(seed: int) -> dict[str, np.random.Generator]:
    names = ("identity", "rig", "appearance", "clicks", "sensor")
    seqs = np.random.SeedSequence(int(seed)).spawn(len(names))
    return {n: np.random.default_rng(s) for n, s in zip(names, seqs, strict=True)}


def synthesize_case(out_dir: str | os.PathLike[str], model: FaceModel, seed: int = 0,
                    noise_px: float = 1.5, size: int = DEFAULT_SIZE,
                    image_noise: float = 2.0, write_focal: bool = False) -> Path:
    """Render one synthetic case with ground truth into ``out_dir`` (module docstring).

    Args:
        out_dir: case directory (created).
        model: face model of the identity (``load_face_model``).
        seed: random seed; the same seed gives the same files.
        noise_px: click noise, standard deviation per axis (px).
        size: photo width = height (px).
        image_noise: sensor noise, standard deviation in grey levels (0 = none).
        write_focal: also give each view's true focal length in ``case.json``
            (``"camera": {"focal_px": f}``, as a phone's EXIF would).
    Returns:
        path of the written ``case.json``.
    """
    from naseview.measurements import clinical_measurements
    from naseview.meshio import export_mesh
    from naseview.reconstruction import Reconstruction

    if not model.curve_vertices:
        raise NaseviewError(f"face model {model.name!r}: no curve_vertices; synthetic "
                            "ground truth needs the SPEC §5 curve paths")
    if size < 64:
        raise NaseviewError(f"--size {size}: photos must be at least 64 px")
    if noise_px < 0 or image_noise < 0:
        raise NaseviewError("--noise-px and --image-noise must be >= 0")
    out = Path(out_dir)
    rs = _streams(seed)
    V, w = sample_identity(model, rs["identity"])
    F = np.asarray(model.faces, dtype=np.int64)
    cams, rig_info = sample_rig(V, model, rs["rig"], size)
    scene, look = build_scene(model, V, rs["appearance"])
    arng = rs["appearance"]
    bg = np.array(BACKDROPS_BGR[int(arng.integers(len(BACKDROPS_BGR)))], dtype=float)
    bg = tuple(int(v) for v in np.clip(bg + arng.uniform(-8, 8, size=3), 0, 255))
    key = np.array([arng.uniform(-0.6, -0.3), arng.uniform(-0.7, -0.4), -1.0])
    fill = np.array([arng.uniform(0.4, 0.8), arng.uniform(-0.2, 0.1), -1.0])
    lights = np.stack([key, fill])
    look.update({"background_bgr": list(bg), "light_dirs_camera": lights.tolist()})

    lv = model.landmark_vertices
    true_lm = {k: V[lv[k]].copy() for k in LANDMARK_IDS}
    curves = truth_curves(model, V)
    helpers = helper_points(model, V)
    images: dict[str, np.ndarray] = {}
    views: dict[str, View] = {}
    boundaries: dict[str, dict[str, list[list[float]]]] = {}
    crng = rs["clicks"]
    contour_px = max(1, int(round(CONTOUR_RADIUS_PX * size / DEFAULT_SIZE)))
    for view in VIEWS:
        cam = cams[view]
        img, depth = render_photo(scene, cam, bg, rs["sensor"], image_noise, lights)
        images[view] = img
        clicks: dict[str, np.ndarray] = {}
        ids = list(VIEW_LANDMARKS[view])
        noise = crng.normal(0.0, noise_px, size=(len(ids), 2))   # one draw per id: stable
        X = np.zeros((len(ids), 3))
        known = np.zeros(len(ids), dtype=bool)
        for k, lid in enumerate(ids):
            if lid in helpers:
                P3, _ = helpers[lid]
                _, i, f = _arc_midpoint(cam.project(P3))
                X[k] = P3[i] + f * (P3[i + 1] - P3[i]) if len(P3) > 1 else P3[0]
                known[k] = True
            elif lid in true_lm:
                X[k] = true_lm[lid]
                known[k] = True
        vis = known & visible_points(X, cam, depth, VISIBILITY_TOL_MM, contour_px)
        uv = cam.project(X) + noise
        m = CLICK_MARGIN_PX
        inside = np.all((uv >= m) & (uv <= size - 1 - m), axis=1)
        for k in np.flatnonzero(vis & inside):
            clicks[ids[k]] = np.round(uv[k], 3)
        camera_json = {"focal_px": round(cam.focal_px, 3)} if write_focal else None
        views[view] = View(view, f"{view}.jpg", clicks, size, size, camera_json)
        for name, vlist in TRUTH_CURVE_VIEWS.items():
            if view in vlist and name in curves:
                pts = boundary_points(curves[name], name in CLOSED_CURVES, cam, depth)
                boundaries.setdefault(name, {})[view] = np.round(pts, 3).tolist()

    al = float(np.linalg.norm(true_lm["al_l"] - true_lm["al_r"]))
    case = Case(root=out, id=f"synth-{model.name}-{seed}", views=views,
                scale_mm={("al_l", "al_r"): round(al, 4)},
                notes=f"synthetic case: naseview synth --model {model.name} --seed {seed} "
                      f"--noise-px {noise_px:g} --size {size} --image-noise {image_noise:g}")
    synth_info = {
        "seed": int(seed), "model": model.name, "credit": model.credit,
        "noise_px": float(noise_px), "image_noise": float(image_noise), "size": int(size),
        "identity_coefficients": w.tolist(), "rig": rig_info, "appearance": look,
        "view_landmarks": {k: list(v) for k, v in VIEW_LANDMARKS.items()},
        "truth_curve_views": {k: list(v) for k, v in TRUTH_CURVE_VIEWS.items()},
    }
    rec = Reconstruction(
        landmarks=true_lm, cameras=cams, curves=curves,
        measurements=clinical_measurements(true_lm, curves, V, F),
        extra={"synth": synth_info,
               "nose_vertex_ids": np.asarray(model.nose_vertices, dtype=int).tolist()})
    out.mkdir(parents=True, exist_ok=True)
    export_mesh(out / "truth_face.ply", V, F)
    atomic_write_json(out / "truth_boundaries.json", boundaries)
    atomic_write_json(out / "truth.json", rec.to_json())
    return write_case(case, out, images)


def synth_command(args: argparse.Namespace) -> int:
    """``naseview synth OUT_DIR [--model M] [--seed S] [--batch N] ...``."""
    from naseview.facemodel import load_face_model

    model = load_face_model(args.model)
    size = int(getattr(args, "size", DEFAULT_SIZE))
    noise_px = float(getattr(args, "noise_px", 1.5))
    image_noise = float(getattr(args, "image_noise", 2.0))
    seed = int(getattr(args, "seed", 0))
    batch = int(getattr(args, "batch", 0) or 0)
    if batch < 0:
        raise NaseviewError("--batch must be >= 0")
    out = Path(args.out_dir)
    if batch:
        for i in range(batch):
            path = synthesize_case(out / f"case-{i:03d}", model, seed + i, noise_px, size,
                                   image_noise)
            print(path.parent)
    else:
        path = synthesize_case(out, model, seed, noise_px, size, image_noise)
        print(path.parent)
    if model.name == "ict" or "ICT" in model.credit:
        print("face model: ICT Face Model (USC Institute for Creative Technologies, MIT)")
    return 0
