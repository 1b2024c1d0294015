"""``naseview reconstruct CASE -o OUT --export glb`` writes the face with its photo
texture, as the app's "textured GLB" download does (issue 25): the same bake
(:func:`naseview.texture.bake.skin_texture` of the case's photos with the stage-1
cameras) and the same writer (:func:`naseview.texture.mesh_files.mesh_file`)."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import cv2
import numpy as np

from naseview.cli import main
from naseview.editing.baseline import baseline_from_output_dir

DEMO = Path(__file__).resolve().parents[2] / "assets" / "demo-case"


def _glb(data: bytes) -> tuple[dict, bytes]:
    """(glTF JSON, binary chunk) of a GLB file."""
    assert data[:4] == b"glTF"
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n]), data[20 + n + 8:]


def _embedded_image(doc: dict, binary: bytes) -> np.ndarray:
    """The first embedded image of a GLB, decoded (H, W, 3) BGR."""
    view = doc["bufferViews"][doc["images"][0]["bufferView"]]
    png = binary[view["byteOffset"]:view["byteOffset"] + view["byteLength"]]
    img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert img is not None
    return img


def test_the_command_lines_glb_carries_the_photo_texture(tmp_path: Path, capsys):
    out = tmp_path / "out"
    rc = main(["reconstruct", str(DEMO), "-o", str(out), "--model", "generic",
               "--export", "glb"])
    assert rc == 0, capsys.readouterr()
    base = baseline_from_output_dir(out)
    for part, n_max in (("face", len(base.V)), ("nose", len(base.V) - 1)):
        doc, binary = _glb((out / f"{part}.glb").read_bytes())
        prim = doc["meshes"][0]["primitives"][0]
        assert "TEXCOORD_0" in prim["attributes"], f"{part}.glb has no texture coordinates"
        assert doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] == 0
        image = _embedded_image(doc, binary)
        assert image.shape[0] >= 256 and image.shape[1] >= 256
        assert image.std() > 5.0, "the texture is a flat colour, not the photos"
        count = doc["accessors"][prim["attributes"]["POSITION"]]["count"]
        assert 0 < count <= n_max
    # the other files of the set are untouched by the texture (PLY stays plain)
    assert b"red" not in (out / "face.ply").read_bytes().split(b"end_header")[0]
