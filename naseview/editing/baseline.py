"""What the editor edits, what a solver returns and what the page shows; no viser here.

The live editor moves the landmarks of a reconstruction and re-runs the ARAP deformation of
stage 3 (paper §3.4, eq. 19-21) on it. This module holds the data of that loop:

- :class:`Baseline`: the reconstruction being edited (never changes while editing), built
  from a pipeline result (:func:`baseline_from_pipeline`), a face model's shape
  (:func:`baseline_from_face_model`) or a ``naseview reconstruct`` output folder (SPEC §5,
  :func:`baseline_from_output_dir`);
- :class:`Solver` and :class:`Solved`: landmark positions in, deformed face out;
- :class:`Simulation`: one solved state, as published to the page
  (:func:`baseline_simulation`: the baseline itself).

Everything is in the SPEC frame (mm, origin glabella ``g``).

Example
-------
>>> import numpy as np
>>> b = Baseline(np.zeros((3, 3)), np.array([[0, 1, 2]]), np.arange(3),
...              {"prn": np.array([0.0, 1.0, 2.0])})
>>> sim = baseline_simulation(b)
>>> sim.revision, sim.landmarks["prn"].tolist()
(0, [0.0, 1.0, 2.0])
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.measurements import clinical_measurements
from naseview.meshio import mesh_from_bytes
from naseview.pipeline import PipelineResult
from naseview.reconstruction import (
    Reconstruction,
    index_array,
    numbers_dict,
    points_array,
    read_output_set,
)
from naseview.stage2_curves import DEFAULT_SUB_LANDMARKS

Landmarks = dict[str, np.ndarray]
"""Landmark id -> (3,) float64 position (mm)."""


def copy_landmarks(lms: Mapping[str, ArrayLike]) -> Landmarks:
    """Landmark id -> (3,) float64 copies of ``lms`` (never shares memory with it)."""
    return {k: np.array(v, dtype=np.float64).reshape(3) for k, v in lms.items()}


def landmarks_equal(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> bool:
    """True when both dicts hold the same ids at bit-identical positions."""
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


@dataclass(frozen=True)
class Baseline:
    """The reconstruction being edited, in the SPEC frame (mm).

    Attributes:
        V: (N, 3) float64 face vertices (stage 3 result).
        F: (M, 3) int64 triangles.
        nose_ids: (K,) int64 vertices of the nose region (the part that deforms).
        landmarks: id -> (3,) the landmarks (21 when all could be placed).
        curves: SPEC §5 curve name -> (L, 3) polyline.
        ad_landmarks: (A, 3) ad-landmarks.
        measurements: name -> value (mm / degrees) of the reconstruction.
        reconstruction: the full :class:`Reconstruction` (cameras, residuals...), or None.
    """

    V: np.ndarray
    F: np.ndarray
    nose_ids: np.ndarray
    landmarks: Landmarks
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    measurements: dict[str, float] = field(default_factory=dict)
    reconstruction: Reconstruction | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``baseline`` object of a session file (``naseview.session/1``)."""
        rec = self.reconstruction or Reconstruction(
            landmarks=self.landmarks, curves=self.curves, ad_landmarks=self.ad_landmarks,
            measurements=self.measurements)
        return {
            "reconstruction": rec.to_json(),
            "landmarks": {k: v.tolist() for k, v in self.landmarks.items()},
            "curves": {k: np.asarray(v).reshape(-1, 3).tolist() for k, v in self.curves.items()},
            "ad_landmarks": np.asarray(self.ad_landmarks).reshape(-1, 3).tolist(),
            "measurements": {k: float(v) for k, v in self.measurements.items()},
            "mesh": {"vertices": self.V.tolist(), "faces": self.F.tolist(),
                     "nose_vertex_ids": self.nose_ids.tolist()},
        }

    @staticmethod
    def from_json(obj: Mapping[str, Any], where: str = "session") -> Baseline:
        """Parse :meth:`to_json` output; ``where`` names the file in errors.

        Raises:
            NaseviewError: a key is missing, an array is malformed or inconsistent.
        """
        for key in ("mesh", "landmarks", "reconstruction"):
            if key not in obj:
                raise NaseviewError(f"{where}: key 'baseline.{key}' missing; the session "
                                    "file is incomplete, save it again from the app")
        mesh = obj["mesh"]
        if not isinstance(mesh, Mapping) or not {"vertices", "faces",
                                                 "nose_vertex_ids"} <= set(mesh):
            raise NaseviewError(f"{where}: key 'baseline.mesh': expected vertices, faces and "
                                "nose_vertex_ids; save the session again from the app")
        V = points_array(mesh["vertices"], where, "baseline.mesh.vertices")
        F = index_array(mesh["faces"], where, "baseline.mesh.faces", len(V), width=3)
        nose = index_array(mesh["nose_vertex_ids"], where, "baseline.mesh.nose_vertex_ids",
                           len(V))
        rec = Reconstruction.from_json(obj["reconstruction"], f"{where}: baseline")
        lms = obj["landmarks"]
        if not isinstance(lms, Mapping):
            raise NaseviewError(f"{where}: key 'baseline.landmarks': expected an object")
        curves = obj.get("curves", {})
        if not isinstance(curves, Mapping):
            raise NaseviewError(f"{where}: key 'baseline.curves': expected an object")
        b = Baseline(
            V=V, F=F, nose_ids=nose,
            landmarks={k: points_array([v], where, f"baseline.landmarks.{k}", 1)[0]
                       for k, v in lms.items()},
            curves={k: points_array(c, where, f"baseline.curves.{k}")
                    for k, c in curves.items()},
            ad_landmarks=points_array(obj.get("ad_landmarks", []), where,
                                      "baseline.ad_landmarks"),
            measurements=numbers_dict(obj.get("measurements", {}), where,
                                      "baseline.measurements"),
            reconstruction=rec)
        b.validate(where)
        return b

    def validate(self, where: str = "baseline") -> None:
        """Raise :class:`NaseviewError` if the arrays are inconsistent."""
        n = len(self.V)
        if self.F.size and (self.F.min() < 0 or self.F.max() >= n):
            raise NaseviewError(f"{where}: key 'mesh.faces': index outside 0..{n - 1}")
        if self.nose_ids.size and (self.nose_ids.min() < 0 or self.nose_ids.max() >= n):
            raise NaseviewError(f"{where}: key 'mesh.nose_vertex_ids': index outside "
                                f"0..{n - 1}")
        if not np.all(np.isfinite(self.V)):
            raise NaseviewError(f"{where}: key 'mesh.vertices': non-finite coordinates")


