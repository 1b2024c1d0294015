"""One patient folder: its record (``patient.json``), its case and its reconstruction.

A patient's case is ``WORK/<id>/case`` (written by the new-patient page) or, for a case
opened from elsewhere (``naseview serve SOMECASE``), the case folder that
``WORK/<id>/patient.json`` links to: its path relative to the patient folder and the
SHA-256 of its ``case.json``. The case is never copied and nothing is written into it; a
link is followed only to a ``case.json`` with the recorded hash, so a case that changed
(or a link edited by mistake) is never opened as this patient. The hash is not a secret:
someone who can edit ``patient.json`` can point it at any case folder whose
``case.json`` they can read, as they could open that folder with ``naseview serve``
anyway. The reconstruction is the
pipeline output set in ``WORK/<id>/reconstruction`` (:func:`save_reconstruction`, all or
nothing), whose ``reconstruction.json`` links the case the same way (``case_dir`` +
``case_sha256``).

Paths come from :class:`naseview.intake.patients.PatientFolders` (the one home of the
layout); nothing here builds a path from a string read from a file.

Example
-------
    pid = patient_for_case(folders, "/data/cases/p7")     # WORK/p7, linked to the case
    saved = save_reconstruction(folders, pid, result)     # WORK/p7/reconstruction
    state = reconstruction_state(folders, pid)            # dir, SHA-256, problem
"""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from naseview.errors import NaseviewError
from naseview.fileio import (
    atomic_write_json,
    current_set_file,
    parse_json,
    read_bytes,
    read_json,
    resolve_stored_path,
    sha256_hex,
)
from naseview.intake.annotation_file import safe_case_id
from naseview.intake.patients import PatientFolders, is_patient_id
from naseview.pipeline import PipelineResult, write_outputs
from naseview.reconstruction import RECONSTRUCTION_FILE, Reconstruction, output_case_dir

PATIENT_FORMAT = "naseview.patient/1"
CASE_FILE = "case.json"


def now_iso() -> str:
    """The local time now, ISO 8601 with offset, to the second."""
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def iso_of_ns(ns: int) -> str:
    """A file time (ns since the epoch) as a local ISO 8601 time."""
    return _dt.datetime.fromtimestamp(ns / 1e9).astimezone().isoformat(timespec="seconds")


@dataclass(frozen=True)
class PatientRecord:
    """``WORK/<id>/patient.json``.

    Attributes:
        patient_id: the id (the folder name).
        created: when the patient folder was made (ISO 8601).
        case_link: the stored path of a case kept elsewhere (relative to the patient
            folder) and the SHA-256 of its ``case.json``, or None (the case is
            ``WORK/<id>/case``).
    """

    patient_id: str
    created: str
    case_link: tuple[str, str] | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``naseview.patient/1`` object."""
        link = (None if self.case_link is None
                else {"path": self.case_link[0], "sha256": self.case_link[1]})
        return {"format": PATIENT_FORMAT, "id": self.patient_id, "created": self.created,
                "case": link}


def _is_sha(v: object) -> bool:
    return isinstance(v, str) and len(v) == 64 and all(c in "0123456789abcdef" for c in v)


def read_record(folders: PatientFolders, pid: str) -> PatientRecord | None:
    """The patient's ``patient.json``, or None when there is none.

    Raises:
        NaseviewError: unreadable or malformed (one line: file, key, fix), or a symbolic
            link.
    """
    path = folders.inside(pid, folders.record_file(pid))
    if not path.is_file():
        return None
    obj = read_json(path)
    fix = f"delete {path} and open the patient's case again"
    if obj.get("format") != PATIENT_FORMAT:
        raise NaseviewError(f"{path}: key 'format': expected {PATIENT_FORMAT!r}; {fix}")
    if obj.get("id") != pid:
        raise NaseviewError(f"{path}: key 'id': expected {pid!r} (the folder's name); {fix}")
    created = obj.get("created")
    if not isinstance(created, str) or len(created) > 40:
        raise NaseviewError(f"{path}: key 'created': expected an ISO 8601 time; {fix}")
    link = obj.get("case")
    if link is None:
        return PatientRecord(pid, created)
    if not isinstance(link, dict) or not isinstance(link.get("path"), str) \
            or not _is_sha(link.get("sha256")):
        raise NaseviewError(f"{path}: key 'case': expected {{\"path\": ..., \"sha256\": 64 "
                            f"hex digits}} or null; {fix}")
    return PatientRecord(pid, created, (link["path"], link["sha256"]))


def write_record(folders: PatientFolders, record: PatientRecord) -> Path:
    """Write ``patient.json`` atomically."""
    path = folders.inside(record.patient_id, folders.record_file(record.patient_id))
    return atomic_write_json(path, record.to_json())


def ensure_record(folders: PatientFolders, pid: str) -> PatientRecord:
    """The patient's record, written now (created = now) if it has none yet."""
    rec = read_record(folders, pid)
    if rec is None:
        rec = PatientRecord(pid, now_iso())
        write_record(folders, rec)
    return rec


