"""Mesh files: triangle-mesh export and import (.ply, .stl, .obj, .glb), and a fast
polygon OBJ reader, all with one-line errors.

Meshes are ``V`` (n, 3) float vertices in mm (SPEC frame) and ``F`` (m, 3) int triangles,
counter-clockwise seen from outside (the ``face.ply`` / ``nose.ply`` of SPEC §5). Writes
are atomic (:mod:`naseview.fileio`): a crash never leaves a half-written file.
:func:`read_obj` keeps polygons as they are (ICT-FaceKit's quads, read by
:mod:`naseview.facemodel.store`); :func:`triangulate_polygons` fans them into triangles.

Example
-------
>>> export_mesh("out/nose.stl", V, F)                  # doctest: +SKIP
>>> V2, F2 = read_mesh("out/nose.stl")                 # doctest: +SKIP
>>> triangulate_polygons(np.array([0, 1, 2, 3]), np.array([4])).tolist()
[[0, 1, 2], [0, 2, 3]]
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import NamedTuple

import numpy as np

from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, one_line, read_bytes

MESH_FORMATS: tuple[str, ...] = ("ply", "stl", "obj", "glb")
"""File types :func:`export_mesh` writes and :func:`read_mesh` reads (by suffix)."""


def _suffix(path: Path) -> str:
    """The mesh type of ``path`` from its suffix (one of :data:`MESH_FORMATS`)."""
    ext = path.suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        raise NaseviewError(f"{path}: unsupported mesh type {path.suffix or '(none)'!r}; "
                            f"use one of {', '.join('.' + f for f in MESH_FORMATS)}")
    return ext


def _check_mesh(V: np.ndarray, F: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` as float64 (n, 3) / int64 (m, 3) after checking shapes and vertex ids."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3 or not np.isfinite(V).all():
        raise NaseviewError(f"{where}: vertices must be a finite (n, 3) array, got shape "
                            f"{V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise NaseviewError(f"{where}: faces must be an (m, 3) integer array, got shape "
                            f"{F.shape} dtype {F.dtype}")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise NaseviewError(f"{where}: faces index vertices outside 0..{len(V) - 1}")
    return V, F.astype(np.int64)


def mesh_bytes(V: np.ndarray, F: np.ndarray, file_type: str,
               vertex_colors: np.ndarray | None = None) -> bytes:
    """Encode a mesh as a file of ``file_type`` (``ply``, ``stl``, ``obj``, ``glb``).

    Args:
        V: (n, 3) vertices, mm.
        F: (m, 3) triangles.
        file_type: one of :data:`MESH_FORMATS`.
        vertex_colors: optional (n, 3) or (n, 4) uint8 RGB(A) (ignored by STL).
    Returns:
        The file content (binary PLY / STL / GLB, text OBJ).
    """
    import trimesh  # lazy: trimesh adds 0.2-0.45 s to start-up; only mesh files need it

    V, F = _check_mesh(V, F, f"mesh ({file_type})")
    colors = None
    if vertex_colors is not None:
        c = np.asarray(vertex_colors)
        if c.shape[0] != len(V) or c.ndim != 2 or c.shape[1] not in (3, 4):
            raise NaseviewError(f"mesh ({file_type}): vertex_colors must be (n, 3|4) for "
                                f"{len(V)} vertices, got {c.shape}")
        colors = c.astype(np.uint8)
    mesh = trimesh.Trimesh(vertices=V, faces=F, vertex_colors=colors, process=False)
    if file_type == "glb":
        # glTF is metres by convention but naseview keeps mm; the scene is written as-is.
        data = trimesh.Scene(mesh).export(file_type="glb")
    elif file_type == "obj":
        data = mesh.export(file_type="obj", include_normals=False, include_texture=False)
    else:
        data = mesh.export(file_type=file_type)
    return data.encode("utf-8") if isinstance(data, str) else bytes(data)


def export_mesh(path: str | os.PathLike[str], V: np.ndarray, F: np.ndarray,
                vertex_colors: np.ndarray | None = None) -> Path:
    """Write a triangle mesh atomically; the type comes from the suffix.

    Args:
        path: ``.ply`` / ``.stl`` / ``.obj`` / ``.glb`` file to write.
        V: (n, 3) vertices in mm (SPEC frame).
        F: (m, 3) int triangles.
        vertex_colors: optional (n, 3|4) uint8 RGB(A) per vertex (not stored in STL).
    Returns:
        The path written.
    Raises:
        NaseviewError: unknown suffix or malformed arrays.
    """
    path = Path(path)
    return atomic_write_bytes(path, mesh_bytes(V, F, _suffix(path), vertex_colors))


def read_mesh(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh written by :func:`export_mesh` (or any tool).

    Vertices are kept in file order (no merging), so vertex ids survive a round trip of
    PLY / OBJ / GLB; STL stores triangle soups, whose duplicate corners are merged.

    Args:
        path: ``.ply`` / ``.stl`` / ``.obj`` / ``.glb`` file.
    Returns:
        ``(V, F)``: (n, 3) float64 vertices, (m, 3) int64 triangles.
    Raises:
        NaseviewError: missing file, unknown suffix, unreadable or empty mesh.
    """
    path = Path(path)
    ext = _suffix(path)
    return mesh_from_bytes(read_bytes(path, "mesh file"), ext, path)