@dataclass(frozen=True)
class Solved:
    """What a solver returns for one set of landmark positions (SPEC frame, mm).

    Attributes:
        V: (N, 3) deformed face (only nose-region rows may differ from the baseline).
        curves: curve name -> (L, 3).
        ad_landmarks: (A, 3).
        measurements: name -> value.
        warnings: one line each (handle clamped, triangles folded...), shown in the page.
        surface_landmarks: id -> (3,) where each landmark sits on the solved surface when
            manoeuvres moved it beyond the requested position (request + the manoeuvres'
            offset), or None (the requested positions are on the surface).
    """

    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]
    warnings: tuple[str, ...] = ()
    surface_landmarks: Landmarks | None = None


Manoeuvres = dict[str, float]
"""Manoeuvre name -> amount (mm or degrees; :data:`naseview.editing.manoeuvres.MANOEUVRES`),
non-zero amounts only."""


class Solver(Protocol):
    """Landmark positions (id -> (3,) mm) -> :class:`Solved`. Called from the worker
    thread only.

    ``interactive`` is True while a drag is in progress: the solver may trade accuracy
    for speed (fewer iterations); the controller asks for a full solve when the drag ends.
    ``manoeuvres`` (given only when some are set): amounts of the surgical manoeuvres to
    add on top of the landmark deformation.
    """

    def __call__(self, landmarks: Mapping[str, np.ndarray],
                 interactive: bool = False, **kwargs: Any) -> Solved: ...


