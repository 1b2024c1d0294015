"""One synthetic case with exact ground truth: :func:`synthesize_case` (SPEC §3, §7).

Every random draw comes from ``seed``, one independent stream per part
(:func:`random_streams`: identity, rig, appearance, clicks, sensor), so changing
``noise_px`` does not change the face or the rig. The truth is written before
``case.json``, which comes last: ``truth_face.ply`` (the true face mesh, model vertices
only, SPEC frame, mm), ``truth_boundaries.json`` and ``truth.json``
(:class:`~naseview.reconstruction.Reconstruction` schema: true landmarks, curves, the four
true cameras (and the obliques', when rendered) and the true clinical measurements;
``extra`` keys ``synth`` (seed, model, identity coefficients, rig and appearance
parameters) and ``nose_vertex_ids``).
``scale_mm`` of the case is the true distance al_l-al_r.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from naseview.camera import Camera
from naseview.case import Case, View, write_case
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.fileio import atomic_write_json
from naseview.landmarks import CURVE_VIEWS, LANDMARK_IDS, VIEW_LANDMARKS, VIEWS
from naseview.measurements import clinical_measurements
from naseview.meshio import export_mesh
from naseview.reconstruction import Reconstruction
from naseview.testbed.synth.clicks import view_clicks
from naseview.testbed.synth.photo import draw_studio, render_photo
from naseview.testbed.synth.rig import (
    DEFAULT_SIZE,
    check_synth_arguments,
    sample_identity,
    sample_rig,
)
from naseview.testbed.synth.scene import build_scene
from naseview.testbed.synth.truth import helper_points, truth_curves, view_boundaries

STREAMS: tuple[str, ...] = ("identity", "rig", "appearance", "clicks", "sensor")
"""The independent random streams of a case, spawned from its seed in this order."""


def random_streams(seed: int) -> dict[str, np.random.Generator]:
    """One generator per name of :data:`STREAMS`, spawned from ``seed``."""
    seqs = np.random.SeedSequence(int(seed)).spawn(len(STREAMS))
    return {n: np.random.default_rng(s) for n, s in zip(STREAMS, seqs, strict=True)}


def _check(model: FaceModel, size: int, seed: int, noise_px: float,
           image_noise: float) -> None:
    """One-line errors for arguments no case can be made with."""
    if not model.curve_vertices:
        raise NaseviewError(f"face model {model.name!r}: no curve_vertices; synthetic "
                            "ground truth needs the SPEC §5 curve paths")
    check_synth_arguments(size, seed, noise_px, image_noise)


def _synth_record(model: FaceModel, seed: int, noise_px: float, image_noise: float,
                  size: int, w: np.ndarray, rig: dict[str, Any],
                  look: dict[str, Any], views: tuple[str, ...]) -> dict[str, Any]:
    """The ``extra.synth`` record of ``truth.json``: how the case was drawn."""
    return {
        "seed": int(seed), "model": model.name, "credit": model.credit,
        "noise_px": float(noise_px), "image_noise": float(image_noise), "size": int(size),
        "identity_coefficients": w.tolist(), "rig": rig, "appearance": look,
        "view_landmarks": {k: list(VIEW_LANDMARKS[k]) for k in views},
        "truth_curve_views": {k: list(v) for k, v in CURVE_VIEWS.items()},
    }


def views_option(views: tuple[str, ...]) -> str:
    """`` --views a,b,..`` for the notes of a case with obliques; '' for the four views."""
    return "" if tuple(views) == VIEWS else f" --views {','.join(views)}"


def _case(out: Path, model: FaceModel, seed: int, noise_px: float, size: int,
          image_noise: float, views: dict[str, View], al_mm: float) -> Case:
    """The case a surgeon would bring: the photos' clicks and the calliper distance."""
    return Case(root=out, id=f"synth-{model.name}-{seed}", views=views,
                scale_mm={("al_l", "al_r"): round(al_mm, 4)},
                notes=f"synthetic case: naseview synth --model {model.name} --seed {seed} "
                      f"--noise-px {noise_px:g} --size {size} --image-noise {image_noise:g}"
                      + views_option(tuple(views)))


def synthesize_case(out_dir: str | os.PathLike[str], model: FaceModel, seed: int = 0,
                    noise_px: float = 1.5, size: int = DEFAULT_SIZE,
                    image_noise: float = 2.0, write_focal: bool = False,
                    views: tuple[str, ...] = VIEWS) -> Path:
    """Render one synthetic case with ground truth into ``out_dir`` (module docstring).

    Args:
        out_dir: case directory (created).
        model: face model of the identity (``load_face_model``).
        seed: random seed; the same seed gives the same files.
        noise_px: click noise, standard deviation per axis (px).
        size: photo width = height (px).
        image_noise: sensor noise, standard deviation in grey levels (0 = none).
        write_focal: also give each view's true focal length in ``case.json``
            (``"camera": {"focal_px": f}``, as a phone's EXIF would).
        views: the photos: the four of :data:`~naseview.landmarks.VIEWS` and any of the
            obliques (:func:`~naseview.testbed.synth.rig.parse_views`); the obliques are
            drawn after the four from every stream, so the four photos, their clicks and
            the truth are those of the four-photo case of the same seed.
    Returns:
        path of the written ``case.json``.
    """
    _check(model, size, seed, noise_px, image_noise)
    out = Path(out_dir)
    rs = random_streams(seed)
    V, w = sample_identity(model, rs["identity"])
    F = np.asarray(model.faces, dtype=np.int64)
    cams, rig_info = sample_rig(V, model, rs["rig"], size, views)
    scene, look = build_scene(model, V, rs["appearance"])
    studio = draw_studio(rs["appearance"])
    look.update({"background_bgr": list(studio.background),
                 "light_dirs_camera": studio.light_dirs.tolist()})
    true_lm = {k: V[model.landmark_vertices[k]].copy() for k in LANDMARK_IDS}
    curves = truth_curves(model, V)
    helpers = helper_points(model, V)
    images: dict[str, np.ndarray] = {}
    photos: dict[str, View] = {}
    boundaries: dict[str, dict[str, list[list[float]]]] = {}
    for view in views:
        cam: Camera = cams[view]
        images[view], depth = render_photo(scene, cam, studio.background, rs["sensor"],
                                           image_noise, studio.light_dirs)
        clicks = view_clicks(view, cam, depth, true_lm, helpers, rs["clicks"], noise_px)
        camera_json = {"focal_px": round(cam.focal_px, 3)} if write_focal else None
        photos[view] = View(view, f"{view}.jpg", clicks, size, size, camera_json)
        for name, pts in view_boundaries(curves, view, cam, depth).items():
            boundaries.setdefault(name, {})[view] = pts
    al = float(np.linalg.norm(true_lm["al_l"] - true_lm["al_r"]))
    case = _case(out, model, seed, noise_px, size, image_noise, photos, al)
    rec = Reconstruction(
        landmarks=true_lm, cameras=cams, curves=curves,
        measurements=clinical_measurements(true_lm, curves, V, F),
        extra={"synth": _synth_record(model, seed, noise_px, image_noise, size, w, rig_info,
                                      look, views),
               "nose_vertex_ids": np.asarray(model.nose_vertices, dtype=int).tolist()})
    out.mkdir(parents=True, exist_ok=True)
    export_mesh(out / "truth_face.ply", V, F)
    atomic_write_json(out / "truth_boundaries.json", boundaries)
    atomic_write_json(out / "truth.json", rec.to_json())
    return write_case(case, out, images)
