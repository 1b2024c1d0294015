"""The annotation session of a new patient, without a browser.

Click order, photo intake (EXIF orientation, metadata stripped, downscaling, refusals),
place / move / skip / undo, autosave and resume after a "restart", guidance hints from a
quick stage 1, and the case directory it writes (read back with read_case).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from naseview.camera import Camera, look_at
from naseview.case import read_case
from naseview.errors import NaseviewError
from naseview.intake.session import (
    CLICK_ORDER,
    MAX_SIDE_PX,
    VIEW_ORDER,
    AnnotationSession,
    decode_photo,
    describe,
    list_in_progress,
)
from naseview.landmarks import ALL_IDS, CURVE_LANDMARKS, VIEWS

# --------------------------------------------------------------------------- helpers


def jpeg_with_exif(image_bgr: np.ndarray, orientation: int, description: str) -> bytes:
    """A JPEG whose APP1 EXIF segment holds an orientation and an ImageDescription."""
    import cv2

    ok, buf = cv2.imencode(".jpg", image_bgr, [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    jpg = buf.tobytes()
    desc = description.encode("ascii") + b"\x00"
    n = 2
    ifd_size = 2 + 12 * n + 4
    desc_off = 8 + ifd_size
    tiff = b"MM\x00\x2a" + struct.pack(">I", 8) + struct.pack(">H", n)
    tiff += struct.pack(">HHI", 0x010E, 2, len(desc)) + struct.pack(">I", desc_off)
    tiff += struct.pack(">HHI", 0x0112, 3, 1) + struct.pack(">HH", orientation, 0)
    tiff += struct.pack(">I", 0) + desc
    app1 = b"Exif\x00\x00" + tiff
    seg = b"\xff\xe1" + struct.pack(">H", len(app1) + 2) + app1
    return jpg[:2] + seg + jpg[2:]


def png_with_text(image_bgr: np.ndarray, key: str, text: str) -> bytes:
    """A PNG with a tEXt chunk inserted after IHDR."""
    import cv2

    ok, buf = cv2.imencode(".png", image_bgr)
    assert ok
    png = buf.tobytes()
    data = key.encode("latin-1") + b"\x00" + text.encode("latin-1")
    chunk = struct.pack(">I", len(data)) + b"tEXt" + data + struct.pack(
        ">I", zlib.crc32(b"tEXt" + data) & 0xFFFFFFFF)
    ihdr_end = 8 + 8 + 13 + 4
    return png[:ihdr_end] + chunk + png[ihdr_end:]


def png_bytes(image_bgr: np.ndarray) -> bytes:
    import cv2

    return cv2.imencode(".png", image_bgr)[1].tobytes()


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


# --------------------------------------------------------------------------- order


def test_click_order_follows_the_curves():
    assert set(VIEW_ORDER) == set(VIEWS)
    assert {i for ids in CLICK_ORDER.values() for i in ids} == set(ALL_IDS)
    mid = CURVE_LANDMARKS["mid"]
    for v in ("front", "left", "right"):
        assert CLICK_ORDER[v][:len(mid)] == mid, v        # down the mid-curve first
    bottom = [i for i in CLICK_ORDER["bottom"] if i in CURVE_LANDMARKS["bottom"]]
    assert tuple(bottom) == CURVE_LANDMARKS["bottom"]    # the bottom curve end to end
    assert CLICK_ORDER["bottom"][:len(bottom)] == CURVE_LANDMARKS["bottom"]
    for side in ("l", "r"):                              # ala- then side-curve, in a row
        order = CLICK_ORDER["left" if side == "l" else "right"]
        seq = [f"ac_{side}", f"al_{side}", f"int_{side}", f"mf_{side}"]
        i = order.index(seq[0])
        assert list(order[i:i + 4]) == seq
    assert all(i.startswith("add") is False for v in ("front", "left", "right")
               for i in CLICK_ORDER[v])                  # helpers only in the bottom view
    for lid in ALL_IDS:
        text = describe(lid, "front")
        assert "\n" not in text and lid in text and len(text) < 160


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


# --------------------------------------------------------------------------- photos


def test_exif_orientation_applied_and_metadata_stripped(tmp_path: Path):
    img = np.zeros((120, 200, 3), np.uint8)
    img[:, :100] = (0, 0, 255)                       # left half red (BGR)
    data = jpeg_with_exif(img, 6, "Patient Jane Doe, born 1970")
    assert b"Jane Doe" in data
    s = AnnotationSession.create(tmp_path / "p")
    info = s.add_photo("front", data, "IMG_0001.JPG")
    # orientation 6: rotate 90 degrees clockwise -> 120 wide, 200 high, red on top
    assert (info.width, info.height) == (120, 200)
    stored = (tmp_path / "p" / info.file).read_bytes()
    assert info.file == "front.jpg"
    assert b"Jane Doe" not in stored and b"Exif" not in stored
    got = s.image("front")
    assert got.shape == (200, 120, 3)
    assert got[20, 60, 2] > 200 and got[20, 60, 0] < 60      # top is red
    assert got[180, 60, 2] < 60                               # bottom is black
    # a PNG's text chunks are dropped as well; PNG stays PNG (lossless)
    png = png_with_text(img, "Author", "Dr Who, patient Jane Doe")
    info = s.add_photo("left", png)
    stored = (tmp_path / "p" / info.file).read_bytes()
    assert info.file == "left.png" and b"Jane Doe" not in stored and b"tEXt" not in stored
    np.testing.assert_array_equal(s.image("left"), img)
    # nothing identifying in the autosave either
    assert b"IMG_0001" not in (tmp_path / "p" / "annotation.json").read_bytes()


def test_huge_photo_is_downscaled_and_clicks_are_in_stored_pixels(tmp_path: Path):
    big = np.full((1800, 3000, 3), 128, np.uint8)
    big[:, :1500] = 30
    s = AnnotationSession.create(tmp_path / "p")
    info = s.add_photo("front", png_bytes(big))
    assert info.downscaled and max(info.width, info.height) == MAX_SIDE_PX
    assert (info.original_width, info.original_height) == (3000, 1800)
    assert (info.width, info.height) == (2048, 1229)
    s.place("front", "g", (2047.0, 1228.0))
    with pytest.raises(NaseviewError, match="outside"):
        s.place("front", "n", (2100.0, 10.0))
    img, orig = decode_photo(png_bytes(big), max_side=1000)
    assert img.shape == (600, 1000, 3) and orig == (3000, 1800)


@pytest.mark.parametrize("data, match", [
    (b"", "empty"),
    (b"hello, this is a text file\n" * 10, "not a JPEG or PNG"),
    (b"\x00\x00\x00\x18ftypheic" + b"\x00" * 64, "HEIC"),
    (b"\xff\xd8\xff\xe0" + b"\x00" * 100, "damaged"),
])
def test_not_an_image_gives_one_line_and_changes_nothing(tmp_path: Path, data, match):
    s = AnnotationSession.create(tmp_path / "p")
    with pytest.raises(NaseviewError, match=match) as e:
        s.add_photo("bottom", data, "notes.txt")
    assert "\n" not in str(e.value) and "bottom" in str(e.value)
    assert "bottom" not in s.photos
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == ["annotation.json"]


# --------------------------------------------------------------------------- autosave


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
    [(found, meta)] = list_in_progress(tmp_path / "in-progress")
    assert found == folder and meta["id"] == "p7"
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


# --------------------------------------------------------------------------- case + hints


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