@dataclass(frozen=True)
class Simulation:
    """A published state: the solved result for landmarks of request ``revision``.

    Attributes:
        revision: the controller's request counter when it was asked for.
        generation: the controller's baseline / solver generation it belongs to.
        landmarks: id -> (3,) positions it was solved for (mm).
        V: (N, 3) face; curves: name -> (L, 3); ad_landmarks: (A, 3).
        measurements: name -> value.
        solve_seconds: wall time of the solve (0 for a cached or baseline state).
        warnings: the solver's one-line warnings.
        interactive: solved during a drag (possibly fewer iterations than a final solve).
        manoeuvres: the manoeuvre amounts it was solved for (empty: none).
        surface_landmarks: where the landmarks sit on ``V`` when manoeuvres moved them
            (:attr:`Solved.surface_landmarks`), else None.
    """

    revision: int
    generation: int
    landmarks: Landmarks
    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]
    solve_seconds: float = 0.0
    warnings: tuple[str, ...] = ()
    interactive: bool = False
    manoeuvres: Manoeuvres = field(default_factory=dict)
    surface_landmarks: Landmarks | None = None

    @property
    def shown_landmarks(self) -> Landmarks:
        """Where the landmarks are drawn: on the surface (after manoeuvres) where known,
        else at the requested positions."""
        return {**self.landmarks, **(self.surface_landmarks or {})}

    def drawn(self, landmarks: Mapping[str, np.ndarray]) -> Landmarks:
        """Where landmarks at ``landmarks`` (controller positions, id -> (3,) mm) are
        drawn on this simulation's surface: each plus its :meth:`landmark_offset`."""
        if self.surface_landmarks is None:
            return dict(landmarks)
        return {k: np.asarray(p, np.float64) + self.landmark_offset(k)
                for k, p in landmarks.items()}

    def landmark_offset(self, landmark: str) -> np.ndarray:
        """(3,) mm from a landmark's requested position to where it is drawn (the
        manoeuvres' displacement of it; zeros without manoeuvres)."""
        s = self.surface_landmarks
        if s is None or landmark not in s or landmark not in self.landmarks:
            return np.zeros(3)
        return np.asarray(s[landmark] - self.landmarks[landmark], np.float64)


def baseline_simulation(baseline: Baseline, revision: int = 0,
                        generation: int = 0) -> Simulation:
    """The baseline itself as a :class:`Simulation` (what reset shows, exactly)."""
    return Simulation(revision, generation, copy_landmarks(baseline.landmarks),
                      baseline.V, dict(baseline.curves), baseline.ad_landmarks,
                      dict(baseline.measurements))


def _measurements_of(rec: Reconstruction, V: np.ndarray, F: np.ndarray) -> dict[str, float]:
    """The reconstruction's measurements as written with it, unless the file is of an
    earlier version (it lacks measurements that are computed today, so its values follow
    older definitions): then computed now on its mesh, as the simulation's values are."""
    now = clinical_measurements(rec.landmarks, rec.curves or None, V, F)
    return dict(rec.measurements) if set(rec.measurements) >= set(now) else now


def _from_reconstruction(rec: Reconstruction, V: np.ndarray, F: np.ndarray,
                         nose: np.ndarray) -> Baseline:
    """A :class:`Baseline` of mesh ``V`` (N, 3), ``F`` (M, 3) and nose ids (K,) with the
    landmarks, curves, ad-landmarks and measurements of ``rec``."""
    return Baseline(V, F, nose,
                    {k: np.asarray(v, np.float64) for k, v in rec.landmarks.items()},
                    {k: np.asarray(c, np.float64).reshape(-1, 3) for k, c in rec.curves.items()},
                    np.asarray(rec.ad_landmarks, np.float64).reshape(-1, 3),
                    _measurements_of(rec, V, F), rec)


