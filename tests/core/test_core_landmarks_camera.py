"""The landmark table and the camera convention (SPEC §1, §4)."""

from __future__ import annotations

import numpy as np

from naseview.camera import Camera, look_at, rodrigues, rotation_to_rvec
from naseview.landmarks import (
    CURVE_LANDMARKS,
    CURVE_NAMES,
    HELPER_IDS,
    LANDMARK_IDS,
    LANDMARKS,
    TABLE1_DISTANCES,
    partner,
)


def test_landmark_table_matches_spec() -> None:
    assert len(LANDMARK_IDS) == 21 and HELPER_IDS == ("add_l", "add_r")
    for lid, lm in LANDMARKS.items():
        if lm.partner is not None:
            assert partner(lm.partner) == lid
            assert lid[-2:] in ("_l", "_r")
        for curve in lm.curves:
            assert curve in CURVE_NAMES
            assert lid in CURVE_LANDMARKS[curve]
    assert set(CURVE_LANDMARKS) == set(CURVE_NAMES)
    assert len(TABLE1_DISTANCES) == 11
    assert all(a in LANDMARK_IDS and b in LANDMARK_IDS for a, b in TABLE1_DISTANCES)


def test_front_camera_sees_subject_left_on_image_right() -> None:
    cam = look_at([0, 0, 500.0], [0, 0, 0], [0, 1, 0], 1000.0, 1024, 1024)
    left, right, up = cam.project(np.array([[30.0, 0, 0], [-30.0, 0, 0], [0, 30.0, 0]]))
    assert left[0] > 511.5 > right[0]  # subject's left (+x) appears on the image's right
    assert up[1] < 511.5  # image y points down
    assert np.isclose(cam.depth(np.zeros((1, 3)))[0], 500.0)


def test_rays_pass_through_projected_points() -> None:
    cam = look_at([300.0, -200, 400], [0, -40, 20], [0, 1, 0], 1400.0, 800, 600)
    X = np.array([[10.0, -50, 30], [-20.0, -10, 5]])
    o, d = cam.rays(cam.project(X))
    v = X - o
    cross = np.cross(v, d)
    assert np.allclose(cross, 0.0, atol=1e-9)
    again = Camera.from_json(cam.to_json())
    assert np.allclose(again.project(X), cam.project(X))


def test_rodrigues_roundtrip() -> None:
    r = np.array([0.3, -0.2, 0.9])
    R = rodrigues(r)
    assert np.allclose(R @ R.T, np.eye(3))
    assert np.allclose(rotation_to_rvec(R), r)