def _linked_path(folders: PatientFolders, record: PatientRecord) -> Path:
    """Where the record's case link points (resolved; not yet checked against its hash)."""
    assert record.case_link is not None
    top = folders.patient_dir(record.patient_id)
    return resolve_stored_path(record.case_link[0], top, Path(os.path.abspath(os.sep)),
                               top / "patient.json", "case.path")


def _case_sha(case_dir: Path) -> str | None:
    try:
        return sha256_hex((case_dir / CASE_FILE).read_bytes())
    except OSError:
        return None


def patient_case_dir(folders: PatientFolders, pid: str) -> Path | None:
    """The patient's case folder: ``WORK/<id>/case`` when it holds ``case.json``, else
    the linked case when its ``case.json`` has the recorded SHA-256, else None (no case).

    Raises:
        NaseviewError: a symbolic link inside the patient folder, a malformed
            ``patient.json``, or a linked case that is missing or changed since (one
            line: file, key, fix).
    """
    own = folders.inside(pid, folders.case_dir(pid))
    if (own / CASE_FILE).is_file():
        folders.inside(pid, own / CASE_FILE)
        return own
    rec = read_record(folders, pid)
    if rec is None or rec.case_link is None:
        return None
    case = _linked_path(folders, rec)
    if _case_sha(case) != rec.case_link[1]:
        raise NaseviewError(f"{folders.record_file(pid)}: key 'case.sha256': the case "
                            f"{case} is missing or has changed since it was opened; open "
                            f"it again (`naseview serve {case}`) to keep it under this "
                            "patient")
    return case


def patient_for_case(folders: PatientFolders, case_dir: str | os.PathLike[str]) -> str:
    """The patient id under which a case folder is kept, made now if needed.

    ``WORK/<id>/case`` is patient ``<id>``. A case elsewhere is kept in ``WORK/<id>``
    (``<id>`` from its ``case.json``, made file-name safe; ``<id>-2``, ``<id>-3``... when
    another case has that folder) with ``patient.json`` linking it; opening the same case
    folder again finds the same patient (and takes its current ``case.json``). Nothing is
    written into ``case_dir``.

    Raises:
        NaseviewError: ``case_dir`` holds no readable ``case.json``; the work folder is
            not writable.
    """
    case = Path(os.path.realpath(case_dir))
    data = read_bytes(case / CASE_FILE, "case.json")
    root = Path(os.path.realpath(folders.root))
    if case.parent.parent == root and case.name == "case" and is_patient_id(case.parent.name):
        return case.parent.name
    raw = parse_json(data, case / CASE_FILE).get("id")
    base = safe_case_id(raw if isinstance(raw, str) else "") or safe_case_id(case.name)
    base = base if is_patient_id(base) else "case"
    digest = sha256_hex(data)
    for k in range(1, 1000):
        pid = base if k == 1 else f"{base[:58]}-{k}"
        top = folders.patient_dir(pid)
        try:
            top.mkdir(parents=True)
        except FileExistsError:
            if _links_to(folders, pid, case):
                write_record(folders, PatientRecord(
                    pid, _created(folders, pid), (_stored(case, top), digest)))
                return pid
            continue
        except OSError as e:
            raise NaseviewError(f"{top}: cannot create the patient folder ({e.strerror}); "
                                "choose a writable work folder (NASEVIEW_WORK_DIR)") from None
        write_record(folders, PatientRecord(pid, now_iso(), (_stored(case, top), digest)))
        return pid
    raise NaseviewError(f"{folders.root}: too many patient folders named {base!r}")


def _stored(case: Path, top: Path) -> str:
    return Path(os.path.relpath(case, os.path.realpath(top))).as_posix()


def _created(folders: PatientFolders, pid: str) -> str:
    try:
        rec = read_record(folders, pid)
    except NaseviewError:
        rec = None
    return rec.created if rec is not None else now_iso()


