"""Linear face models (3D morphable models) with nasal landmarks and regions.

A :class:`FaceModel` is ``mean + sum_k w_k basis[k]`` with ``w_k ~ N(0, 1)``, in mm, in the
SPEC axes (+x subject's left, +y up, +z anterior); its origin is the model's own (not g).

Two models ship with naseview:

- ``ict``: ICT Face Model Light (USC Institute for Creative Technologies, MIT licence),
  installed by ``naseview model fetch`` or ``naseview model import-ict``
  (:mod:`naseview.facemodel.ict`, :mod:`naseview.facemodel.store`);
- ``generic``: a face built by naseview's own code, used when nothing is installed
  (:mod:`naseview.facemodel.generic`).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> fm = load_face_model("generic")                   # doctest: +SKIP
>>> V = fm.shape(np.zeros(fm.n_modes))                # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from naseview.errors import NaseviewError


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


def load_face_model(name: str | None = None) -> FaceModel:
    """Load a face model by name or path.

    Args:
        name: ``"ict"`` (installed ICT model), ``"generic"`` (built-in), a path to an
            ICT-format ``.npz``, or ``None`` for ``ict`` when installed, else ``generic``.
    Raises:
        NaseviewError: ``ict`` requested but not installed (names the commands that
            install it), unreadable file.
    """
    from naseview.facemodel import generic, store

    if name is None:
        path = store.find_ict_npz()
        return store.load_ict_npz(path) if path is not None else generic.generic_face_model()
    if name == "generic":
        return generic.generic_face_model()
    if name == "ict":
        path = store.find_ict_npz()
        if path is None:
            raise NaseviewError(
                "face model 'ict' is not installed; run `naseview model fetch` (download) or "
                "`naseview model import-ict DIR` (an ICT-FaceKit checkout), or use "
                "--model generic")
        return store.load_ict_npz(path)
    return store.load_ict_npz(name)
