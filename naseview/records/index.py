"""The patient list: ``WORK/index.sqlite``, a cache of the patient folders.

The folders are the source of truth; the index only saves reading every simulation file
each time the start page lists the patients. Each patient row carries a *stamp* of its
folder (time stamps and sizes of the patient folder, its case, record, reconstruction and
simulation files); a listing scans the folder names and stamps (no file is read) and
reads again only the patients whose stamp changed, adds new folders and drops rows whose
folder is gone. The index is rebuilt from the folders when it is missing, is not a
database, or was written by another version (:data:`SCHEMA`).

Safety:

- paths are derived from validated ids and slugs (:class:`~naseview.intake.patients.
  PatientFolders`), never from strings in the index: a row naming ``../elsewhere`` is not a
  folder of ``WORK`` and is dropped;
- parameterised SQL only;
- two servers on one ``WORK``: WAL journal and a busy timeout; a database that stays
  locked (or any other SQLite error) degrades to a folder scan, never an error shown to
  the user.

Example
-------
    for p in PatientIndex(folders).patients():        # newest first
        print(p.patient_id, p.modified, [s.name for s in p.simulations])
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.intake.patients import PatientFolders, is_patient_id, is_simulation_slug
from naseview.records.patient import iso_of_ns, read_record
from naseview.records.simulations import list_simulations, simulation_stamps

log = logging.getLogger(__name__)

SCHEMA = "naseview.index/1"
"""The index version; an index of another version is rebuilt."""

BUSY_TIMEOUT_S = 2.0
"""How long a listing waits for another server's write before scanning the folders."""


@dataclass(frozen=True)
class SimulationSummary:
    """A simulation as the patient list shows it.

    Attributes:
        slug: its file name without ``.json``; name: its name.
        modified: when it was last saved (ISO 8601); modified_ns: the same in ns.
        reconstruction_sha256: the reconstruction it was made on, or None.
        problem: one line when it cannot be opened, else None.
    """

    slug: str
    name: str
    modified: str
    modified_ns: int
    reconstruction_sha256: str | None
    problem: str | None


@dataclass(frozen=True)
class PatientSummary:
    """A patient as the start page lists it.

    Attributes:
        patient_id: the id (folder name).
        created: when the patient was created (ISO 8601).
        modified: the latest change in the folder (ISO 8601); modified_ns: in ns.
        has_case, has_reconstruction: what the folder holds.
        simulations: newest first.
    """

    patient_id: str
    created: str
    modified: str
    modified_ns: int
    has_case: bool
    has_reconstruction: bool
    simulations: tuple[SimulationSummary, ...]


def _mtime(path: Path) -> tuple[int, int]:
    try:
        st = os.lstat(path)
        return st.st_mtime_ns, st.st_size
    except OSError:
        return 0, -1


def folder_stamp(folders: PatientFolders, pid: str) -> str:
    """The stamp of a patient folder: changes whenever naseview (or a person) changes
    what the listing shows. Reads file times only."""
    top = folders.patient_dir(pid)
    parts = {name: _mtime(top / name) for name in (
        "", "case", "case/case.json", "patient.json", "reconstruction",
        "reconstruction/reconstruction.json", "simulations")}
    try:
        parts.update({f"sim:{s}": (t, 0) for s, t in simulation_stamps(folders, pid).items()})
    except NaseviewError:  # a symbolic link: listed without simulations
        parts["sim:"] = (-1, -1)
    return json.dumps(sorted(parts.items()))


def _latest_ns(stamp: str) -> int:
    return max((int(v[0]) for _, v in json.loads(stamp)), default=0)


