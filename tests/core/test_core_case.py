"""Case directories (SPEC §3): every bad input gives a one-line error and writes nothing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import write_projected_case

from naseview.case import read_case, write_case
from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_json
from naseview.imagefile import write_image


def _make_case(root: Path, **overrides: object) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    img = np.full((64, 80, 3), 200, np.uint8)
    for v in ("front", "left", "right", "bottom"):
        write_image(root / f"{v}.png", img)
    obj: dict = {
        "format": "naseview.case/1",
        "id": "t1",
        "views": {
            "front": {"image": "front.png", "landmarks": {"g": [40.0, 10.0], "prn": [40, 40]}},
            "left": {"image": "left.png", "landmarks": {}},
            "right": {"image": "right.png", "landmarks": {"prn": [20.5, 30.0]}},
            "bottom": {"image": "bottom.png", "landmarks": {"add_l": [10.0, 12.0]}},
        },
        "scale_mm": {"al_l-al_r": 34.5},
    }
    obj.update(overrides)
    (root / "case.json").write_text(json.dumps(obj))
    return root


def test_valid_case_reads(tmp_path: Path) -> None:
    case = read_case(_make_case(tmp_path / "c"))
    assert case.id == "t1"
    assert case.views["front"].width == 80 and case.views["front"].height == 64
    np.testing.assert_allclose(case.views["front"].landmarks["prn"], [40, 40])
    assert case.scale_mm == {("al_l", "al_r"): 34.5}
    # helper clicks are kept but never counted as observations of the 21 landmarks
    assert ("bottom", "add_l") not in {(v, i) for v, i, _ in case.observations()}


def _views_with(view: str, **entry: object) -> dict:
    views = {v: {"image": f"{v}.png", "landmarks": {}} for v in
             ("front", "left", "right", "bottom")}
    views[view].update(entry)
    return views


@pytest.mark.parametrize(
    ("overrides", "needle"),
    [
        ({"format": "other/1"}, "'format'"),
        ({"views": {"front": {"image": "front.png"}}}, "views.left"),
        ({"views": _views_with("front", landmarks={"nose": [1, 2]})},
         "views.front.landmarks.nose"),
        ({"views": _views_with("left", landmarks={"prn": [500.0, 10.0]})}, "outside"),
        ({"views": _views_with("left", landmarks={"prn": [1.0]})}, "[x, y]"),
        ({"views": _views_with("bottom", image="missing.jpg")}, "missing.jpg"),
        ({"scale_mm": {}}, "scale_mm"),
        ({"scale_mm": {"al_l-al_l": 30}}, "scale_mm.al_l-al_l"),
        ({"scale_mm": {"al_l-al_r": -3}}, "positive"),
        ({"views": _views_with("front", camera={"focal_px": -1})}, "focal_px"),
    ],
)
def test_bad_case_one_line_error(tmp_path: Path, overrides: dict, needle: str) -> None:
    root = _make_case(tmp_path / "c", **overrides)
    with pytest.raises(NaseviewError) as e:
        read_case(root)
    msg = str(e.value)
    assert "\n" not in msg
    assert "case.json" in msg or "missing.jpg" in msg
    assert needle in msg


def test_corrupt_image_and_json(tmp_path: Path) -> None:
    root = _make_case(tmp_path / "c")
    (root / "left.png").write_bytes(b"not an image")
    with pytest.raises(NaseviewError, match=r"left\.png: not a readable"):
        read_case(root)
    (root / "case.json").write_text("{ broken")
    with pytest.raises(NaseviewError, match=r"case\.json: invalid JSON at line 1"):
        read_case(root)


def test_cli_prints_one_line_and_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         ) -> None:
    root = _make_case(tmp_path / "c", scale_mm={})
    out = tmp_path / "out"
    assert main(["reconstruct", str(root), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("naseview: error:") and "scale_mm" in err and "\n" not in err
    assert not out.exists()  # nothing written


def test_write_case_roundtrip_and_atomic(tmp_path: Path) -> None:
    case = read_case(_make_case(tmp_path / "c"))
    out = tmp_path / "copy"
    write_case(case, out)
    again = read_case(out)
    assert again.to_json() == case.to_json()
    assert not list(out.glob("*.tmp")) and not list(out.glob(".*"))
    # a failing write leaves the previous file intact
    before = (out / "case.json").read_bytes()
    with pytest.raises(TypeError):
        atomic_write_json(out / "case.json", {"bad": object()})
    assert (out / "case.json").read_bytes() == before


def test_write_case_validates_before_writing(tmp_path: Path) -> None:
    case = read_case(_make_case(tmp_path / "c"))
    case.views["front"].landmarks["bogus"] = np.array([1.0, 2.0])
    out = tmp_path / "copy"
    with pytest.raises(NaseviewError, match="bogus"):
        write_case(case, out)
    assert not out.exists()


@pytest.mark.parametrize("where", ["absolute", "dotdot", "symlink"])
def test_case_photo_outside_the_case_folder_is_refused(tmp_path: Path, where: str) -> None:
    other = tmp_path / "other-patient"
    other.mkdir()
    write_image(other / "front.png", np.full((64, 80, 3), 90, np.uint8))  # a real photo
    root = tmp_path / "c"
    image = {"absolute": str(other / "front.png"), "dotdot": "../other-patient/front.png",
             "symlink": "link/front.png"}[where]
    _make_case(root, views=_views_with("front", image=image))
    (root / "link").symlink_to(other)
    with pytest.raises(NaseviewError) as e:
        read_case(root)
    msg = str(e.value)
    assert "\n" not in msg and "case.json" in msg and "views.front.image" in msg
    assert "absolute" in msg if where == "absolute" else "outside" in msg


def test_case_photo_in_a_subfolder_is_fine(tmp_path: Path) -> None:
    root = _make_case(tmp_path / "c", views=_views_with("front", image="photos/front.png"))
    write_image(root / "photos" / "front.png", np.full((64, 80, 3), 90, np.uint8))
    assert read_case(root).image_path("front").is_file()


def test_scale_out_of_range_states_the_accepted_range(tmp_path: Path) -> None:
    root = _make_case(tmp_path / "c", scale_mm={"al_l-al_r": 5000})
    with pytest.raises(NaseviewError) as e:
        read_case(root)
    msg = str(e.value)
    assert "scale_mm.al_l-al_r" in msg and "5000" in msg and "(0, 500)" in msg


def test_case_json_key_twice_is_named_and_bom_is_accepted(tmp_path: Path) -> None:
    root = _make_case(tmp_path / "c")
    text = (root / "case.json").read_text()
    (root / "case.json").write_bytes(b"\xef\xbb\xbf" + text.encode())   # Notepad's BOM
    assert read_case(root).id == "t1"
    (root / "case.json").write_text(text.replace('"prn": [40, 40]',
                                                 '"prn": [40, 40], "prn": [41, 41]'))
    with pytest.raises(NaseviewError) as e:
        read_case(root)
    assert "case.json" in str(e.value) and "'prn'" in str(e.value)


def test_image_path_that_goes_down_and_back_up_is_named_before_any_work(tmp_path: Path):
    """``left.jpg/../left.jpg`` names the key at reading, not a misleading "not found"."""
    case_dir = write_projected_case(tmp_path / "case", seed=83)
    obj = json.loads((case_dir / "case.json").read_text())
    obj["views"]["left"]["image"] = f"{obj['views']['left']['image']}/../x"
    (case_dir / "case.json").write_text(json.dumps(obj))
    with pytest.raises(NaseviewError, match=r"views\.left\.image.*'\.\.'"):
        read_case(case_dir)
