"""Nose surface error by anatomical region, and the error colour map of a case.

The regions are defined from the **truth landmarks** alone (SPEC frame: +x subject's left,
+y up, +z anterior), so they work on any truth mesh (a face model's, a face scan or a
whole head). The nose is the SPEC §6 nose region of the surface error
(:func:`naseview.testbed.surface.nose_region`: the box from the truth landmarks, the
forward-facing triangles), cavities included. A point of it with unit surface normal
``n`` is, in this order of precedence:

1. ``nostril interior``: ambient occlusion above 0.6 (the cavities; the SPEC §6 headline
   figure leaves them out, this region shows them separately);
2. ``columella/sill``: the underside: ``n_y < -0.5`` (facing down) and below the level of
   alp (mean height of alp_l, alp_r);
3. ``tip lobule``: within ``|prn - alp|`` (mean of both sides) of prn, or below the
   level of int (that side's int) and no further from the midline than md (that side's
   ``|x(md)|``);
4. ``alae``: below the level of int, further from the midline than md;
5. ``dorsum``: no further from the midline than 30 % of that side's ``|x(int)|``;
6. ``sidewalls``: the rest (between dorsum and cheek, above the alae, and the alar-facial
   grooves' upper part).

Each region's error is the SPEC §6 distance of its samples to the rigidly aligned
reconstruction. :func:`error_map_png` paints the per-vertex error on the truth mesh seen
from the front, the (left) profile and below, with a colour bar in mm.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2
import igl
import numpy as np

from naseview.camera import orbit_camera
from naseview.geometry.alignment import umeyama
from naseview.landmarks import LANDMARK_IDS
from naseview.render import render_mesh
from naseview.testbed.surface import MAX_OCCLUSION, nose_region, sample_triangles

REGIONS: tuple[str, ...] = ("dorsum", "tip lobule", "sidewalls", "alae", "columella/sill",
                            "nostril interior")
"""Region names, in report order (module docstring for the definitions)."""

INTERIOR_OCCLUSION = MAX_OCCLUSION
"""Ambient occlusion above which a point is nostril interior (the SPEC §6 limit)."""

DORSUM_FRACTION = 0.3
"""The dorsum's half-width as a fraction of |x(int)| on that side."""

MAP_MAX_MM = 3.0
"""Top of the colour scale of the error map (mm); larger errors show its colour."""


def _side(lm: Mapping[str, np.ndarray], name: str, x: np.ndarray) -> np.ndarray:
    """(N, 3) the landmark ``name_l`` where x >= 0, else ``name_r``."""
    left, right = np.asarray(lm[f"{name}_l"], float), np.asarray(lm[f"{name}_r"], float)
    return np.where((x >= 0)[:, None], left, right)


def classify(P: np.ndarray, N: np.ndarray, occlusion: np.ndarray,
             landmarks: Mapping[str, np.ndarray]) -> np.ndarray:
    """(n,) region index into :data:`REGIONS` of points P (n, 3) with unit normals N (n, 3)
    and ambient occlusion (n,) (module docstring)."""
    lm = {k: np.asarray(v, float) for k, v in landmarks.items()}
    x, y = P[:, 0] - lm["prn"][0], P[:, 1]
    ax = np.abs(x)
    y_alp = 0.5 * (lm["alp_l"][1] + lm["alp_r"][1])
    r_tip = 0.5 * (np.linalg.norm(lm["prn"] - lm["alp_l"]) + np.linalg.norm(lm["prn"]
                                                                           - lm["alp_r"]))
    integ, md = _side(lm, "int", x), _side(lm, "md", x)
    below_int = y < integ[:, 1]
    inner = ax <= np.abs(md[:, 0] - lm["prn"][0])
    out = np.full(len(P), REGIONS.index("sidewalls"))
    out[ax <= DORSUM_FRACTION * np.abs(integ[:, 0] - lm["prn"][0])] = REGIONS.index("dorsum")
    out[below_int & ~inner] = REGIONS.index("alae")
    tip = (np.linalg.norm(P - lm["prn"], axis=1) <= r_tip) | (below_int & inner)
    out[tip] = REGIONS.index("tip lobule")
    out[(N[:, 1] < -0.5) & (y < y_alp)] = REGIONS.index("columella/sill")
    out[occlusion > INTERIOR_OCCLUSION] = REGIONS.index("nostril interior")
    return out


