"""A face scan with landmarks (SPEC §8) as a synthetic case: ``naseview synth --scan``.

The out-of-model test bed: any face scan (OBJ with its MTL/texture, or PLY; mm) and a
``naseview.scan-landmarks/1`` file become a case with the usual rig, click noise and
sensor noise (:mod:`~naseview.testbed.synth.rig`, :mod:`~naseview.testbed.synth.clicks`,
:mod:`~naseview.testbed.synth.photo`) and its SPEC §7 truth: the scan itself is the true
face (``truth_face.ply``, SPEC frame), the landmark file gives the true landmarks and the
``add`` helpers. No face model is involved, so naseview can be measured on faces its face
models have never seen.

- :func:`read_scan`: the two (three) files, validated once, with one-line errors that
  name the file, the key and the fix; the scan moved into the SPEC frame
  (``X_spec = R @ X_obj + t``).
- the photo: the scan is rasterised with its texture sampled per pixel (bilinear, at the
  perspective-correct texture coordinates), lit like every synthetic photo; a head proxy
  (:mod:`~naseview.testbed.synth.head`) closes an open scan behind the face.
- the true curves: SPEC §5 vertex paths through the landmarks' nearest scan vertices
  (:func:`naseview.facemodel.meshcurves.curve_paths`; no nostril sills: a scan does not
  say which vertices are nostril), projected as the 2D truth of ``truth_boundaries.json``.

Example
-------
    scan = read_scan("../shared/data/scans/james/james.obj",
                     "../shared/data/scans/james/landmarks.json")
    synthesize_scan_case("/tmp/james-0", scan, seed=0)
    # -> PosixPath('/tmp/james-0/case.json')
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from naseview.camera import Camera
from naseview.case import Case as CaseData
from naseview.case import View, write_case
from naseview.errors import NaseviewError
from naseview.facemodel.meshcurves import curve_paths
from naseview.fileio import atomic_write_json, one_line, read_json
from naseview.geometry.mesh import vertex_normals
from naseview.imagefile import read_image
from naseview.landmarks import HELPER_IDS, LANDMARK_IDS, VIEWS
from naseview.measurements import clinical_measurements
from naseview.meshio import export_mesh, read_mesh, triangulate_polygons
from naseview.reconstruction import Reconstruction
from naseview.render import rasterize, shade_vertices
from naseview.stage1_landmarks.template import plausible_distance, typical_distance_mm
from naseview.testbed.synth.clicks import view_clicks
from naseview.testbed.synth.head import head_proxy
from naseview.testbed.synth.photo import Studio, draw_studio
from naseview.testbed.synth.rig import DEFAULT_SIZE, check_synth_arguments, sample_rig_points
from naseview.testbed.synth.skin import HAIR_RGB, hair_weight
from naseview.testbed.synth.truth import view_boundaries

SCAN_FORMAT = "naseview.scan-landmarks/1"
"""The ``format`` of a scan-landmarks file (SPEC §8)."""

MAX_LANDMARK_OFF_SURFACE_MM = 3.0
"""A landmark further than this from the scan surface means a wrong frame or file."""

MAX_SCAN_VERTICES = 2_000_000
"""Largest scan accepted (vertices): a bigger one is a wrong file or needs decimating."""


@dataclass
class ScanFace:
    """A face scan in the SPEC frame with its true landmarks.

    Attributes:
        V: (n, 3) vertices, mm, SPEC frame. F: (m, 3) triangles.
        uv: (m, 3, 2) texture coordinates of each triangle corner (OBJ ``vt``: u right,
            v up), or None.
        texture: (H, W, 3) uint8 BGR texture, or None (then a uniform skin tone).
        landmarks: the 21 landmark ids -> (3,) true position (mm, SPEC frame).
        helpers: ``add_l`` / ``add_r`` -> (1, 3) true helper point.
        source: JSON-able record of the files (and the file's ``credit``, if any).
    """

    V: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    texture: np.ndarray | None
    landmarks: dict[str, np.ndarray]
    helpers: dict[str, np.ndarray]
    source: dict[str, Any]


def _vector(path: Path, key: str, value: object, n: int) -> np.ndarray:
    """``value`` as n finite numbers, or a one-line error naming file and key."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise NaseviewError(f"{path}: key {key!r}: expected a list of {n} finite numbers, "
                            f"got {str(value)[:60]}")
    return a


