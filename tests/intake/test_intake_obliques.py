"""Issue 24 item 4: the optional oblique photos in a new patient's session: the four
photos alone still make a case; an oblique upload is checked like the others, its guided
clicks start at the nasal root (g, mf) and land in case.json under views.oblique_left."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import png_bytes
from test_intake_session import NOSE, SIZE, annotate_all, true_clicks

from naseview.camera import look_at
from naseview.errors import NaseviewError
from naseview.intake.click_order import CLICK_ORDER, PHOTO_ORDER, VIEW_ORDER
from naseview.intake.session import AnnotationSession
from naseview.landmarks import ALL_VIEWS, VIEW_LANDMARKS


def oblique_clicks() -> dict[str, np.ndarray]:
    target = np.array([0.0, -32.0, 0.0])
    d = np.array([0.7, 0.0, 0.7]) / np.linalg.norm([0.7, 0.0, 0.7])
    cam = look_at(target + 400.0 * d, target, (0, 1.0, 0), 2000.0, SIZE, SIZE)
    ids = list(VIEW_LANDMARKS["oblique_left"])
    uv = cam.project(np.array([NOSE[i] for i in ids]))
    return {i: uv[k] for k, i in enumerate(ids)}


def test_the_oblique_click_order_starts_at_the_nasal_root():
    assert PHOTO_ORDER == VIEW_ORDER + ("oblique_left", "oblique_right")
    for v in ("oblique_left", "oblique_right"):
        assert CLICK_ORDER[v][:3] in (("g", "mf_l", "mf_r"), ("g", "mf_r", "mf_l"))
        assert set(CLICK_ORDER[v]) == set(VIEW_LANDMARKS[v])


def test_an_oblique_upload_is_optional_checked_and_written(tmp_path: Path):
    rng = np.random.default_rng(0)
    img = rng.integers(90, 160, (SIZE, SIZE, 3)).astype(np.uint8)
    s = AnnotationSession.create(tmp_path / "p", "obl-1")
    with pytest.raises(NaseviewError, match="oblique_left"):
        s.add_photo("oblique_left", b"not a photo")          # the same photo checks
    for v in VIEW_ORDER:
        s.add_photo(v, png_bytes(img))
    clicks = true_clicks()
    annotate_all(s, clicks)
    s.set_scale("al_l", "al_r", 33.0)
    assert s.problems() == [] and s.missing_photos() == []   # four photos: a case
    assert s.progress()[1] == sum(len(CLICK_ORDER[v]) for v in VIEW_ORDER)
    s.add_photo("oblique_left", png_bytes(img))
    assert s.next_target() == ("oblique_left", "g")
    ob = oblique_clicks()
    clicks["oblique_left"] = ob
    annotate_all(s, clicks)
    assert s.problems() == []
    path = s.write_case(tmp_path / "case")
    views = json.loads(path.read_text())["views"]
    assert set(views) == set(VIEW_ORDER) | {"oblique_left"}
    written = views["oblique_left"]["landmarks"]
    assert set(written) == set(ob)
    np.testing.assert_allclose(written["mf_l"], ob["mf_l"], atol=1e-6)
    reopened = AnnotationSession.open(tmp_path / "p")          # autosaved with the oblique
    assert set(reopened.clicks["oblique_left"]) == set(ob)
    assert "oblique_right" in ALL_VIEWS and "oblique_right" not in reopened.photos
