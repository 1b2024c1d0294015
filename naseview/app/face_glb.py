"""The face as two glTF parts for viser: the static rest and the live nose, one skin.

viser's simple meshes take neither a texture nor vertex colours, and each computes its own
normals, so the border between two of them shows as a lighter, stair-stepped seam. Here
the face ``V`` (n, 3) mm (SPEC frame, +y up), ``F`` (m, 3), is first hole-capped
(:func:`naseview.geometry.closing.cap_holes`: the eye and mouth openings show the photo's
eyes and mouth, as the texture was baked, not black sockets), then split into the
triangles touching the moving region (the *nose part*) and the rest
(:func:`naseview.app.scene_geometry.split_region`). Normals are computed once on the WHOLE capped
face; on an update only the moving vertices' normals are recomputed (every triangle
touching them lies in the nose part), while the part's border vertices — shared with the
rest, never moving — keep the whole-face normals the rest was sent with, so both parts
shade identically along the border: no seam.

Each part is a GLB (positions in mm: the scene's unit; ``add_glb(scale=1)``) with a
matte material: the baked texture (:class:`naseview.texture.bake.FaceTexture`, cropped to
the part's chart box and JPEG-encoded ONCE) or, without photos, a plain skin colour.
Precompute / solve: :class:`FaceGlb` builds the layout, the texture bytes and the static
tail of each part once; :meth:`FaceGlb.nose_glb` only re-packs positions and normals.

Example (``base`` a :class:`~naseview.editing.baseline.Baseline`)::

    parts = FaceGlb(base.V, base.F, region=base.nose_ids, texture=tex)
    rest = parts.rest_glb()                 # once
    nose = parts.nose_glb(simulated_V)      # every solve
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from naseview.app.scene_geometry import split_region
from naseview.errors import NaseviewError
from naseview.geometry.closing import cap_holes, cap_values
from naseview.geometry.mesh import vertex_normals
from naseview.imagefile import image_bytes
from naseview.texture.bake import FaceTexture

SKIN_RGB = (226, 192, 168)
"""sRGB skin colour of the untextured face."""

JPEG_QUALITY = 90
"""Quality of the texture JPEGs sent to the browser."""

NOSE_TEXTURE_MAX_PX = 512
"""Largest side of the nose part's texture (it travels with every update)."""

EMISSIVE_SHARE = 0.45
"""Share of the texture shown unlit (glTF ``emissiveTexture``): the photos already carry
their light, so the viewer's lights add only enough shading to read the shape."""

_GLTF_FLOAT, _GLTF_UINT = 5126, 5125
_ARRAY, _ELEMENTS = 34962, 34963


def _pad4(b: bytes, fill: bytes = b"\0") -> bytes:
    return b + fill * (-len(b) % 4)


@dataclass(frozen=True)
class _Part:
    """One GLB part: its vertex ids into the capped face, the static binary tail (uv,
    indices, image) and its JSON skeleton."""

    ids: np.ndarray
    n: int
    tail: bytes
    doc: dict[str, object]


