"""A hand-edited or damaged ``annotation.json`` is refused on resume with one line naming
the file and the key (issue 12, finding 7 for the intake autosave): ids in range, finite
numbers inside the photo, photo paths inside the in-progress folder."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import png_bytes

from naseview.errors import NaseviewError
from naseview.intake.in_progress import list_in_progress
from naseview.intake.session import AnnotationSession

Edit = Callable[[dict[str, Any], Path], None]
BIG = "<1e999>"
"""Written as the JSON number ``1e999``, which Python reads as infinity."""


@pytest.fixture()
def saved(tmp_path: Path) -> Path:
    """An in-progress folder: front and bottom photos, clicks, a skip, undo history,
    distances, its case written next to it."""
    folder = tmp_path / "work" / "in-progress" / "p1"
    s = AnnotationSession.create(folder, "p1")
    s.add_photo("front", png_bytes(np.full((300, 200, 3), 90, np.uint8)))
    s.add_photo("bottom", png_bytes(np.full((200, 200, 3), 140, np.uint8)))
    s.place("front", "g", (100.0, 40.0))
    s.place("front", "n", (100.0, 80.0))
    s.skip("front", "k")
    s.place("bottom", "prn", (100.0, 100.0))
    s.set_scale("al_l", "al_r", 33.0)
    return folder


def edit(fn: Callable[[dict[str, Any]], object]) -> Edit:
    return lambda obj, folder: fn(obj) and None


def symlink_out(obj: dict[str, Any], folder: Path) -> None:
    outside = folder.parent.parent.parent / "elsewhere.png"
    outside.write_bytes((folder / obj["photos"]["front"]["file"]).read_bytes())
    (folder / "front-7.png").symlink_to(outside)
    obj["photos"]["front"]["file"] = "front-7.png"


HAND_EDITS: dict[str, tuple[Edit, str]] = {
    "id with a path": (edit(lambda o: o.update(id="../../P001")), "'id'"),
    "id not a string": (edit(lambda o: o.update(id=7)), "'id'"),
    "photo outside the folder": (
        edit(lambda o: o["photos"]["front"].update(file="../p2/front.png")),
        "'photos.front.file'"),
    "absolute photo path": (
        edit(lambda o: o["photos"]["front"].update(file="/etc/passwd")),
        "'photos.front.file'"),
    "photo symlinked out of the folder": (symlink_out, "'photos.front.file'"),
    "two views, one file": (
        edit(lambda o: o["photos"]["bottom"].update(file=o["photos"]["front"]["file"])),
        "'photos.bottom.file'"),
    "negative width": (edit(lambda o: o["photos"]["front"].update(width=-5)),
                       "'photos.front.width'"),
    "width not the photo's": (edit(lambda o: o["photos"]["front"].update(width=250)),
                              "'photos.front.width'"),
    "unknown view": (edit(lambda o: o["photos"].update(top=o["photos"]["front"])),
                     "'photos.top'"),
    "unknown landmark id": (edit(lambda o: o["clicks"]["front"].update(zz=[1.0, 1.0])),
                            "'clicks.front.zz'"),
    "landmark of another photo": (
        edit(lambda o: o["clicks"]["front"].update(add_l=[1.0, 1.0])),
        "'clicks.front.add_l'"),
    "infinite click": (edit(lambda o: o["clicks"]["front"].update(g=[BIG, 3.0])),
                       "'clicks.front.g'"),
    "click outside the photo": (edit(lambda o: o["clicks"]["front"].update(g=[5000, 3])),
                                "'clicks.front.g'"),
    "click not a pair": (edit(lambda o: o["clicks"]["front"].update(g="100,40")),
                         "'clicks.front.g'"),
    "clicks on a photo not uploaded": (
        edit(lambda o: o["clicks"].update(left={"g": [1.0, 1.0]})), "'clicks.left'"),
    "skipped id out of range": (edit(lambda o: o["skipped"].update(front=["k", "x"])),
                                "'skipped.front'"),
    "negative distance": (edit(lambda o: o["scale_mm"].update({"al_l-al_r": -3})),
                          "'scale_mm.al_l-al_r'"),
    "distance of unknown ids": (edit(lambda o: o["scale_mm"].update({"a-b": 3})),
                                "'scale_mm.a-b'"),
    "undo of an unknown view": (edit(lambda o: o["undo"][0].update(view="top")),
                                "'undo.0.view'"),
    "undo position not finite": (edit(lambda o: o["undo"][1].update(before=[BIG, 1])),
                                 "'undo.1.before'"),
    "undo action unknown": (edit(lambda o: o["undo"][0].update(action="explode")),
                            "'undo.0.action'"),
    "active view unknown": (edit(lambda o: o.update(active_view="top")), "'active_view'"),
    "negative revision": (edit(lambda o: o.update(revision=-1)), "'revision'"),
    "counter not a number": (edit(lambda o: o["stats"].update(places="many")),
                             "'stats.places'"),
    "case folder outside the work folder": (
        edit(lambda o: o.update(case_dir="../../../../etc")), "'case_dir'"),
}


@pytest.mark.parametrize("name", list(HAND_EDITS))
def test_a_hand_edited_annotation_is_refused_naming_file_and_key(saved: Path, name: str):
    change, key = HAND_EDITS[name]
    path = saved / "annotation.json"
    obj = json.loads(path.read_text())
    change(obj, saved)
    path.write_text(json.dumps(obj).replace(json.dumps(BIG), "1e999"))
    with pytest.raises(NaseviewError) as e:
        AnnotationSession.open(saved)
    msg = str(e.value)
    assert msg.startswith(f"{path}: key {key}") and "\n" not in msg, msg
    [listed] = list_in_progress(saved.parent)          # listed as damaged, with the line
    assert listed.problem == msg and listed.case_id == "p1"


def test_the_saved_annotation_resumes_and_keeps_no_absolute_path(saved: Path):
    s = AnnotationSession.open(saved)
    assert s.case_id == "p1" and s.clicks["front"]["g"].tolist() == [100.0, 40.0]
    assert s.skipped["front"] == {"k"} and len(s._undo) == 4
    s.case_dir = saved.parent.parent / "p1" / "case"
    s.save()
    text = (saved / "annotation.json").read_text()
    assert str(saved.parent.parent) not in text
    assert json.loads(text)["case_dir"] == "../../p1/case"
    assert AnnotationSession.open(saved).case_dir == saved.parent.parent / "p1" / "case"
