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


def test_a_photo_never_textures_the_back_of_a_triangle() -> None:
    """Issue 27: a folded triangle's smooth normal can face a photo that sees its back;
    that photo must not lend it a colour (the flap out of the nostril got the cheek's)."""
    from naseview.camera import orbit_camera
    from naseview.texture.bake import BakeParams, bake_texture

    xs, ys = np.meshgrid(np.linspace(-20, 20, 9), np.linspace(-20, 20, 9))
    V = np.c_[xs.ravel(), ys.ravel(), np.zeros(81)]
    F = np.array([[r * 9 + c, r * 9 + c + 1, (r + 1) * 9 + c] for r in range(8)
                  for c in range(8)] + [[r * 9 + c + 1, (r + 1) * 9 + c + 1,
                                         (r + 1) * 9 + c] for r in range(8) for c in range(8)])
    W = V.copy()
    W[40] += [-8.0, -7.0, 0.0]                       # pulled across: triangles turn over
    fn = np.cross(W[F[:, 1]] - W[F[:, 0]], W[F[:, 2]] - W[F[:, 0]])
    back = np.flatnonzero(fn[:, 2] < 0)
    assert len(back)
    cam = orbit_camera(np.zeros(3), (0.0, 0.0, 1.0), 600.0, 60.0, 200)
    photo = np.full((200, 200, 3), (40, 80, 200), np.uint8)
    tex = bake_texture(W, F, {"front": cam}, {"front": photo},
                       BakeParams(size=128, mask_backdrop=False, border_feather=0.0))
    from naseview.texture.bake import texel_plan
    plan = texel_plan(W, F, 128)
    on_back = np.isin(plan.tri, back)
    assert on_back.any()
    covered = tex.coverage.reshape(-1)[plan.texels]
    assert not covered[on_back].any()
    assert covered[~on_back].mean() > 0.5
