"""Mesh files of the face (or its nose) with the photo texture: the one writer of the
app's downloads and of ``naseview reconstruct --export``.

GLB is written in metres (glTF), the others in mm (:func:`naseview.meshio.mesh_bytes`);
with a :class:`~naseview.texture.bake.FaceTexture` a GLB embeds the texture as PNG with
its UVs, a PLY or OBJ carries the texture's per-vertex colours, and
:func:`textured_obj_zip` is the OBJ + MTL + PNG of one download. A watertight solid for
printing (:func:`naseview.geometry.closing.close_solid`) carries no texture. Coordinates
are in the SPEC frame (mm, origin g, +x subject's left, +y up, +z anterior).
"""

from __future__ import annotations

import io
import zipfile

import numpy as np

from naseview.geometry.closing import close_solid
from naseview.geometry.region import submesh
from naseview.meshio import mesh_bytes, textured_obj_files
from naseview.texture.bake import FaceTexture

MESH_TYPES: tuple[str, ...] = ("stl", "obj", "ply", "glb")
"""The mesh types offered for download."""


def _select(V: np.ndarray, F: np.ndarray, vertex_ids: np.ndarray | None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(V', F', ids)``: the whole mesh when ``vertex_ids`` is None, else the triangles
    whose corners all lie in ``vertex_ids``, compacted
    (:func:`naseview.geometry.region.submesh`, ``V' = V[ids]``)."""
    if vertex_ids is None:
        return V, F, np.arange(len(V))
    return submesh(V, F, vertex_ids)


def mesh_file(V: np.ndarray, F: np.ndarray, file_type: str,
              vertex_ids: np.ndarray | None = None, *, watertight: bool = False,
              texture: FaceTexture | None = None,
              vertex_colors: np.ndarray | None = None) -> bytes:
    """A mesh file (``stl``, ``obj``, ``ply``, ``glb``) of the face, or of the triangles
    whose corners all lie in ``vertex_ids`` (e.g. the nose), vertices (N, 3) in mm.

    GLB is written in metres (glTF), the others in mm (:func:`naseview.meshio.mesh_bytes`).

    Args:
        V: (N, 3) vertices (mm); F: (M, 3) triangles.
        file_type: one of :data:`MESH_TYPES`.
        vertex_ids: keep only these vertices' triangles.
        watertight: close the holes and the open border into a solid
            (:func:`naseview.geometry.closing.close_solid`), for printing; ignores the
            texture.
        texture: embed the baked texture (GLB only, the PNG embedded: the face with its
            photo texture, as the app's download and ``naseview reconstruct --export
            glb`` write it; for OBJ use :func:`textured_obj_zip`); for PLY / OBJ its
            per-vertex colours are written instead.
        vertex_colors: (N, 3) uint8 RGB per vertex (PLY, OBJ, GLB).
    """
    V, F, ids = _select(np.asarray(V, np.float64), np.asarray(F, np.int64), vertex_ids)
    colors = None if vertex_colors is None else np.asarray(vertex_colors)[ids]
    if watertight:
        V, F = close_solid(V, F)
        return mesh_bytes(V, F, file_type)
    if texture is not None:
        if file_type == "glb":
            return mesh_bytes(V, F, file_type, colors, uv=texture.uv[ids],
                              texture=texture.image)
        if colors is None and file_type != "stl":
            colors = texture.vertex_colors[ids]
    return mesh_bytes(V, F, file_type, colors)


def textured_obj_zip(V: np.ndarray, F: np.ndarray, texture: FaceTexture,
                     vertex_ids: np.ndarray | None = None, name: str = "face") -> bytes:
    """One ZIP download of a textured OBJ: ``name.obj`` (mm), ``name.mtl``, ``name.png``
    (:func:`naseview.meshio.textured_obj_files`), of the face or of ``vertex_ids``'
    triangles."""
    V, F, ids = _select(np.asarray(V, np.float64), np.asarray(F, np.int64), vertex_ids)
    files = textured_obj_files(V, F, texture.uv[ids], texture.image, name)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for fname, data in files.items():
            z.writestr(fname, data)
    return buf.getvalue()


__all__ = ["MESH_TYPES", "mesh_file", "textured_obj_zip"]
