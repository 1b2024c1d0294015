"""Everything a synthetic photo shows: the face, a head behind it, eyes (SPEC §7 test bed).

The face mesh (back faces culled when rendered) is closed by a head proxy behind it
(:mod:`~naseview.testbed.synth.head`, with hair on top and at the back) and, when the mask
has eye holes, two eyeballs; a mesh that models the eyes (the generic face) gets them
painted on (:mod:`~naseview.testbed.synth.eyes`). The skin is
:mod:`~naseview.testbed.synth.skin`. :func:`build_scene` draws the case's appearance
(hairline, skin tone, hair and iris colour) from the appearance stream first, in that
order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from naseview.facemodel import FaceModel
from naseview.geometry.mesh import vertex_normals
from naseview.testbed.synth.blend import interp_rgb
from naseview.testbed.synth.eyes import IRIS_RGB, eyeball, paint_modelled_eyes, refine_around_eyes
from naseview.testbed.synth.features import FaceFeatures, face_features
from naseview.testbed.synth.head import head_proxy
from naseview.testbed.synth.skin import HAIR_RGB, SKIN_TONES_RGB, hair_weight, skin_colors


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
        normals: (N, 3) unit vertex normals.
    """

    V: np.ndarray
    F: np.ndarray
    colors: np.ndarray
    specular: np.ndarray
    n_face: int
    normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


@dataclass(frozen=True)
class Appearance:
    """The case's draw of colours.

    Attributes:
        hairline_mm: how far the hairline is raised (mm).
        skin_tone: 0 (light) .. 1 (dark), position along the skin palette.
        tone: (3,) skin albedo, BGR in [0, 1]; hair, iris: (3,) likewise.
    """

    hairline_mm: float
    skin_tone: float
    tone: np.ndarray
    hair: np.ndarray
    iris: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """The ``appearance`` record of ``truth.json`` (before backdrop and lights)."""
        return {"skin_tone": float(self.skin_tone), "hairline_mm": self.hairline_mm,
                "skin_bgr": self.tone.tolist(), "hair_bgr": self.hair.tolist(),
                "iris_bgr": self.iris.tolist()}


def draw_appearance(rng: np.random.Generator, scale: float) -> Appearance:
    """Hairline, skin tone (with a +-4 % jitter per channel), hair and iris colour; darker
    skin takes from the darker hair and iris colours."""
    hairline_mm = float(rng.uniform(42.0, 60.0)) * scale
    t_skin = float(rng.uniform(0.0, 1.0))
    tone = interp_rgb(SKIN_TONES_RGB, t_skin) * rng.uniform(0.96, 1.04, size=3)
    hair = interp_rgb(HAIR_RGB, float(rng.uniform(0, 1))) if t_skin < 0.5 else \
        interp_rgb(HAIR_RGB[:3], float(rng.uniform(0, 1)))
    iris = interp_rgb(IRIS_RGB, float(rng.uniform(0, 1))) if t_skin < 0.45 else \
        interp_rgb(IRIS_RGB[:2], float(rng.uniform(0, 1)))
    return Appearance(hairline_mm, t_skin, tone, hair, iris)


MeshPart = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""(V (n, 3), F (m, 3) local ids, colours (n, 3), specular (n,), normals (n, 3))."""


def _face_part(model: FaceModel, V: np.ndarray, F: np.ndarray, feats: FaceFeatures,
               look: Appearance, rng: np.random.Generator) -> MeshPart:
    """The face with its skin; finer around painted eyes when the mesh models them."""
    N = vertex_normals(V, F)
    C, spec = skin_colors(V, N, model, feats, look.hairline_mm, look.tone, look.hair, rng)
    if not feats.eye_weights:
        return V, F, C, spec, N
    Fv, (Mf, Vf, Nf, Cf, Sf) = refine_around_eyes(
        F, np.asarray(model.mean, dtype=float), [V, N, C, spec[:, None]])
    Nf = Nf / np.linalg.norm(Nf, axis=1, keepdims=True)
    Cf, Sf1 = paint_modelled_eyes(Mf[:, :2], Nf, Cf, Sf[:, 0], look.iris)
    return Vf, Fv, Cf, Sf1, Nf


def _head_part(V: np.ndarray, F: np.ndarray, feats: FaceFeatures,
               look: Appearance) -> MeshPart:
    """The head proxy: skin, hair above the hairline, a dark mouth in the mouth hole."""
    PV, PF, hole_w = head_proxy(V, F, feats.scale)
    hw = hair_weight(PV, feats.scale, look.hairline_mm)
    pc = np.tile(look.tone, (len(PV), 1))
    pc = pc * (1 - hw[:, None]) + hw[:, None] * look.hair
    mouth_dark = np.array([0.10, 0.10, 0.22]) * (0.5 + look.tone.mean())
    pc = pc * (1 - hole_w[:, None]) + hole_w[:, None] * mouth_dark
    pspec = (1 - 0.7 * hw) * (1 - hole_w)
    return PV, PF, pc, pspec, vertex_normals(PV, PF)


def _eyeball_parts(V: np.ndarray, feats: FaceFeatures, look: Appearance) -> list[MeshPart]:
    """One eyeball behind each eye hole (none for a mesh without holes)."""
    parts = []
    for side in ("l", "r"):
        loop = feats.eye_loops.get(side)
        if loop is None:
            continue
        EV, EF, EC, ES = eyeball(V[loop], look.iris, feats.scale)
        parts.append((EV, EF, EC, ES, vertex_normals(EV, EF)))
    return parts


def _join(parts: list[MeshPart]) -> Scene:
    """One scene from its parts (face first), triangle ids shifted to the joined mesh."""
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    return Scene(np.concatenate([p[0] for p in parts]),
                 np.concatenate([p[1] + o for p, o in zip(parts, offsets, strict=True)]),
                 np.concatenate([p[2] for p in parts]), np.concatenate([p[3] for p in parts]),
                 len(parts[0][0]), np.concatenate([p[4] for p in parts]))


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
    feats = face_features(V, F, model)
    look = draw_appearance(rng, feats.scale)
    parts = [_face_part(model, V, F, feats, look, rng), _head_part(V, F, feats, look),
             *_eyeball_parts(V, feats, look)]
    return _join(parts), look.to_json()
