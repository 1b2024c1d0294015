"""The new-patient page, issue 27 item 4: what a surgeon met on the page (no browser).

Glabella in one photo warns instead of blocking (as the command line does); landmarks are
named one way (:func:`naseview.app.landmark_names.display_name`) in the heading and the
drop-down; choosing a landmark in the drop-down always selects it and the page stays on
its photo after it is clicked; the hint never shows a ``case.json`` key; an opened page
leaves no empty in-progress folder, and a finished patient is marked as such.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import png_bytes

from naseview.app.annotate_page import PICK_NONE, AnnotatePage
from naseview.app.guard import guarded_viser_server
from naseview.app.landmark_names import display_name
from naseview.intake.click_order import CLICK_ORDER
from naseview.intake.guidance import quick_stage1
from naseview.intake.session import AnnotationSession


def photo() -> bytes:
    return png_bytes(np.full((400, 300, 3), 120, np.uint8))


@pytest.fixture()
def page(tmp_path: Path):
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    page = AnnotatePage(server, None, work_dir=tmp_path, diagram_model="generic")
    try:
        yield page
    finally:
        page.close()
        server.stop()


def place_all(session: AnnotationSession, view: str) -> None:
    for k, lid in enumerate(CLICK_ORDER[view]):
        session.place(view, lid, (20.0 + 10 * k, 30.0 + 8 * k))


def test_glabella_in_one_photo_warns_and_does_not_block(tmp_path: Path):
    s = AnnotationSession.create(tmp_path / "p", "p")
    for v in ("front", "bottom", "left", "right"):
        s.add_photo(v, photo())
    s.set_scale("al_l", "al_r", 34.0)
    for v in ("front", "bottom", "left", "right"):
        for k, lid in enumerate(CLICK_ORDER[v]):
            if lid != "g" or v == "front":
                s.place(v, lid, (20.0 + 10 * k, 30.0 + 8 * k))
    assert s.problems() == []                                      # Reconstruct is enabled
    assert any("glabella (g) is clicked in the front photo only" in c for c in s.cautions())
    s.clicks["front"].pop("g")                                     # g nowhere at all...
    assert any("glabella g" in p for p in s.problems())            # ...blocks, like the CLI


def test_heading_and_dropdown_name_landmarks_the_same_way(page: AnnotatePage):
    page.start("n1")
    page.upload("front", photo())
    assert page.wait_idle(10)
    assert page.target == ("front", "g")
    assert f"Click **{display_name('g')}**" in page.target_md.content
    assert "(g)" not in page.target_md.content.split("\n", 1)[1]   # no id in the text
    assert f"· {display_name('g')}" in page.pick.options
    assert not any(o.endswith(" alpp_r") for o in page.pick.options)
    assert page.pick.value == f"· {display_name('g')}"


def test_choosing_a_landmark_selects_it_and_the_page_stays_on_its_photo(page: AnnotatePage):
    s = page.start("n2")
    page.upload("front", photo())
    page.upload("left", photo())
    assert page.wait_idle(10)
    page.submit(lambda: page.set_view("front"))
    place_all(s, "front")
    page.submit(page._redraw)
    assert page.wait_idle(10)
    assert page.target == ("left", "g")          # the guided flow goes on in the left photo
    assert page.pick.value == PICK_NONE          # no stale entry shown for the front photo
    # choosing g in the front photo while the guided target is g in the left one
    page._on_pick(f"✓ {display_name('g')}")
    assert page.wait_idle(10)
    assert page.target == ("front", "g")
    page.submit(lambda: page._place_click("front", np.array([55.0, 66.0])))
    assert page.wait_idle(10)
    np.testing.assert_allclose(s.clicks["front"]["g"], [55.0, 66.0])
    assert page.view == "front"                  # stays until the user moves on


def test_hints_never_show_a_case_json_key():
    clicks = {v: {i: np.array([10.0 + k, 20.0 + 2 * k]) for k, i in
                  enumerate(CLICK_ORDER[v][:8])} for v in ("front", "bottom")}
    g = quick_stage1(clicks, {"front": (400, 300), "bottom": (400, 300)})
    assert g.message.startswith("No hints yet")
    assert "'views." not in g.message and "key" not in g.message


def test_opening_the_page_leaves_no_empty_folder_and_finished_patients_are_marked(
        page: AnnotatePage, tmp_path: Path):
    page.show_start()
    assert page.wait_idle(10)
    page.hide()
    assert not (tmp_path / "in-progress").exists() or not any(
        (tmp_path / "in-progress").iterdir())
    page.show_start()                            # again: still nothing on disk
    assert page.wait_idle(10)
    assert not (tmp_path / "in-progress").exists() or not any(
        (tmp_path / "in-progress").iterdir())
    s = page._need_session()
    page.upload("front", photo())                # the first real input makes the folder
    assert page.wait_idle(10)
    assert (s.folder / "annotation.json").is_file() and s.folder.parent == (
        tmp_path / "in-progress")
    s.case_dir = tmp_path / s.case_id / "case"   # as write_case leaves it
    s.save()
    page.start("n3")
    page._refresh_resume_list()
    finished = [o for o in page.resume_dd.options if o.startswith(s.case_id)]
    assert finished and "reconstructed" in finished[0]


def test_the_next_landmark_is_pre_placed_and_accepted_in_one_click(page: AnnotatePage):
    """From two clicks in a photo, the next landmark has a marker; "Accept the marker"
    places it there (a confirmation instead of finding it)."""
    from naseview.intake.predict import template_layout
    s = page.start("n4")
    page.upload("front", png_bytes(np.full((800, 600, 3), 120, np.uint8)))
    assert page.wait_idle(10)
    assert page.accept_btn.disabled                    # no click yet: nothing to predict
    lay = template_layout("front")
    for i in ("g", "n"):
        page.submit(lambda i=i: page._place_click("front", lay[i] * 6.0 + [300.0, 250.0]))
    assert page.wait_idle(10)
    assert page.target == ("front", "k") and not page.accept_btn.disabled
    hint = page._handles["hint"]
    assert hint.visible is page.active
    page.submit(page._accept)
    assert page.wait_idle(10)
    np.testing.assert_allclose(s.clicks["front"]["k"], lay["k"] * 6.0 + [300.0, 250.0],
                               atol=1e-6)
    assert page.target == ("front", "r")


def test_a_house_as_front_photo_and_a_profile_as_bottom_photo_are_named_at_upload(
        page: AnnotatePage):
    """Issue 27 item 7: taken all the same, but one line in the panel names the slot and
    what looks wrong; a real front photo gets none."""
    import cv2
    house = np.full((600, 800, 3), (235, 206, 135), np.uint8)          # sky
    house[250:600, 150:650] = (60, 60, 160)                           # red walls
    cv2.fillPoly(house, [np.array([[120, 250], [400, 80], [680, 250]])], (40, 40, 40))
    page.start("n5")
    page.upload("front", png_bytes(house))
    assert page.wait_idle(10)
    assert "⚠ the 'front' photo looks like no face" in page.photo_info.content
    scans = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "scan-cases"
    if not (scans / "james-a" / "left.jpg").is_file():
        pytest.skip("../shared/data/scan-cases/james-a is missing")
    page.upload("bottom", (scans / "james-a" / "left.jpg").read_bytes())
    assert page.wait_idle(10)
    assert "⚠ the 'bottom' photo looks like a profile" in page.photo_info.content
    page.upload("front", (scans / "james-a" / "front.jpg").read_bytes())
    assert page.wait_idle(10)
    assert "'front'" not in page.photo_info.content
