"""What a report may contain: the de-identified version carries no id, name, date or path
anywhere (title, headings, alt text, PNGs, file names); photos come only from a case folder
that lies where the session / output says it may; a report is written all or nothing."""

from __future__ import annotations

import errno
import json
import os
import re
import struct
from pathlib import Path

import numpy as np
import pytest
from helpers import write_projected_case

from naseview.cli import main
from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController
from naseview.editing.session import save_session
from naseview.errors import NaseviewError
from naseview.measurements import clinical_measurements
from naseview.pipeline import PipelineResult, write_outputs
from naseview.reconstruction import Reconstruction
from naseview.report import ReportData, write_report

CASE_ID = "PATIENT_DOE_J_0042"
PATIENT_FOLDER = "Jane_Doe_19700101"
OUT_FOLDER = "out_Doe_consult"
DATE = re.compile(rb"(19|20)\d\d[-/.]\d\d[-/.]\d\d|\d\d[-/.]\d\d[-/.](19|20)\d\d")


def _bump_face(n: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """A height field with a nose-like bump (mm, SPEC frame)."""
    xs, ys = np.meshgrid(np.linspace(-50, 50, n), np.linspace(-90, 20, n))
    Z = 22.0 * np.exp(-(xs**2) / 120.0 - (ys + 40) ** 2 / 500.0)
    V = np.column_stack([xs.ravel(), ys.ravel(), Z.ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.column_stack([a.ravel(), c.ravel(), b.ravel()]),
                   np.column_stack([b.ravel(), c.ravel(), d.ravel()])])
    nose = np.flatnonzero((np.abs(V[:, 0]) < 20) & (V[:, 1] < -10) & (V[:, 1] > -70))

    def at(x: float, y: float) -> np.ndarray:
        return V[int(np.argmin((V[:, 0] - x) ** 2 + (V[:, 1] - y) ** 2))].copy()

    lms = {"g": at(0, 0), "n": at(0, -12), "prn": at(0, -42), "sn": at(0, -58),
           "al_l": at(16, -45), "al_r": at(-16, -45)}
    return V, F, nose, lms


@pytest.fixture(scope="module")
def patient(tmp_path_factory) -> Path:
    """<tmp>/Jane_Doe_19700101/out_Doe_consult/: the output of a reconstruction of the
    case in its subfolder ``case`` (with photos)."""
    root = tmp_path_factory.mktemp("privacy") / PATIENT_FOLDER
    case = write_projected_case(root / OUT_FOLDER / "case", seed=83)
    obj = json.loads((case / "case.json").read_text())
    obj["id"], obj["notes"] = CASE_ID, f"seen on 2024-03-05 by Dr X about {CASE_ID}"
    (case / "case.json").write_text(json.dumps(obj))
    V, F, nose, lms = _bump_face()
    rec = Reconstruction(landmarks=lms, measurements=clinical_measurements(lms),
                         extra={"mesh": {"credit": "test face"}})
    write_outputs(PipelineResult(reconstruction=rec, face_vertices=V, faces=F,
                                 nose_vertex_ids=nose, case_root=case), root / OUT_FOLDER)
    return root


def _png_chunks(data: bytes) -> list[bytes]:
    out, i = [], 8
    while i < len(data):
        n = struct.unpack(">I", data[i:i + 4])[0]
        out.append(data[i + 4:i + 8])
        i += 12 + n
    return out


def test_the_deidentified_report_names_no_id_no_date_and_no_path(patient: Path):
    out = patient / OUT_FOLDER
    assert main(["report", str(out), "--deidentified"]) == 0
    assert main(["report", str(out)]) == 0                 # the full report, for contrast
    full = (out / "report.html").read_bytes()
    assert CASE_ID.encode() in full and DATE.search(full)      # the full one does name them
    assert OUT_FOLDER.encode() not in full                     # the case id, not the folder
    assert (out / "report-photos.png").is_file()
    written = sorted(p for p in out.iterdir() if "deidentified" in p.name)
    assert [p.name for p in written] == ["report-deidentified-measurements.png",
                                         "report-deidentified-views.png",
                                         "report-deidentified.html"]
    html = (out / "report-deidentified.html").read_bytes()
    text = re.sub(rb"data:image/png;base64,[A-Za-z0-9+/=]+", b"", html)
    for p in written:
        data = text if p.suffix == ".html" else p.read_bytes()
        short = ("Doe",) if p.suffix == ".html" else ()   # 3 bytes may occur in pixels
        for needle in (CASE_ID, PATIENT_FOLDER, OUT_FOLDER, str(patient), *short):
            assert needle.encode() not in data, f"{needle!r} in {p.name}"
            assert needle not in p.name
        assert not DATE.search(data), f"a date in {p.name}"
        if p.suffix == ".png":                             # pixels only, no text chunks
            assert set(_png_chunks(data)) <= {b"IHDR", b"PLTE", b"IDAT", b"IEND"}
    assert b"<title>" in text and b"alt='" in text         # what was searched is there


def test_the_output_stores_its_case_folder_relative_and_no_absolute_path(patient: Path):
    text = (patient / OUT_FOLDER / "reconstruction.json").read_text()
    assert json.loads(text)["case_dir"] == "case"
    assert str(patient) not in text and PATIENT_FOLDER not in text


def test_a_hand_edited_case_folder_cannot_pull_in_another_patients_photos(
        patient: Path, tmp_path: Path, capsys):
    other = write_projected_case(tmp_path / "other-patient", seed=84)
    out = tmp_path / "out"
    src = patient / OUT_FOLDER
    out.mkdir()
    (out / "link").symlink_to(other)
    for name in ("face.ply", "nose.ply"):
        (out / name).write_bytes((src / name).read_bytes())
    for value in (str(other), "../other-patient", "link"):   # absolute, .., symlink
        obj = json.loads((src / "reconstruction.json").read_text())
        obj["case_dir"] = value
        (out / "reconstruction.json").write_text(json.dumps(obj))
        assert main(["report", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "reconstruction.json" in err and "'case_dir'" in err
        assert "outside" in err and "--case" in err
    assert not (out / "report.html").exists()
    assert main(["report", str(out), "--deidentified"]) == 0   # needs no photos at all
    assert main(["report", str(out), "--case", str(other)]) == 0   # chosen explicitly


def test_a_session_cannot_pull_in_another_patients_photos(tmp_path: Path, capsys):
    other = write_projected_case(tmp_path / "other-patient", seed=85)
    folder = tmp_path / "sessions"
    folder.mkdir()
    V, F, nose, lms = _bump_face(20)
    ctl = EditController(Baseline(V, F, nose, lms, measurements=clinical_measurements(lms)),
                         None)
    try:
        path = save_session(folder / "s.json", ctl, {"case_id": "P9"})
    finally:
        ctl.close()
    obj = json.loads(path.read_text())
    obj["app"]["case_dir"] = "../other-patient"
    path.write_text(json.dumps(obj))
    assert main(["report", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "s.json" in err and "'app.case_dir'" in err
    assert not (folder / "report.html").exists()
    assert other.is_dir()


def test_a_report_on_a_full_disk_keeps_the_earlier_report(tmp_path: Path, monkeypatch):
    V, F, nose, lms = _bump_face(20)
    m = clinical_measurements(lms)
    first = write_report(ReportData("A", V, F, nose, m), tmp_path / "r.html", render_size=64)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real, calls = os.fsync, []

    def full_on_the_third(fd: int) -> None:                # the disk fills up mid-report
        calls.append(fd)
        if len(calls) >= 3:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd)

    monkeypatch.setattr(os, "fsync", full_on_the_third)
    with pytest.raises(NaseviewError, match="disk is full.*unchanged"):
        write_report(ReportData("B", V + 1.0, F, nose, m), first, render_size=64)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_the_cli_names_surgeon_clinic_patient_and_prints_a_clean_deidentified_pdf(
        patient: Path):
    from test_report_pdf import chromium_or_fail
    out = patient / OUT_FOLDER
    who = ["--surgeon", "Dr Zed Surgeon", "--clinic", "Clinic Quux",
           "--patient-name", "Jane Doe"]
    assert main(["report", str(out), *who, "-o", str(out / "named.html")]) == 0
    full = (out / "named.html").read_text(encoding="utf-8")
    assert "<title>Nose consultation report — Jane Doe</title>" in full
    assert "Dr Zed Surgeon" in full and "Clinic Quux" in full and CASE_ID in full
    assert "seen on 2024-03-05" in full                    # the notes a person typed
    chromium_or_fail()
    assert main(["report", str(out), "--deidentified", "--pdf", *who,
                 "-o", str(out / "anon-cli.html")]) == 0
    pdf = (out / "anon-cli.pdf").read_bytes()             # beside the HTML
    assert pdf[:5] == b"%PDF-"
    # the page text is the checked HTML's; here the PDF's own plain parts (title, info)
    for needle in ("Zed", "Quux", "Doe", CASE_ID, OUT_FOLDER, str(patient)):
        assert needle.encode() not in pdf, needle
    assert not DATE.search(pdf) and not re.search(rb"/CreationDate\s*\(D:\d", pdf)
