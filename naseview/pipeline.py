"""The reconstruction pipeline and ``naseview reconstruct``.

:func:`reconstruct` runs the paper's stages in order on a :class:`~naseview.case.Case`:

1. ``landmarks``: 3D landmarks and cameras by bundle adjustment (:mod:`naseview.stage1_landmarks`);
2. ``curves``: boundary curves and ad-landmarks (:mod:`naseview.stage2_curves`);
3. ``mesh``: base face fit and ARAP refinement of the nose (:mod:`naseview.stage3_mesh`).

Each stage is one call below, timed into ``PipelineResult.stage_seconds`` and reported
through ``progress(stage_name, seconds)``. :func:`write_outputs` writes SPEC §5 files.

Example
-------
>>> from naseview.case import read_case
>>> res = reconstruct(read_case("assets/demo-case"), stages=(1,))    # doctest: +SKIP
>>> write_outputs(res, "/tmp/out")                                   # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from naseview.errors import NaseviewError
from naseview.reconstruction import Reconstruction, write_reconstruction
from naseview.stage1_landmarks.solve import SfmParams, SfmResult, bundle_adjust

STAGE_NAMES: dict[int, str] = {1: "landmarks", 2: "curves", 3: "mesh"}
"""Stage number -> name used in ``stage_seconds`` and progress lines."""

ProgressFn = Callable[[str, float], Any]


@dataclass
class PipelineParams:
    """Tunables of every stage (``None``: that stage's defaults).

    Attributes:
        sfm: stage 1, :class:`naseview.stage1_landmarks.SfmParams`.
        curves: stage 2, ``naseview.stage2_curves.CurveParams``.
        refine: stage 3, ``naseview.stage3_mesh.RefineParams``.
    """

    sfm: SfmParams = field(default_factory=SfmParams)
    curves: Any = None
    refine: Any = None


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
        stage_seconds: stage name -> wall time (s).
        warnings: one-line messages for the user, from all stages.
    """

    reconstruction: Reconstruction
    sfm: SfmResult | None = None
    curves: Any = None
    refined: Any = None
    face_vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    nose_vertex_ids: np.ndarray | None = None
    stage_seconds: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


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
        raise NaseviewError(f"--stages {stages!r}: expected a comma list of 1, 2, 3 that "
                            "includes 1 (every stage builds on the landmarks), e.g. 1,2,3")
    return tuple(sorted(nums))


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


def reconstruct(case: Any, model: Any = None, stages: Iterable[int] | str = (1, 2, 3),
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
    rec = result.reconstruction

    def timed(stage: int, fn: Callable[[], Any]) -> Any:
        t0 = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t0
        result.stage_seconds[STAGE_NAMES[stage]] = dt
        if progress is not None:
            progress(STAGE_NAMES[stage], dt)
        return out

    # Stage 1: 3D landmarks and cameras (paper section 3.2).
    sfm = timed(1, lambda: bundle_adjust(case, params.sfm))
    result.sfm = sfm
    rec.landmarks = dict(sfm.landmarks)
    rec.cameras = dict(sfm.cameras)
    rec.reprojection_rmse_px = float(sfm.reprojection_rmse_px)
    rec.extra.update(stage1_extra(sfm))
    rec.measurements = _landmark_measurements(rec.landmarks)
    result.warnings.extend(sfm.warnings)

    # Stage 2: boundary curves and ad-landmarks (paper section 3.3).
    if 2 in stages:
        curves = timed(2, lambda: _stage2(case, sfm, params.curves))
        result.curves = curves
        rec.curves = dict(curves.curves)
        rec.ad_landmarks = curves.ad_landmarks
        rec.ad_landmark_tags = list(curves.ad_landmark_tags)
        rec.extra["curve_flags"] = dict(curves.flags)
        result.warnings.extend(curves.warnings)
    # Stage 3: base face model, ARAP and smoothing of the nose (paper section 3.4).
    if 3 in stages:
        refined = timed(3, lambda: _stage3(rec, model, params.refine))
        result.refined = refined
        result.face_vertices, result.faces = refined.V, refined.F
        result.nose_vertex_ids = refined.nose_vertex_ids
        result.warnings.extend(refined.warnings)
        rec.measurements = _mesh_measurements(rec, refined)
        rec.extra.update(stage3_extra(refined))
    rec.extra["case_dir"] = str(Path(case.root).resolve())  # lets the app find the photos
    rec.extra["warnings"] = list(result.warnings)
    rec.extra["stage_seconds"] = {k: round(v, 4) for k, v in result.stage_seconds.items()}
    return result


def _stage2(case: Any, sfm: SfmResult, params: Any) -> Any:
    """Stage 2 on the photos of ``case`` with the stage-1 cameras and landmarks:
    :func:`naseview.stage2_curves.extract_curves` (``params``: a CurveParams or None)."""
    from naseview.stage2_curves import extract_curves

    return extract_curves(case, None, sfm, params)


def _stage3(rec: Reconstruction, model: Any, params: Any) -> Any:
    """Stage 3 on the landmarks (and ad-landmarks) of ``rec``: :func:`naseview.stage3_mesh.solve`
    with ``model`` a FaceModel, a model name / path or None (default model)."""
    from naseview.facemodel import FaceModel, load_face_model
    from naseview.stage3_mesh.solve import refine

    fm = model if isinstance(model, FaceModel) else load_face_model(model)
    return refine(fm, rec, params)


def _mesh_measurements(rec: Reconstruction, refined: Any) -> dict[str, float]:
    """Clinical measurements from the landmarks, the mid-curve and the refined mesh."""
    from naseview.measurements import clinical_measurements

    return clinical_measurements(rec.landmarks, rec.curves or None, refined.V, refined.F)


def stage3_extra(refined: Any) -> dict[str, Any]:
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


def _landmark_measurements(landmarks: dict[str, np.ndarray]) -> dict[str, float]:
    """Clinical measurements that need only the landmarks (:mod:`naseview.measurements`)."""
    from naseview.measurements import clinical_measurements

    return clinical_measurements(landmarks)


def write_outputs(result: PipelineResult, out_dir: str | os.PathLike[str],
                  export: Iterable[str] = ()) -> list[Path]:
    """Write the SPEC §5 outputs of a pipeline run, each file atomically.

    ``reconstruction.json`` always; ``face.ply`` and ``nose.ply`` (plus ``face.<fmt>`` and
    ``nose.<fmt>`` for each ``export`` format: stl, obj, glb) when stage 3 made a mesh.

    Returns:
        the paths written.
    """
    out = Path(out_dir)
    written = [write_reconstruction(result.reconstruction, out / "reconstruction.json")]
    if result.face_vertices is not None and result.faces is not None:
        from naseview.meshio import export_mesh
        from naseview.stage3_mesh.solve import submesh

        V, F = np.asarray(result.face_vertices), np.asarray(result.faces)
        Vn, Fn = submesh(V, F, np.asarray(result.nose_vertex_ids))[:2]
        for fmt in ("ply", *[e for e in export if e != "ply"]):
            written.append(export_mesh(out / f"face.{fmt}", V, F))
            written.append(export_mesh(out / f"nose.{fmt}", Vn, Fn))
    return written


def reconstruct_command(args: argparse.Namespace) -> int:
    """``naseview reconstruct CASE_DIR -o OUT_DIR [--stages 1,2,3] [--export stl]``."""
    from naseview.case import read_case

    stages = parse_stages(getattr(args, "stages", "1,2,3"))
    case = read_case(args.case_dir)

    def progress(name: str, seconds: float) -> None:
        print(f"stage {name}: done in {seconds:.2f} s", flush=True)

    result = reconstruct(case, model=getattr(args, "model", None), stages=stages,
                         progress=progress)
    paths = write_outputs(result, args.output, export=getattr(args, "export", ()) or ())
    sfm = result.sfm
    if sfm is not None:
        print(f"{len(sfm.landmarks)} landmarks, reprojection RMSE "
              f"{sfm.reprojection_rmse_px:.2f} px")
    for w in result.warnings:
        print(f"warning: {w}")
    for p in paths:
        print(f"wrote {p}")
    return 0
