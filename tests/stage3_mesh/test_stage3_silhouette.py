"""The photo-silhouette constraints of stage 3 (naseview.stage3_mesh.silhouette)."""

from __future__ import annotations

import igl
import numpy as np

from naseview.camera import look_at
from naseview.stage3_mesh.silhouette import (
    contour_targets,
    edge_faces,
    occluding_contour,
    silhouette_from_mask,
)


def _sphere(r: float, n: int = 3) -> tuple[np.ndarray, np.ndarray]:
    V, F = igl.icosahedron()
    V, F = np.asarray(V, float), np.asarray(F, np.int64)
    for _ in range(n):
        V, F = igl.upsample(V, F)
        V /= np.linalg.norm(V, axis=1, keepdims=True)
    return r * V, np.asarray(F, np.int64)


def _camera():  # type: ignore[no-untyped-def]
    return look_at([300.0, 0, 0], [0, 0, 0], [0, 1, 0], 2000.0, 400, 400)


def _disk_mask(cam, r: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The exact silhouette of a sphere of radius r at the origin (pixel centres)."""
    yy, xx = np.mgrid[0:cam.height, 0:cam.width]
    C, d = cam.rays(np.column_stack([xx.ravel(), yy.ravel()]))
    t = -(d @ C)
    miss = np.linalg.norm(C + t[:, None] * d, axis=1)
    return (miss <= r).reshape(cam.height, cam.width)


def test_contour_is_the_outline_and_targets_reach_the_bigger_silhouette() -> None:
    V, F = _sphere(10.0)
    cam = _camera()
    E, EF = edge_faces(F)
    ids = occluding_contour(V, F, cam, E, EF, np.ones(len(V), bool), outline_px=2.0)
    assert len(ids) > 20
    assert np.abs(V[ids, 0]).max() < 2.0           # the rim seen from +x: x about 0
    sil = silhouette_from_mask("left", cam, _disk_mask(cam, 10.5), (0, 0, 400, 400))
    ids, tg, names = contour_targets(V, F, [sil], np.ones(len(V), bool), np.zeros((0, 3)),
                                     1.0, 3.0, (E, EF), detrend=False)
    assert len(ids) > 20 and set(names) == {"sil:left"}
    grow = np.linalg.norm(tg[:, 1:], axis=1) - np.linalg.norm(V[ids, 1:], axis=1)
    assert abs(float(np.median(grow)) - 0.5) < 0.1   # outward by the radius difference


def test_detrend_removes_a_shift_of_the_photo() -> None:
    V, F = _sphere(10.0)
    cam = _camera()
    mask = np.roll(_disk_mask(cam, 10.0), 3, axis=1)  # the camera's error: 3 px sideways
    sil = silhouette_from_mask("left", cam, mask, (0, 0, 400, 400))
    mov = np.ones(len(V), bool)
    ids0, tg0, _ = contour_targets(V, F, [sil], mov, np.zeros((0, 3)), 1.0, 3.0)
    ids, tg, _ = contour_targets(V, F, [sil], mov, np.zeros((0, 3)), 1.0, 3.0, detrend=True)
    assert np.median(np.linalg.norm(tg0 - V[ids0], axis=1)) > 0.2   # 3 px = 0.45 mm
    assert np.median(np.linalg.norm(tg - V[ids], axis=1)) < 0.06


def test_the_reconstruction_follows_the_profile_photos() -> None:
    """End to end on the bundled demo case (generic base): with the silhouette rounds the
    nose's outline in the profile photos is closer to the photos' silhouettes than
    without them (the residual the rounds minimise falls), and the mesh still passes
    through the landmarks."""
    import copy
    import dataclasses
    from pathlib import Path

    from naseview.case import read_case
    from naseview.facemodel import load_face_model
    from naseview.pipeline import photo_silhouettes, reconstruct, run_stage3
    from naseview.stage3_mesh import RefineParams
    from naseview.stage3_mesh.solve import surface_distances

    case = read_case(Path(__file__).resolve().parents[2] / "assets" / "demo-case")
    model = load_face_model("generic")
    res12 = reconstruct(case, None, stages=(1, 2))
    sils = photo_silhouettes(case, res12.reconstruction)
    assert {s.view for s in sils} == {"left", "right"}
    residual = {}
    for rounds in (0, 2):
        res = copy.deepcopy(res12)
        run_stage3(res, case, model, dataclasses.replace(RefineParams(),
                                                         silhouette_rounds=rounds))
        assert res.refined is not None and res.face_vertices is not None
        V, F = res.face_vertices, res.refined.F
        movable = np.zeros(len(V), bool)
        movable[res.refined.nose_vertex_ids] = True
        ids, tg, _ = contour_targets(V, F, sils, movable, np.zeros((0, 3)), 1.0, 3.0,
                                     edge_faces(F), True)
        assert len(ids) > 10
        residual[rounds] = float(np.mean(np.linalg.norm(tg - V[ids], axis=1)))
        lm = res.reconstruction.landmarks
        d = surface_distances(V, F, np.array([lm[k] for k in ("n", "prn", "sn")]))
        assert d.max() < 0.2
        # the generic face (9 modes) keeps the mid-curve's hard handles beside them
        assert any(n.startswith("mid") for n in res.refined.handles.names)
    assert residual[2] < 0.8 * residual[0]


def test_no_box_where_the_nose_is_not_in_front_of_the_camera() -> None:
    """A camera the landmarks are behind, or that sees them off its image, gives no
    silhouette box (a hand-edited reconstruction must not crash stage 3)."""
    from naseview.stage3_mesh.silhouette import nose_box

    cam = _camera()
    lms = {k: np.array([0.0, -10.0 * i, 5.0]) for i, k in enumerate(("n", "k", "prn", "sn"))}
    assert nose_box(cam, lms) is not None
    behind = {k: p + [600.0, 0, 0] for k, p in lms.items()}
    assert nose_box(cam, behind) is None
    off = {k: p + [0, 0, 400.0] for k, p in lms.items()}      # far outside the image
    assert nose_box(cam, off) is None
