"""A patient's named simulations: ``WORK/<id>/simulations/<slug>.json`` session files.

Each simulation is a ``naseview.session/1`` file (:mod:`naseview.editing.session`) with
its ``record`` object: the name the surgeon sees ("Simulation 2"), when it was created
and last saved, and the SHA-256 of the ``reconstruction.json`` it was made on. The slug
(the file name) is chosen once, from the first name, and never changes: renaming
rewrites the name inside the file only, so an autosave writing it is never pointed at a
moved file.

- creating writes the whole file under a hidden name and links it to ``<slug>.json``
  (``os.link`` fails when the name is taken: two servers never share a slug);
- deleting moves the file to ``WORK/<id>/trash/<slug>-<time>-<random>.json`` (move it back to
  restore it); a simulation being autosaved is refused;
- opening checks the file like any session file (one line naming the file, the key and
  the fix; a file over :data:`MAX_SIMULATION_BYTES` is refused before it is read), and
  refuses, unless asked to open it as saved, a simulation made on another
  reconstruction than the patient's current one (:func:`stale_reason`).

Example
-------
    info = create_simulation(folders, "p1", controller.snapshot(), "Simulation 1", sha)
    rename_simulation(folders, "p1", info.slug, "Shorter tip")
    session = load_simulation(folders, "p1", info.slug, current_sha)
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import re
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from naseview.editing.session import (
    Session,
    SessionRecord,
    check_name,
    session_from_json,
    session_to_json,
)
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, folder_lock, one_line, parse_json
from naseview.intake.patients import PatientFolders, is_simulation_slug
from naseview.records.patient import iso_of_ns, now_iso

MAX_SIMULATION_BYTES = 64 * 1024 * 1024
"""Largest simulation file naseview reads (a session of the ICT face is about 1 MB; a
junk file in the folder costs no more than this at each rescan of the patient list)."""

DEFAULT_NAME = "Simulation"


@dataclass(frozen=True)
class SimulationInfo:
    """One simulation as listed (read from its file).

    Attributes:
        patient_id: the patient; slug: the file name without ``.json``.
        name: the name shown ("Simulation 2"); the slug when the file cannot be read.
        created: when it was started (ISO 8601) or None.
        modified: when the file was last written (its time stamp, ISO 8601).
        modified_ns: the same, ns since the epoch (for sorting).
        reconstruction_sha256: the reconstruction it was made on, or None.
        problem: one line (file, key, fix) when the file cannot be opened, else None.
    """

    patient_id: str
    slug: str
    name: str
    created: str | None
    modified: str
    modified_ns: int
    reconstruction_sha256: str | None
    problem: str | None = None


def session_bytes(obj: Mapping[str, Any]) -> bytes:
    """A session JSON object as the bytes of a simulation file: compact UTF-8 JSON (the C
    encoder: an ICT face's session is written in a fraction of the time of indented JSON,
    which matters on the autosave thread), ``NaN`` refused."""
    return json.dumps(obj, allow_nan=False, separators=(",", ":")).encode("utf-8")


def _size_checked(path: Path) -> bytes:
    """The bytes of a simulation file, refused above :data:`MAX_SIMULATION_BYTES`."""
    try:
        size = os.stat(path).st_size
        if size > MAX_SIMULATION_BYTES:
            raise NaseviewError(f"{path}: {size // 2**20} MB is larger than a simulation "
                                f"can be ({MAX_SIMULATION_BYTES // 2**20} MB); it is not a "
                                "file naseview wrote, move it out of the folder")
        with open(path, "rb") as f:
            return f.read(MAX_SIMULATION_BYTES + 1)
    except FileNotFoundError:
        raise NaseviewError(f"{path}: simulation not found; choose one from the patient's "
                            "list") from None
    except OSError as e:
        raise NaseviewError(f"{path}: cannot read ({one_line(e.strerror or e)})") from None


def _path(folders: PatientFolders, pid: str, slug: str) -> Path:
    return folders.inside(pid, folders.simulation_file(pid, slug))


def read_simulation(folders: PatientFolders, pid: str, slug: str) -> Session:
    """Parse and check ``WORK/<id>/simulations/<slug>.json``.

    Raises:
        NaseviewError: missing, too large, a symbolic link, not a session, a malformed
            key, or an ``app.case_dir`` leaving the simulations folder (one line).
    """
    path = _path(folders, pid, slug)
    obj = parse_json(_size_checked(path), path)
    session = session_from_json(obj, str(path), path)
    session.case_folder()  # a hand-edited app.case_dir leading out is refused
    if session.record is None:
        raise NaseviewError(f"{path}: key 'record': missing; a simulation of a patient "
                            "folder names itself; save it again from the app")
    return session


def _info(folders: PatientFolders, pid: str, slug: str, mtime_ns: int) -> SimulationInfo:
    try:
        rec = read_simulation(folders, pid, slug).record
        assert rec is not None
        return SimulationInfo(pid, slug, rec.name, rec.created, iso_of_ns(mtime_ns),
                              mtime_ns, rec.reconstruction_sha256)
    except NaseviewError as e:
        return SimulationInfo(pid, slug, slug, None, iso_of_ns(mtime_ns), mtime_ns, None,
                              str(e))


def simulation_stamps(folders: PatientFolders, pid: str) -> dict[str, int]:
    """slug -> file time (ns) of each simulation file (plain ``<slug>.json`` files; hidden
    and temporary files, other names and symbolic links are not simulations).

    Raises:
        NaseviewError: the simulations folder is a symbolic link.
    """
    d = folders.inside(pid, folders.simulations_dir(pid))
    try:
        entries = list(os.scandir(d))
    except OSError:
        return {}
    out = {}
    for e in entries:
        slug = e.name[:-5] if e.name.endswith(".json") else ""
        if is_simulation_slug(slug) and e.is_file(follow_symlinks=False):
            with contextlib.suppress(OSError):
                out[slug] = e.stat(follow_symlinks=False).st_mtime_ns
    return out


def list_simulations(folders: PatientFolders, pid: str) -> list[SimulationInfo]:
    """The patient's simulations, newest first (each file read; a file that cannot be
    opened is listed with its ``problem``).

    Raises:
        NaseviewError: the simulations folder is a symbolic link.
    """
    infos = [_info(folders, pid, s, t) for s, t in simulation_stamps(folders, pid).items()]
    return sorted(infos, key=lambda i: (-i.modified_ns, i.slug))


def stale_reason(folders: PatientFolders, pid: str, slug: str, made_on: str | None,
                 current: str | None) -> str | None:
    """Why a simulation made on reconstruction ``made_on`` (SHA-256) does not belong to
    the patient's current reconstruction ``current``, as one line; None when it does."""
    if made_on is not None and made_on == current:
        return None
    path = folders.simulation_file(pid, slug)
    if current is None:
        return (f"{path}: key 'record.reconstruction_sha256': the patient has no saved "
                "reconstruction to check it against; reconstruct the case, or open the "
                "simulation as saved")
    if made_on is None:
        return (f"{path}: key 'record.reconstruction_sha256': missing, so naseview cannot "
                "tell which reconstruction it was made on; open it as saved, or start a "
                "new simulation")
    return (f"{path}: key 'record.reconstruction_sha256': made on an earlier "
            "reconstruction of this patient (reconstructed again since); open it as saved "
            "(its own baseline), or start a new simulation")


