"""Where the eyes and the mouth of a face mesh are (what the painting needs to know).

A mask with eye holes gives the eyes (hole centres above prn, off the midline) and the
mouth (a hole below sn near the midline); a mesh without holes gets estimated positions,
the cornea of a mesh that models its eyes (:func:`~naseview.testbed.synth.eyes.
modelled_eyes`), and the mouth line as the deepest midline crease about 21 mm below sn.
All lengths scale with the face: ``scale`` = alar width / 35 mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from naseview.facemodel import FaceModel
from naseview.facemodel.meshcurves import mean_curvature, region_boundary_loops
from naseview.testbed.synth.eyes import modelled_eyes


@dataclass(frozen=True)
class FaceFeatures:
    """Eyes and mouth of one face (SPEC frame, mm).

    Attributes:
        eye_center: side ``"l"`` / ``"r"`` -> (3,) eye centre.
        eye_loops: side -> vertex ids of the eye-hole loop (holes only).
        eye_weights: side -> ((V,) fissure indicator, (V,) distance to the cornea centre)
            of a mesh that models its eyes (empty otherwise).
        mouth_loop: vertex ids of the mouth hole, or None.
        mouth_center: (3,) centre of the mouth line.
        mouth_half_width: half the mouth width (mm).
        scale: alar width / 35 mm.
        mean_curvature: (V,) mean curvature (1/mm, < 0 in creases), smoothed.
    """

    eye_center: dict[str, np.ndarray]
    eye_loops: dict[str, np.ndarray]
    eye_weights: dict[str, tuple[np.ndarray, np.ndarray]]
    mouth_loop: np.ndarray | None
    mouth_center: np.ndarray
    mouth_half_width: float
    scale: float
    mean_curvature: np.ndarray


def _holes(V: np.ndarray, F: np.ndarray, P: dict[str, np.ndarray], scale: float
           ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray | None]:
    """Eye-hole centres and loops per side and the mouth loop, from the mesh's inner
    boundary loops (the first loop, the outer border, is skipped)."""
    eyes: dict[str, np.ndarray] = {}
    eye_loops: dict[str, np.ndarray] = {}
    mouth = None
    for loop in region_boundary_loops(F, np.arange(len(V)))[1:]:
        c = V[loop].mean(axis=0)
        if len(loop) < 8:
            continue
        if c[1] > P["prn"][1] and abs(c[0]) > 12.0 * scale:
            s = "l" if c[0] > 0 else "r"
            eyes[s] = c
            eye_loops[s] = loop
        elif c[1] < P["sn"][1] and abs(c[0]) < 10.0 * scale and mouth is None:
            mouth = loop
    return eyes, eye_loops, mouth


def _eye_centres(V: np.ndarray, P: dict[str, np.ndarray], scale: float,
                 holes: dict[str, np.ndarray],
                 weights: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, np.ndarray]:
    """Per side: the hole centre, else the modelled cornea vertex, else an estimate
    beside the nasion."""
    est = {
        "l": np.array([31.0 * scale, P["n"][1] - 6.0 * scale, P["n"][2] - 14.0 * scale]),
        "r": np.array([-31.0 * scale, P["n"][1] - 6.0 * scale, P["n"][2] - 14.0 * scale]),
    }
    for side, (_, r) in weights.items():
        est[side] = V[int(np.argmin(r))]
    return {s: holes.get(s, est[s]) for s in ("l", "r")}


def _mouth(V: np.ndarray, P: dict[str, np.ndarray], scale: float, loop: np.ndarray | None,
           H: np.ndarray) -> tuple[np.ndarray, float]:
    """(3,) mouth centre and half width: of the mouth hole, else the deepest crease on
    the midline about 21 mm below sn (24 mm wide each side)."""
    if loop is not None:
        M = V[loop]
        return M.mean(axis=0), 0.5 * float(M[:, 0].max() - M[:, 0].min())
    mouth_c = P["sn"] + np.array([0.0, -21.0, -2.0]) * scale
    near = np.flatnonzero((np.abs(V[:, 0] - P["sn"][0]) < 3.0 * scale)
                          & (np.abs(V[:, 1] - mouth_c[1]) < 7.0 * scale)
                          & (V[:, 2] > mouth_c[2] - 10.0 * scale))
    if near.size:
        mouth_c = V[near[np.argmin(H[near])]].copy()
    return mouth_c, 24.0 * scale


def face_features(V: np.ndarray, F: np.ndarray, model: FaceModel) -> FaceFeatures:
    """Eye and mouth positions of the face ``V`` (V, 3), ``F`` (F, 3) (module docstring)."""
    P = {k: V[i] for k, i in model.landmark_vertices.items()}
    scale = float(np.linalg.norm(P["al_l"] - P["al_r"])) / 35.0
    eyes, eye_loops, mouth = _holes(V, F, P, scale)
    eye_weights = modelled_eyes(model) if not eye_loops else {}
    H = mean_curvature(V, F, smooth_iterations=4)
    mouth_c, mouth_hw = _mouth(V, P, scale, mouth, H)
    return FaceFeatures(_eye_centres(V, P, scale, eyes, eye_weights), eye_loops, eye_weights,
                        mouth, mouth_c, mouth_hw, scale, H)
