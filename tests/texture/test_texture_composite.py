"""The simulation on the photo (naseview.texture.composite): unchanged where nothing moved,
the patient's own pixels moved where the face moved, no backdrop hole left behind."""

from __future__ import annotations

import numpy as np
import pytest
from scenes import BACKDROP_BGR, camera_towards, dome, pattern_rgb, photograph

from naseview.errors import NaseviewError
from naseview.texture.composite import blend, changed_region, composite_photo, ghost


@pytest.fixture(scope="module")
def scene():
    V, F = dome(n=41)
    rgb = pattern_rgb(V)
    cams = {"front": camera_towards((0.0, 0.0, 1.0)), "side": camera_towards((1.0, 0.0, 0.0))}
    photos = {k: photograph(V, F, rgb, c) for k, c in cams.items()}
    return V, F, cams, photos


def _push_in(V: np.ndarray, centre: np.ndarray, depth: float, radius: float = 18.0,
             direction: tuple[float, float, float] = (0.0, 0.0, -1.0)) -> np.ndarray:
    """``V`` with the vertices within ``radius`` of ``centre`` moved ``depth`` mm (fading)."""
    w = np.clip(1.0 - np.linalg.norm(V - centre, axis=1) / radius, 0.0, 1.0) ** 2
    return V + depth * w[:, None] * np.asarray(direction)


def test_unchanged_face_returns_the_photo(scene) -> None:
    V, F, cams, photos = scene
    for k in cams:
        out = composite_photo(photos[k], cams[k], V, V.copy(), F)
        assert np.array_equal(out, photos[k])
        assert out is not photos[k]


def test_moved_region_changes_only_pixels_near_it(scene) -> None:
    V, F, cams, photos = scene
    pole = V[np.argmax(V[:, 2])]
    V1 = _push_in(V, pole, 6.0, direction=(0.0, 0.6, -0.8))    # up and back
    moved = np.linalg.norm(V1 - V, axis=1) > 1e-3
    for k in cams:
        out = composite_photo(photos[k], cams[k], V, V1, F)
        diff = changed_region(photos[k], out)
        assert diff.sum() > 50, k
        uv = cams[k].project(np.vstack([V[moved], V1[moved]]))
        ys, xs = np.nonzero(diff)
        pad = 20   # how far uncovered outline is filled (12 px) and the feather (6 px)
        assert xs.min() >= uv[:, 0].min() - pad and xs.max() <= uv[:, 0].max() + pad
        assert ys.min() >= uv[:, 1].min() - pad and ys.max() <= uv[:, 1].max() + pad


def test_reduced_profile_is_filled_with_backdrop(scene) -> None:
    V, F, cams, photos = scene
    tip = V[np.argmax(V[:, 2])]
    V1 = _push_in(V, tip, 10.0, radius=30.0)     # the profile recedes by about 5 mm
    cam = cams["side"]
    out = composite_photo(photos["side"], cam, V, V1, F)
    # the pole's old outline in the side photo (1-2 mm inside it) is now backdrop green
    inner = tip[None] - np.c_[np.zeros((2, 2)), np.arange(1.0, 3.0)]
    px = np.round(cam.project(inner)).astype(int)
    before = photos["side"][px[:, 1], px[:, 0]].astype(int)
    now = out[px[:, 1], px[:, 0]].astype(int)
    assert (np.abs(before - BACKDROP_BGR).max(axis=1) > 100).all()     # it was skin
    assert (np.abs(now - BACKDROP_BGR).max(axis=1) < 40).all(), now


def test_blend_and_ghost(scene) -> None:
    V, F, cams, photos = scene
    V1 = _push_in(V, V[np.argmax(V[:, 2])], 6.0)
    before = photos["side"]
    after = composite_photo(before, cams["side"], V, V1, F)
    assert np.array_equal(blend(before, after, 0.0), before)
    assert np.array_equal(blend(before, after, 1.0), after)
    mid = blend(before, after, 0.5).astype(int)
    assert np.abs(mid - (before.astype(int) + after) / 2).max() <= 1
    g = ghost(before, after)
    assert g.shape == after.shape and not np.array_equal(g, after)
    assert np.array_equal(ghost(before, before), before)


def test_wrong_photo_size_is_an_error(scene) -> None:
    V, F, cams, photos = scene
    with pytest.raises(NaseviewError, match="camera"):
        composite_photo(photos["front"][:100], cams["front"], V, V, F)
