"""Triangle-mesh export and import (.ply, .stl, .obj, .glb) with one-line errors.

Meshes are ``V`` (n, 3) float vertices in mm (SPEC frame) and ``F`` (m, 3) int triangles,
counter-clockwise seen from outside. Writes are atomic (:mod:`naseview.fileio`): a crash
never leaves a half-written file.

Example
-------
>>> export_mesh("out/nose.stl", V, F)                  # doctest: +SKIP
>>> V2, F2 = read_mesh("out/nose.stl")                 # doctest: +SKIP
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes

MESH_FORMATS: tuple[str, ...] = ("ply", "stl", "obj", "glb")
"""File types :func:`export_mesh` writes and :func:`read_mesh` reads (by suffix)."""


def _suffix(path: Path) -> str:
    ext = path.suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        raise NaseviewError(f"{path}: unsupported mesh type {path.suffix or '(none)'!r}; "
                            f"use one of {', '.join('.' + f for f in MESH_FORMATS)}")
    return ext


def _check_mesh(V: np.ndarray, F: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
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
    import trimesh

    V, F = _check_mesh(V, F, f"mesh ({file_type})")
    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False)
    if vertex_colors is not None:
        c = np.asarray(vertex_colors)
        if c.shape[0] != len(V) or c.ndim != 2 or c.shape[1] not in (3, 4):
            raise NaseviewError(f"mesh ({file_type}): vertex_colors must be (n, 3|4) for "
                                f"{len(V)} vertices, got {c.shape}")
        mesh.visual.vertex_colors = c.astype(np.uint8)
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
    import trimesh

    path = Path(path)
    ext = _suffix(path)
    if not path.is_file():
        raise NaseviewError(f"{path}: mesh file not found")
    try:
        loaded = trimesh.load(io.BytesIO(path.read_bytes()), file_type=ext, process=False,
                              force="mesh", merge_norm=True, merge_tex=True)
    except Exception as e:  # trimesh raises many types on corrupt files
        raise NaseviewError(f"{path}: not a readable {ext.upper()} mesh ({type(e).__name__}); "
                            "re-export it as a triangle mesh") from None
    V = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    F = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if ext == "stl" and len(V):
        V, inverse = np.unique(V, axis=0, return_inverse=True)
        F = inverse.reshape(-1)[F]
    if len(V) == 0 or len(F) == 0 or F.ndim != 2 or F.shape[1] != 3:
        raise NaseviewError(f"{path}: holds no triangles; expected a triangle mesh")
    return V, F
