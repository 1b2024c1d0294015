"""Outlines traced over the face (stage 2's alar curves) as stage-3 contour silhouettes."""

from __future__ import annotations

import numpy as np

from naseview.camera import Camera
from naseview.stage3_mesh import RefineParams
from naseview.stage3_mesh.silhouette import curve_piece, near_chain, silhouette_from_curve


def _camera() -> Camera:
    K = np.array([[1000.0, 0, 100], [0, 1000, 100], [0, 0, 1]])
    return Camera(K, np.eye(3), np.array([0, 0, 500.0]), 200, 200)


def _bulge() -> np.ndarray:
    t = np.linspace(-1, 1, 60)
    return np.c_[100 - 40 * np.cos(1.2 * t), 100 + 60 * t]   # bulges to the left (-x)


def test_curve_silhouette_matches_onto_the_curve_only_where_the_curve_is_nearest():
    s = silhouette_from_curve("ala_l", _camera(), _bulge(), np.zeros((2, 3)))
    assert s is not None and not s.outline and s.view == "front" and s.label == "sil:ala_l"
    # just outside and just inside the curve at its middle (x = 60): both pulled onto it
    off, ok = s.match(np.array([[55.0, 100.0], [64.0, 100.0]]))
    assert ok.all()
    np.testing.assert_allclose(55 + off[0, 0], 60, atol=0.7)
    np.testing.assert_allclose(64 + off[1, 0], 60, atol=0.7)
    # beside the closing chord (x ~ 85 at mid-height), nothing matches; nor past an end
    _, ok = s.match(np.array([[82.0, 100.0], [85.0, 30.0]]))
    assert not ok.any()


def test_curve_piece_and_chain_reach():
    uv = _bulge()
    piece = curve_piece(uv, uv[50] + 0.3, uv[10] - 0.2)
    np.testing.assert_array_equal(piece, uv[10:51])
    chain = np.array([[0.0, 0, 0], [10, 0, 0]])
    inside = near_chain(np.array([[5.0, 4.9, 0], [5.0, 5.1, 0], [-4.0, 0, 0]]), chain, 5.0)
    assert inside.tolist() == [True, False, True]


def test_too_small_or_bad_curves_give_no_silhouette():
    cam = _camera()
    assert silhouette_from_curve("bottom_l", cam, np.zeros((2, 2)), np.zeros((2, 3))) is None
    bad = _bulge()
    bad[3] = np.nan
    assert silhouette_from_curve("bottom_l", cam, bad, np.zeros((2, 3))) is None


def test_outline_curves_names_are_validated():
    import pytest

    from naseview.errors import NaseviewError

    p = RefineParams(outline_curves=("bottom_l", "bottom_r", "ala_l", "ala_r"))
    assert p.outline_curves[0] == "bottom_l"
    with pytest.raises(NaseviewError, match="outline_curves"):
        RefineParams(outline_curves=("nose",))