def baseline_from_pipeline(result: PipelineResult) -> Baseline:
    """A :class:`Baseline` from a :class:`naseview.pipeline.PipelineResult`.

    Raises:
        NaseviewError: the result has no face mesh (stage 3 did not run).
    """
    if result.face_vertices is None or result.faces is None \
            or result.nose_vertex_ids is None:
        raise NaseviewError("reconstruction: stage 3 produced no face mesh; run all three "
                            "stages (--stages 1,2,3)")
    V = np.asarray(result.face_vertices, np.float64)
    F = np.asarray(result.faces, np.int64)
    nose = np.asarray(result.nose_vertex_ids, np.int64)
    return _from_reconstruction(result.reconstruction, V, F, nose)


def _even_points(P: np.ndarray, n: int) -> list[np.ndarray]:
    """``n`` points (3,) at arc-length fractions 1/(n+1) .. n/(n+1) of polyline P (L, 3)
    (none for a zero-length polyline)."""
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    cum = np.r_[0.0, np.cumsum(seg)]
    if cum[-1] <= 0 or n <= 0:
        return []
    t = cum[-1] * (np.arange(1, n + 1) / (n + 1))
    return list(np.column_stack([np.interp(t, cum, P[:, k]) for k in range(3)]))


def baseline_from_face_model(model: FaceModel, coeffs: ArrayLike | None = None) -> Baseline:
    """A face model's shape as an editable :class:`Baseline` (no photos needed).

    The face ``model.shape(coeffs)`` is moved so that glabella ``g`` is the origin (SPEC
    frame); landmarks are its annotated vertices, curves its annotated vertex paths, and
    the ad-landmarks the 21 landmarks plus points at even arc-length fractions of each
    curve (stage 2's default counts, paper §3.3).
    """
    V = model.shape(coeffs)
    V = V - V[model.landmark_vertices["g"]]
    F = np.asarray(model.faces, np.int64)
    lms = {k: V[i].copy() for k, i in model.landmark_vertices.items()}
    curves: dict[str, np.ndarray] = {}
    for name, path in model.curve_vertices.items():
        P = V[np.asarray(path, np.int64)]
        curves[name] = np.concatenate([P, P[:1]]) if name.startswith("sill") else P
    ad = [lms[k] for k in lms]
    for name, P in curves.items():
        ad += _even_points(P, int(DEFAULT_SUB_LANDMARKS.get(name, 3)))
    return Baseline(V, F, np.asarray(model.nose_vertices, np.int64), lms, curves,
                    np.array(ad), clinical_measurements(lms, curves, V, F))


def baseline_from_output_dir(out_dir: str | os.PathLike[str]) -> Baseline:
    """A :class:`Baseline` from ``naseview reconstruct`` output (SPEC §5).

    ``reconstruction.json``, ``face.ply`` and ``nose.ply`` are read as one set
    (:func:`naseview.reconstruction.read_output_set`): a folder mixing two runs is refused,
    and a run being written right now gives the previous or the new result.

    Raises:
        NaseviewError: a file is missing, the files do not belong together, or the nose
            mesh does not match the face mesh.
    """
    out_dir = Path(out_dir)
    meshes = ("face.ply", "nose.ply")
    got = read_output_set(out_dir, meshes)
    rec = got.reconstruction
    for name in meshes:
        if name not in got.files:
            raise NaseviewError(f"{out_dir / name}: file not found; re-run `naseview "
                                f"reconstruct CASE -o {out_dir}` (stage 3 writes it)")
    V, F = mesh_from_bytes(got.files["face.ply"], "ply", out_dir / "face.ply")
    Vn, _ = mesh_from_bytes(got.files["nose.ply"], "ply", out_dir / "nose.ply")
    d, ids = cKDTree(V).query(Vn)
    if len(d) and float(d.max()) > 1e-4:
        raise NaseviewError(f"{out_dir / 'nose.ply'}: its vertices are not vertices of "
                            "face.ply; re-run `naseview reconstruct` to write both")
    return _from_reconstruction(rec, V, F, np.unique(ids).astype(np.int64))
