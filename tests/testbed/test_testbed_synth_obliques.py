"""``naseview synth --views ...`` with the oblique photos (issue 24): the four photos,
their clicks and the truth are those of the four-photo case of the same seed; each
oblique camera stands about 45 degrees towards its side; clicks only where visible."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from naseview.case import read_case
from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.facemodel import load_face_model
from naseview.landmarks import ALL_VIEWS, VIEW_LANDMARKS, VIEWS
from naseview.reconstruction import read_reconstruction
from naseview.testbed.sheet import LEGEND_H, contact_sheet
from naseview.testbed.synth import synthesize_case
from naseview.testbed.synth.rig import parse_views

SIZE = 320


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The same generic case (seed 4) with four and with six photos."""
    model = load_face_model("generic")
    root = tmp_path_factory.mktemp("obliques")
    synthesize_case(root / "four", model, seed=4, size=SIZE)
    synthesize_case(root / "six", model, seed=4, size=SIZE, views=ALL_VIEWS)
    return root / "four", root / "six"


def test_four_photos_unchanged_by_the_obliques(pair: tuple[Path, Path]) -> None:
    four, six = pair
    a, b = json.loads((four / "case.json").read_text()), json.loads((six / "case.json").read_text())
    assert list(a["views"]) == list(VIEWS) and list(b["views"]) == list(ALL_VIEWS)
    for v in VIEWS:
        assert a["views"][v] == b["views"][v], v
        assert (four / f"{v}.jpg").read_bytes() == (six / f"{v}.jpg").read_bytes(), v
    ta, tb = read_reconstruction(four / "truth.json"), read_reconstruction(six / "truth.json")
    for v in VIEWS:
        np.testing.assert_array_equal(ta.cameras[v].R, tb.cameras[v].R)
        np.testing.assert_array_equal(ta.cameras[v].t, tb.cameras[v].t)
    assert set(tb.cameras) == set(ALL_VIEWS)


def test_oblique_cameras_stand_45_degrees_towards_their_side(pair: tuple[Path, Path]) -> None:
    truth = read_reconstruction(pair[1] / "truth.json")
    front = truth.cameras["front"]
    for v, side in (("oblique_left", 1.0), ("oblique_right", -1.0)):
        cam = truth.cameras[v]
        angle = np.degrees(np.arccos(np.clip(cam.R[2] @ front.R[2], -1.0, 1.0)))
        assert 45.0 - 14.0 < angle < 45.0 + 14.0, (v, angle)
        assert side * cam.center[0] > 100.0, v          # on the subject's left / right (mm)
        assert cam.focal_px == pytest.approx(front.focal_px)   # one phone


def test_oblique_clicks_only_where_visible(pair: tuple[Path, Path]) -> None:
    case = read_case(pair[1])
    truth = read_reconstruction(pair[1] / "truth.json")
    for v, near in (("oblique_left", "l"), ("oblique_right", "r")):
        clicks = case.views[v].landmarks
        assert set(clicks) <= set(VIEW_LANDMARKS[v])
        # the nasal root and the near alar crease show
        assert {"n", "prn", f"mf_{near}", f"ac_{near}"} <= set(clicks), v
        for lid, uv in clicks.items():   # 1.5 px noise: within 8 px of the true projection
            assert np.linalg.norm(truth.cameras[v].project(truth.landmarks[lid])[0] - uv) < 8.0


def test_five_photos_and_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "five"
    assert main(["synth", str(out), "--model", "generic", "--seed", "2", "--size", "256",
                 "--views", "oblique_right,front,left,right,bottom"]) == 0
    case = read_case(out)
    assert tuple(case.views) == (*VIEWS, "oblique_right")
    assert "--views front,left,right,bottom,oblique_right" in case.notes


@pytest.mark.parametrize(("text", "needle"), [
    ("front,left,right,bottom,oblique", "unknown view 'oblique'"),
    ("front,left,oblique_left", "right, bottom missing"),
])
def test_bad_views_are_one_line_errors(text: str, needle: str) -> None:
    with pytest.raises(NaseviewError, match=needle):
        parse_views(text)


def test_contact_sheet_shows_the_obliques_in_a_third_row(pair: tuple[Path, Path]) -> None:
    four, six = (contact_sheet(read_case(d), tile=160) for d in pair)
    assert four.shape[1] == six.shape[1] == 320
    assert six.shape[0] - four.shape[0] == (four.shape[0] - LEGEND_H) // 2   # one row more
