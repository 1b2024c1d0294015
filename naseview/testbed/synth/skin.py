"""Skin, lips, eyebrows, hair, creases and nostrils: the albedo of the face vertices.

A random skin tone from light to dark with smooth low-frequency variation, a redder nose
tip and cheeks, vermilion lips around the mouth line, arched eyebrows above the eyes,
hair above a hairline, creases darkened by a cavity term from the mean curvature (1/mm,
< 0 in creases) and nostril vertices (``model.nostril_vertices``) nearly black. Colours
are BGR in [0, 1]; every random draw comes from the appearance stream, in a fixed order.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from naseview.facemodel import FaceModel
from naseview.geometry.mesh import vertex_adjacency
from naseview.testbed.synth.blend import smoothstep
from naseview.testbed.synth.features import FaceFeatures

SKIN_TONES_RGB: tuple[tuple[float, float, float], ...] = (
    (243, 214, 196), (226, 185, 160), (205, 160, 128), (176, 128, 95), (141, 98, 70),
    (104, 70, 50), (78, 52, 38),
)
"""Skin albedo anchors from light to dark (RGB 0-255); a case picks a point between two."""

HAIR_RGB: tuple[tuple[float, float, float], ...] = (
    (22, 18, 16), (45, 32, 24), (80, 56, 38), (120, 90, 60), (170, 140, 95), (150, 145, 140),
)
"""Hair colour anchors (RGB 0-255)."""


def hair_weight(P: np.ndarray, scale: float, hairline_mm: float) -> np.ndarray:
    """(N,) in [0, 1]: how much each point (N, 3) is hair (scalp above a hairline raised
    by ``hairline_mm``, SPEC frame)."""
    s = scale
    lon = np.degrees(np.abs(np.arctan2(P[:, 0], P[:, 2] + 85.0 * s)))
    hairline = np.interp(lon, [0, 30, 55, 80, 105, 125, 180],
                         [0.0, -2.0, -12.0, -18.0, -20.0, -100.0, -125.0]) * s
    return smoothstep((P[:, 1] - hairline - hairline_mm) / (6.0 * s))


def _tone_variation(V: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(V,) relative brightness change: eight soft random blobs (+-5 %)."""
    lo, hi = V.min(axis=0), V.max(axis=0)
    bright = np.zeros(len(V))
    for _ in range(8):
        c = rng.uniform(lo, hi)
        sig = rng.uniform(15.0, 40.0)
        bright += rng.uniform(-0.05, 0.05) * np.exp(-np.sum((V - c) ** 2, axis=1)
                                                    / (2 * sig * sig))
    return bright


def _redness(V: np.ndarray, P: dict[str, np.ndarray], s: float) -> np.ndarray:
    """(V,) weight of the redder nose tip and cheeks."""
    redness = 1.0 * np.exp(-np.sum((V - P["prn"]) ** 2, axis=1) / (2 * (11.0 * s) ** 2))
    for side, sign in (("l", 1.0), ("r", -1.0)):
        cheek = P[f"ac_{side}"] + np.array([sign * 28.0, 10.0, -8.0]) * s
        redness += 0.9 * np.exp(-np.sum((V - cheek) ** 2, axis=1) / (2 * (17.0 * s) ** 2))
    return redness


def _mouth_line(V: np.ndarray, feats: FaceFeatures) -> np.ndarray:
    """(V,) height (y, mm) of the mouth line above each vertex's x: along the mouth hole,
    else level with the mouth centre."""
    loop = feats.mouth_loop
    if loop is None:
        return np.full(len(V), feats.mouth_center[1])
    L = V[loop]
    xs = np.linspace(L[:, 0].min(), L[:, 0].max(), 9)
    ys = [L[np.abs(L[:, 0] - x) <= 0.7 * (xs[1] - xs[0]), 1].mean() for x in xs]
    return np.interp(V[:, 0], xs, ys)


def _lips(V: np.ndarray, feats: FaceFeatures, A: sp.csr_matrix, deg: np.ndarray) -> np.ndarray:
    """(V,) lip weight: vermilion bands above and below the mouth line, soft edges."""
    s = feats.scale
    m = feats.mouth_center
    u = np.abs(V[:, 0] - m[0]) / max(feats.mouth_half_width, 1e-6)
    dy = (V[:, 1] - _mouth_line(V, feats)) / s
    arc = np.sqrt(np.clip(1.0 - u ** 2, 0.0, 1.0))
    w_up = smoothstep((8.0 * arc + 0.5 - dy) / 2.0) * (dy >= -0.5)
    w_lo = smoothstep((10.0 * arc + 0.5 + dy) / 2.0) * (dy < -0.5)
    lip = np.maximum(w_up, w_lo) * smoothstep((1.08 - u) / 0.2)
    lip *= smoothstep((V[:, 2] - (m[2] - 14.0 * s)) / (4.0 * s))
    if feats.mouth_loop is not None:
        d, _ = cKDTree(V[feats.mouth_loop]).query(V)
        lip *= smoothstep((15.0 * s - d) / (3.0 * s))
    for _ in range(2):                       # soften the vertex-sampled border
        lip = 0.5 * lip + 0.5 * (A @ lip) / deg
    return lip


