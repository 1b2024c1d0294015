"""The reconstruction pipeline and ``naseview reconstruct``: stage 1 -> 2 -> 3 (paper §3).

:func:`reconstruct` runs the paper's stages in order on a :class:`~naseview.case.Case`:

1. stage 1 — landmarks (paper §3.2): 3D landmarks and cameras by bundle adjustment
   (:mod:`naseview.stage1_landmarks`, result :class:`~naseview.stage1_landmarks.SfmResult`);
2. stage 2 — curves (paper §3.3): the six boundary curves and the ad-landmarks
   (:mod:`naseview.stage2_curves`, result :class:`~naseview.stage2_curves.CurvesResult`);
3. stage 3 — mesh (paper §3.4): base face fit, ARAP and cotangent smoothing of the nose
   (:mod:`naseview.stage3_mesh`, result :class:`~naseview.stage3_mesh.RefineResult`).

Each stage is one call below, timed into ``PipelineResult.stage_seconds`` under its name in
:data:`naseview.stages.STAGE_NAMES` and reported through ``progress(stage_name, seconds)``.
:func:`write_outputs` writes the SPEC §5 files (see ``docs/formats.md``).

Example
-------
>>> from naseview.case import read_case
>>> res = reconstruct(read_case("assets/demo-case"), stages=(1,))    # doctest: +SKIP
>>> write_outputs(res, "/tmp/out")                                   # doctest: +SKIP
>>> parse_stages("2,1")
(1, 2)
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from naseview.camera import Camera
from naseview.case import Case, read_case
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel, load_face_model
from naseview.fileio import (
    COMMIT_PREFIX,
    STAGING_PREFIX,
    check_output_dir,
    json_bytes,
    sha256_hex,
    write_file_set,
)
from naseview.geometry.region import submesh
from naseview.measurements import clinical_measurements
from naseview.measurements.uncertainty import DIRECTION_KEY
from naseview.meshio import MESH_FORMATS, mesh_bytes
from naseview.reconstruction import (
    CASE_DIR_KEY,
    CASE_SHA256_KEY,
    FILES_KEY,
    RECONSTRUCTION_FILE,
    SCALE_KEY,
    Reconstruction,
)
from naseview.stage1_landmarks import SfmParams, SfmResult, bundle_adjust
from naseview.stage1_landmarks.single_view import one_photo_sight_lines
from naseview.stage2_curves import CurveParams, CurvesResult, extract_curves
from naseview.stage2_curves.mask import estimate_background, foreground_mask
from naseview.stage3_mesh import RefineParams, RefineResult, refine
from naseview.stage3_mesh.profile_band import profile_box
from naseview.stage3_mesh.sightline import Placed, SightLine, place_one_photo_landmarks
from naseview.stage3_mesh.silhouette import (
    OUTLINE_CURVES,
    SILHOUETTE_VIEWS,
    Silhouette,
    curve_piece,
    silhouette_from_curve,
    silhouette_from_mask,
)
from naseview.stages import STAGE_NAMES
from naseview.texture.bake import FaceTexture, case_photos, skin_texture
from naseview.texture.mesh_files import mesh_file

ProgressFn = Callable[[str, float], object]
"""``progress(stage_name, seconds)``, called after each stage."""

_T = TypeVar("_T")


@dataclass(frozen=True)
class PipelineParams:
    """Tunables of every stage (``None``: that stage's defaults).

    Attributes:
        sfm: stage 1 — landmarks, :class:`~naseview.stage1_landmarks.SfmParams`.
        curves: stage 2 — curves, :class:`~naseview.stage2_curves.CurveParams` or None.
        refine: stage 3 — mesh, :class:`~naseview.stage3_mesh.RefineParams` or None.
    Raises:
        NaseviewError: a field holds something else than its stage's params type.
    """

    sfm: SfmParams = field(default_factory=SfmParams)
    curves: CurveParams | None = None
    refine: RefineParams | None = None

    def __post_init__(self) -> None:
        for name, cls, optional in (("sfm", SfmParams, False), ("curves", CurveParams, True),
                                    ("refine", RefineParams, True)):
            value = getattr(self, name)
            if not isinstance(value, cls) and not (optional and value is None):
                allowed = f"a {cls.__name__}" + (" or None" if optional else "")
                raise NaseviewError(f"PipelineParams.{name}: {type(value).__name__} is not "
                                    f"{allowed}; pass the stage's own params object")


@dataclass
class PipelineResult:
    """What :func:`reconstruct` produced.

    Attributes:
        reconstruction: the SPEC §5 result (landmarks, cameras, curves, measurements...).
        sfm: stage-1 result (residuals, uncertainties, suspect clicks).
        curves: stage-2 result, or None when stage 2 did not run.
        refined: stage-3 result, or None when stage 3 did not run.
        face_vertices: (V, 3) refined face mesh (mm, SPEC frame), or None.
        faces: (F, 3) its triangles, or None.
        nose_vertex_ids: (N,) vertices of the nose region, or None.
        stage_seconds: stage name (:data:`STAGE_NAMES`) -> wall time (s).
        warnings: one-line messages for the user, from all stages.
        case_root: the case folder the run read (:func:`write_outputs` stores it relative
            to the output folder as ``case_dir``), or None.
    """

    reconstruction: Reconstruction
    sfm: SfmResult | None = None
    curves: CurvesResult | None = None
    refined: RefineResult | None = None
    face_vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    nose_vertex_ids: np.ndarray | None = None
    stage_seconds: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    case_root: Path | None = None


def parse_stages(stages: Iterable[int] | str) -> tuple[int, ...]:
    """``"1,2"`` or ``(1, 2)`` -> sorted stage numbers; stage 1 is always needed.

    Raises:
        NaseviewError: unknown stage, or stages without stage 1.
    """
    if isinstance(stages, str):
        try:
            nums = {int(s) for s in stages.replace(" ", "").split(",") if s}
        except ValueError:
            nums = {0}
    else:
        nums = {int(s) for s in stages}
    if not nums or not nums <= set(STAGE_NAMES) or 1 not in nums:
        raise NaseviewError(f"--stages {stages!r}: expected a comma list of 1 (landmarks), "
                            "2 (curves), 3 (mesh) that includes 1 (every stage builds on the "
                            "landmarks), e.g. 1,2,3")
    return tuple(sorted(nums))


def reconstruct(case: Case, model: FaceModel | str | None = None,
                stages: Iterable[int] | str = (1, 2, 3),
                params: PipelineParams | None = None,
                progress: ProgressFn | None = None) -> PipelineResult:
    """Run the pipeline stages on a case.

    Args:
        case: a validated :class:`~naseview.case.Case`.
        model: base face model for stage 3: a ``FaceModel``, a name for
            ``load_face_model`` (``"ict"``, ``"generic"``, a path) or None (default model).
        stages: which stages to run (must include 1), e.g. ``(1, 2, 3)`` or ``"1,2"``.
        params: tunables of each stage (default :class:`PipelineParams`).
        progress: called as ``progress(stage_name, seconds)`` after each stage.
    Returns:
        :class:`PipelineResult`.
    Raises:
        NaseviewError: bad input found by a stage (one line naming file, key and fix).
    """
    stages = parse_stages(stages)
    params = params or PipelineParams()
    result = PipelineResult(reconstruction=Reconstruction())
    sfm = _timed(result, progress, 1, lambda: bundle_adjust(case, params.sfm))
    _take_stage1(result, sfm)
    if 2 in stages:
        _take_stage2(result, _timed(result, progress, 2,
                                    lambda: extract_curves(case, None, sfm, params.curves)))
    if 3 in stages:
        run_stage3(result, case, _face_model(model), params.refine, progress, params.curves)
    _take_run_info(result, case)
    return result


def run_stage3(result: PipelineResult, case: Case, model: FaceModel,
               params: RefineParams | None = None,
               progress: ProgressFn | None = None,
               curve_params: CurveParams | None = None) -> None:
    """Stage 3 on a result of stages 1(-2) of ``case``, in place: the one-photo landmarks
    on their lines of sight, then :func:`~naseview.stage3_mesh.refine` with the profile
    photos' silhouettes (masked with stage 2's ``curve_params``; the benchmarks run it on
    a copy of a cached stage-1/2 result for each stage-3 variant)."""
    rec = result.reconstruction

    def stage3() -> RefineResult:
        _take_sight_lines(result, case, model, params)
        sils: list[Silhouette] = []
        p = params or RefineParams()
        if p.silhouette_rounds:
            sils = photo_silhouettes(case, rec, curve_params, p)
            sils += outline_silhouettes(result.curves, rec, p.outline_curves)
        return refine(model, rec, params, sils)

    _take_stage3(result, _timed(result, progress, 3, stage3))


def photo_silhouettes(case: Case, rec: Reconstruction,
                      curve_params: CurveParams | None = None,
                      refine_params: RefineParams | None = None) -> list[Silhouette]:
    """The profile photos' silhouettes near the nose for stage 3's contour handles
    (:mod:`~naseview.stage3_mesh.silhouette`): stage 2's background model and foreground
    mask, with the same thresholds as stage 2 (``curve_params``' mask fields), in a box
    around the projected nose landmarks grown to the profile band of ``refine_params``
    (:func:`~naseview.stage3_mesh.profile_band.profile_box`: glabella to upper lip), for
    each of ``SILHOUETTE_VIEWS`` whose border is a uniform background."""
    p = curve_params or CurveParams()
    rp = refine_params or RefineParams()
    out = []
    for v in SILHOUETTE_VIEWS:
        cam = rec.cameras.get(v)
        if v not in case.views or cam is None:
            continue
        box = profile_box(cam, rec.landmarks, rp.profile_above_g_mm, rp.profile_below_sn_mm)
        if box is None:
            continue
        img = case.load_image(v)
        bg = estimate_background(img, p.border_px, p.hue_tol, p.sat_tol, p.val_tol,
                                 p.grey_sat, p.border_min_inlier)
        if bg.uniform:
            mask = foreground_mask(img, bg, p.mask_clean_px, box)
            out.append(silhouette_from_mask(v, cam, mask, box))
    return out


def outline_silhouettes(curves: CurvesResult | None, rec: Reconstruction,
                        names: Iterable[str]) -> list[Silhouette]:
    """The outlines over the face that stage 2 traced in the photos (the pieces ``names``
    of :data:`~naseview.stage3_mesh.silhouette.OUTLINE_CURVES`), as silhouettes for stage
    3's contour handles: only from curves found in the photo (flag ``"image"``), each
    piece cut between the points nearest its end landmarks as the photo's camera
    projects them."""
    out: list[Silhouette] = []
    if curves is None:
        return out
    for name in names:
        curve, view, chain = OUTLINE_CURVES[name]
        uv = curves.curves_2d.get(curve, {}).get(view)
        cam = rec.cameras.get(view)
        if (curves.flags.get(curve) != "image" or uv is None or cam is None
                or any(k not in rec.landmarks for k in chain)):
            continue
        P = np.array([rec.landmarks[k] for k in chain], float)
        ends = cam.project(P[[0, -1]])
        s = silhouette_from_curve(name, cam, curve_piece(uv, ends[0], ends[1]), P)
        if s is not None:
            out.append(s)
    return out


def _take_sight_lines(result: PipelineResult, case: Case, model: FaceModel,
                      params: RefineParams | None) -> None:
    """Landmarks clicked in one photo (placed by stage 1 by symmetry or template, or left
    out) moved to where their line of sight meets the fitted face
    (:func:`~naseview.stage3_mesh.sightline.place_one_photo_landmarks`), with their
    uncertainty along the ray and the ray's unit direction
    (``extra["landmark_sight_direction"]``, for
    :func:`~naseview.measurements.measurement_uncertainty`); a placed g moves the whole
    frame so that g stays the origin (SPEC §4). Stage 1's placement stays where the line
    misses the face."""
    rec, sfm = result.reconstruction, result.sfm
    if sfm is None:
        return
    ids = [k for k in (*sfm.one_photo, *sfm.left_out)]
    lines = {k: SightLine(*v) for k, v in
             one_photo_sight_lines(case, dict(rec.cameras), ids).items()}
    placed = _fused(place_one_photo_landmarks(model, rec, lines, params), lines, rec, sfm)
    if not placed:
        return
    shift = placed["g"].position if "g" in placed else np.zeros(3)
    if "g" in placed:
        _translate(rec, -shift)
    unc = rec.extra.setdefault("landmark_uncertainty_mm", {})
    how = rec.extra.setdefault("landmarks_one_photo", {})
    ray = rec.extra.setdefault(DIRECTION_KEY, {})   # what the sd is along (measurements)
    for k, pl in placed.items():
        rec.landmarks[k] = np.asarray(pl.position, float) - shift
        unc[k] = round(float(pl.sd_along_mm), 4)
        how[k] = "line of sight"
        d = np.asarray(lines[k].d, float)
        ray[k] = [round(float(x), 5) for x in d / max(float(np.linalg.norm(d)), 1e-12)]
    rec.extra["landmarks_left_out"] = [k for k in rec.extra.get("landmarks_left_out", [])
                                       if k not in placed]
    rec.measurements = clinical_measurements(rec.landmarks, rec.curves or None)
    for k, pl in placed.items():  # stage 1's placement note gives way to this one
        line = (f"landmark {k!r} is clicked in photo {pl.view!r} only; placed on its line "
                f"of sight at the depth of the fitted face (+-{pl.sd_along_mm:.1f} mm along "
                "the ray); click it in a second photo")
        stage1 = f"landmark {k!r} is clicked in photo "
        at = [i for i, w in enumerate(result.warnings) if w.startswith(stage1)]
        if at:
            result.warnings[at[0]] = line
        else:
            result.warnings.append(line)


def _fused(placed: dict[str, Placed], lines: dict[str, SightLine], rec: Reconstruction,
           sfm: SfmResult) -> dict[str, Placed]:
    """Each placement on the face combined with stage 1's (symmetry or template) depth on
    the same ray, by inverse variance along the ray: two independent estimates of one
    depth. Only where the face states a smaller uncertainty along the ray than stage 1
    does; elsewhere stage 1's placement stays. A landmark stage 1 left out keeps the
    face's."""
    out = {}
    for k, pl in placed.items():
        ln, cov = lines[k], sfm.covariance_mm2.get(k)
        if k not in rec.landmarks or cov is None:
            out[k] = pl
            continue
        sd1 = float(np.sqrt(max(float(ln.d @ np.asarray(cov) @ ln.d), 1e-12)))
        if pl.sd_along_mm >= sd1:
            continue
        lam1 = float((np.asarray(rec.landmarks[k]) - ln.C) @ ln.d)
        lam2 = float((pl.position - ln.C) @ ln.d)
        w1, w2 = 1.0 / sd1 ** 2, 1.0 / pl.sd_along_mm ** 2
        lam = (w1 * lam1 + w2 * lam2) / (w1 + w2)
        out[k] = Placed(ln.C + lam * ln.d, float(1.0 / np.sqrt(w1 + w2)), pl.view)
    return out


def _translate(rec: Reconstruction, delta: np.ndarray) -> None:
    """Move every 3D quantity of ``rec`` by ``delta`` (mm): landmarks, curves,
    ad-landmarks and cameras (``x_cam = R (X - delta) + t'``, ``t' = t + R delta``)."""
    rec.landmarks = {k: np.asarray(v, float) + delta for k, v in rec.landmarks.items()}
    rec.curves = {k: np.asarray(v, float).reshape(-1, 3) + delta if len(v) else v
                  for k, v in (rec.curves or {}).items()}
    if rec.ad_landmarks is not None and len(rec.ad_landmarks):
        rec.ad_landmarks = np.asarray(rec.ad_landmarks, float) + delta
    rec.cameras = {v: Camera(c.K, c.R, c.t - c.R @ delta, c.width, c.height)
                   for v, c in rec.cameras.items()}


def _timed(result: PipelineResult, progress: ProgressFn | None, stage: int,
           run: Callable[[], _T]) -> _T:
    """``run()``, its wall time stored in ``result.stage_seconds`` and sent to ``progress``."""
    t0 = time.perf_counter()
    out = run()
    dt = time.perf_counter() - t0
    result.stage_seconds[STAGE_NAMES[stage]] = dt
    if progress is not None:
        progress(STAGE_NAMES[stage], dt)
    return out


def _face_model(model: FaceModel | str | None) -> FaceModel:
    """The base face of stage 3: ``model`` itself, or ``load_face_model(model)``."""
    return model if isinstance(model, FaceModel) else load_face_model(model)


def _take_stage1(result: PipelineResult, sfm: SfmResult) -> None:
    """Stage 1 into the result: landmarks, cameras, RMSE, diagnostics, landmark measurements."""
    rec = result.reconstruction
    result.sfm = sfm
    rec.landmarks = dict(sfm.landmarks)
    rec.cameras = dict(sfm.cameras)
    rec.reprojection_rmse_px = float(sfm.reprojection_rmse_px)
    rec.extra.update(stage1_extra(sfm))
    rec.measurements = clinical_measurements(rec.landmarks)
    result.warnings.extend(sfm.warnings)


def _take_stage2(result: PipelineResult, curves: CurvesResult) -> None:
    """Stage 2 into the result: the SPEC §5 curves, the ad-landmarks and the curve flags."""
    rec = result.reconstruction
    result.curves = curves
    rec.curves = dict(curves.curves)
    rec.ad_landmarks = curves.ad_landmarks
    rec.ad_landmark_tags = list(curves.ad_landmark_tags)
    rec.extra["curve_flags"] = dict(curves.flags)
    result.warnings.extend(curves.warnings)


def _take_stage3(result: PipelineResult, refined: RefineResult) -> None:
    """Stage 3 into the result: the meshes, the mesh measurements and the fit diagnostics."""
    rec = result.reconstruction
    result.refined = refined
    result.face_vertices, result.faces = refined.V, refined.F
    result.nose_vertex_ids = refined.nose_vertex_ids
    result.warnings.extend(refined.warnings)
    rec.measurements = clinical_measurements(rec.landmarks, rec.curves or None,
                                             refined.V, refined.F)
    rec.extra.update(stage3_extra(refined))


def _take_run_info(result: PipelineResult, case: Case) -> None:
    """What every run adds: the case folder (:func:`write_outputs` stores it, the app
    finds the photos there), all warnings and the stage times."""
    rec = result.reconstruction
    result.case_root = Path(case.root)
    rec.extra["warnings"] = list(result.warnings)
    rec.extra["stage_seconds"] = {k: round(v, 4) for k, v in result.stage_seconds.items()}
    rec.extra[SCALE_KEY] = {f"{a}-{b}": float(d) for (a, b), d in case.scale_mm.items()}


def stage1_extra(sfm: SfmResult) -> dict[str, Any]:
    """reconstruction.json keys (beyond SPEC §5) with the stage-1 diagnostics."""
    return {
        "landmark_uncertainty_mm": {k: round(float(v), 4) for k, v in sfm.uncertainty_mm.items()},
        "residuals_px": {v: {k: round(float(r), 3) for k, r in res.items()}
                         for v, res in sfm.residuals_px.items()},
        "suspect_clicks": [s.to_json() for s in sfm.suspect_clicks],
        "landmarks_one_photo": dict(sfm.one_photo),
        "landmarks_left_out": list(sfm.left_out),
    }


def stage3_extra(refined: RefineResult) -> dict[str, Any]:
    """reconstruction.json keys (beyond SPEC §5) with the stage-3 diagnostics."""
    fit = refined.fit
    rep = refined.report
    return {"mesh": {
        "face_model": refined.model_name, "credit": refined.credit,
        "vertices": int(len(refined.V)), "nose_vertices": int(len(refined.nose_vertex_ids)),
        "fit_scale": round(float(fit.scale), 5),
        "fit_residuals_mm": {k: round(v, 3) for k, v in fit.residuals_mm.items()},
        "handles": int(len(refined.handles.vertex_ids)),
        "released_handles": list(refined.released),
        "arap_iterations": None if rep is None else int(rep.arap_iterations),
        "folded_triangles": None if rep is None else int(len(rep.folded_faces)),
        "seconds": {k: round(v, 4) for k, v in refined.seconds.items()},
    }}


def stored_case_dir(result: PipelineResult, out_dir: str | os.PathLike[str]
                    ) -> tuple[str | None, str | None]:
    """The ``case_dir`` and ``case_sha256`` of ``reconstruction.json`` in ``out_dir``: the
    case folder relative to the output folder and the SHA-256 of its ``case.json`` (a
    reader follows a folder outside the output only to that very case,
    :func:`naseview.reconstruction.output_case_dir`); (None, None) when the run read no
    folder."""
    if result.case_root is None:
        return None, None
    case_json = Path(result.case_root) / "case.json"
    try:
        digest: str | None = sha256_hex(case_json.read_bytes())
    except OSError:
        digest = None
    rel = Path(os.path.relpath(os.path.realpath(result.case_root), os.path.realpath(out_dir)))
    return rel.as_posix(), digest


def output_files(result: PipelineResult, out_dir: str | os.PathLike[str],
                 export: Iterable[str] = (), texture: FaceTexture | None = None
                 ) -> dict[str, bytes]:
    """File name -> content of the output set of a run, ``reconstruction.json`` last.

    ``face.ply`` and ``nose.ply`` (plus ``face.<fmt>`` and ``nose.<fmt>`` for each
    ``export`` format: stl, obj, glb) when stage 3 made a mesh; the GLBs embed
    ``texture`` (the face's photo texture, :func:`photo_texture`) when given, as the
    app's textured download does (:func:`naseview.texture.mesh_files.mesh_file`);
    ``reconstruction.json`` records their SHA-256 (key ``files``) and the case folder
    relative to ``out_dir``.
    """
    files: dict[str, bytes] = {}
    if result.face_vertices is not None and result.faces is not None:
        V, F = np.asarray(result.face_vertices), np.asarray(result.faces)
        nose = np.asarray(result.nose_vertex_ids)
        Vn, Fn = submesh(V, F, nose)[:2]
        for fmt in dict.fromkeys(("ply", *export)):
            if fmt == "glb" and texture is not None:
                files["face.glb"] = mesh_file(V, F, "glb", texture=texture)
                files["nose.glb"] = mesh_file(V, F, "glb", nose, texture=texture)
                continue
            files[f"face.{fmt}"] = mesh_bytes(V, F, fmt)
            files[f"nose.{fmt}"] = mesh_bytes(Vn, Fn, fmt)
    obj = result.reconstruction.to_json()
    obj[CASE_DIR_KEY], obj[CASE_SHA256_KEY] = stored_case_dir(result, out_dir)
    obj[FILES_KEY] = {name: sha256_hex(data) for name, data in files.items()}
    files[RECONSTRUCTION_FILE] = json_bytes(obj)
    return files


MESH_FILES = tuple(f"{part}.{fmt}" for part in ("face", "nose") for fmt in MESH_FORMATS)
"""Every mesh file name a run may write into its output folder (``face.ply``, ``nose.stl``,
...): a run removes those of an earlier run that it does not write again."""


def photo_texture(result: PipelineResult, case: Case) -> FaceTexture | None:
    """The face's texture baked from ``case``'s photos with the stage-1 cameras, as the
    app bakes it (:func:`naseview.texture.bake.skin_texture`, the same size); None
    without a stage-3 mesh or when no photo can be baked (logged)."""
    if result.face_vertices is None or result.faces is None:
        return None
    cameras = result.reconstruction.cameras
    return skin_texture(result.face_vertices, result.faces, cameras,
                        case_photos(case, cameras))


def write_outputs(result: PipelineResult, out_dir: str | os.PathLike[str],
                  export: Iterable[str] = (), texture: FaceTexture | None = None
                  ) -> list[Path]:
    """Write the SPEC §5 outputs of a pipeline run (:func:`output_files`), all or nothing.

    Readers see the previous set or the new one, never a mix
    (:func:`naseview.fileio.write_file_set`); meshes of an earlier run that this one does
    not write (another ``--export``, no stage 3) are removed with the new set. The GLBs
    embed ``texture`` when given (:func:`output_files`).

    Returns:
        the paths written, ``reconstruction.json`` last.
    Raises:
        NaseviewError: the folder is not writable or the disk is full (the previous
            result is then unchanged).
    """
    return write_file_set(out_dir, output_files(result, out_dir, export, texture),
                          remove=MESH_FILES)


def check_not_foreign(out_dir: str | os.PathLike[str],
                      case_dir: str | os.PathLike[str]) -> None:
    """Before a run: ``out_dir`` is not the case folder nor another case's (one with a
    ``case.json``: the result would lie among the photos), and holds no mesh file a run
    writes or removes (``face.ply``, ``nose.stl``, ...) unless it is a previous result
    (it has ``reconstruction.json``, or the commit folder of a run killed while moving
    its set in, which this run finishes): a user's own files are never overwritten or
    deleted.

    Raises:
        NaseviewError: naming the folder, the files and the fix.
    """
    out = Path(out_dir)
    if not out.is_dir():
        return
    if os.path.realpath(out) == os.path.realpath(case_dir):
        raise NaseviewError(f"{out}: is the case folder; give -o another folder (the "
                            "result would lie among the photos)")
    if (out / "case.json").exists():
        raise NaseviewError(f"{out}: is another case's folder (it holds case.json); give -o "
                            "another folder (the result would lie among that case's photos)")
    if (out / RECONSTRUCTION_FILE).exists() or any(
            p.name.startswith((COMMIT_PREFIX, STAGING_PREFIX)) for p in out.iterdir()):
        return                  # a previous result, or one a killed run left to finish
    clash = [n for n in MESH_FILES if (out / n).exists()]
    if clash:
        raise NaseviewError(f"{out}: holds {', '.join(clash)}, which no naseview result "
                            f"there wrote (no {RECONSTRUCTION_FILE}); give -o a new or empty "
                            "folder, or move those files away")


def reconstruct_command(args: argparse.Namespace) -> int:
    """``naseview reconstruct CASE_DIR -o OUT_DIR [--stages 1,2,3] [--export stl]``."""
    stages = parse_stages(getattr(args, "stages", "1,2,3"))
    check_output_dir(args.output)
    check_not_foreign(args.output, args.case_dir)
    case = read_case(args.case_dir)

    def progress(name: str, seconds: float) -> None:
        print(f"stage {name}: done in {seconds:.2f} s", flush=True)

    result = reconstruct(case, model=getattr(args, "model", None), stages=stages,
                         progress=progress)
    export = list(getattr(args, "export", ()) or ())
    texture = photo_texture(result, case) if "glb" in export else None
    paths = write_outputs(result, args.output, export=export, texture=texture)
    sfm = result.sfm
    if sfm is not None:
        print(f"{len(sfm.landmarks)} landmarks, reprojection RMSE "
              f"{sfm.reprojection_rmse_px:.2f} px")
    for w in result.warnings:
        print(f"warning: {w}")
    if "glb" in export and texture is None and result.face_vertices is not None:
        print("note: face.glb and nose.glb are untextured (no photo could be baked onto "
              "the face)")
    for p in paths:
        print(f"wrote {p}")
    return 0
