"""The consultation report is written into the patient's own folder, never out of the
work folder through a symbolic link (the full report embeds the photos)."""

from __future__ import annotations

import pytest
from helpers import open_tab

from naseview.errors import NaseviewError


def test_report_is_never_written_through_a_link_out_of_the_work_folder(ict_app, tmp_path):
    server, app, tabs = ict_app
    tab, screen = open_tab(server, app)
    tabs.append(tab)
    outside = tmp_path / "outside"
    outside.mkdir()
    patient = app.work_dir / "ict-mean"
    patient.mkdir(parents=True)
    (patient / "report").symlink_to(outside, target_is_directory=True)
    with pytest.raises(NaseviewError, match="symbolic link"):
        screen.patient.write_report(deidentified=False)
    assert list(outside.iterdir()) == []
    (patient / "report").unlink()
    path = screen.patient.write_report(deidentified=False)   # the real folder: written
    assert path.parent == patient / "report" and path.is_file()