def region_samples(V: np.ndarray, F: np.ndarray, landmarks: Mapping[str, np.ndarray],
                   n_samples: int = 20000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Area-uniform points of the whole SPEC §6 nose region (cavities included) and their
    region: ((n, 3) points, (n,) region index). Empty when no triangle is in the region.

    Raises:
        NaseviewError: a landmark bounding the region is missing (naming truth.json).
    """
    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    reg = nose_region(V, F, landmarks)
    if not len(reg.triangles):
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    P, k = sample_triangles(V, F, reg.triangles, reg.area, n_samples, seed)
    return P, classify(P, reg.normals[k], reg.occlusion[k], landmarks)


def _aligned(V: np.ndarray, landmarks: Mapping[str, np.ndarray],
             truth_landmarks: Mapping[str, np.ndarray]) -> np.ndarray:
    """The reconstruction moved rigidly onto the truth (Kabsch on shared landmarks)."""
    common = [k for k in LANDMARK_IDS if k in truth_landmarks and k in landmarks]
    X = np.array([np.asarray(landmarks[k], float) for k in common])
    Y = np.array([np.asarray(truth_landmarks[k], float) for k in common])
    _, R, t = umeyama(X, Y, with_scale=False)
    return np.ascontiguousarray(np.asarray(V, float) @ R.T + t)


def _distances(P: np.ndarray, Va: np.ndarray, F: np.ndarray) -> np.ndarray:
    d2, _, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(P, np.float64), Va,
                                               np.ascontiguousarray(F, np.int64))
    return np.asarray(np.sqrt(d2))


def region_errors(truth_V: np.ndarray, truth_F: np.ndarray,
                  truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray, F: np.ndarray,
                  landmarks: Mapping[str, np.ndarray],
                  samples: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> dict[str, dict[str, float]]:
    """Region name -> ``{"mean_mm", "p95_mm", "fraction"}`` (fraction: of the nose area)
    of the truth-to-reconstruction distance after rigid landmark alignment."""
    P, lab = samples if samples is not None else region_samples(truth_V, truth_F,
                                                                truth_landmarks)
    d = _distances(P, _aligned(V, landmarks, truth_landmarks), F)
    out: dict[str, dict[str, float]] = {}
    for i, name in enumerate(REGIONS):
        m = lab == i
        if m.any():
            out[name] = {"mean_mm": float(d[m].mean()), "p95_mm": float(np.percentile(d[m], 95)),
                         "fraction": float(m.mean())}
    return out


def _colour(err: np.ndarray) -> np.ndarray:
    """(n, 3) BGR in [0, 1]: the error on a 0..MAP_MAX_MM turbo scale."""
    t = np.clip(err / MAP_MAX_MM, 0, 1)
    lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8)[:, None], cv2.COLORMAP_TURBO)
    return np.asarray(lut[(t * 255).astype(int), 0] / 255.0)


def _colour_bar(height: int) -> np.ndarray:
    """(height, 90, 3) uint8 vertical colour bar 0..MAP_MAX_MM mm with tick labels."""
    bar = np.full((height, 90, 3), 255, np.uint8)
    top, bot = 30, height - 20
    vals = np.linspace(MAP_MAX_MM, 0, bot - top)
    bar[top:bot, 10:30] = (_colour(vals)[:, None, :] * 255).astype(np.uint8)
    for v in np.arange(0, MAP_MAX_MM + 1e-9, 0.5):
        yy = int(bot - 1 - v / MAP_MAX_MM * (bot - top - 1))
        cv2.line(bar, (30, yy), (36, yy), (0, 0, 0), 1)
        label = f"{v:.1f}" + ("+" if v >= MAP_MAX_MM else "")
        cv2.putText(bar, label, (38, yy + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1,
                    cv2.LINE_AA)
    cv2.putText(bar, "mm", (38, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return bar


def error_map_png(path: str | os.PathLike[str], truth_V: np.ndarray, truth_F: np.ndarray,
                  truth_landmarks: Mapping[str, np.ndarray], V: np.ndarray, F: np.ndarray,
                  landmarks: Mapping[str, np.ndarray], title: str = "",
                  size: int = 360) -> Path:
    """Write the error colour map of one case: the truth mesh, each vertex of the nose
    coloured by its distance to the aligned reconstruction (grey outside the SPEC §6 nose
    region, cavities included), from
    the front, the left profile and below, with a colour bar in mm. Returns the path."""
    from naseview.imagefile import write_image

    tV = np.asarray(truth_V, float)
    tF = np.asarray(truth_F, np.int64)
    lm = {k: np.asarray(v, float) for k, v in truth_landmarks.items()}
    nose = np.zeros(len(tV), bool)
    nose[tF[nose_region(tV, tF, lm).triangles].ravel()] = True
    err = np.zeros(len(tV))
    if nose.any():
        err[nose] = _distances(tV[nose], _aligned(V, landmarks, truth_landmarks), F)
    C = np.full((len(tV), 3), 0.78)
    C[nose] = _colour(err[nose])
    centre = 0.5 * (lm["n"] + lm["sn"])
    field = 2.2 * float(np.linalg.norm(lm["n"] - lm["sn"]))
    panels = []
    for name, d in (("front", (0, 0, 1)), ("profile (left)", (1, 0, 0.05)),
                    ("below", (0, -0.8, 0.6))):
        cam = orbit_camera(centre, d, 500.0, field, size)
        img = render_mesh(tV, tF, cam, vertex_colors=C, ambient=0.55, specular=0.0,
                          background=(255, 255, 255), supersample=2,
                          cull_backfaces=True).image
        cv2.putText(img, name, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1,
                    cv2.LINE_AA)
        panels.append(img)
    row = np.concatenate([*panels, _colour_bar(size)], axis=1)
    head = np.full((28, row.shape[1], 3), 255, np.uint8)
    cv2.putText(head, f"nose surface error {title}", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                (0, 0, 0), 1, cv2.LINE_AA)
    return write_image(Path(path), np.concatenate([head, row], axis=0))


def regions_summary(cases: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Region -> mean over cases of its mean and p95 (cases without the region skipped)."""
    out = {}
    for name in REGIONS:
        vals = [c[name] for c in cases if name in c]
        if vals:
            out[name] = {"mean_mm": float(np.mean([v["mean_mm"] for v in vals])),
                         "p95_mm": float(np.mean([v["p95_mm"] for v in vals])),
                         "fraction": float(np.mean([v["fraction"] for v in vals]))}
    return out
