"""The face-model type: a linear 3D morphable model with nasal annotations.

``mean + sum_k w_k basis[k]`` with ``w_k ~ N(0, 1)``, in mm, in the SPEC axes (+x subject's
left, +y up, +z anterior); its origin is the model's own (not g). Stage 3 fits it (paper
§3.4, eq. 18). Everyone imports it as ``naseview.facemodel.FaceModel``.

Example
-------
>>> import numpy as np
>>> fm = FaceModel("toy", np.zeros((3, 3)), np.array([[0, 1, 2]]), np.ones((1, 3, 3)),
...                {}, np.arange(3), np.zeros(0, np.int64))
>>> fm.n_modes, fm.shape([2.0])[0].tolist()
(1, [2.0, 2.0, 2.0])
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class FaceModel:
    """A linear face model with nasal annotations.

    Attributes:
        name: ``"ict"``, ``"generic"``, ...
        mean: (V, 3) float64 neutral face, mm.
        faces: (F, 3) int64 triangles, counter-clockwise seen from outside.
        basis: (K, V, 3) float64 displacement per unit coefficient (mm); coefficients ~ N(0,1).
        landmark_vertices: landmark id -> vertex index, for all 21 landmarks of SPEC §1.
        nose_vertices: (N,) int64 vertices of the nose region (refined by stage 3).
        nostril_vertices: (M,) int64 vertices inside the nostrils (rendered dark).
        curve_vertices: SPEC §5 curve name -> (L,) int64 vertex path along that curve
            (sills are closed loops, first vertex not repeated).
        mode_names: K names of the basis modes (interpretable for the built-in model).
        credit: attribution line to show wherever the model is used.
    """

    name: str
    mean: np.ndarray
    faces: np.ndarray
    basis: np.ndarray
    landmark_vertices: dict[str, int]
    nose_vertices: np.ndarray
    nostril_vertices: np.ndarray
    curve_vertices: dict[str, np.ndarray] = field(default_factory=dict)
    mode_names: tuple[str, ...] = ()
    credit: str = ""

    @property
    def n_modes(self) -> int:
        return int(self.basis.shape[0])

    @property
    def n_vertices(self) -> int:
        return int(self.mean.shape[0])

    def shape(self, coeffs: ArrayLike | None = None) -> np.ndarray:
        """(V, 3) face for coefficients (K,) or fewer (the rest 0); ``None`` = mean."""
        if coeffs is None:
            return self.mean.copy()
        w = np.asarray(coeffs, dtype=np.float64).ravel()
        if w.size > self.n_modes:
            raise ValueError(f"{w.size} coefficients for a model with {self.n_modes} modes")
        return self.mean + np.tensordot(w, self.basis[: w.size], axes=1)

    def landmark_positions(self, V: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Landmark id -> (3,) position on the face ``V`` (default: the mean)."""
        V = self.mean if V is None else V
        return {k: V[i].copy() for k, i in self.landmark_vertices.items()}