def _brows(V: np.ndarray, N: np.ndarray, feats: FaceFeatures) -> np.ndarray:
    """(V,) eyebrow weight: an arched band above each eye, on front-facing skin."""
    s = feats.scale
    brow = np.zeros(len(V))
    for side, sign in (("l", 1.0), ("r", -1.0)):
        e = feats.eye_center[side]
        uu = (V[:, 0] - e[0]) * sign / s                # lateral positive, mm
        vv = (V[:, 1] - e[1]) / s
        centre = 15.0 + 3.0 * np.exp(-((uu - 2.0) / 14.0) ** 2) - 0.01 * np.maximum(uu, 0) ** 2
        half = np.interp(uu, [-17.0, -10.0, 10.0, 24.0], [1.5, 4.0, 3.2, 0.8])
        along = smoothstep((uu + 17.0) / 4.0) * smoothstep((25.0 - uu) / 5.0)
        w = along * smoothstep((half - np.abs(vv - centre)) / 3.0 + 0.5)
        brow = np.maximum(brow, w)
    return brow * smoothstep((N[:, 2] - 0.1) / 0.3)


def _nostrils(model: FaceModel, n: int, A: sp.csr_matrix, deg: np.ndarray) -> np.ndarray:
    """(V,) nostril weight, its border rounded by one averaging step over the edges."""
    dark = np.zeros(n)
    dark[model.nostril_vertices] = 1.0
    avg = (A @ dark) / deg
    return np.maximum(dark * smoothstep((avg - 0.2) / 0.5), 0.0)


def skin_colors(V: np.ndarray, N: np.ndarray, model: FaceModel, feats: FaceFeatures,
                hairline_mm: float, tone: np.ndarray, hair: np.ndarray,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) BGR albedo and (V,) specular multiplier of the face-model vertices.

    Args:
        V: (V, 3) face (mm); N: (V, 3) its unit normals.
        model: gives the landmarks, triangles and nostrils.
        feats: eyes and mouth; hairline_mm: the case's hairline offset.
        tone: (3,) skin albedo BGR; hair: (3,) hair albedo BGR.
        rng: the appearance stream (10 draws per blob and one for the redness).
    """
    P = {k: V[i] for k, i in model.landmark_vertices.items()}
    s = feats.scale
    C = np.tile(tone, (len(V), 1))
    C *= (1.0 + _tone_variation(V, rng))[:, None]
    red = np.array([-0.03, -0.05, 0.05])            # BGR shift towards red
    C += rng.uniform(0.5, 1.0) * _redness(V, P, s)[:, None] * red * (0.4 + tone.mean())
    A = vertex_adjacency(len(V), model.faces)
    deg = np.maximum(np.asarray(A.sum(axis=1)).ravel(), 1)
    lip = _lips(V, feats, A, deg)
    lip_col = tone * np.array([0.72, 0.68, 0.88])
    C = C * (1 - 0.7 * lip[:, None]) + 0.7 * lip[:, None] * lip_col
    brow = _brows(V, N, feats)
    C = C * (1 - 0.65 * brow[:, None]) + 0.65 * brow[:, None] * hair
    hairw = hair_weight(V, s, hairline_mm)
    C = C * (1 - hairw[:, None]) + hairw[:, None] * hair
    # creases (alar groove, nasolabial fold, lid creases) catch less light: baked cavity
    # occlusion from the mean curvature
    C *= np.clip(1.0 + 1.5 * np.minimum(feats.mean_curvature, 0.0), 0.78, 1.0)[:, None]
    dark = _nostrils(model, len(V), A, deg)
    C = C * (1 - dark[:, None]) + dark[:, None] * (tone * 0.07)
    spec = np.ones(len(V))
    spec += 0.6 * np.exp(-np.sum((V - P["prn"]) ** 2, axis=1) / (2 * (9.0 * s) ** 2))
    spec = spec * (1 - 0.7 * hairw) * (1 - 0.5 * brow) * (1 - dark)
    return np.clip(C, 0.0, 1.0), spec
