"""Projective texturing (naseview.texture.bake): the photos' colours land on the right
texels, the backdrop and occluders never do, exposure differences are equalised."""

from __future__ import annotations

import numpy as np
import pytest
from scenes import (
    bumped_sheet,
    camera_towards,
    dome,
    pattern_rgb,
    photograph,
)

from naseview.errors import NaseviewError
from naseview.geometry.mesh import vertex_normals
from naseview.texture.bake import BakeParams, bake_texture, push_pull
from naseview.texture.uv import face_uv, flipped_triangles

PARAMS = BakeParams(size=256, feather_px=4.0)
VIEWS = {"front": (0.0, 0.0, 1.0), "left": (1.0, 0.0, 0.6), "right": (-1.0, 0.0, 0.6),
         "bottom": (0.0, -1.0, 0.6)}


def _seen(V: np.ndarray, F: np.ndarray, cams: dict, cos_min: float = 0.6) -> np.ndarray:
    """Vertices some camera looks at squarely (so their texels are photo colour)."""
    N = vertex_normals(V, F)
    ok = np.zeros(len(V), bool)
    for cam in cams.values():
        d = cam.center - V
        ok |= np.einsum("ij,ij->i", N, d / np.linalg.norm(d, axis=1, keepdims=True)) > cos_min
    return ok


def test_dome_recovers_the_colour_pattern() -> None:
    V, F = dome()
    rgb = pattern_rgb(V)
    cams = {k: camera_towards(d) for k, d in VIEWS.items()}
    photos = {k: photograph(V, F, rgb, c) for k, c in cams.items()}
    tex = bake_texture(V, F, cams, photos, PARAMS)
    assert tex.image.shape == (256, 256, 3) and tex.image.dtype == np.uint8
    assert tex.uv.shape == (len(V), 2) and not flipped_triangles(tex.uv, F).any()
    seen = _seen(V, F, cams)
    err = np.abs(tex.vertex_colors[seen].astype(float) - rgb[seen]).mean()
    assert err < 6.0, err
    # the chart is filled everywhere: no black holes in the texture
    assert tex.image.reshape(-1, 3).sum(axis=1).min() > 60
    assert 0.2 < tex.coverage.mean() < 0.95
    # the same photos all equal in exposure: gains stay near 1
    assert all(np.allclose(g, 1.0, atol=0.05) for g in tex.gains.values())


def test_backdrop_is_never_sampled() -> None:
    # the photos show a slightly smaller dome than the mesh (a reconstruction is never
    # exact): the mesh's rim projects onto the green backdrop
    V, F = dome()
    rgb = pattern_rgb(V)
    cams = {k: camera_towards(d) for k, d in VIEWS.items()}
    photos = {k: photograph(V * 0.93, F, rgb, c) for k, c in cams.items()}
    tex = bake_texture(V, F, cams, photos, PARAMS)
    px = tex.image.reshape(-1, 3).astype(int)
    greenish = (px[:, 1] > px[:, 0] + 40) & (px[:, 1] > px[:, 2] + 40)
    assert not greenish.any(), int(greenish.sum())
    # without the backdrop mask the rim would be green: the test can fail
    loose = bake_texture(V, F, cams, photos, BakeParams(size=256, feather_px=4.0,
                                                        mask_backdrop=False))
    q = loose.image.reshape(-1, 3).astype(int)
    assert ((q[:, 1] > q[:, 0] + 40) & (q[:, 1] > q[:, 2] + 40)).any()


def test_occluded_texels_do_not_take_the_occluders_colour() -> None:
    # a red bump on a blue sheet, seen from two oblique cameras: the sheet each camera sees
    # only behind the bump must come from the other camera, never red
    V, F = bumped_sheet(height=50.0, sigma=10.0)
    rgb = np.where((V[:, 2] > 3.0)[:, None], [230, 30, 30], [30, 40, 220]).astype(np.uint8)
    cams = {"left": camera_towards((1.0, 0.0, 1.0)), "right": camera_towards((-1.0, 0.0, 1.0))}
    photos = {k: photograph(V, F, rgb, c) for k, c in cams.items()}
    # depth steps are not masked here, so that only the z-buffer test protects the sheet
    tex = bake_texture(V, F, cams, photos, BakeParams(size=256, feather_px=4.0, jump_mm=1e9))
    # sheet vertices in the bump's shadow of one camera (behind it, seen from that side)
    shadow = (V[:, 2] < 0.5) & (np.abs(V[:, 1]) < 6.0) & (np.abs(V[:, 0]) > 25.0) \
        & (np.abs(V[:, 0]) < 40.0)
    assert shadow.sum() >= 8
    col = tex.vertex_colors[shadow].astype(int)
    assert (col[:, 0] < 80).all() and (col[:, 2] > 170).all(), col


def test_gain_compensation_equalises_a_darker_photo() -> None:
    V, F = dome()
    rgb = pattern_rgb(V)
    cams = {k: camera_towards(d) for k, d in VIEWS.items()}
    photos = {k: photograph(V, F, rgb, c) for k, c in cams.items()}
    photos["left"] = np.clip(photos["left"].astype(float) * 0.7, 0, 255).astype(np.uint8)
    tex = bake_texture(V, F, cams, photos, PARAMS)
    assert np.allclose(tex.gains["left"], 1 / 0.7, atol=0.08), tex.gains["left"]
    assert np.allclose(tex.gains["front"], 1.0)
    # the left side of the dome is as bright as the truth
    left = _seen(V, F, {"left": cams["left"]}, 0.8)
    err = np.abs(tex.vertex_colors[left].astype(float) - rgb[left]).mean()
    assert err < 8.0, err


def test_push_pull_fills_holes_smoothly() -> None:
    img = np.zeros((64, 64, 3), np.float32)
    img[:, :32] = 100.0
    img[:, 32:] = 200.0
    w = np.ones((64, 64), np.float32)
    w[20:44, 20:44] = 0.0          # a hole across the step
    out = push_pull(img * w[:, :, None], w)
    assert np.allclose(out[w > 0], img[w > 0])
    hole = out[20:44, 20:44, 0]
    assert 95.0 <= hole.min() and hole.max() <= 205.0
    assert np.all(np.diff(hole[12], axis=0) >= -1.0)      # a ramp, not a stripe


def test_bad_inputs_are_one_line_errors() -> None:
    V, F = dome(n=9)
    cam = camera_towards((0.0, 0.0, 1.0), size=64)
    with pytest.raises(NaseviewError, match="no photo has a camera"):
        bake_texture(V, F, {}, {"front": np.zeros((64, 64, 3), np.uint8)})
    with pytest.raises(NaseviewError, match="cameras.front") as e:
        bake_texture(V, F, {"front": cam}, {"front": np.zeros((32, 64, 3), np.uint8)})
    assert "\n" not in str(e.value)
    closed_F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    with pytest.raises(NaseviewError, match="no border"):
        face_uv(np.eye(4, 3) + [0, 0, 0.1], closed_F)
