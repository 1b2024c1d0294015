"""Issue 27 item 1: ICT's empty eye sockets were textured in streaks. The chart left each
eye opening a free border, and the conformal map squeezed it (24 x 16 mm became 76 x 17
texels): the cap a renderer puts over the opening had a third of the texels it needs
across. The holes are now closed for the map: an opening keeps its shape and texel
density in the chart, and the chart folds no more triangles than before."""

from __future__ import annotations

import numpy as np
from helpers import ict_baseline

from naseview.geometry.closing import boundary_loops
from naseview.texture.uv import face_uv, flipped_triangles


def _polygon_area(P: np.ndarray) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _in_plane(P: np.ndarray) -> np.ndarray:
    """A 3D rim (k, 3) in its best-fit plane (k, 2)."""
    Q = P - P.mean(axis=0)
    return Q @ np.linalg.svd(Q, full_matrices=False)[2][:2].T


def _aspect(Q: np.ndarray) -> float:
    s = np.linalg.svd(Q - Q.mean(axis=0), compute_uv=False)
    return float(s[0] / s[1])


def test_ict_eye_openings_keep_their_shape_and_texels_in_the_chart() -> None:
    b = ict_baseline()
    V, F = b.V, b.F
    uv = face_uv(V, F)
    loops = sorted(boundary_loops(F), key=len)
    eyes = [lp for lp in loops if abs(V[lp].mean(axis=0)[0]) > 15.0][:2]   # beside the nose
    assert len(eyes) == 2, "the ICT face has two eye openings"
    a, c = uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]
    uv_area = 0.5 * np.abs(a[:, 0] * c[:, 1] - a[:, 1] * c[:, 0])
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                axis=1)
    for lp in eyes:
        rim = _in_plane(V[lp])
        near = np.linalg.norm(V[F].mean(axis=1) - V[lp].mean(axis=0), axis=1) < 25.0
        around = float(np.median(uv_area[near] / np.maximum(area[near], 1e-12)))
        inside = _polygon_area(uv[lp]) / _polygon_area(rim)
        assert inside > 0.5 * around, (
            f"the eye opening has {inside / around:.2f} x the texel density around it")
        assert _aspect(uv[lp]) < 1.5 * _aspect(rim), (
            f"the eye opening is squeezed in the chart: aspect {_aspect(uv[lp]):.1f} in the "
            f"chart, {_aspect(rim):.1f} on the face")
    assert int(flipped_triangles(uv, F).sum()) <= 4


def test_a_face_without_holes_keeps_its_chart() -> None:
    gx, gy = np.meshgrid(np.linspace(-50, 50, 11), np.linspace(-50, 50, 11))
    V = np.c_[gx.ravel(), gy.ravel(), -0.01 * (gx.ravel() ** 2 + gy.ravel() ** 2)]
    i = np.arange(121).reshape(11, 11)
    F = np.r_[np.c_[i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel()],
              np.c_[i[:-1, :-1].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()]]
    uv = face_uv(V, F)
    assert not flipped_triangles(uv, F).any()
    assert uv.min() >= 0.0 and uv.max() <= 1.0