def scan_patient(folders: PatientFolders, pid: str, stamp: str | None = None
                 ) -> PatientSummary:
    """A patient's summary, read from its folder (every simulation file is read)."""
    stamp = stamp if stamp is not None else folder_stamp(folders, pid)
    top = folders.patient_dir(pid)
    latest = _latest_ns(stamp)
    try:
        rec = read_record(folders, pid)
    except NaseviewError:
        rec = None
    created = rec.created if rec is not None else iso_of_ns(
        _mtime(top / "case" / "case.json")[0] or _mtime(top)[0])
    has_case = (top / "case" / "case.json").is_file() or (
        rec is not None and rec.case_link is not None)
    has_rec = (top / "reconstruction" / "reconstruction.json").is_file()
    try:
        listed = list_simulations(folders, pid)
    except NaseviewError:
        listed = []
    sims = tuple(SimulationSummary(i.slug, i.name, i.modified, i.modified_ns,
                                   i.reconstruction_sha256, i.problem) for i in listed)
    return PatientSummary(pid, created, iso_of_ns(latest), latest, has_case, has_rec, sims)


def _newest_first(items: list[PatientSummary]) -> list[PatientSummary]:
    return sorted(items, key=lambda p: (-p.modified_ns, p.patient_id))


_TABLES = (
    "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "CREATE TABLE IF NOT EXISTS patients (id TEXT PRIMARY KEY, stamp TEXT NOT NULL, "
    "created TEXT NOT NULL, modified TEXT NOT NULL, modified_ns INTEGER NOT NULL, "
    "has_case INTEGER NOT NULL, has_reconstruction INTEGER NOT NULL)",
    "CREATE TABLE IF NOT EXISTS simulations (patient_id TEXT NOT NULL, slug TEXT NOT NULL, "
    "name TEXT NOT NULL, modified TEXT NOT NULL, modified_ns INTEGER NOT NULL, "
    "reconstruction_sha256 TEXT, problem TEXT, PRIMARY KEY (patient_id, slug))",
)


class PatientIndex:
    """``WORK/index.sqlite`` over a work folder (module docstring).

    Args:
        folders: the work folder layout.
    """

    def __init__(self, folders: PatientFolders) -> None:
        self.folders = folders
        self.path = folders.index_file
        self.last_source = ""
        """How the last listing was made: ``"index"``, ``"rebuilt"`` or ``"scan"``."""

    # connection
    @contextlib.contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        if self.path.is_symlink():
            raise sqlite3.DatabaseError(f"{self.path} is a symbolic link")
        con = sqlite3.connect(str(self.path), timeout=BUSY_TIMEOUT_S, isolation_level=None)
        try:
            con.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
            con.execute("PRAGMA journal_mode = WAL")
            yield con
        finally:
            con.close()

    def _discard(self) -> bool:
        """Delete an index that is not a database (it is only a cache). False when it
        cannot be deleted (a folder in its place, a read-only work folder): the listing
        then scans the folders."""
        for suffix in ("", "-wal", "-shm", "-journal"):
            try:
                os.unlink(f"{self.path}{suffix}")
            except FileNotFoundError:
                continue
            except OSError as e:
                log.warning("patient index %s%s: cannot delete it (%s); listing the "
                            "folders", self.path, suffix, e.strerror or e)
                return False
        return True

    def _prepare(self, con: sqlite3.Connection) -> bool:
        """Tables of :data:`SCHEMA`; False when they were (re)made empty."""
        con.execute("BEGIN IMMEDIATE")
        try:
            try:
                row = con.execute("SELECT value FROM meta WHERE key = ?",
                                  ("schema",)).fetchone()
            except sqlite3.OperationalError:  # no table yet
                row = None
            fresh = row is None or row[0] != SCHEMA
            if fresh:
                for table in ("meta", "patients", "simulations"):
                    con.execute(f"DROP TABLE IF EXISTS {table}")
                for sql in _TABLES:
                    con.execute(sql)
                con.execute("INSERT INTO meta (key, value) VALUES (?, ?)", ("schema", SCHEMA))
            con.execute("COMMIT")
        except BaseException:
            con.execute("ROLLBACK")
            raise
        return not fresh

    # listing
    def patients(self) -> list[PatientSummary]:
        """Every patient of the work folder, newest first, with its simulations.

        Never raises for the index: a locked, damaged or foreign index, a folder in its
        place or a read-only work folder gives a folder scan (and a damaged one is
        rebuilt when it can be)."""
        if not self.folders.root.is_dir():
            self.last_source = "scan"
            return []
        ids = self.folders.patient_ids()
        stamps = {pid: folder_stamp(self.folders, pid) for pid in ids}
        for attempt in range(2):
            try:
                return self._listed(stamps)
            except (sqlite3.DatabaseError, ValueError, TypeError) as e:
                locked = isinstance(e, sqlite3.OperationalError) and "locked" in str(e)
                if locked or attempt:
                    log.warning("patient index %s: %s; listing the folders", self.path, e)
                    break
                log.warning("patient index %s: %s; rebuilding it", self.path, e)
                if not self._discard():
                    break
            except OSError as e:
                log.warning("patient index %s: %s; listing the folders", self.path, e)
                break
        self.last_source = "scan"
        return _newest_first([scan_patient(self.folders, pid, s) for pid, s in stamps.items()])

    def _listed(self, stamps: dict[str, str]) -> list[PatientSummary]:
        with self._connect() as con:
            kept = self._prepare(con)
            rows = {r[0]: r for r in con.execute(
                "SELECT id, stamp, created, modified, modified_ns, has_case, "
                "has_reconstruction FROM patients")}
            sims: dict[str, list[SimulationSummary]] = {}
            for pid, slug, name, mod, mod_ns, sha, problem in con.execute(
                    "SELECT patient_id, slug, name, modified, modified_ns, "
                    "reconstruction_sha256, problem FROM simulations"):
                if is_simulation_slug(slug):
                    sims.setdefault(pid, []).append(SimulationSummary(
                        slug, str(name), str(mod), int(mod_ns), sha, problem))
            out: list[PatientSummary] = []
            fresh: list[PatientSummary] = []
            for pid, stamp in stamps.items():
                r = rows.get(pid)
                if r is not None and r[1] == stamp:
                    out.append(PatientSummary(
                        pid, str(r[2]), str(r[3]), int(r[4]), bool(r[5]), bool(r[6]),
                        tuple(sorted(sims.get(pid, []),
                                     key=lambda s: (-s.modified_ns, s.slug)))))
                else:
                    p = scan_patient(self.folders, pid, stamp)
                    fresh.append(p)
                    out.append(p)
            gone = [pid for pid in rows if pid not in stamps or not is_patient_id(pid)]
            if fresh or gone:
                self._write(con, fresh, gone, stamps)
            self.last_source = "index" if kept else "rebuilt"
            return _newest_first(out)

    @staticmethod
    def _write(con: sqlite3.Connection, fresh: list[PatientSummary], gone: list[str],
               stamps: dict[str, str]) -> None:
        con.execute("BEGIN IMMEDIATE")
        try:
            for pid in gone + [p.patient_id for p in fresh]:
                con.execute("DELETE FROM patients WHERE id = ?", (pid,))
                con.execute("DELETE FROM simulations WHERE patient_id = ?", (pid,))
            for p in fresh:
                con.execute(
                    "INSERT INTO patients (id, stamp, created, modified, modified_ns, "
                    "has_case, has_reconstruction) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (p.patient_id, stamps[p.patient_id], p.created, p.modified,
                     p.modified_ns, int(p.has_case), int(p.has_reconstruction)))
                con.executemany(
                    "INSERT INTO simulations (patient_id, slug, name, modified, modified_ns, "
                    "reconstruction_sha256, problem) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    [(p.patient_id, s.slug, s.name, s.modified, s.modified_ns,
                      s.reconstruction_sha256, s.problem) for s in p.simulations])
            con.execute("COMMIT")
        except BaseException:
            con.execute("ROLLBACK")
            raise

    def rebuild(self) -> list[PatientSummary]:
        """Forget the index and list again from the folders."""
        self._discard()
        return self.patients()


__all__ = ["SCHEMA", "PatientIndex", "PatientSummary", "SimulationSummary", "folder_stamp",
           "scan_patient"]
