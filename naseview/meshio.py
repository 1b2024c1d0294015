"""Mesh files: triangle-mesh export and import (.ply, .stl, .obj, .glb), and a fast
polygon OBJ reader, all with one-line errors.

Meshes are ``V`` (n, 3) float vertices in mm (SPEC frame; a GLB file holds metres, as
glTF 2.0 requires, see :data:`GLB_SCALE`) and ``F`` (m, 3) int triangles,
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
from naseview.imagefile import image_bytes

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


GLB_SCALE = 0.001
"""Metres per millimetre: GLB files hold metres (glTF 2.0 §3.4), naseview keeps mm, so
:func:`mesh_bytes` multiplies the vertices by this and :func:`mesh_from_bytes` divides."""


def _check_uv_texture(uv: np.ndarray | None, texture: np.ndarray | None, n: int,
                      where: str) -> tuple[np.ndarray, np.ndarray] | None:
    """``(uv (n, 2) float64, texture (H, W, 3) uint8)`` checked, or None if neither given."""
    if uv is None and texture is None:
        return None
    if uv is None or texture is None:
        raise NaseviewError(f"{where}: a textured mesh needs both uv and texture")
    uv = np.asarray(uv, dtype=np.float64)
    tex = np.asarray(texture)
    if uv.shape != (n, 2) or not np.isfinite(uv).all():
        raise NaseviewError(f"{where}: uv must be a finite ({n}, 2) array, got {uv.shape}")
    if tex.ndim != 3 or tex.shape[2] != 3 or tex.dtype != np.uint8 or min(tex.shape[:2]) < 1:
        raise NaseviewError(f"{where}: texture must be an (H, W, 3) uint8 RGB image, got "
                            f"shape {tex.shape} dtype {tex.dtype}")
    return uv, tex


def _png_rgb(image: np.ndarray) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 RGB image."""
    return image_bytes(np.ascontiguousarray(image[:, :, ::-1]), ".png", where="texture")


