"""The built-in generic face: a linear face model made entirely by naseview's own code.

Used when the ICT model is not installed, for the bundled demo case, and in benchmarks as a
base face whose mesh has nothing in common with the ICT ground truth.

How the face is made, one module per step
-----------------------------------------
1. **Shape** (``shapes.py``, ``face.py``, ``nose.py``). The whole face is a height field
   ``z = S(x, y)`` (mm): the face without the nose (:func:`face_height`) and the external
   nose (:func:`nose_height`) joined by smooth maxima (:func:`surface_height`).
2. **Mesh** (``plane.py``, ``lattice.py``, ``triangulate.py``). A graded, mirror-symmetric
   lattice over an egg-shaped face outline in a plane whose normal ``d`` points forwards and
   25 degrees down; each vertex is where the ray along ``d`` meets the surface. Delaunay in
   the plane, then edge flips to the surface-Delaunay triangulation.
3. **Nostrils** (``nostrils.py``; assembled in ``mesh.py``). The vertices inside each
   nostril ellipse move up into the nose onto a half-ellipsoid cup: a real concave opening.
4. **Annotations** (``annotate.py``). The 21 landmarks found on the mean surface from their
   definitions; the curves from :func:`naseview.facemodel.meshcurves.curve_paths`; the
   nose region where the nose stands out of the face.
5. **Modes** (``modes.py``). One smooth, localised deformation field per anatomical
   parameter, scaled so that a unit coefficient is about one population SD of its
   measurement; no triangle flips within +-2 SD.

Frame: SPEC axes (+x subject's left, +y up, +z anterior), millimetres; the origin is the
nasion of the design (not ``g``).

Example
-------
>>> from naseview.facemodel.generic import generic_face_model
>>> fm = generic_face_model()                          # doctest: +SKIP
>>> fm.mode_names[:3]                                  # doctest: +SKIP
('nose_length', 'projection', 'dorsal_hump')
"""

from __future__ import annotations

import functools

import numpy as np

from naseview.facemodel.generic.annotate import find_landmarks, nose_region
from naseview.facemodel.generic.face import eye_fissure, face_height
from naseview.facemodel.generic.mesh import GenericMesh, generic_mesh
from naseview.facemodel.generic.modes import (
    FACE_MODES,
    MODE_SD_MM,
    NOSE_MODES,
    mode_basis,
    mode_measurements,
)
from naseview.facemodel.generic.nose import nose_height, surface_height
from naseview.facemodel.generic.plane import TILT_DEG, D
from naseview.facemodel.meshcurves import curve_paths
from naseview.facemodel.model import FaceModel

__all__ = [
    "CREDIT", "D", "FACE_MODES", "GenericMesh", "MODE_SD_MM", "NOSE_MODES", "TILT_DEG",
    "eye_fissure", "face_height", "find_landmarks", "generic_face_model", "generic_mesh",
    "mode_measurements", "nose_height", "nose_region", "surface_height",
]

CREDIT = "built-in generic face (naseview)"
"""Attribution line shown wherever the generic face is used."""


@functools.lru_cache(maxsize=1)
def generic_face_model() -> FaceModel:
    """The built-in generic face (deterministic; built in under a second, then cached).

    Returns:
        FaceModel ``"generic"``: mean (N, 3) mm in the SPEC axes (origin at the design's
        nasion), CCW faces, basis (9, N, 3) with modes :data:`NOSE_MODES` +
        :data:`FACE_MODES` (a unit coefficient is about one population SD), the 21
        landmark vertices, nose, nostril and curve vertices. Arrays are read-only
        (shared by every caller).
    """
    mesh = generic_mesh()
    lm = find_landmarks(mesh)
    nostrils = np.flatnonzero(mesh.nostril_side != 0)
    curves = curve_paths(mesh.V, mesh.F, lm, nostrils)
    model = FaceModel(
        name="generic", mean=mesh.V, faces=mesh.F, basis=mode_basis(mesh, lm),
        landmark_vertices=lm, nose_vertices=nose_region(mesh, lm),
        nostril_vertices=nostrils, curve_vertices=curves,
        mode_names=NOSE_MODES + FACE_MODES, credit=CREDIT)
    for arr in (model.mean, model.faces, model.basis, model.nose_vertices,
                model.nostril_vertices, *model.curve_vertices.values()):
        arr.flags.writeable = False
    return model
