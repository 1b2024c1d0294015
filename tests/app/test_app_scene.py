"""The app's 3D scene with a real viser server (no browser), and its pure helpers."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import GaussianSolver, drag, ict_baseline

from naseview.app.colormap import diverging_colors, nice_limit
from naseview.app.guard import guarded_viser_server
from naseview.app.scene import FaceScene
from naseview.app.scene_geometry import split_region
from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController


@pytest.fixture(scope="module")
def baseline() -> Baseline:
    return ict_baseline()


def test_scene_update_sends_only_the_nose(baseline):
    """With a real viser server (no browser): a solve updates the nose mesh handle and
    never resends the rest of the face."""
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    ctl = EditController(baseline, GaussianSolver(baseline))
    try:
        scene = FaceScene(server, ctl, ["prn", "al_l", "al_r"], region=baseline.nose_ids)
        sent: list[object] = []
        ws = server._websock_server
        orig = ws.queue_message
        ws.queue_message = lambda m: (sent.append(m), orig(m))[1]
        before = np.asarray(scene.nose.vertices).copy()
        drag(ctl, "prn", np.array([0.0, 1.5, 0.0]))
        assert ctl.wait_idle(10)
        after = np.asarray(scene.nose.vertices)
        assert np.abs(after - before).max() > 0.5
        names = {getattr(m, "name", "") for m in sent}
        assert "/face/nose" in names and "/face/rest" not in names
        np.testing.assert_allclose(
            np.asarray(scene.spheres.batched_positions)[0], ctl.landmarks["prn"], atol=1e-4)
        scene.set_view(colormap=True)
        assert scene.colormap is not None and scene.colormap_limit >= 1.0
        scene.remove()
    finally:
        ctl.close()
        server.stop()


def test_split_region_and_colour_map():
    F = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 5, 2]])
    part, pf, rest, rf = split_region(F, np.array([1]), 6)
    assert set(part) == {0, 1, 2, 3} and set(rest) == {2, 3, 4, 5}
    assert 1 not in set(rest)                     # region vertices never in the rest mesh
    assert part[pf].tolist() == [[0, 1, 2], [1, 3, 2]]
    c = diverging_colors(np.array([-2.0, 0.0, 2.0]), 2.0)
    assert c[0, 2] > c[0, 0] and c[2, 0] > c[2, 2] and (c[1] > 240).all()
    assert nice_limit(0.0) == 0.5 and nice_limit(2.2) == 3.0