def _glb(V: np.ndarray, F: np.ndarray, colors: np.ndarray | None,
         textured: tuple[np.ndarray, np.ndarray] | None) -> bytes:
    """A glTF 2.0 binary file of one mesh, vertices in metres (:data:`GLB_SCALE`).

    Smooth normals, a matte non-metallic material (glTF's default is fully metallic),
    ``COLOR_0`` (linear, from sRGB ``colors``) and/or ``TEXCOORD_0`` with the texture
    embedded as PNG (glTF UVs: origin at the image's top-left, v down).
    """
    import json
    import struct

    import trimesh  # lazy: see mesh_bytes

    normals = np.asarray(trimesh.Trimesh(V, F, process=False).vertex_normals, np.float32)
    pos = (V * GLB_SCALE).astype(np.float32)
    chunks: list[bytes] = []
    views: list[dict[str, int]] = []
    accessors: list[dict[str, object]] = []

    def add_view(data: bytes, target: int | None = None) -> int:
        offset = sum(len(c) for c in chunks)
        chunks.append(data + b"\0" * (-len(data) % 4))
        view: dict[str, int] = {"buffer": 0, "byteOffset": offset, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        views.append(view)
        return len(views) - 1

    def add_accessor(arr: np.ndarray, ctype: int, kind: str, target: int,
                     normalized: bool = False, bounds: bool = False) -> int:
        acc: dict[str, object] = {"bufferView": add_view(arr.tobytes(), target),
                                  "componentType": ctype, "count": int(len(arr)),
                                  "type": kind}
        if normalized:
            acc["normalized"] = True
        if bounds:
            acc["min"] = arr.min(axis=0).astype(float).tolist()
            acc["max"] = arr.max(axis=0).astype(float).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    attrs = {"POSITION": add_accessor(pos, 5126, "VEC3", 34962, bounds=True),
             "NORMAL": add_accessor(normals, 5126, "VEC3", 34962)}
    pbr: dict[str, object] = {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                              "metallicFactor": 0.0, "roughnessFactor": 1.0}
    doc: dict[str, object] = {}
    if colors is not None:
        rgb = colors[:, :3].astype(np.float64) / 255.0
        linear = np.round(255.0 * rgb ** 2.2).astype(np.uint8)   # glTF COLOR_0 is linear
        attrs["COLOR_0"] = add_accessor(np.ascontiguousarray(linear), 5121, "VEC3", 34962,
                                        normalized=True)
    if textured is not None:
        uv, tex = textured
        attrs["TEXCOORD_0"] = add_accessor(uv.astype(np.float32), 5126, "VEC2", 34962)
        image_view = add_view(_png_rgb(tex))
        doc["images"] = [{"bufferView": image_view, "mimeType": "image/png"}]
        doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071,
                            "wrapT": 33071}]
        doc["textures"] = [{"sampler": 0, "source": 0}]
        pbr["baseColorTexture"] = {"index": 0, "texCoord": 0}
    indices = add_accessor(F.astype(np.uint32).reshape(-1), 5125, "SCALAR", 34963)
    doc.update({
        "asset": {"version": "2.0", "generator": "naseview"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "face"}],
        "meshes": [{"primitives": [{"attributes": attrs, "indices": indices,
                                    "material": 0, "mode": 4}]}],
        "materials": [{"pbrMetallicRoughness": pbr, "doubleSided": True}],
        "buffers": [{"byteLength": sum(len(c) for c in chunks)}],
        "bufferViews": views, "accessors": accessors,
    })
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    binary = b"".join(chunks)
    body = (struct.pack("<II", len(js), 0x4E4F534A) + js
            + struct.pack("<II", len(binary), 0x004E4942) + binary)
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def mesh_bytes(V: np.ndarray, F: np.ndarray, file_type: str,
               vertex_colors: np.ndarray | None = None, *, uv: np.ndarray | None = None,
               texture: np.ndarray | None = None) -> bytes:
    """Encode a mesh as a file of ``file_type`` (``ply``, ``stl``, ``obj``, ``glb``).

    GLB (glTF 2.0) is written in **metres** (vertices x :data:`GLB_SCALE`), with smooth
    normals and a matte material, so any glTF viewer shows the face at its real size; the
    other types keep millimetres (they carry no unit).

    Args:
        V: (n, 3) vertices, mm.
        F: (m, 3) triangles.
        file_type: one of :data:`MESH_FORMATS`.
        vertex_colors: optional (n, 3) or (n, 4) uint8 sRGB(A) (ignored by STL).
        uv: (n, 2) texture coordinates in [0, 1], origin at the texture's top-left, v down
            (the glTF convention), with ``texture``; GLB only (the PNG is embedded). For
            a textured OBJ use :func:`textured_obj_files`.
        texture: (H, W, 3) uint8 RGB image, with ``uv``.
    Returns:
        The file content (binary PLY / STL / GLB, text OBJ).
    Raises:
        NaseviewError: malformed arrays, or a texture for a type other than GLB.
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
    textured = _check_uv_texture(uv, texture, len(V), f"mesh ({file_type})")
    if textured is not None and file_type != "glb":
        raise NaseviewError(f"mesh ({file_type}): only GLB embeds a texture; use GLB, or "
                            "textured_obj_files for OBJ + MTL + PNG")
    if file_type == "glb":
        return _glb(V, F, colors, textured)
    mesh = trimesh.Trimesh(vertices=V, faces=F, vertex_colors=colors, process=False)
    if file_type == "obj":
        data = mesh.export(file_type="obj", include_normals=False, include_texture=False)
    else:
        data = mesh.export(file_type=file_type)
    return data.encode("utf-8") if isinstance(data, str) else bytes(data)


def textured_obj_files(V: np.ndarray, F: np.ndarray, uv: np.ndarray, texture: np.ndarray,
                       name: str = "face") -> dict[str, bytes]:
    """A textured Wavefront OBJ as three files: ``name.obj``, ``name.mtl``, ``name.png``.

    The OBJ holds ``v`` (mm), ``vt`` (OBJ convention: origin at the image's bottom-left, so
    ``vt = (u, 1 - v)`` of the glTF-style ``uv``) and ``f v/vt`` lines, and names the MTL,
    which names the PNG; write them together (:func:`naseview.fileio.write_file_set`) or
    zip them.

    Args:
        V: (n, 3) vertices, mm; F: (m, 3) triangles.
        uv: (n, 2) texture coordinates in [0, 1], origin top-left, v down.
        texture: (H, W, 3) uint8 RGB image.
        name: base name of the three files (letters, digits, ``-``, ``_``).
    Returns:
        file name -> content, OBJ first.
    Raises:
        NaseviewError: malformed arrays or name.
    """
    V, F = _check_mesh(V, F, "textured OBJ")
    checked = _check_uv_texture(uv, texture, len(V), "textured OBJ")
    assert checked is not None
    uv, tex = checked
    if not name or not all(ch.isalnum() or ch in "-_" for ch in name):
        raise NaseviewError(f"textured OBJ: name {name!r} must be letters, digits, - or _")
    buf = io.StringIO()
    buf.write(f"# naseview textured face, millimetres (SPEC frame)\nmtllib {name}.mtl\n")
    np.savetxt(buf, V, fmt="v %.6f %.6f %.6f")
    np.savetxt(buf, np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]), fmt="vt %.6f %.6f")
    buf.write(f"usemtl {name}\n")
    f1 = F + 1
    np.savetxt(buf, np.repeat(f1, 2, axis=1), fmt="f %d/%d %d/%d %d/%d")
    mtl = (f"# naseview\nnewmtl {name}\nKa 1.000 1.000 1.000\nKd 1.000 1.000 1.000\n"
           f"Ks 0.000 0.000 0.000\nd 1.0\nillum 1\nmap_Kd {name}.png\n")
    return {f"{name}.obj": buf.getvalue().encode("utf-8"), f"{name}.mtl": mtl.encode("utf-8"),
            f"{name}.png": _png_rgb(tex)}


def export_mesh(path: str | os.PathLike[str], V: np.ndarray, F: np.ndarray,
                vertex_colors: np.ndarray | None = None, *, uv: np.ndarray | None = None,
                texture: np.ndarray | None = None) -> Path:
    """Write a triangle mesh atomically; the type comes from the suffix.

    Args:
        path: ``.ply`` / ``.stl`` / ``.obj`` / ``.glb`` file to write.
        V: (n, 3) vertices in mm (SPEC frame).
        F: (m, 3) int triangles.
        vertex_colors: optional (n, 3|4) uint8 RGB(A) per vertex (not stored in STL).
        uv, texture: a texture to embed (GLB only, see :func:`mesh_bytes`).
    Returns:
        The path written (a GLB holds metres, see :data:`GLB_SCALE`).
    Raises:
        NaseviewError: unknown suffix or malformed arrays.
    """
    path = Path(path)
    return atomic_write_bytes(path, mesh_bytes(V, F, _suffix(path), vertex_colors, uv=uv,
                                               texture=texture))


def read_mesh(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh written by :func:`export_mesh` (or any tool).

    Vertices are kept in file order (no merging), so vertex ids survive a round trip of
    PLY / OBJ / GLB; STL stores triangle soups, whose duplicate corners are merged. A GLB
    holds metres (glTF) and is read back in millimetres.

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
        ``(V, F)``: (n, 3) finite float64 vertices (mm; a GLB's metres are converted),
        (m, 3) int64 triangles whose ids lie in ``0..n-1``.
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
    if ext == "glb":
        V = V / GLB_SCALE
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
