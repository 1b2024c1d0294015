"""Mesh export round trips and one-line mesh errors (naseview.meshio)."""

from __future__ import annotations

import numpy as np
import pytest

from naseview.errors import NaseviewError
from naseview.meshio import export_mesh, read_mesh


@pytest.mark.parametrize("ext", ["ply", "stl", "obj", "glb"])
def test_export_round_trip(tmp_path, ext: str) -> None:
    rng = np.random.default_rng(1)
    # a bumpy open grid: distinct vertices, consistent orientation
    gx, gy = np.meshgrid(np.arange(6.0), np.arange(5.0))
    V = np.c_[gx.ravel() * 2.5, gy.ravel() * 2.5, rng.normal(0, 1, gx.size)]
    idx = np.arange(gx.size).reshape(gx.shape)
    F = np.concatenate([
        np.c_[idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()],
        np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()]])
    colors = rng.integers(0, 255, (len(V), 3)).astype(np.uint8)
    path = export_mesh(tmp_path / f"m.{ext}", V, F, vertex_colors=colors)
    V2, F2 = read_mesh(path)
    assert len(F2) == len(F) and len(V2) == len(V)
    # same triangles (as point triples, order-insensitive for STL's merged vertices)
    tri = np.sort(V[F].reshape(len(F), -1), axis=0)
    tri2 = np.sort(V2[F2].reshape(len(F2), -1), axis=0)
    assert np.allclose(tri, tri2, atol=1e-5)
    if ext != "stl":
        assert np.allclose(V2, V, atol=1e-5) and (F2 == F).all()
    assert not list(tmp_path.glob(".*.tmp"))


def test_mesh_errors_are_one_line(tmp_path) -> None:
    V = np.eye(3)
    F = np.array([[0, 1, 2]])
    with pytest.raises(NaseviewError, match="unsupported mesh type"):
        export_mesh(tmp_path / "m.xyz", V, F)
    with pytest.raises(NaseviewError, match="outside"):
        export_mesh(tmp_path / "m.ply", V, np.array([[0, 1, 5]]))
    with pytest.raises(NaseviewError, match="not found"):
        read_mesh(tmp_path / "none.ply")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"this is not a mesh")
    with pytest.raises(NaseviewError) as e:
        read_mesh(bad)
    assert "\n" not in str(e.value)


def _glb_json(data: bytes) -> dict:
    import json
    import struct

    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])


def _sheet() -> tuple[np.ndarray, np.ndarray]:
    gx, gy = np.meshgrid(np.linspace(-70.0, 70.0, 5), np.linspace(-100.0, 100.0, 6))
    V = np.c_[gx.ravel(), gy.ravel(), 0.01 * gx.ravel() ** 2]
    idx = np.arange(gx.size).reshape(gx.shape)
    F = np.concatenate([
        np.c_[idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()],
        np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()]])
    return V, F


def test_glb_is_in_metres() -> None:
    import io

    import trimesh

    from naseview.meshio import mesh_bytes, mesh_from_bytes

    V, F = _sheet()                                   # 140 mm x 200 mm
    data = mesh_bytes(V, F, "glb")
    acc = _glb_json(data)["accessors"][0]
    assert np.allclose(acc["max"], V.max(axis=0) / 1000.0, atol=1e-6)
    assert np.allclose(acc["min"], V.min(axis=0) / 1000.0, atol=1e-6)
    # what any glTF reader sees: a face-sized object in metres
    raw = trimesh.load(io.BytesIO(data), file_type="glb", force="mesh", process=False)
    assert np.allclose(raw.extents, np.ptp(V, axis=0) / 1000.0, atol=1e-6)
    # read back by naseview in millimetres
    V2, F2 = mesh_from_bytes(data, "glb", "m.glb")
    assert np.allclose(V2, V, atol=1e-3) and (F2 == F).all()
    mat = _glb_json(data)["materials"][0]["pbrMetallicRoughness"]
    assert mat["metallicFactor"] == 0.0                # not glTF's default metal


def test_textured_glb_and_obj() -> None:
    import io

    import cv2
    import trimesh

    from naseview.meshio import mesh_bytes, textured_obj_files

    V, F = _sheet()
    uv = np.c_[(V[:, 0] + 70) / 140, (100 - V[:, 1]) / 200]    # top of the sheet at v = 0
    tex = np.zeros((8, 16, 3), np.uint8)
    tex[:4] = (255, 0, 0)                                   # top half red (RGB)
    tex[4:] = (0, 0, 255)
    glb = mesh_bytes(V, F, "glb", uv=uv, texture=tex)
    doc = _glb_json(glb)
    assert doc["images"][0]["mimeType"] == "image/png"
    prim = doc["meshes"][0]["primitives"][0]
    assert "TEXCOORD_0" in prim["attributes"]
    loaded = trimesh.load(io.BytesIO(glb), file_type="glb", force="mesh", process=False)
    # trimesh flips glTF's v (top-left origin) to its bottom-left convention
    assert np.allclose(loaded.visual.uv[:, 1], 1.0 - uv[:, 1], atol=1e-6)
    img = np.asarray(loaded.visual.material.baseColorTexture.convert("RGB"))
    assert tuple(img[0, 0]) == (255, 0, 0)
    files = textured_obj_files(V, F, uv, tex, "face")
    assert list(files) == ["face.obj", "face.mtl", "face.png"]
    obj = files["face.obj"].decode()
    assert "mtllib face.mtl" in obj and "map_Kd face.png" in files["face.mtl"].decode()
    vt = np.array([[float(x) for x in ln.split()[1:]] for ln in obj.splitlines()
                   if ln.startswith("vt ")])
    assert np.allclose(vt[:, 1], 1.0 - uv[:, 1], atol=1e-6)          # OBJ: bottom-left
    assert obj.count("\nf ") == len(F) and "f 1/1 " in obj
    png = cv2.imdecode(np.frombuffer(files["face.png"], np.uint8), cv2.IMREAD_COLOR)
    assert tuple(png[0, 0]) == (0, 0, 255)                            # BGR of red


def test_texture_errors_are_one_line() -> None:
    from naseview.meshio import mesh_bytes

    V, F = _sheet()
    with pytest.raises(NaseviewError, match="only GLB embeds a texture"):
        mesh_bytes(V, F, "stl", uv=np.zeros((len(V), 2)), texture=np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(NaseviewError, match="uv must be"):
        mesh_bytes(V, F, "glb", uv=np.zeros((3, 2)), texture=np.zeros((4, 4, 3), np.uint8))