def load_simulation(folders: PatientFolders, pid: str, slug: str, current: str | None,
                    allow_stale: bool = False) -> Session:
    """The simulation, to reopen exactly (``EditController.from_session``).

    Args:
        current: SHA-256 of the patient's current ``reconstruction.json`` (None: none).
        allow_stale: open it with its own saved baseline even if it was made on another
            reconstruction.
    Raises:
        NaseviewError: the file cannot be opened (:func:`read_simulation`), or it was made
            on another reconstruction and ``allow_stale`` is False (:func:`stale_reason`).
    """
    session = read_simulation(folders, pid, slug)
    assert session.record is not None
    why = stale_reason(folders, pid, slug, session.record.reconstruction_sha256, current)
    if why is not None and not allow_stale:
        raise NaseviewError(why)
    return session


def slug_for(name: str) -> str:
    """A file-name slug for a simulation name: lower case, runs of other characters
    become ``-``, at most 48 characters (``simulation`` when nothing is left).

    >>> slug_for("Simulation 2"), slug_for("Tip +2 mm / rot."), slug_for("Ω")
    ('simulation-2', 'tip-2-mm-rot', 'simulation')
    """
    s = re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-")[:48].strip("-")
    return s or "simulation"


def next_name(folders: PatientFolders, pid: str) -> str:
    """``Simulation N``, N one more than the largest N in use (1 for the first)."""
    taken = [i.name for i in list_simulations(folders, pid)]
    nums = [int(m.group(1)) for n in taken if (m := re.fullmatch(
        rf"{DEFAULT_NAME} (\d{{1,6}})", n))]
    return f"{DEFAULT_NAME} {max(nums, default=0) + 1}"


def check_free_name(folders: PatientFolders, pid: str, name: str,
                     keep: str | None = None) -> str:
    """``name`` checked (:func:`~naseview.editing.session.check_name`) and not used by
    another simulation of the patient (ignoring upper / lower case)."""
    name = check_name(name, f"simulation name {name[:80]!r}" if isinstance(name, str)
                      else "simulation name", "name")
    for i in list_simulations(folders, pid):
        if i.slug != keep and i.name.casefold() == name.casefold():
            raise NaseviewError(f"simulation name {name!r}: patient {pid} already has a "
                                "simulation with that name; choose another name")
    return name


