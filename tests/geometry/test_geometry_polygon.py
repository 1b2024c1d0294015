"""Point in polygon (naseview.geometry.polygon): one exact method.

The generic face's mask used a 0.1 mm raster (OpenCV ``fillPoly``) and the surface error
(until SPEC §6 gave it a 3D nose region) an exact crossing-number test; the generic face
now uses the exact one. The raster is kept here as the reference the generic face was
built with: its mesh comes out the same either way, and on a nose outline the two agree
away from the border.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from naseview.facemodel import load_face_model
from naseview.facemodel.generic import lattice, mesh, triangulate
from naseview.geometry.polygon import points_in_polygon

OUTLINE = ("mf_r", "mf_l", "int_l", "al_l", "ac_l", "sn", "ac_r", "al_r", "int_r")
"""A concave landmark outline of the nose (the surface error's nose until SPEC §6 gave it
a 3D region), as a polygon of the size the callers meet."""


def _raster_inside(P: np.ndarray, poly: np.ndarray, res: float = 0.1) -> np.ndarray:
    """The generic face's former test: ``poly`` filled on a ``res`` mm raster."""
    lo = poly.min(axis=0) - 1.0
    size = np.ceil((poly.max(axis=0) + 1.0 - lo) / res).astype(np.int64) + 1
    mask = np.zeros((int(size[1]), int(size[0])), dtype=np.uint8)
    pix = np.round((poly - lo) / res * 16.0).astype(np.int32)     # 4 fractional bits
    cv2.fillPoly(mask, [pix], 1, lineType=cv2.LINE_8, shift=4)
    ij = np.round((P - lo) / res).astype(np.int64)
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < size[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < size[1])
    out = np.zeros(len(P), dtype=bool)
    out[ok] = mask[ij[ok, 1], ij[ok, 0]] == 1
    return out


def _distance_to_border(P: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """(n,) distance of 2D points to the closed polygon's edges."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("pkd,kd->pk", P[:, None] - a[None], ab) / (ab ** 2).sum(1), 0, 1)
    return np.linalg.norm(P[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(1)


def test_square_concave_and_outside() -> None:
    square = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])
    assert points_in_polygon(np.array([[1.0, 1], [3, 1], [1, -0.5], [-1, 1]]),
                             square).tolist() == [True, False, False, False]
    notch = np.array([[0.0, 0], [4, 0], [4, 4], [2, 1], [0, 4]])       # concave at (2, 1)
    assert points_in_polygon(np.array([[2.0, 0.5], [2, 2], [1, 2], [3, 2]]),
                             notch).tolist() == [True, False, True, True]


def test_generic_face_mesh_is_the_same_with_the_raster(monkeypatch: pytest.MonkeyPatch) -> None:
    exact = mesh.generic_mesh()
    monkeypatch.setattr(lattice, "points_in_polygon", _raster_inside)
    monkeypatch.setattr(triangulate, "points_in_polygon", _raster_inside)
    raster = mesh.generic_mesh.__wrapped__()
    assert np.array_equal(raster.V, exact.V) and np.array_equal(raster.F, exact.F)
    assert np.array_equal(raster.nostril_side, exact.nostril_side)


def test_nose_outline_agrees_with_the_raster_away_from_the_border() -> None:
    m = load_face_model("generic")
    lm = m.landmark_positions()
    poly = np.array([lm[k][:2] for k in OUTLINE])
    C = m.mean[m.faces].mean(1)[:, :2]
    far = _distance_to_border(C, poly) > 0.1
    exact, raster = points_in_polygon(C, poly), _raster_inside(C, poly)
    assert exact.sum() > 1000 and np.array_equal(exact[far], raster[far])