def _part(ids: np.ndarray, faces: np.ndarray, uv: np.ndarray | None,
          jpeg: bytes | None, color: tuple[int, int, int]) -> _Part:
    """Layout ``[positions][normals][uv][indices][image]`` of one part (positions and
    normals re-packed on every update, the rest fixed)."""
    n = len(ids)
    f32 = 12 * n
    views: list[dict[str, int]] = [
        {"buffer": 0, "byteOffset": 0, "byteLength": f32, "target": _ARRAY},
        {"buffer": 0, "byteOffset": f32, "byteLength": f32, "target": _ARRAY}]
    accessors: list[dict[str, object]] = [
        {"bufferView": 0, "componentType": _GLTF_FLOAT, "count": n, "type": "VEC3",
         "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0]},
        {"bufferView": 1, "componentType": _GLTF_FLOAT, "count": n, "type": "VEC3"}]
    tail: list[bytes] = []
    offset = 2 * f32
    attrs: dict[str, int] = {"POSITION": 0, "NORMAL": 1}

    def add(data: bytes, target: int | None) -> int:
        nonlocal offset
        view: dict[str, int] = {"buffer": 0, "byteOffset": offset, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        views.append(view)
        padded = _pad4(data)
        tail.append(padded)
        offset += len(padded)
        return len(views) - 1

    linear = [float((c / 255.0) ** 2.2) for c in color]
    pbr: dict[str, object] = {"metallicFactor": 0.0, "roughnessFactor": 0.9,
                              "baseColorFactor": [*linear, 1.0]}
    material: dict[str, object] = {"pbrMetallicRoughness": pbr, "doubleSided": True}
    doc: dict[str, object] = {}
    if uv is not None and jpeg is not None:
        accessors.append({"bufferView": add(uv.astype(np.float32).tobytes(), _ARRAY),
                          "componentType": _GLTF_FLOAT, "count": n, "type": "VEC2"})
        attrs["TEXCOORD_0"] = 2
    idx = faces.astype(np.uint32).reshape(-1)
    accessors.append({"bufferView": add(idx.tobytes(), _ELEMENTS),
                      "componentType": _GLTF_UINT, "count": int(len(idx)), "type": "SCALAR"})
    if uv is not None and jpeg is not None:
        doc["images"] = [{"bufferView": add(jpeg, None), "mimeType": "image/jpeg"}]
        doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071,
                            "wrapT": 33071}]
        doc["textures"] = [{"sampler": 0, "source": 0}]
        pbr["baseColorFactor"] = [1.0 - EMISSIVE_SHARE] * 3 + [1.0]
        pbr["baseColorTexture"] = {"index": 0}
        material["emissiveTexture"] = {"index": 0}
        material["emissiveFactor"] = [EMISSIVE_SHARE] * 3
    body = b"".join(tail)
    doc.update({
        "asset": {"version": "2.0", "generator": "naseview"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attrs, "indices": len(accessors) - 1,
                                    "material": 0, "mode": 4}]}],
        "materials": [material],
        "buffers": [{"byteLength": 2 * f32 + len(body)}],
        "bufferViews": views, "accessors": accessors})
    return _Part(ids, n, body, doc)


def _pack(part: _Part, positions: np.ndarray, normals: np.ndarray) -> bytes:
    """GLB bytes of ``part`` with (n, 3) ``positions`` (mm) and unit ``normals``."""
    P = np.ascontiguousarray(positions, dtype=np.float32)
    N = np.ascontiguousarray(normals, dtype=np.float32)
    acc = part.doc["accessors"]
    assert isinstance(acc, list)
    acc[0]["min"] = P.min(axis=0).tolist() if len(P) else [0.0] * 3
    acc[0]["max"] = P.max(axis=0).tolist() if len(P) else [0.0] * 3
    js = _pad4(json.dumps(part.doc, separators=(",", ":")).encode("utf-8"), b" ")
    binary = P.tobytes() + N.tobytes() + part.tail
    total = 12 + 8 + len(js) + 8 + len(binary)
    return b"".join([struct.pack("<III", 0x46546C67, 2, total),
                     struct.pack("<II", len(js), 0x4E4F534A), js,
                     struct.pack("<II", len(binary), 0x004E4942), binary])


def _jpeg(image_rgb: np.ndarray) -> bytes:
    return image_bytes(np.ascontiguousarray(image_rgb[:, :, ::-1]), ".jpg", JPEG_QUALITY,
                       where="texture")


def _crop_chart(uv: np.ndarray, image: np.ndarray, margin_px: int = 4
                ) -> tuple[np.ndarray, np.ndarray]:
    """The texture box covering ``uv`` (k, 2) (plus a margin) and the uv re-expressed in
    it: a part sends only the texels it uses."""
    H, W = image.shape[:2]
    x0 = int(max(np.floor(uv[:, 0].min() * W) - margin_px, 0))
    x1 = int(min(np.ceil(uv[:, 0].max() * W) + margin_px, W))
    y0 = int(max(np.floor(uv[:, 1].min() * H) - margin_px, 0))
    y1 = int(min(np.ceil(uv[:, 1].max() * H) + margin_px, H))
    if x1 - x0 < 2 or y1 - y0 < 2:
        return uv, image
    crop = image[y0:y1, x0:x1]
    out = np.column_stack([(uv[:, 0] * W - x0) / (x1 - x0), (uv[:, 1] * H - y0) / (y1 - y0)])
    return out, crop


def _median_rgb(image_rgb: np.ndarray) -> tuple[int, int, int]:
    """The median colour (sRGB 0-255) of an (h, w, 3) RGB image's non-black pixels (the
    texture's skin; black is where no photo saw it)."""
    px = np.asarray(image_rgb).reshape(-1, 3)
    px = px[px.max(axis=1) > 16]
    if not len(px):
        return SKIN_RGB
    r, g, b = (int(v) for v in np.median(px, axis=0))
    return (r, g, b)


