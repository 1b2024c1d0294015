"""Issue 26: the patients' records under concurrency and hostile folders: two servers
saving one simulation at the same moment lose nothing (the loser is told), and the
patient list scans the folders when ``index.sqlite`` cannot be used at all."""

from __future__ import annotations

import errno
import sqlite3
import threading
from pathlib import Path

import numpy as np
import pytest
from helpers import drag
from records_fixtures import Patient

import naseview.records.index as index_module
from naseview.editing.controller import EditController
from naseview.records import PatientRecords
from naseview.records.simulations import read_simulation


def _listing(r: PatientRecords) -> list[tuple[str, bool, bool, list[str]]]:
    return [(p.patient_id, p.has_case, p.has_reconstruction,
             [s.name for s in p.simulations]) for p in r.list_patients()]


def test_the_list_scans_the_folders_when_the_index_is_a_folder(patient: Patient):
    r = patient.records
    want = _listing(r)
    r.folders.index_file.unlink()
    for extra in ("-wal", "-shm"):
        Path(f"{r.folders.index_file}{extra}").unlink(missing_ok=True)
    r.folders.index_file.mkdir()              # IsADirectoryError on delete
    assert _listing(r) == want and r.index.last_source == "scan"
    assert r.folders.index_file.is_dir()      # left alone (not ours to delete)


def test_the_list_scans_the_folders_on_a_read_only_work_folder(patient: Patient,
                                                                monkeypatch):
    r = patient.records
    want = _listing(r)

    def read_only(*a, **k):
        raise sqlite3.OperationalError("attempt to write a readonly database")

    def erofs(path, *a, **k):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(index_module.sqlite3, "connect", read_only)
    monkeypatch.setattr(index_module.os, "unlink", erofs)
    assert _listing(r) == want and r.index.last_source == "scan"
    assert [p.patient_id for p in r.index.rebuild()] == ["P001"]


def test_two_servers_saving_one_simulation_at_once_lose_nothing(patient: Patient):
    """50 races: two servers (two PatientRecords) flush an edit of one simulation at the
    same moment. A save reported as done (no error) is on disk; the other is told in one
    line. Lost = a window saying saved whose edit is not in the file."""
    root = patient.records.folders.root
    slug = patient.first_simulation()
    lost = told = 0
    for trial in range(50):
        autos, ctls, recs = [], [], []
        for _ in range(2):
            rec = PatientRecords(root)
            session = rec.load_simulation(patient.pid, slug)
            c = EditController.from_session(session, None)
            autos.append(rec.resume_simulation(patient.pid, slug, c, session, delay=60.0))
            ctls.append(c)
            recs.append(rec)
        for k, c in enumerate(ctls):
            drag(c, "prn", np.array([0.0, 0.1 * (trial + 1), 0.3 * (k + 1)]))
        barrier = threading.Barrier(2)

        def save(a, barrier=barrier):
            barrier.wait()
            a.flush()

        threads = [threading.Thread(target=save, args=(a,)) for a in autos]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        on_disk = read_simulation(patient.records.folders, patient.pid, slug).landmarks["prn"]
        winners = [k for k, a in enumerate(autos) if a.error is None]
        for k, a in enumerate(autos):
            if a.error is None:
                if not np.allclose(on_disk, ctls[k].landmarks["prn"]):
                    lost += 1
            else:
                assert "another naseview window" in a.error and "\n" not in a.error
                told += 1
        assert len(winners) >= 1
        for a, c, rec in zip(autos, ctls, recs, strict=True):
            a.close()
            c.close()
            rec.close()
    assert lost == 0, f"{lost}/50 saves reported done were lost"
    assert told >= 1


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(pytest.main([__file__, "-q"]))