def write_new(folders: PatientFolders, pid: str, session: Session, name: str) -> str:
    """Write ``session`` as a new simulation named ``name``; returns its slug. The file
    appears complete or not at all, under a slug no other simulation has."""
    d = folders.inside(pid, folders.simulations_dir(pid))
    base = slug_for(name)
    data = session_bytes(session_to_json(session))
    tmp = atomic_write_bytes(d / f".new-{uuid.uuid4().hex}.json", data)
    try:
        for k in range(1, 10_000):
            slug = base if k == 1 else f"{base}-{k}"
            try:
                os.link(tmp, _path(folders, pid, slug))
            except FileExistsError:
                continue
            except OSError as e:
                raise NaseviewError(f"{d}: cannot write ({one_line(e.strerror or e)}); "
                                    "check the work folder") from None
            return slug
        raise NaseviewError(f"{d}: too many simulations named {base!r}")
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


def create_simulation(folders: PatientFolders, pid: str, session: Session,
                      name: str | None = None, reconstruction_sha256: str | None = None
                      ) -> SimulationInfo:
    """A new simulation of the patient holding ``session`` (e.g. a controller's
    :meth:`~naseview.editing.controller.EditController.snapshot`).

    Args:
        name: its name (default :func:`next_name`); refused if the patient has it.
        reconstruction_sha256: the reconstruction the session's baseline is.
    """
    name = check_free_name(folders, pid, name if name is not None else next_name(folders,
                                                                                    pid))
    t = now_iso()
    rec = SessionRecord(name, t, t, reconstruction_sha256)
    slug = write_new(folders, pid, dataclasses.replace(session, record=rec, app={
        k: v for k, v in session.app.items() if k != "case_dir"}), name)
    return info_of(folders, pid, slug)


def info_of(folders: PatientFolders, pid: str, slug: str) -> SimulationInfo:
    """The :class:`SimulationInfo` of one simulation."""
    path = _path(folders, pid, slug)
    try:
        t = os.stat(path).st_mtime_ns
    except OSError:
        raise NaseviewError(f"{path}: simulation not found; choose one from the patient's "
                            "list") from None
    return _info(folders, pid, slug, t)


def rewrite_record(folders: PatientFolders, pid: str, slug: str, session: Session,
                   record: SessionRecord) -> Path:
    """Write ``session`` with ``record`` over ``<slug>.json``, atomically (under the
    simulations folder's lock, so an autosave's compare-and-swap sees it)."""
    path = _path(folders, pid, slug)
    data = session_bytes(session_to_json(dataclasses.replace(session, record=record)))
    with folder_lock(path.parent):
        return atomic_write_bytes(path, data)


def rename_simulation(folders: PatientFolders, pid: str, slug: str, name: str
                      ) -> SimulationInfo:
    """Give a simulation another name (the file keeps its slug)."""
    name = check_free_name(folders, pid, name, keep=slug)
    session = read_simulation(folders, pid, slug)
    assert session.record is not None
    rewrite_record(folders, pid, slug, session,
                   dataclasses.replace(session.record, name=name, modified=now_iso()))
    return info_of(folders, pid, slug)


def duplicate_simulation(folders: PatientFolders, pid: str, slug: str,
                         name: str | None = None) -> SimulationInfo:
    """A copy of a simulation under a new name (default "<name> (copy)")."""
    session = read_simulation(folders, pid, slug)
    assert session.record is not None
    name = name if name is not None else f"{session.record.name[:70]} (copy)"
    return create_simulation(folders, pid, session, name,
                             session.record.reconstruction_sha256)


def delete_simulation(folders: PatientFolders, pid: str, slug: str) -> Path:
    """Move a simulation to ``WORK/<id>/trash/<slug>-<time>.json``; returns where.

    Raises:
        NaseviewError: no such simulation, or the trash cannot be written.
    """
    src = _path(folders, pid, slug)
    if not src.is_file():
        raise NaseviewError(f"{src}: simulation not found; choose one from the patient's "
                            "list")
    trash = folders.inside(pid, folders.trash_dir(pid))
    stamp = now_iso().replace(":", "").replace("+", "p")
    try:
        trash.mkdir(parents=True, exist_ok=True)
        dst = trash / f"{slug}-{stamp}-{uuid.uuid4().hex[:6]}.json"
        os.rename(src, dst)
    except OSError as e:
        raise NaseviewError(f"{src}: cannot move it to {trash} "
                            f"({one_line(e.strerror or e)}); check the work folder") from None
    return dst


__all__ = ["MAX_SIMULATION_BYTES", "SimulationInfo", "check_free_name", "create_simulation",
           "delete_simulation", "duplicate_simulation", "info_of", "list_simulations",
           "load_simulation", "next_name", "read_simulation", "rename_simulation",
           "rewrite_record", "session_bytes", "simulation_stamps", "slug_for",
           "stale_reason", "write_new"]