def _transform(path: Path, data: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """``transform_from_obj`` (R a rotation, t mm), identity when absent."""
    tr = data.get("transform_from_obj")
    if tr is None:
        return np.eye(3), np.zeros(3)
    if not isinstance(tr, dict) or "R" not in tr or "t" not in tr:
        raise NaseviewError(f"{path}: key 'transform_from_obj': expected "
                            '{"R": [[3 x 3]], "t": [3]} (or leave it out for identity)')
    rows = tr["R"] if isinstance(tr["R"], list) and len(tr["R"]) == 3 else [None] * 3
    R = np.array([_vector(path, "transform_from_obj.R", r, 3) for r in rows])
    if not (np.allclose(R @ R.T, np.eye(3), atol=1e-3) and np.linalg.det(R) > 0):
        raise NaseviewError(f"{path}: key 'transform_from_obj.R' is not a rotation "
                            "(orthonormal, determinant +1); the scan must keep its size "
                            "and handedness")
    return R, _vector(path, "transform_from_obj.t", tr["t"], 3)


def read_scan_landmarks(path: str | os.PathLike[str]
                        ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray,
                                   dict[str, Any]]:
    """A SPEC §8 scan-landmarks file: (id -> (3,) SPEC-frame point for the 21 landmarks
    and both helpers, R (3, 3), t (3,), the parsed JSON).

    Raises:
        NaseviewError: unreadable JSON, wrong ``format`` or ``units``, a landmark missing
            or not 3 finite numbers, a transform that is not a rotation.
    """
    path = Path(path)
    data = read_json(path)
    if data.get("format") != SCAN_FORMAT:
        raise NaseviewError(f"{path}: key 'format' is {data.get('format')!r}; expected "
                            f"{SCAN_FORMAT!r} (SPEC §8)")
    if data.get("units", "mm") != "mm":
        raise NaseviewError(f"{path}: key 'units' is {data.get('units')!r}; scans must be in "
                            "mm (scale the scan and its landmarks)")
    R, t = _transform(path, data)
    lms = data.get("landmarks")
    if not isinstance(lms, dict):
        raise NaseviewError(f"{path}: key 'landmarks': expected an object id -> [x, y, z]")
    missing = [k for k in (*LANDMARK_IDS, *HELPER_IDS) if k not in lms]
    if missing:
        raise NaseviewError(f"{path}: key 'landmarks' lacks {', '.join(missing)}; SPEC §8 "
                            "needs all 21 landmarks and both add helpers")
    pts = {k: _vector(path, f"landmarks.{k}", lms[k], 3) for k in (*LANDMARK_IDS, *HELPER_IDS)}
    for a, b in (("al_l", "al_r"), ("g", "prn")):   # the size of the nose: mm, one face
        d = float(np.linalg.norm(pts[a] - pts[b]))
        if not plausible_distance(a, b, d):
            raise NaseviewError(
                f"{path}: key 'landmarks': {a}-{b} is {d:.3g} mm, not a nose's (about "
                f"{typical_distance_mm(a, b):.0f} mm); give the landmarks in millimetres "
                "and check that each is at its own point (SPEC §8)")
    return pts, R, t, data


def _obj_uv(path: Path, lines: list[bytes], n_corners: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(T, 2) ``vt`` coordinates and (S,) the vt id of every face corner (file order), or
    None when the faces carry no texture coordinates."""
    vt = [ln.split()[1:3] for ln in lines if ln.startswith(b"vt ")]
    if not vt:
        return None
    corners = [c for ln in lines if ln.startswith(b"f ") for c in ln.split()[1:]]
    parts = [c.split(b"/") for c in corners]
    if len(parts) != n_corners or any(len(p) < 2 or not p[1] for p in parts):
        return None
    try:
        T = np.array(vt, dtype=np.float64)
        ids = np.array([p[1] for p in parts]).astype(np.int64)
    except ValueError:
        raise NaseviewError(f"{path}: malformed 'vt' line or face texture index") from None
    ids = np.where(ids < 0, len(T) + ids, ids - 1)
    if ids.min() < 0 or ids.max() >= len(T):
        raise NaseviewError(f"{path}: a face refers to texture coordinate {int(ids.max()) + 1}"
                            f", but the file has {len(T)} 'vt' lines")
    return T, ids


def _mtl_texture(path: Path, lines: list[bytes]) -> Path | None:
    """The ``map_Kd`` image of the OBJ's first ``mtllib``, if both exist."""
    for ln in lines:
        if ln.startswith(b"mtllib "):
            mtl = path.parent / ln.split(None, 1)[1].decode(errors="replace").strip()
            if not mtl.is_file():
                return None
            for m in mtl.read_bytes().splitlines():
                if m.strip().startswith(b"map_Kd "):
                    return mtl.parent / m.strip().split(None, 1)[1].decode(
                        errors="replace").strip()
    return None


def _read_obj_textured(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None,
                                            Path | None]:
    """(V, F, corner uv (m, 3, 2) or None, texture path from the MTL or None)."""
    from naseview.meshio import read_obj

    obj = read_obj(path)
    pos = triangulate_polygons(np.arange(len(obj.indices)), obj.sizes)
    F = obj.indices[pos]
    lines = path.read_bytes().splitlines()
    uv = _obj_uv(path, lines, len(obj.indices))
    corner_uv = None if uv is None else uv[0][uv[1][pos]]
    return obj.vertices, F, corner_uv, _mtl_texture(path, lines)


def read_scan(scan: str | os.PathLike[str], landmarks: str | os.PathLike[str],
              texture: str | os.PathLike[str] | None = None) -> ScanFace:
    """A face scan and its SPEC §8 landmark file, validated, in the SPEC frame.

    Args:
        scan: OBJ (with ``vt`` and an MTL ``map_Kd`` for its texture) or PLY, mm.
        landmarks: the ``naseview.scan-landmarks/1`` JSON file.
        texture: an image that overrides the MTL's (OBJ with ``vt`` only).
    Returns:
        :class:`ScanFace` (moved so that g is the origin, if it was not exactly).
    Raises:
        NaseviewError: a bad file (names the file, key and fix), a landmark further than
            :data:`MAX_LANDMARK_OFF_SURFACE_MM` from the scan (a wrong transform).
    """
    scan, lm_path = Path(scan), Path(landmarks)
    pts, R, t, data = read_scan_landmarks(lm_path)
    if not scan.is_file():
        raise NaseviewError(f"{scan}: scan file not found (--scan)")
    suffix = scan.suffix.lower()
    uv: np.ndarray | None = None
    tex_path: Path | None = None
    if suffix == ".obj":
        V0, F, uv, tex_path = _read_obj_textured(scan)
    elif suffix == ".ply":
        V0, F = read_mesh(scan)
    else:
        raise NaseviewError(f"{scan}: --scan must be an .obj or .ply mesh")
    if not _has_area(np.asarray(V0, np.float64), np.asarray(F, np.int64)):
        raise NaseviewError(f"{scan}: no triangle of the scan has a non-zero area; "
                            "re-export it as a triangle mesh of the face")
    if len(V0) > MAX_SCAN_VERTICES:
        raise NaseviewError(f"{scan}: {len(V0)} vertices, more than {MAX_SCAN_VERTICES}; "
                            "decimate the scan first")
    if texture is not None:
        if uv is None:
            raise NaseviewError(f"{scan}: --texture needs an OBJ with texture coordinates "
                                "('vt' and 'f v/vt' lines)")
        tex_path = Path(texture)
    tex = None
    if tex_path is not None and uv is not None:
        if not tex_path.is_file():
            raise NaseviewError(f"{tex_path}: texture image not found (--texture, or the "
                                "MTL's map_Kd)")
        tex = read_image(tex_path)
    V = np.asarray(V0, np.float64) @ R.T + t
    g = pts["g"].copy()
    V -= g
    pts = {k: p - g for k, p in pts.items()}
    _check_on_surface(lm_path, V, np.asarray(F, np.int64), pts)
    source = {"scan": scan.name, "landmarks": lm_path.name,
              "texture": None if tex_path is None else tex_path.name,
              "credit": str(data.get("credit", _licence_line(scan)))}
    return ScanFace(V, np.asarray(F, np.int64), uv, tex,
                    {k: pts[k] for k in LANDMARK_IDS}, {k: pts[k][None] for k in HELPER_IDS},
                    source)


def anonymous_scan_id(scan: ScanFace) -> str:
    """8 hex digits from the scan's geometry: the same scan gives the same case ids, and
    ``case.json`` (SPEC §3: an anonymised id) never carries the scan's file name, which is
    often the person's; the file names stay in ``truth.json`` (``synth.scan``) only."""
    return hashlib.sha256(np.ascontiguousarray(scan.V, np.float64).tobytes()).hexdigest()[:8]


def _has_area(V: np.ndarray, F: np.ndarray) -> bool:
    """Whether any triangle of (V, F) has an area above 1e-12 of the squared mesh size."""
    if not len(F):
        return False
    size2 = float(np.ptp(V, axis=0).max()) ** 2
    a = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    return bool(size2 > 0 and (a > 1e-12 * size2).any())


def _licence_line(scan: Path) -> str:
    """``scan NAME`` plus the first line of a LICENSE file beside the scan, if any."""
    lic = scan.parent / "LICENSE"
    try:
        first = lic.read_text(errors="replace").strip().splitlines()[0] if lic.is_file() else ""
    except (OSError, IndexError):
        first = ""
    return f"scan {scan.name}" + (f" ({lic.name}: {first})" if first else "")


def _check_on_surface(path: Path, V: np.ndarray, F: np.ndarray,
                      pts: dict[str, np.ndarray]) -> None:
    """Every landmark lies on the scan (within :data:`MAX_LANDMARK_OFF_SURFACE_MM`)."""
    import igl

    P = np.array(list(pts.values()))
    d2, _, _ = igl.point_mesh_squared_distance(P, np.ascontiguousarray(V),
                                               np.ascontiguousarray(F))
    d = np.sqrt(d2)
    if d.max() > MAX_LANDMARK_OFF_SURFACE_MM:
        k = list(pts)[int(np.argmax(d))]
        raise NaseviewError(
            f"{path}: key 'landmarks.{k}' lies {d.max():.1f} mm from the scan surface (at "
            f"most {MAX_LANDMARK_OFF_SURFACE_MM:g}); check 'transform_from_obj' and that "
            "the landmarks are in the SPEC frame (SPEC §8)")


@dataclass
class _ScanScene:
    """The rendered geometry: scan first (``n_scan`` triangles), then the head proxy."""

    V: np.ndarray
    F: np.ndarray
    N: np.ndarray
    C: np.ndarray
    n_scan_faces: int
    uv: np.ndarray | None
    texture: np.ndarray | None
    tone: np.ndarray


def _scan_scene(scan: ScanFace, rng: np.random.Generator) -> tuple[_ScanScene, dict[str, Any]]:
    """The scan (white albedo where textured: the texture multiplies per pixel) and a head
    proxy behind it in the scan's mean skin tone, hair above a random hairline."""
    s = float(np.linalg.norm(scan.landmarks["al_l"] - scan.landmarks["al_r"])) / 35.0
    if scan.texture is not None and scan.uv is not None:
        tone = _mean_skin(scan)
    else:
        tone = np.array([0.62, 0.70, 0.86]) * float(rng.uniform(0.8, 1.05))
    hair = np.asarray(HAIR_RGB[int(rng.integers(len(HAIR_RGB)))][::-1], float) / 255.0
    hairline = float(rng.uniform(42.0, 60.0)) * s
    PV, PF, _ = head_proxy(scan.V, scan.F, s)
    hw = hair_weight(PV, s, hairline)
    PC = tone * (1 - hw[:, None]) + hw[:, None] * hair
    Cs = np.ones((len(scan.V), 3)) if scan.texture is not None else np.tile(tone, (len(scan.V), 1))
    V = np.concatenate([scan.V, PV])
    F = np.concatenate([scan.F, PF + len(scan.V)])
    N = np.concatenate([vertex_normals(scan.V, scan.F), vertex_normals(PV, PF)])
    look = {"skin_bgr": tone.tolist(), "hair_bgr": hair.tolist(), "hairline_mm": hairline}
    return _ScanScene(V, F, N, np.concatenate([Cs, PC]), len(scan.F), scan.uv, scan.texture,
                      tone), look


def _mean_skin(scan: ScanFace) -> np.ndarray:
    """(3,) BGR in [0, 1]: the texture's median colour around the nose and cheeks."""
    assert scan.texture is not None and scan.uv is not None
    C = scan.V[scan.F].mean(1)
    near = np.linalg.norm(C - scan.landmarks["prn"], axis=1) < 40.0
    uv = scan.uv[near].reshape(-1, 2) if near.any() else scan.uv.reshape(-1, 2)
    H, W = scan.texture.shape[:2]
    x = np.clip((uv[:, 0] % 1.0) * (W - 1), 0, W - 1).astype(int)
    y = np.clip((1.0 - uv[:, 1] % 1.0) * (H - 1), 0, H - 1).astype(int)
    return np.asarray(np.median(scan.texture[y, x], axis=0) / 255.0)


def _sample_texture(tex: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 3) bilinear samples of an image at pixel coordinates x, y (N,) (cv2.remap,
    whose maps must stay below 32767 columns: laid out 4096 wide)."""
    n = len(x)
    cols = 4096
    rows = max(1, -(-n // cols))
    mx = np.zeros(rows * cols, np.float32)
    my = np.zeros(rows * cols, np.float32)
    mx[:n], my[:n] = x, y
    out = cv2.remap(tex, mx.reshape(rows, cols), my.reshape(rows, cols), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REFLECT)
    return np.asarray(out.reshape(-1, 3)[:n])


def _render_scan_photo(sc: _ScanScene, cam: Camera, studio: Studio, rng: np.random.Generator,
                       image_noise: float) -> tuple[np.ndarray, np.ndarray]:
    """One photo of the scan scene: (H, W, 3) uint8 BGR and the (H, W) depth (mm)."""
    lit = shade_vertices(sc.V, sc.N, sc.C, cam, light_dirs=studio.light_dirs,
                         light_intensities=(0.55, 0.24), ambient=0.26, specular=0.05,
                         shininess=20.0)
    ras = rasterize(sc.V, sc.F, cam, supersample=1, cull_backfaces=True)
    H, W = ras.depth.shape
    out = np.empty((H * W, 3), np.float32)
    out[:] = np.asarray(studio.background, np.float32) / 255.0
    if ras.pixels.size:
        col = ras.interpolate(sc.F, lit)
        fid = ras.face_id.reshape(-1)[ras.pixels]
        on_scan = fid < sc.n_scan_faces
        if sc.texture is not None and sc.uv is not None and on_scan.any():
            b = ras.bary[on_scan].astype(np.float64)
            uv = np.einsum("ik,ikj->ij", b, sc.uv[fid[on_scan]])
            th, tw = sc.texture.shape[:2]
            alb = _sample_texture(sc.texture, (uv[:, 0] % 1.0) * tw - 0.5,
                                  (1.0 - uv[:, 1] % 1.0) * th - 0.5)
            col[on_scan] *= alb.astype(np.float32) / 255.0
        out[ras.pixels] = col
    img = cv2.GaussianBlur((out.reshape(H, W, 3) * 255.0), (0, 0), 0.6)
    if image_noise > 0:
        noise = rng.standard_normal(img.shape, dtype=np.float32)
        img = img + noise * np.float32(image_noise)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8), ras.depth


def _truth_curves(scan: ScanFace) -> dict[str, np.ndarray]:
    """SPEC §5 curves (no sills) as scan vertex paths through the landmarks' nearest
    vertices; empty when the scan's edge graph does not join them."""
    import scipy.spatial

    tree = scipy.spatial.cKDTree(scan.V)
    lv = {k: int(tree.query(p)[1]) for k, p in scan.landmarks.items()}
    try:
        paths = curve_paths(scan.V, scan.F, lv, np.zeros(0, np.int64))
    except (KeyError, ValueError):
        return {}
    return {k: scan.V[p] for k, p in paths.items() if len(p) >= 2}


def synthesize_scan_case(out_dir: str | os.PathLike[str], scan: ScanFace, seed: int = 0,
                         noise_px: float = 1.5, size: int = DEFAULT_SIZE,
                         image_noise: float = 2.0, views: tuple[str, ...] = VIEWS) -> Path:
    """Render one case of a scan with its SPEC §7 truth into ``out_dir`` (module doc).

    The seed draws the rig, the studio, the head proxy's colours, the click noise and the
    sensor noise (:func:`~naseview.testbed.synth.synthesize.random_streams`); the face is
    always the scan. ``views``: the four and any obliques, as
    :func:`~naseview.testbed.synth.synthesize.synthesize_case`. ``truth.json`` holds the
    true landmarks, curves and cameras and ``extra.synth`` (seed, noise, rig, the scan's
    source and credit).

    Returns:
        path of the written ``case.json`` (written last).
    Raises:
        NaseviewError: ``size``, ``seed`` or a noise out of range
            (:func:`~naseview.testbed.synth.rig.check_synth_arguments`).
    """
    from naseview.testbed.synth.synthesize import random_streams, views_option

    check_synth_arguments(size, seed, noise_px, image_noise)
    out = Path(out_dir)
    rs = random_streams(seed)
    cams, rig_info = sample_rig_points(scan.landmarks, rs["rig"], size, views)
    sc, look = _scan_scene(scan, rs["appearance"])
    studio = draw_studio(rs["appearance"])
    curves = _truth_curves(scan)
    images: dict[str, np.ndarray] = {}
    photos: dict[str, View] = {}
    boundaries: dict[str, dict[str, list[list[float]]]] = {}
    for view in views:
        images[view], depth = _render_scan_photo(sc, cams[view], studio, rs["sensor"],
                                                 image_noise)
        clicks = view_clicks(view, cams[view], depth, scan.landmarks, scan.helpers,
                             rs["clicks"], noise_px)
        photos[view] = View(view, f"{view}.jpg", clicks, size, size, None)
        for name, pts in view_boundaries(curves, view, cams[view], depth).items():
            boundaries.setdefault(name, {})[view] = pts
    al = float(np.linalg.norm(scan.landmarks["al_l"] - scan.landmarks["al_r"]))
    case = CaseData(root=out, id=f"scan-{anonymous_scan_id(scan)}-{seed}", views=photos,
                    scale_mm={("al_l", "al_r"): round(al, 4)},
                    notes=f"synthetic case of a face scan: naseview synth --scan --seed "
                          f"{seed} --noise-px {noise_px:g} --size {size}"
                          + views_option(views))
    rec = Reconstruction(
        landmarks=dict(scan.landmarks), cameras=cams, curves=curves,
        measurements=clinical_measurements(scan.landmarks, curves or None, scan.V, scan.F),
        extra={"synth": {"seed": int(seed), "scan": scan.source, "noise_px": float(noise_px),
                         "image_noise": float(image_noise), "size": int(size),
                         "rig": rig_info, "appearance": {
                             **look, "background_bgr": list(studio.background),
                             "light_dirs_camera": studio.light_dirs.tolist()}},
               "helpers": {k: v[0].tolist() for k, v in scan.helpers.items()}})
    try:
        out.mkdir(parents=True, exist_ok=True)
        export_mesh(out / "truth_face.ply", scan.V, scan.F)
        atomic_write_json(out / "truth_boundaries.json", boundaries)
        atomic_write_json(out / "truth.json", rec.to_json())
    except OSError as e:
        raise NaseviewError(f"{out}: cannot write the case ({one_line(e)})") from None
    return write_case(case, out, images)
