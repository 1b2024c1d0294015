"""The consultation report and ``naseview report`` as a new user meets them (issue 27
item 5): a missing case folder is warned in one line, an existing report is never
overwritten, the usual ranges are the app's, a change matches the rounded values."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
from test_report import height_field_face

from naseview.app.export import measurements_markdown
from naseview.editing.baseline import Baseline, Solved
from naseview.editing.controller import EditController
from naseview.editing.session import save_session
from naseview.errors import NaseviewError
from naseview.fileio import write_file_set
from naseview.measurements import MEASUREMENT_INFO, clinical_measurements
from naseview.report import (
    RENDER_VIEWS,
    ReportData,
    measurement_rows,
    report_command,
    report_html,
)
from naseview.report.page import OUTLINE_SENTENCE
from naseview.report.table import format_change, format_range
from naseview.report.views import OUTLINE_BGR


def _session(tmp_path: Path) -> Path:
    """A session file of a height-field face with a simulation and no case folder."""
    V, F, nose, lms = height_field_face()
    base = Baseline(V, F, nose, lms, measurements=clinical_measurements(lms))

    def solver(landmarks, interactive=False, **kwargs):
        Vn = V.copy()
        Vn += np.exp(-np.sum((V - lms["prn"]) ** 2, axis=1) / 72.0)[:, None] \
            * (np.asarray(landmarks["prn"]) - lms["prn"])
        return Solved(Vn, {}, np.zeros((0, 3)), clinical_measurements(landmarks))

    ctl = EditController(base, solver)
    try:
        ctl.move_landmarks({"prn": lms["prn"] + np.array([0.0, 2.0, -2.0])})
        assert ctl.wait_idle(20)
        save_session(tmp_path / "s.json", ctl, {"case_id": "case-9"})
    finally:
        ctl.close()
    return tmp_path / "s.json"


def _args(path: Path, output: Path | None = None, deid: bool = False) -> argparse.Namespace:
    return argparse.Namespace(path=path, output=output, deidentified=deid, case=None)


def test_a_report_without_photos_says_so_in_one_line(tmp_path, capsys):
    s = _session(tmp_path)
    assert report_command(_args(s)) == 0
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no photos" in err and "--case" in err
    assert str(s) in err
    assert report_command(_args(s, deid=True)) == 0           # wants none: no warning
    assert capsys.readouterr().err == ""


def test_report_never_overwrites_an_existing_report(tmp_path, capsys):
    s = _session(tmp_path)
    assert report_command(_args(s)) == 0
    first = (tmp_path / "report.html").read_bytes()
    assert report_command(_args(s)) == 0                      # a new name, the first kept
    assert (tmp_path / "report.html").read_bytes() == first
    assert (tmp_path / "report-2.html").is_file() and (tmp_path / "report-2-views.png").is_file()
    assert capsys.readouterr().out.split()[-1] == str(tmp_path / "report-2.html")
    with pytest.raises(NaseviewError, match=r"report\.html: already exists.*another name"):
        report_command(_args(s, output=tmp_path / "report.html"))
    assert (tmp_path / "report.html").read_bytes() == first


def test_a_file_set_that_may_not_overwrite_writes_nothing(tmp_path):
    (tmp_path / "b.png").write_bytes(b"old")
    with pytest.raises(NaseviewError, match="b.png: already exists"):
        write_file_set(tmp_path, {"a.html": b"new", "b.png": b"new"}, overwrite=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.png"]
    assert (tmp_path / "b.png").read_bytes() == b"old"


def test_the_report_shows_the_apps_usual_range():
    # one source of truth: MEASUREMENT_INFO.normal, which the app's table uses
    rows = measurement_rows({k: 1.0 for k in MEASUREMENT_INFO})
    for r in rows:
        info = MEASUREMENT_INFO[r["name"]]
        if info.normal is not None:
            assert r["usual"] == f"usual range {format_range(info.normal, info.unit)}"
    nla = next(r for r in rows if r["name"] == "nasolabial_angle")
    assert nla["usual"] == "usual range 90–120°"


def test_a_change_is_the_difference_of_the_shown_values():
    assert format_change(-1.36, -1.33, "mm") == "+0.1 mm"     # -1.4 -> -1.3 (was +0.0)
    assert format_change(-1.40, -1.42, "mm") == "+0.0 mm"     # both -1.4
    assert format_change(0.561, 0.556, "") == "+0.00"
    assert format_change(10.0, None, "mm") == "—"
    md = measurements_markdown({"nasal_length": -1.36}, {"nasal_length": -1.33})
    assert "| -1.4 | -1.3 | **+0.1** |" in md


def _blue(img: np.ndarray) -> int:
    """Pixels of the outline's blue (BGR 200, 110, 30) in a render."""
    d = np.abs(img.astype(int) - np.array(OUTLINE_BGR)).max(axis=2)
    return int((d < 40).sum())


def test_the_blue_line_is_the_profile_before_and_said_only_there():
    V, F, nose, lms = height_field_face()
    V2 = V + np.exp(-np.sum((V - lms["prn"]) ** 2, axis=1) / 72.0)[:, None] \
        * np.array([0.0, 3.0, -3.0])
    data = ReportData("case-5", V, F, nose, clinical_measurements(lms), V2,
                      clinical_measurements(lms), {})
    text, imgs = report_html(data, render_size=120)
    assert text.count(OUTLINE_SENTENCE) == 1
    assert "outline before" not in text
    pair = text.split("id='pair-left'")[1].split("</section>")[0]
    assert OUTLINE_SENTENCE in pair
    rows = {v: imgs["views"][k * 120:(k + 1) * 120, 120:] for k, v in enumerate(RENDER_VIEWS)}
    assert _blue(rows["left"]) > 20                 # the profile before, in blue
    assert _blue(rows["front"]) == 0 and _blue(rows["base"]) == 0   # no head outline


def _readme_row(command: str) -> str:
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    return next(line for line in readme.splitlines()
                if line.startswith(f"| `naseview {command}"))


def test_the_readme_report_row_names_every_option_of_the_command():
    from naseview.cli import build_parser

    sub = next(a for a in build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    report = sub.choices["report"]
    row = _readme_row("report")
    for action in report._actions:
        if action.option_strings and action.dest != "help":
            assert any(o in row for o in action.option_strings), action.option_strings
    model = _readme_row("model")
    assert "import-ict ../shared/data/ict-face-model" in model and "offline" in model
