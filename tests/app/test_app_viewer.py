"""The clinical viewer (issue 14, items 3-5 in the app), with a real viser server and
headless tabs: the default view frames the nose, the standard view buttons put the camera
on the right side, construction overlays are hidden until asked for, the face is sent
textured (one skin: no seam between nose and face), the simulation shows on the photos
after a drag, and the view is saved as a PNG."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from helpers import drag, open_tab, wait_for

from naseview.app.face_glb import FaceGlb
from naseview.app.face_look import make_look, set_face_look
from naseview.app.gui_value import set_value
from naseview.app.viewer import camera_of_view
from naseview.camera import standard_camera
from naseview.editing.baseline import Baseline
from naseview.render import render_mesh


def skin_photos(b: Baseline, size: int = 256) -> tuple[dict, dict]:
    """Four small photos of the face with a striped skin pattern, and their cameras."""
    V = b.V
    rgb = np.column_stack([200 + 40 * np.sin(V[:, 0] / 4.0), 150 + 30 * np.cos(V[:, 1] / 5.0),
                           130 + 0 * V[:, 2]]) / 255.0
    cams, photos = {}, {}
    for view, std in (("front", "front"), ("left", "left"), ("right", "right"),
                      ("bottom", "base")):
        cams[view] = standard_camera(V, std, size)
        photos[view] = render_mesh(V, b.F, cams[view], vertex_colors=rgb[:, ::-1],
                                   background=(0, 255, 0), supersample=1).image
    return cams, photos


@pytest.fixture()
def served(ict_app):
    """(server, app, tabs): see ``ict_app`` in conftest."""
    return ict_app


def glb_parts(data: bytes) -> tuple[dict, bytes]:
    n = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20:20 + n])
    return doc, data[20 + n + 8:]


def glb_array(doc: dict, binary: bytes, accessor: int) -> np.ndarray:
    acc = doc["accessors"][accessor]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = np.float32 if acc["componentType"] == 5126 else np.uint32
    width = {"VEC3": 3, "VEC2": 2, "SCALAR": 1}[acc["type"]]
    a = np.frombuffer(binary, dtype, acc["count"] * width, view["byteOffset"])
    return a.reshape(acc["count"], width)


def recorded_messages(tab) -> list[object]:
    """The list every message queued for ``tab`` from now on is appended to (and sent)."""
    sent: list[object] = []
    ws = tab.client._websock_connection
    orig = ws.queue_message
    ws.queue_message = lambda m: (sent.append(m), orig(m))[1]
    return sent


def nose_box(tab, baseline: Baseline) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    c = tab.client.camera
    cam = camera_of_view(c.position, c.look_at, c.up_direction, c.fov, c.aspect, 600)
    uv = cam.project(baseline.V[baseline.nose_ids])
    return uv.min(axis=0), uv.max(axis=0), (cam.width, cam.height)


def test_the_default_view_frames_the_nose(served, baseline):
    server, app, tabs = served
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    wait_for(lambda: np.linalg.norm(np.asarray(tab.client.camera.look_at)
                                    - baseline.V[baseline.nose_ids].mean(0)) < 20, 10,
             "the tab's camera on the nose")
    lo, hi, (w, h) = nose_box(tab, baseline)
    assert (lo > 0).all() and hi[0] < w and hi[1] < h          # all of it in view
    centre = 0.5 * (lo + hi)
    assert abs(centre[0] - w / 2) < 0.1 * w and abs(centre[1] - h / 2) < 0.1 * h
    assert 0.4 < (hi[1] - lo[1]) / h < 0.8                     # the nose fills the view


@pytest.mark.parametrize("view, axis, sign", [("front", 2, 1), ("left", 0, 1),
                                              ("right", 0, -1), ("base", 1, -1),
                                              ("three_quarter_left", 0, 1),
                                              ("three_quarter_right", 0, -1)])
def test_standard_views_put_the_camera_on_their_side(served, baseline, view, axis, sign):
    server, app, tabs = served
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    screen.show_standard_view(view)
    nose = baseline.V[baseline.nose_ids].mean(0)
    d = np.asarray(tab.client.camera.position) - nose
    assert sign * d[axis] > 0.4 * np.linalg.norm(d), (view, d)  # SPEC +x: subject's left
    lo, hi, (w, h) = nose_box(tab, baseline)
    assert (lo > -0.05 * w).all() and hi[0] < 1.05 * w and hi[1] < 1.05 * h
    bar = screen._scale_bar[0]                                 # 10 mm, facing the view
    seg = np.asarray(bar.points)[0]
    assert abs(np.linalg.norm(seg[1] - seg[0]) - 10.0) < 1e-4   # float32 in the scene
    fwd = np.asarray(tab.client.camera.look_at) - np.asarray(tab.client.camera.position)
    assert abs(np.dot(seg[1] - seg[0], fwd / np.linalg.norm(fwd))) < 1e-3


def test_construction_overlays_are_hidden_until_asked_for(served):
    server, app, tabs = served
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    sc = screen.scene
    assert not sc.construction.visible and not screen.panels.show_construction.value
    assert sc.spheres.visible                       # the surgeon's drag handles stay
    assert not any(h.visible for h in sc.labels.values())
    set_value(screen.panels.show_construction, True)
    assert sc.construction.visible
    set_value(screen.panels.show_construction, False)
    assert not sc.construction.visible
    screen.patient.enter()                          # patient mode: no drag handles either
    assert not sc.spheres.visible
    screen.patient.exit()
    assert sc.spheres.visible and not sc.construction.visible


def test_the_face_is_sent_textured_and_without_a_seam(served, baseline):
    server, app, tabs = served
    cams, photos = skin_photos(baseline)
    look = make_look(baseline, app.moving, cams, photos, size=128)
    assert look.texture is not None
    set_face_look(app, look)
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    sent = recorded_messages(tab)
    screen.show_case()                              # what the tab is sent for the case
    glbs = {m.name: m.props.glb_data for m in sent if hasattr(m, "props")
            and hasattr(m.props, "glb_data")}
    assert {"/face/rest", "/face/nose"} <= set(glbs)
    for name in ("/face/rest", "/face/nose"):
        doc, _ = glb_parts(glbs[name])
        assert doc["images"][0]["mimeType"] == "image/jpeg"   # the patient's own skin
        assert "TEXCOORD_0" in doc["meshes"][0]["primitives"][0]["attributes"]
    # after an edit, the nose's border vertices shade exactly like the rest's
    drag(app.controller, "prn", np.array([0.0, 2.0, 2.0]))
    assert app.controller.wait_idle(10)
    parts: FaceGlb = screen.scene.parts
    V = app.controller.simulation.V
    P, N = parts.nose_geometry(V)
    border = parts.nose_ids[~np.isin(parts.nose_ids, parts.region)]
    rdoc, rbin = glb_parts(parts.rest_glb())
    rest_ids = parts._rest.ids
    rN = glb_array(rdoc, rbin, 1)[np.searchsorted(rest_ids, border)]
    nN = N[np.searchsorted(parts.nose_ids, border)]
    assert len(border) > 10
    np.testing.assert_allclose(nN, rN, atol=1e-6)
    assert np.abs(P[np.isin(parts.nose_ids, parts.region)]
                  - parts.base_Vc[parts.nose_ids[np.isin(parts.nose_ids, parts.region)]]
                  ).max() > 0.5                                  # ...while the nose moved


def test_untextured_face_has_no_image(baseline):
    parts = FaceGlb(baseline.V, baseline.F, baseline.nose_ids)
    doc, _ = glb_parts(parts.nose_glb(baseline.V))
    assert "images" not in doc
    assert doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"][0] > 0.5


def test_the_photo_simulation_updates_after_a_drag(served, baseline):
    server, app, tabs = served
    cams, photos = skin_photos(baseline)
    set_face_look(app, make_look(baseline, app.moving, cams, photos, size=128))
    app.cameras = cams
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    display = screen.photo_sim.displays[0]
    set_value(display.view, "left")
    wait_for(lambda: screen.photo_sim.cached("left") is not None, 20, "the first composite")
    before0, after0 = screen.photo_sim.cached("left")
    np.testing.assert_array_equal(before0, after0)          # no edit: the photo itself
    screen.photo_sim.computed.clear()
    drag(app.controller, "prn", np.array([0.0, 0.0, 4.0]))
    assert app.controller.wait_idle(10)
    wait_for(lambda: (c := screen.photo_sim.cached("left")) is not None
             and np.abs(c[1].astype(int) - c[0].astype(int)).max() > 30, 20,
             "the composite of the edit")
    assert display.image.visible
    set_value(display.slider, 0.0)                          # before
    np.testing.assert_array_equal(display.image.image, screen.photo_sim.cached("left")[0])


def test_save_view_as_png(served, monkeypatch):
    server, app, tabs = served
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    got: list[tuple[str, bytes]] = []
    monkeypatch.setattr(tab.client, "send_file_download",
                        lambda name, data, **kw: got.append((name, data)))
    screen.show_standard_view("left")
    screen.save_view_png(tab.client)
    wait_for(lambda: got, 30, "the PNG download")
    name, data = got[0]
    assert name.endswith("-left.png") and data[:8] == b"\x89PNG\r\n\x1a\n"
    import cv2
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert img.shape[0] == 900 and img.std() > 10                # a face, not blank


def test_the_nose_never_leaves_a_hole_while_its_glb_loads(served, baseline):
    """Issue 27 item 2: a browser draws nothing where a replaced GLB is still decoding
    (2 s and more with software WebGL). Under the textured nose lies a plain mesh of it in
    the skin's colour, just inside it, whose vertices are sent first on every edit: after a
    drag it has the new shape before the GLB is replaced, and hides and goes with it."""
    from naseview.app.scene import UNDERLAY_INSET_MM

    server, app, tabs = served
    cams, photos = skin_photos(baseline)
    set_face_look(app, make_look(baseline, app.moving, cams, photos, size=128))
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    sent = recorded_messages(tab)
    node = screen.scene.nose
    parts: FaceGlb = screen.scene.parts
    assert parts.nose_rgb != (0, 0, 0) and max(parts.nose_rgb) > 60   # skin, not black
    drag(app.controller, "prn", np.array([0.0, 2.0, 2.0]))
    assert app.controller.wait_idle(10)
    P, N = parts.nose_geometry(app.controller.simulation.V)
    np.testing.assert_allclose(node.underlay.vertices, P - UNDERLAY_INSET_MM * N, atol=1e-4)
    kinds = [type(m).__name__ for m in sent]
    last_glb = max(i for i, m in enumerate(sent) if getattr(m, "name", "") == "/face/nose")
    under = [i for i, m in enumerate(sent)
             if getattr(m, "name", "") == "/face/nose_underlay" and i < last_glb]
    assert under, kinds            # the underlay's new shape went out before the new GLB
    node.visible = False
    assert not node.underlay.visible
    node.visible = True