def mesh_from_bytes(data: bytes, file_type: str, where: str | os.PathLike[str]
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Parse the content of a mesh file of ``file_type`` (see :func:`read_mesh`).

    Args:
        data: the file content.
        file_type: one of :data:`MESH_FORMATS`.
        where: the file, for errors.
    Returns:
        ``(V, F)``: (n, 3) finite float64 vertices, (m, 3) int64 triangles whose ids lie
        in ``0..n-1``.
    Raises:
        NaseviewError: unreadable, empty, non-finite or out-of-range mesh.
    """
    import trimesh  # lazy: see mesh_bytes

    ext = _suffix(Path(f"mesh.{file_type}"))
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=ext, process=False,
                              force="mesh", merge_norm=True, merge_tex=True)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise NaseviewError(f"{where}: not a readable {ext.upper()} mesh ({type(e).__name__}); "
                            "re-export it as a triangle mesh") from None
    V = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    F = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if ext == "stl" and len(V):
        V, inverse = np.unique(V, axis=0, return_inverse=True)
        F = inverse.reshape(-1)[F]
    if len(V) == 0 or len(F) == 0 or F.ndim != 2 or F.shape[1] != 3:
        raise NaseviewError(f"{where}: holds no triangles; expected a triangle mesh")
    return _check_mesh(V, F, str(where))


class ObjPolygons(NamedTuple):
    """Vertices and polygons of a Wavefront OBJ file.

    Attributes:
        vertices: (V, 3) float64 positions (file units).
        indices: (S,) int64 0-based vertex ids of all polygons, concatenated.
        sizes: (P,) int64 corner count of each polygon, in file order.
    """

    vertices: np.ndarray
    indices: np.ndarray
    sizes: np.ndarray


def read_obj(path: str | os.PathLike[str], faces: bool = True) -> ObjPolygons:
    """Read the ``v`` and ``f`` lines of an OBJ file (everything else is ignored).

    Faces may be triangles, quads or larger polygons, with ``v``, ``v/vt``, ``v//vn`` or
    ``v/vt/vn`` corners and negative (relative) indices. About 0.1 s for ICT-FaceKit's
    26,719-vertex head.

    Args:
        path: the ``.obj`` file.
        faces: ``False`` to skip the face lines (returns empty ``indices`` / ``sizes``).
    Raises:
        NaseviewError: missing file, malformed line (names the file and the line number).
    """
    path = Path(path)
    try:
        lines = path.read_bytes().splitlines()
    except OSError as e:
        raise NaseviewError(f"{path}: cannot read OBJ file ({one_line(e)})") from None
    vlines = [ln for ln in lines if ln.startswith(b"v ")]
    V = _parse_obj_vertices(path, lines, vlines)
    if not faces:
        return ObjPolygons(V, np.zeros(0, np.int64), np.zeros(0, np.int64))
    fl = [(no, ln) for no, ln in enumerate(lines, 1) if ln.startswith(b"f ")]
    tokens = [ln.split()[1:] for _, ln in fl]
    sizes = np.array([len(t) for t in tokens], dtype=np.int64)
    if sizes.size and sizes.min() < 3:
        bad = fl[int(np.argmin(sizes))][0]
        raise NaseviewError(f"{path}: line {bad}: a face needs at least 3 corners")
    try:
        idx = np.array([c.split(b"/", 1)[0] for t in tokens for c in t]).astype(np.int64)
    except ValueError:
        for no, ln in fl:
            try:
                [int(c.split(b"/", 1)[0]) for c in ln.split()[1:]]
            except ValueError:
                raise NaseviewError(f"{path}: line {no}: malformed face line") from None
        raise NaseviewError(f"{path}: malformed face line") from None
    if idx.size and idx.min() < 0:  # relative ids count back from the vertices read so far
        vcount = np.cumsum([ln.startswith(b"v ") for ln in lines])
        before = np.repeat(vcount[[no - 1 for no, _ in fl]], sizes)
        idx = np.where(idx < 0, before + idx + 1, idx)
    idx = idx - 1
    if idx.size and (idx.min() < 0 or idx.max() >= len(V)):
        raise NaseviewError(
            f"{path}: a face refers to vertex {int(idx.max()) + 1} or {int(idx.min()) + 1}, "
            f"but the file has {len(V)} vertices")
    return ObjPolygons(V, idx, sizes)


def _parse_obj_vertices(path: Path, lines: list[bytes], vlines: list[bytes]) -> np.ndarray:
    """(V, 3) positions of the ``v`` lines: one fast parse, else line by line to name the bad
    line."""
    if not vlines:
        raise NaseviewError(f"{path}: no vertex ('v') lines; not an OBJ mesh")
    try:
        ncol = {len(vlines[0].split()), len(vlines[-1].split())}
        if len(ncol) == 1 and ncol.pop() >= 4:
            arr = np.loadtxt(io.BytesIO(b"\n".join(vlines)), usecols=(1, 2, 3),
                             dtype=np.float64, comments=None, ndmin=2)
            if len(arr) == len(vlines) and np.isfinite(arr).all():
                return arr
    except ValueError:
        pass
    out = np.empty((len(vlines), 3))
    k = 0
    for no, ln in enumerate(lines, 1):
        if not ln.startswith(b"v "):
            continue
        parts = ln.split()
        try:
            out[k] = [float(x) for x in parts[1:4]]
            if len(parts) < 4 or not np.isfinite(out[k]).all():
                raise ValueError
        except ValueError:
            raise NaseviewError(f"{path}: line {no}: malformed vertex line") from None
        k += 1
    return out


def triangulate_polygons(indices: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """(T, 3) triangles of polygons: a fan from the first corner, (a,b,c), (a,c,d), ...

    Each polygon's triangles are consecutive, in fan order (for ICT quads: (a,b,c) then
    (a,c,d), as in the published ``.npz``).
    """
    indices = np.asarray(indices, dtype=np.int64)
    sizes = np.asarray(sizes, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    ntri = sizes - 2
    poly = np.repeat(np.arange(len(sizes)), ntri)
    k = np.arange(int(ntri.sum())) - np.repeat(np.cumsum(ntri) - ntri, ntri)
    s = starts[poly]
    return np.stack([indices[s], indices[s + k + 1], indices[s + k + 2]], axis=1)
