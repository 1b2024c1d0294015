"""The optional oblique photos of a case (issue 24, SPEC §2-3 extended): four photos are a
valid case as before, five or six are read in SPEC order, and a malformed oblique view is
a one-line error naming the file, the key and the fix."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from naseview.case import read_case, write_case
from naseview.errors import NaseviewError
from naseview.imagefile import write_image
from naseview.landmarks import ALL_VIEWS, OBLIQUE_VIEWS, VIEW_LANDMARKS, VIEWS


def _case_dir(root: Path, obliques: dict[str, object]) -> Path:
    """A small case directory with the four photos and the given oblique entries (each
    photo a 64 x 80 grey PNG)."""
    root.mkdir(parents=True, exist_ok=True)
    img = np.full((64, 80, 3), 200, np.uint8)
    for v in ALL_VIEWS:
        write_image(root / f"{v}.png", img)
    views: dict[str, object] = {v: {"image": f"{v}.png", "landmarks": {}} for v in VIEWS}
    views["front"] = {"image": "front.png", "landmarks": {"g": [40.0, 10.0]}}
    views.update(obliques)
    obj = {"format": "naseview.case/1", "id": "o", "views": views,
           "scale_mm": {"al_l-al_r": 34.5}}
    (root / "case.json").write_text(json.dumps(obj))
    return root


def test_four_five_and_six_photos_read_in_spec_order(tmp_path: Path) -> None:
    four = read_case(_case_dir(tmp_path / "4", {}))
    assert tuple(four.views) == VIEWS
    five = read_case(_case_dir(tmp_path / "5", {"oblique_right": {
        "image": "oblique_right.png", "landmarks": {"mf_l": [30.0, 20.0]}}}))
    assert tuple(five.views) == (*VIEWS, "oblique_right")
    np.testing.assert_allclose(five.views["oblique_right"].landmarks["mf_l"], [30.0, 20.0])
    six = read_case(_case_dir(tmp_path / "6", {v: {"image": f"{v}.png", "landmarks": {}}
                                               for v in reversed(OBLIQUE_VIEWS)}))
    assert tuple(six.views) == ALL_VIEWS
    # a null oblique is an absent one
    assert tuple(read_case(_case_dir(tmp_path / "n", {"oblique_left": None})).views) == VIEWS


def test_six_photo_case_writes_and_reads_back(tmp_path: Path) -> None:
    case = read_case(_case_dir(tmp_path / "a", {v: {"image": f"{v}.png", "landmarks": {
        "n": [41.0, 12.5]}} for v in OBLIQUE_VIEWS}))
    write_case(case, tmp_path / "b")
    again = read_case(tmp_path / "b")
    assert tuple(again.views) == ALL_VIEWS
    np.testing.assert_allclose(again.views["oblique_left"].landmarks["n"], [41.0, 12.5])


@pytest.mark.parametrize(
    ("entry", "key", "fix"),
    [
        ("oblique_left.png", "'views.oblique_left'", "leave this optional oblique view out"),
        ({"landmarks": {}}, "'views.oblique_left.image'", "file name"),
        ({"image": "missing.png"}, "'views.oblique_left.image'", "put it next to case.json"),
        ({"image": "oblique_left.png", "landmarks": {"nose": [1.0, 2.0]}},
         "'views.oblique_left.landmarks.nose'", "known ids"),
        ({"image": "oblique_left.png", "landmarks": {"g": [500.0, 2.0]}},
         "'views.oblique_left.landmarks.g'", "re-click it inside the photo"),
        ({"image": "oblique_left.png", "camera": {"focal_px": "wide"}},
         "'views.oblique_left.camera.focal_px'", "focal length in pixels"),
    ],
)
def test_malformed_oblique_is_one_line_naming_file_key_and_fix(
        tmp_path: Path, entry: object, key: str, fix: str) -> None:
    root = _case_dir(tmp_path / "c", {"oblique_left": entry})
    with pytest.raises(NaseviewError) as e:
        read_case(root)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(str(root / "case.json")) and key in msg and fix in msg


def test_oblique_views_show_their_side() -> None:
    # the near side's sidewall and alar groove, and both medial canthi
    assert {"int_l", "ac_l", "mf_l", "mf_r"} <= set(VIEW_LANDMARKS["oblique_left"])
    assert {"int_r", "ac_r", "mf_r", "mf_l"} <= set(VIEW_LANDMARKS["oblique_right"])
    assert "int_r" not in VIEW_LANDMARKS["oblique_left"]
    assert "int_l" not in VIEW_LANDMARKS["oblique_right"]