def _links_to(folders: PatientFolders, pid: str, case: Path) -> bool:
    """Whether patient ``pid`` is the link to ``case`` (a real folder, no own case)."""
    try:
        folders.inside(pid, folders.patient_dir(pid))
        if (folders.case_dir(pid) / CASE_FILE).exists():
            return False
        rec = read_record(folders, pid)
        return rec is not None and rec.case_link is not None and \
            _linked_path(folders, rec) == case
    except NaseviewError:
        return False


@dataclass(frozen=True)
class SavedReconstruction:
    """What :func:`save_reconstruction` wrote.

    Attributes:
        folder: ``WORK/<id>/reconstruction``.
        sha256: SHA-256 of its ``reconstruction.json`` (simulations record it).
        paths: the files written, ``reconstruction.json`` last.
    """

    folder: Path
    sha256: str
    paths: tuple[Path, ...]


def save_reconstruction(folders: PatientFolders, pid: str, result: PipelineResult,
                        export: Iterable[str] = ()) -> SavedReconstruction:
    """Write a pipeline result of the patient's case as ``WORK/<id>/reconstruction``
    (:func:`naseview.pipeline.write_outputs`: all or nothing; ``reconstruction.json``
    links the case by relative path and SHA-256 of its ``case.json``).

    Raises:
        NaseviewError: the patient has no case, ``result`` was not made from it, or the
            folder is not writable (the previous reconstruction is then unchanged).
    """
    case = patient_case_dir(folders, pid)
    if case is None:
        raise NaseviewError(f"{folders.patient_dir(pid)}: the patient has no case; write "
                            "or open the case before saving its reconstruction")
    if result.case_root is None or os.path.realpath(result.case_root) != str(case):
        raise NaseviewError(f"{folders.reconstruction_dir(pid)}: the reconstruction was made "
                            f"from {result.case_root}, not from the patient's case {case}; "
                            "reconstruct the patient's case")
    ensure_record(folders, pid)
    out = folders.inside(pid, folders.reconstruction_dir(pid))
    paths = write_outputs(result, out, export)
    digest = sha256_hex(current_set_file(out, RECONSTRUCTION_FILE).read_bytes())
    return SavedReconstruction(out, digest, tuple(paths))


@dataclass(frozen=True)
class ReconstructionState:
    """The patient's saved reconstruction, as :func:`reconstruction_state` found it.

    Attributes:
        folder: ``WORK/<id>/reconstruction`` when it holds a reconstruction of the
            patient's current case, else None.
        sha256: SHA-256 of its ``reconstruction.json`` (None without one).
        problem: one line (file, key, fix) when there is a reconstruction that cannot be
            used (another case, changed case, damaged), else None.
    """

    folder: Path | None
    sha256: str | None
    problem: str | None = None


def reconstruction_state(folders: PatientFolders, pid: str,
                         case_dir: Path | None = None) -> ReconstructionState:
    """The patient's reconstruction, if it was made from ``case_dir`` (default:
    :func:`patient_case_dir`) as it is now (``case_sha256``)."""
    out = folders.reconstruction_dir(pid)
    try:
        folders.inside(pid, out)
        index = current_set_file(out, RECONSTRUCTION_FILE)
        if not index.is_file():
            return ReconstructionState(None, None)
        folders.inside(pid, index)
        data = index.read_bytes()
        digest = sha256_hex(data)
        rec = Reconstruction.from_json(parse_json(data, out / RECONSTRUCTION_FILE),
                                       str(out / RECONSTRUCTION_FILE))
        case = case_dir if case_dir is not None else patient_case_dir(folders, pid)
        made_from = output_case_dir(out, rec)
    except (NaseviewError, OSError) as e:
        return ReconstructionState(None, None, str(e) if isinstance(e, NaseviewError)
                                   else f"{out}: cannot read ({e.strerror})")
    if case is None or made_from is None or Path(os.path.realpath(made_from)) != \
            Path(os.path.realpath(case)):
        return ReconstructionState(None, digest, (
            f"{out / RECONSTRUCTION_FILE}: key 'case_dir': not a reconstruction of the "
            f"patient's case ({case}); reconstruct the case again"))
    return ReconstructionState(out, digest)


__all__ = ["PATIENT_FORMAT", "PatientRecord", "ReconstructionState", "SavedReconstruction",
           "ensure_record", "iso_of_ns", "now_iso", "patient_case_dir", "patient_for_case",
           "read_record", "reconstruction_state", "save_reconstruction", "write_record"]
