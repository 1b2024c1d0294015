"""The annotation session of a new patient, without a browser.

Place / move / skip / undo, clicks outside the photo, autosave and resume after a
"restart", guidance hints from a quick stage 1, and the case directory it writes (read
back with read_case).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import png_bytes

from naseview.camera import Camera, look_at
from naseview.case import read_case
from naseview.errors import NaseviewError
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.intake.in_progress import list_in_progress
from naseview.intake.session import AnnotationSession
from naseview.landmarks import VIEWS

# A plausible nose (mm, SPEC frame, origin g) and a four-camera rig: clicks are exact
# projections, so hints can be checked against the truth.
NOSE = {
    "g": (0.0, 0.0, 0.0), "n": (0.0, -13.0, -7.0), "k": (0.0, -25.0, -2.0),
    "r": (0.0, -32.0, 2.0), "prn": (0.0, -46.0, 15.0), "c": (0.0, -52.0, 10.0),
    "sn": (0.0, -58.0, -2.0),
    "mf_l": (10.0, -11.0, -12.0), "int_l": (10.0, -39.0, 0.0), "al_l": (16.5, -47.0, -5.0),
    "alp_l": (8.0, -51.0, 6.0), "alpp_l": (5.5, -54.0, 2.0), "ac_l": (14.0, -51.0, -9.0),
    "md_l": (6.5, -50.0, 8.5), "add_l": (4.0, -49.0, 11.0),
}
for _k in list(NOSE):
    if _k.endswith("_l"):
        x, y, z = NOSE[_k]
        NOSE[_k[:-2] + "_r"] = (-x * 1.02, y + 0.3, z)
SIZE = 800


def rig() -> dict[str, Camera]:
    target = np.array([0.0, -32.0, 0.0])
    dirs = {"front": (0.05, 0.02, 1.0), "left": (1.0, 0.05, 0.1), "right": (-1.0, 0.0, 0.12),
            "bottom": (0.02, -0.77, 0.64)}
    out = {}
    for v, d in dirs.items():
        d = np.asarray(d) / np.linalg.norm(d)
        up = (0, 0, 1.0) if v == "bottom" else (0, 1.0, 0)
        out[v] = look_at(target + 400.0 * d, target, up, 2000.0, SIZE, SIZE)
    return out


def true_clicks() -> dict[str, dict[str, np.ndarray]]:
    cams = rig()
    out = {}
    for v, cam in cams.items():
        ids = [i for i in CLICK_ORDER[v] if not (v == "left" and i.endswith("_r"))
               and not (v == "right" and i.endswith("_l"))]
        uv = cam.project(np.array([NOSE[i] for i in ids]))
        out[v] = {i: uv[k] for k, i in enumerate(ids)}
    return out


@pytest.fixture()
def photos() -> dict[str, bytes]:
    rng = np.random.default_rng(0)
    img = (rng.integers(90, 160, (SIZE, SIZE, 3))).astype(np.uint8)
    return {v: png_bytes(img) for v in VIEWS}


def annotate_all(s: AnnotationSession, clicks: dict[str, dict[str, np.ndarray]]) -> None:
    """Follow the guided order: click what is visible, skip the rest."""
    while (t := s.next_target()) is not None:
        v, lid = t
        s.set_active_view(v)
        if lid in clicks[v]:
            s.place(v, lid, clicks[v][lid])
        else:
            s.skip(v, lid)


def test_next_target_skip_undo_and_progress(tmp_path: Path, photos):
    s = AnnotationSession.create(tmp_path / "p", "p1")
    assert s.next_target() is None                  # no photo yet
    s.add_photo("front", photos["front"])
    assert s.next_target() == ("front", "g")
    s.place("front", "g", (400, 100))
    s.place("front", "n", (401, 160))
    assert s.next_target() == ("front", "k")
    s.skip("front", "k")
    assert s.next_target() == ("front", "r")
    assert s.progress("front") == (3, len(CLICK_ORDER["front"]))
    s.place("front", "n", (405, 170))              # re-click = move
    assert s.undo() == ("front", "n")
    np.testing.assert_array_equal(s.clicks["front"]["n"], [401, 160])
    assert s.undo() == ("front", "k")              # the skip
    assert s.status("front", "k") == "todo"
    s.skip("front", "g")                            # skipping a placed click removes it
    assert "g" not in s.clicks["front"]
    assert s.undo() == ("front", "g")
    np.testing.assert_array_equal(s.clicks["front"]["g"], [400, 100])
    s.move("front", "g", (410, 105))
    np.testing.assert_array_equal(s.clicks["front"]["g"], [410, 105])
    with pytest.raises(NaseviewError, match="not placed"):
        s.move("front", "sn", (1, 1))
    with pytest.raises(NaseviewError, match="not marked in the front photo"):
        s.place("front", "add_l", (1, 1))


def test_click_outside_the_photo_is_rejected(tmp_path: Path, photos):
    s = AnnotationSession.create(tmp_path / "p")
    s.add_photo("front", photos["front"])
    rev = s.revision
    for xy in ((-3.0, 10.0), (SIZE + 0.0, 10.0), (10.0, SIZE - 0.4), (np.nan, 1.0)):
        with pytest.raises(NaseviewError) as e:
            s.place("front", "g", xy)
        assert "\n" not in str(e.value)
    assert "outside" in str(pytest.raises(NaseviewError, s.place, "front", "g",
                                          (SIZE + 5.0, 5.0)).value)
    assert s.revision == rev and not s.clicks["front"]
    with pytest.raises(NaseviewError, match="upload it first"):
        s.place("left", "g", (5, 5))


def test_autosave_and_resume_after_restart(tmp_path: Path, photos):
    folder = tmp_path / "in-progress" / "p7"
    s = AnnotationSession.create(folder, "p7")
    for v in ("front", "bottom"):
        s.add_photo(v, photos[v])
    s.set_scale("al_l", "al_r", 34.5)
    s.set_scale_text("n-prn=45.2, mf_l-mf_r 18")
    s.place("front", "g", (400.5, 100.25))
    s.place("front", "n", (401, 160))
    s.skip("front", "k")
    s.place("front", "n", (402, 161))
    s.set_active_view("bottom")
    del s                                            # "server restart": nothing in memory
    with pytest.raises(NaseviewError, match="already in progress"):
        AnnotationSession.create(folder)
    [found] = list_in_progress(tmp_path / "in-progress")
    assert found.folder == folder and found.case_id == "p7" and found.problem is None
    assert found.clicks == 2 and not found.finished     # g and n; k is skipped
    r = AnnotationSession.open(folder)
    assert r.case_id == "p7" and r.active_view == "bottom"
    assert set(r.photos) == {"front", "bottom"}
    np.testing.assert_array_equal(r.clicks["front"]["g"], [400.5, 100.25])
    np.testing.assert_array_equal(r.clicks["front"]["n"], [402, 161])
    assert r.skipped["front"] == {"k"}
    assert r.scale_mm == {("al_l", "al_r"): 34.5, ("n", "prn"): 45.2, ("mf_l", "mf_r"): 18.0}
    assert r.next_target("front") == ("front", "r")
    assert r.undo() == ("front", "n")                # undo history survives the restart
    np.testing.assert_array_equal(r.clicks["front"]["n"], [401, 160])
    assert AnnotationSession.open(folder).clicks["front"]["n"].tolist() == [401, 160]
    assert r.image("front").shape == (SIZE, SIZE, 3)
    with pytest.raises(NaseviewError, match="expected <id>-<id>=<mm>"):
        r.set_scale_text("n-prn=45, oops")
    assert ("n", "prn") in r.scale_mm                # a bad entry changes nothing


def test_case_written_and_readable(tmp_path: Path, photos):
    clicks = true_clicks()
    s = AnnotationSession.create(tmp_path / "p", "case-9")
    assert any("photo is missing" in p for p in s.problems())
    for v in VIEW_ORDER:
        s.add_photo(v, photos[v])
    annotate_all(s, clicks)
    assert "al_l-al_r" in " ".join(s.problems())
    with pytest.raises(NaseviewError, match="al_l-al_r"):
        s.write_case(tmp_path / "case")
    s.set_scale("al_l", "al_r", 3.3)                  # centimetres typed as mm
    assert s.problems() == ["the distance al_l-al_r of 3.3 mm is not a nose's (about "
                            "34 mm); enter the calliper reading in mm"]
    with pytest.raises(NaseviewError, match="3.3 mm is not a nose's"):
        s.write_case(tmp_path / "case")
    s.set_scale("al_l", "al_r", 33.0)
    assert s.problems() == []
    path = s.write_case(tmp_path / "case")
    case = read_case(path.parent)
    assert case.id == "case-9" and case.scale_mm == {("al_l", "al_r"): 33.0}
    for v in VIEWS:
        assert set(case.views[v].landmarks) == set(clicks[v])
        for i, xy in clicks[v].items():
            np.testing.assert_allclose(case.views[v].landmarks[i], xy, atol=1e-9)
        assert case.views[v].width == SIZE
    assert (tmp_path / "case" / "front.png").read_bytes() == \
        (tmp_path / "p" / "front.png").read_bytes()
    assert AnnotationSession.open(tmp_path / "p").case_dir == tmp_path / "case"


def test_guidance_hints_reproject_the_remaining_landmarks(tmp_path: Path, photos):
    cams = rig()
    clicks = true_clicks()
    s = AnnotationSession.create(tmp_path / "p")
    for v in VIEW_ORDER:
        s.add_photo(v, photos[v])
    s.set_scale("al_l", "al_r", 33.0)
    for v in ("front", "bottom"):
        for i in CLICK_ORDER[v]:
            s.place(v, i, clicks[v][i])
    g = s.guidance()
    assert not g.cameras and "Hints start" not in g.message   # g seen in one photo only
    for i in CLICK_ORDER["left"][:6]:                          # g n k r prn c
        s.place("left", i, clicks["left"][i])
    g = s.guidance()
    assert {"front", "bottom", "left"} <= set(g.cameras), g.message
    hints = g.hints("left", set(s.clicks["left"]))
    todo = [i for i in CLICK_ORDER["left"][6:] if i in clicks["left"]]
    assert set(todo) <= set(hints)
    err = {i: np.linalg.norm(hints[i] - clicks["left"][i]) for i in todo}
    two_views = [i for i in todo if i in clicks["bottom"]]       # triangulated: exact
    assert two_views and max(err[i] for i in two_views) < 1.0, err
    assert max(err.values()) < 0.02 * SIZE, err                  # mf_l, int_l: symmetry
    # the right photo is placed by resection after four clicks
    for i in CLICK_ORDER["right"][:4]:
        s.place("right", i, clicks["right"][i])
    g = s.guidance()
    hints = g.hints("right", set(s.clicks["right"]))
    for i in ("prn", "al_r", "mf_r"):
        assert np.linalg.norm(hints[i] - clicks["right"][i]) < 0.03 * SIZE, i
    assert cams["right"].width == SIZE


def test_guidance_asks_for_mf_in_a_profile_without_blocking_reconstruct(tmp_path: Path,
                                                                         photos):
    """mf clicked in the front photo only (hidden in the profiles): the hints ask for it in
    the profile where it shows; Reconstruct is not blocked (issue 23 item 5)."""
    clicks = true_clicks()
    hidden = {v: {i: p for i, p in c.items() if not (v in ("left", "right") and
                                                     i.startswith("mf"))}
              for v, c in clicks.items()}
    s = AnnotationSession.create(tmp_path / "p")
    for v in VIEW_ORDER:
        s.add_photo(v, photos[v])
    s.set_scale("al_l", "al_r", 33.0)
    annotate_all(s, hidden)
    assert s.problems() == []                                   # ready to reconstruct
    notes = s.guidance().notes
    assert len(notes) == 2
    assert notes[0].startswith("mf_l is clicked in the front photo only: click it in the "
                               "left profile too")
    assert "radix height is only an estimate" in notes[0] and "mf_r" in notes[1]
    s.place("left", "mf_l", clicks["left"]["mf_l"])             # clicked there: asked no more
    notes = s.guidance().notes
    assert [n[:4] for n in notes] == ["mf_r"]
