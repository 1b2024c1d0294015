"""The before/after colour map of the app: how far each point of the nose moved, in a
diverging palette with its colour bar (the surgeon's "Colour map" view, issue 6).

- :func:`signed_displacement` - (k,) mm each vertex moved along its rest normal (+ out);
- :func:`diverging_colors` - those values as RdBu colours, blue in, red out;
- :func:`vertex_color_glb` - a mesh with per-vertex colours as a GLB (viser's simple mesh
  has no vertex colours);
- :func:`nice_limit`, :func:`colorbar_image` - the scale's round limit and its bar.
"""

from __future__ import annotations

import json
import struct

import cv2
import numpy as np

_RDBU = np.array([[33, 102, 172], [103, 169, 207], [209, 229, 240], [247, 247, 247],
                  [253, 219, 199], [239, 138, 98], [178, 24, 43]], dtype=np.float64)


def diverging_colors(values: np.ndarray, limit: float,
                     neutral: tuple[int, int, int] | None = None) -> np.ndarray:
    """Blue (``-limit``) - white (0) - red (``+limit``) colours, (N, 3) uint8.

    With ``neutral`` (e.g. the skin colour) the middle of the scale is that colour, so an
    unchanged surface keeps its look and only the change is coloured.
    """
    v = np.asarray(values, dtype=np.float64)
    t = np.clip((v / max(limit, 1e-9) + 1.0) / 2.0, 0, 1)
    x = t * (len(_RDBU) - 1)
    i = np.minimum(np.floor(x).astype(int), len(_RDBU) - 2)
    f = (x - i)[:, None]
    c = _RDBU[i] * (1 - f) + _RDBU[i + 1] * f
    if neutral is not None:
        a = np.clip(np.abs(v) / max(limit, 1e-9), 0, 1)[:, None] ** 0.6
        ends = np.where((v < 0)[:, None], _RDBU[0], _RDBU[-1])
        c = np.asarray(neutral, dtype=np.float64) * (1 - a) + ends * a
    return np.round(c).astype(np.uint8)


def vertex_color_glb(V: np.ndarray, F: np.ndarray, colors: np.ndarray) -> bytes:
    """A GLB of a mesh with per-vertex sRGB ``colors`` (N, 3) uint8 and smooth normals,
    with a matte, non-metallic material so it shades like viser's simple meshes (glTF's
    default material is fully metallic)."""
    import trimesh  # lazy: importing trimesh takes ~0.5 s and every `naseview` command
    #                 imports this module (through the CLI); only the colour map needs it

    mesh = trimesh.Trimesh(np.asarray(V, np.float64), np.asarray(F, np.int64), process=False)
    linear = np.round(255.0 * (np.asarray(colors) / 255.0) ** 2.2).astype(np.uint8)
    visual = mesh.visual
    assert isinstance(visual, trimesh.visual.ColorVisuals)  # a new mesh: plain colours
    visual.vertex_colors = np.column_stack([linear, np.full(len(linear), 255, np.uint8)])
    _ = mesh.vertex_normals                     # cached normals are exported
    glb = mesh.export(file_type="glb")
    assert isinstance(glb, bytes)
    n = struct.unpack("<I", glb[12:16])[0]
    doc = json.loads(glb[20:20 + n])
    rest = glb[20 + n:]
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                                                  "metallicFactor": 0.0,
                                                  "roughnessFactor": 1.0},
                         "doubleSided": True}]
    for m in doc.get("meshes", []):
        for prim in m.get("primitives", []):
            prim["material"] = 0
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + rest
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def signed_displacement(V0: np.ndarray, V: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(N,) displacement along the outward normal, mm: + outwards (augmentation),
    - inwards (reduction). ``V0``, ``V``, ``normals`` are (N, 3)."""
    return np.einsum("ij,ij->i", np.asarray(V) - np.asarray(V0), normals)


def nice_limit(max_abs_mm: float) -> float:
    """A round colour-scale limit (mm) at least ``max_abs_mm`` (minimum 0.5 mm)."""
    for lim in (0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0, 15.0, 20.0, 30.0, 50.0):
        if max_abs_mm <= lim:
            return lim
    return float(np.ceil(max_abs_mm / 10.0) * 10.0)


def colorbar_image(limit: float, width: int = 300, height: int = 54,
                   neutral: tuple[int, int, int] | None = None) -> np.ndarray:
    """(H, W, 3) uint8 RGB colour bar with tick labels for :func:`diverging_colors`."""
    img = np.full((height, width, 3), 255, dtype=np.uint8)
    pad = 18
    bar = diverging_colors(np.linspace(-limit, limit, width - 2 * pad), limit, neutral)
    img[4:22, pad:width - pad] = bar[None, :, :]
    cv2.rectangle(img, (pad, 4), (width - pad - 1, 21), (90, 90, 90), 1)
    for v in (-limit, -limit / 2, 0.0, limit / 2, limit):
        x = int(round(pad + (v + limit) / (2 * limit) * (width - 2 * pad - 1)))
        cv2.line(img, (x, 22), (x, 26), (60, 60, 60), 1)
        text = f"{v:+g}" if v else "0"
        (tw, _), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)
        cv2.putText(img, text, (int(np.clip(x - tw // 2, 0, width - tw)), 40),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, (40, 40, 40), 1, cv2.LINE_AA)
    cv2.putText(img, "mm  (blue: inwards, red: outwards)", (pad, 52),
                cv2.FONT_HERSHEY_SIMPLEX, 0.36, (70, 70, 70), 1, cv2.LINE_AA)
    return img
