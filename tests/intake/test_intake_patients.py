"""One id per patient (issue 12, finding 3): a second new patient typed as "P001" never
replaces the first one's photos, clicks or case; it is asked for another id, and the first
patient can be found to be opened on purpose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import png_bytes

from naseview.case import read_case
from naseview.errors import NaseviewError
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER
from naseview.intake.patients import PatientFolders
from naseview.intake.session import AnnotationSession

SIZE = 256


def ready(s: AnnotationSession, shade: int) -> None:
    """Four photos (one grey ``shade``) and enough clicks for a case: the first eight
    landmarks of each photo on a diagonal, al_l-al_r 33 mm."""
    img = np.full((SIZE, SIZE, 3), shade, np.uint8)
    for v in VIEW_ORDER:
        s.add_photo(v, png_bytes(img))
        for k, lid in enumerate(CLICK_ORDER[v][:8]):
            s.place(v, lid, (20.0 + 25 * k, 30.0 + 20 * k))
    s.set_scale("al_l", "al_r", 33.0)
    assert s.problems() == []


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative name -> bytes)."""
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_an_existing_case_id_is_refused_and_the_first_patient_is_untouched(tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    first = work.new_session("P001")
    ready(first, 100)
    first.write_case(work.case_dir("P001"))
    before = snapshot(work.patient_dir("P001"))

    second = work.new_session()
    assert second.folder != first.folder and second.case_id != "P001"
    ready(second, 200)
    for typed in ("P001", " P001 ", "p001"):          # same id, as typed or in other case
        with pytest.raises(NaseviewError) as e:
            work.rename(second, typed)
        msg = str(e.value)
        assert "\n" not in msg and "already used by another patient" in msg
        assert "choose a different id" in msg and str(work.patient_dir("P001")) in msg
    assert second.case_id != "P001"
    with pytest.raises(NaseviewError, match="already used"):
        work.new_session("P001")

    # the first patient is found, to be opened on purpose
    found = work.find("P001")
    assert found is not None and found.case_dir == work.case_dir("P001")
    assert found.annotation is None                   # its annotation is finished

    # even past the id check, writing the case never replaces the first patient's
    second.set_case_id("P001")
    with pytest.raises(NaseviewError, match="another patient's case is already there"):
        second.write_case(work.case_dir("P001"))
    assert snapshot(work.patient_dir("P001")) == before
    assert read_case(work.case_dir("P001")).load_image("front")[0, 0, 0] == 100

    # a free id is taken and the case goes to its own folder
    work.rename(second, "P002")
    second.write_case(work.case_dir("P002"))
    assert read_case(work.case_dir("P002")).load_image("front")[0, 0, 0] == 200
    assert snapshot(work.patient_dir("P001")) == before


def test_a_patient_rewrites_its_own_case_all_at_once(tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    s = work.new_session("P010")
    ready(s, 120)
    out = work.case_dir("P010")
    s.write_case(out)
    work.rename(s, "P010")                            # its own id stays its own
    s.place("front", "g", (100.0, 101.0))
    s.write_case(out)
    assert read_case(out).views["front"].landmarks["g"].tolist() == [100.0, 101.0]
    assert sorted(p.name for p in out.parent.iterdir()) == ["case"]   # no leftovers
    # resumed after a restart it is still the same patient: it may rewrite its case
    r = AnnotationSession.open(s.folder)
    assert r.uid == s.uid and r.case_dir == out
    r.place("front", "g", (90.0, 91.0))
    r.write_case(out)
    assert read_case(out).views["front"].landmarks["g"].tolist() == [90.0, 91.0]


def test_an_unfinished_patient_holds_its_id(tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    first = work.new_session("P020")
    other = work.new_session()
    with pytest.raises(NaseviewError, match="the unfinished patient in in-progress/P020"):
        work.rename(other, "P020")
    found = work.find("P020")
    assert found is not None and found.annotation == first.folder and found.case_dir is None
    assert work.find("P999") is None
    # two new patients never share a folder, even with the same default id
    folders = {work.new_session().folder for _ in range(3)}
    assert len(folders) == 3


def test_every_path_comes_from_a_checked_id_and_slug(tmp_path: Path):
    """The layout (issue 14): reconstruction, simulations, trash and record live in the
    patient folder, derived from a checked id; reserved names are never patients."""
    work = PatientFolders(tmp_path / "work")
    top = work.patient_dir("P030")
    assert work.reconstruction_dir("P030") == top / "reconstruction"
    assert work.simulation_file("P030", "simulation-2") == top / "simulations" / \
        "simulation-2.json"
    assert work.trash_dir("P030") == top / "trash" and work.record_file("P030") == \
        top / "patient.json"
    assert work.index_file == work.root / "index.sqlite"
    assert work.report_dir("P030") == top / "report"
    for bad in ("..", "../x", "a/b", "x\0", "P" * 65, "", "in-progress", "INDEX.sqlite"):
        with pytest.raises(NaseviewError, match="not a patient folder name"):
            work.patient_dir(bad)
    for bad in ("../x", "A", "-x", "x.json", "a" * 65):
        with pytest.raises(NaseviewError, match="not a simulation name"):
            work.simulation_file("P030", bad)
    with pytest.raises(NaseviewError, match="a name naseview uses"):
        work.new_session("in-progress")
    assert work.find("") is None


def test_a_patient_with_its_reconstruction_and_simulations_may_rewrite_its_case(
        tmp_path: Path):
    work = PatientFolders(tmp_path / "work")
    s = work.new_session("P040")
    ready(s, 90)
    s.write_case(work.case_dir("P040"))
    for folder in ("reconstruction", "simulations", "trash"):
        (work.patient_dir("P040") / folder).mkdir()
    (work.record_file("P040")).write_text("{}")
    work.rename(s, "P040")                            # still its own id
    s.write_case(work.case_dir("P040"))
    other = work.new_session()
    with pytest.raises(NaseviewError, match="already used"):
        work.rename(other, "P040")