class FaceGlb:
    """The rest and nose GLBs of one face (see the module doc).

    Args:
        V: (n, 3) face vertices (mm), the reconstruction.
        F: (m, 3) triangles.
        region: (k,) ids of the vertices that may move (the nose part is every triangle
            touching them).
        texture: the face's baked texture (its ``uv`` has n rows), or None: skin colour.
        color: sRGB colour of the untextured face.
    """

    def __init__(self, V: ArrayLike, F: ArrayLike, region: ArrayLike,
                 texture: FaceTexture | None = None,
                 color: tuple[int, int, int] = SKIN_RGB) -> None:
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
        if texture is not None and len(texture.uv) != len(V):
            raise NaseviewError(f"texture: baked for {len(texture.uv)} vertices, the face has "
                                f"{len(V)}; bake it again for this reconstruction")
        self.n = len(V)
        self.textured = texture is not None
        Vc, Fc = cap_holes(V, F)
        self.base_Vc = Vc
        # cap centre = mean of its rim (the caps were baked flat: recess 0)
        fans = Fc[len(F):]
        self._cap_rims = [fans[fans[:, 2] == c][:, 1] for c in range(self.n, len(Vc))]
        region = np.asarray(region, dtype=np.int64)
        self.region = region
        part_ids, part_F, rest_ids, rest_F = split_region(Fc, region, len(Vc))
        self.normals_c = vertex_normals(Vc, Fc)
        moving = np.zeros(len(Vc), dtype=bool)
        moving[region] = True
        self._part_moving = moving[part_ids]
        self._part_F = part_F
        self._moving_caps = [(c, rim) for c, rim in enumerate(self._cap_rims)
                             if moving[rim].any()]
        uvc = cap_values(texture.uv, F, V) if texture is not None else None
        parts = []
        for ids, faces in ((rest_ids, rest_F), (part_ids, part_F)):
            uv = jpeg = None
            if texture is not None and uvc is not None and len(ids):
                uv, crop = _crop_chart(uvc[ids], texture.image)
                if ids is part_ids and max(crop.shape[:2]) > NOSE_TEXTURE_MAX_PX:
                    k = NOSE_TEXTURE_MAX_PX / max(crop.shape[:2])   # sent on every update
                    crop = cv2.resize(crop, (max(2, round(crop.shape[1] * k)),
                                             max(2, round(crop.shape[0] * k))),
                                      interpolation=cv2.INTER_AREA)
                jpeg = _jpeg(crop)
            parts.append(_part(ids, faces, uv, jpeg, color))
            if ids is part_ids:
                self.nose_rgb: tuple[int, int, int] = (
                    _median_rgb(crop) if texture is not None and uv is not None else color)
        self._rest, self._nose = parts

    @property
    def nose_ids(self) -> np.ndarray:
        """(p,) ids into the capped face of the nose part's vertices (the first n are the
        face's own ids)."""
        return self._nose.ids

    def rest_glb(self) -> bytes:
        """GLB of the static rest of the face (with the eye / mouth caps)."""
        ids = self._rest.ids
        return _pack(self._rest, self.base_Vc[ids], self.normals_c[ids])

    def nose_geometry(self, V: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(p, 3) positions and normals of the nose part for the face ``V`` (n, 3) mm:
        moving vertices' normals from the part, the border's from the whole face."""
        V = np.asarray(V, dtype=np.float64)
        ids = self._nose.ids
        P = self.base_Vc[ids].copy()
        inner = ids < self.n
        P[inner] = V[ids[inner]]
        for c, rim in self._moving_caps:      # a cap whose rim moves follows it
            P[ids == self.n + c] = V[rim].mean(axis=0)
        N = self.normals_c[ids].copy()
        if self._part_moving.any():
            N_part = vertex_normals(P, self._part_F)
            N[self._part_moving] = N_part[self._part_moving]
        return P, N

    @property
    def nose_faces(self) -> np.ndarray:
        """(t, 3) the nose part's triangles, indices into :meth:`nose_geometry`'s rows."""
        return self._part_F

    def nose_glb(self, V: ArrayLike) -> bytes:
        """GLB of the nose part for the face ``V`` (n, 3) mm (only positions and normals
        are packed anew)."""
        return self.pack_nose(*self.nose_geometry(V))

    def pack_nose(self, P: np.ndarray, N: np.ndarray) -> bytes:
        """GLB of the nose part with positions ``P`` and normals ``N`` (p, 3) as
        :meth:`nose_geometry` gives them."""
        return _pack(self._nose, P, N)


__all__ = ["EMISSIVE_SHARE", "FaceGlb", "SKIN_RGB"]
