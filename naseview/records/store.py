"""The app's entry to the patients' records: :class:`PatientRecords`.

One object per server over the work folder (``$NASEVIEW_WORK_DIR``): the patient list
for the start page (:mod:`naseview.records.index`), opening a patient (its case, its
reconstruction if it was made from that case, its latest simulation), saving a
reconstruction, and the named simulations with their autosave
(:class:`~naseview.records.autosave.Autosave`). Every method takes a patient id and a
simulation slug, checked by :class:`~naseview.intake.patients.PatientFolders`; a problem
is one :class:`~naseview.errors.NaseviewError` line naming the file, the key and the fix.

Example
-------
    records = PatientRecords()
    pid = records.patient_for_case(case_dir)          # serve SOMECASE / new patient
    saved = records.save_reconstruction(pid, result)  # after every reconstruction
    auto = records.start_simulation(pid, controller, reconstruction_sha256=saved.sha256)
    ...
    opened = records.open_patient(pid)                # start page: "open"
    session = records.load_simulation(pid, opened.simulation.slug)
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from naseview.editing.controller import EditController
from naseview.editing.session import Session
from naseview.errors import NaseviewError
from naseview.intake.patients import PatientFolders
from naseview.pipeline import PipelineResult
from naseview.records import simulations as sims
from naseview.records.autosave import DEFAULT_DELAY, Autosave
from naseview.records.index import PatientIndex, PatientSummary
from naseview.records.patient import (
    SavedReconstruction,
    patient_case_dir,
    patient_for_case,
    reconstruction_state,
    save_reconstruction,
)
from naseview.records.simulations import SimulationInfo


@dataclass(frozen=True)
class OpenedPatient:
    """What the app needs to open a patient (:meth:`PatientRecords.open_patient`).

    Attributes:
        patient_id: the id; folder: ``WORK/<id>``.
        case_dir: the case folder (photos), or None (no case, or a link that broke).
        reconstruction_dir: ``WORK/<id>/reconstruction`` when it was made from the case
            as it is now (open it with ``baseline_from_output_dir``), else None
            (reconstruct the case, then :meth:`PatientRecords.save_reconstruction`).
        reconstruction_sha256: SHA-256 of that ``reconstruction.json``, or None.
        simulation: the most recently saved simulation that can be opened on that
            reconstruction, or None (start "Simulation 1").
        simulations: every simulation, newest first.
        stale: slug -> one line, for each simulation that cannot be opened on the current
            reconstruction (made on another, or unreadable).
        problems: one line each (file, key, fix) for what could not be used.
    """

    patient_id: str
    folder: Path
    case_dir: Path | None
    reconstruction_dir: Path | None
    reconstruction_sha256: str | None
    simulation: SimulationInfo | None
    simulations: tuple[SimulationInfo, ...]
    stale: dict[str, str]
    problems: tuple[str, ...]


class PatientRecords:
    """The patients' records over one work folder (module docstring).

    Args:
        work_dir: the work folder (default ``$NASEVIEW_WORK_DIR`` or
            ``~/naseview-patients``).
    """

    def __init__(self, work_dir: str | os.PathLike[str] | None = None) -> None:
        self.folders = PatientFolders(work_dir)
        self.index = PatientIndex(self.folders)
        self._lock = threading.Lock()
        self._active: dict[tuple[str, str], Autosave] = {}

    # the start page
    def list_patients(self) -> list[PatientSummary]:
        """Every patient, newest first, with its simulations (from the index, brought up
        to date from the folders; never an error for the index)."""
        return self.index.patients()

    # opening
    def patient_for_case(self, case_dir: str | os.PathLike[str]) -> str:
        """The patient a case folder is kept under (``WORK/<id>/case`` -> ``<id>``; a case
        elsewhere -> a patient folder linking it, made now if needed; the case folder is
        never written)."""
        return patient_for_case(self.folders, case_dir)

    def _existing(self, pid: str) -> Path:
        top = self.folders.inside(pid, self.folders.patient_dir(pid))
        if not top.is_dir():
            raise NaseviewError(f"{top}: no such patient; choose one from the patient list")
        return top

    def open_patient(self, pid: str) -> OpenedPatient:
        """The patient's case, reconstruction and latest usable simulation.

        Raises:
            NaseviewError: not a patient id, no such patient, or a symbolic link in its
                folder.
        """
        top = self._existing(pid)
        problems: list[str] = []
        try:
            case = patient_case_dir(self.folders, pid)
        except NaseviewError as e:
            case = None
            problems.append(str(e))
        state = reconstruction_state(self.folders, pid, case) if case is not None else None
        if state is not None and state.problem is not None:
            problems.append(state.problem)
        current = state.sha256 if state is not None and state.folder is not None else None
        try:
            listed = sims.list_simulations(self.folders, pid)
        except NaseviewError as e:
            listed = []
            problems.append(str(e))
        stale: dict[str, str] = {}
        for i in listed:
            why = i.problem or sims.stale_reason(self.folders, pid, i.slug,
                                                 i.reconstruction_sha256, current)
            if why is not None:
                stale[i.slug] = why
        problems += list(stale.values())
        latest = next((i for i in listed if i.slug not in stale), None)
        return OpenedPatient(pid, top, case, state.folder if state else None, current,
                             latest, tuple(listed), stale, tuple(problems))

    def save_reconstruction(self, pid: str, result: PipelineResult,
                            export: Iterable[str] = ()) -> SavedReconstruction:
        """Keep a reconstruction of the patient's case in ``WORK/<id>/reconstruction``
        (all or nothing; see :func:`naseview.records.patient.save_reconstruction`)."""
        return save_reconstruction(self.folders, pid, result, export)

    # simulations
    def simulations(self, pid: str) -> list[SimulationInfo]:
        """The patient's simulations, newest first."""
        self._existing(pid)
        return sims.list_simulations(self.folders, pid)

    def load_simulation(self, pid: str, slug: str, *, allow_stale: bool = False) -> Session:
        """A simulation to reopen (``EditController.from_session``); one made on another
        reconstruction than the patient's current one is refused unless
        ``allow_stale`` (it then opens on its own saved baseline)."""
        self._existing(pid)
        case = None
        try:
            case = patient_case_dir(self.folders, pid)
        except NaseviewError:
            pass
        state = reconstruction_state(self.folders, pid, case) if case is not None else None
        current = state.sha256 if state is not None and state.folder is not None else None
        return sims.load_simulation(self.folders, pid, slug, current, allow_stale)

    def _watch(self, auto: Autosave) -> Autosave:
        with self._lock:
            old = self._active.get((auto.patient_id, auto.slug))
            if old is not None and old is not auto and old.controller is not auto.controller:
                old.close()
            self._active[(auto.patient_id, auto.slug)] = auto
        return auto

    def active(self, pid: str, slug: str) -> Autosave | None:
        """The open autosave of a simulation in this server, if any."""
        with self._lock:
            auto = self._active.get((pid, slug))
        return None if auto is None or auto.closed else auto

    def start_simulation(self, pid: str, controller: EditController, *,
                         reconstruction_sha256: str | None, name: str | None = None,
                         app_state: Callable[[], Mapping[str, Any]] | None = None,
                         delay: float = DEFAULT_DELAY) -> Autosave:
        """A new named simulation holding the controller's current state (written now;
        default name "Simulation N"), autosaved from now on."""
        self._existing(pid)
        app = dict(app_state()) if app_state is not None else {}
        info = sims.create_simulation(self.folders, pid, controller.snapshot(app), name,
                                      reconstruction_sha256)
        return self._watch(Autosave(self.folders, pid, info.slug, controller,
                                    name=info.name, created=info.created,
                                    reconstruction_sha256=reconstruction_sha256,
                                    app_state=app_state, delay=delay, on_disk=True))

    def resume_simulation(self, pid: str, slug: str, controller: EditController,
                          session: Session, *,
                          app_state: Callable[[], Mapping[str, Any]] | None = None,
                          delay: float = DEFAULT_DELAY) -> Autosave:
        """Autosave a simulation reopened from :meth:`load_simulation` (``session``) into
        ``controller``."""
        if session.record is None:
            raise NaseviewError(f"{self.folders.simulation_file(pid, slug)}: key 'record': "
                                "missing; open it with load_simulation")
        r = session.record
        return self._watch(Autosave(self.folders, pid, slug, controller, name=r.name,
                                    created=r.created,
                                    reconstruction_sha256=r.reconstruction_sha256,
                                    app_state=app_state, delay=delay, on_disk=True))

    def rename_simulation(self, pid: str, slug: str, name: str) -> SimulationInfo:
        """Rename a simulation (the one being autosaved here too)."""
        self._existing(pid)
        auto = self.active(pid, slug)
        if auto is None:
            return sims.rename_simulation(self.folders, pid, slug, name)
        sims.check_free_name(self.folders, pid, name, keep=slug)
        auto.rename(name)
        return sims.info_of(self.folders, pid, slug)

    def duplicate_simulation(self, pid: str, slug: str, name: str | None = None
                             ) -> SimulationInfo:
        """A copy of a simulation (as last saved) under a new name."""
        self._existing(pid)
        auto = self.active(pid, slug)
        if auto is not None:
            auto.flush()
        return sims.duplicate_simulation(self.folders, pid, slug, name)

    def delete_simulation(self, pid: str, slug: str) -> Path:
        """Move a simulation to the patient's trash; returns where it went.

        Raises:
            NaseviewError: it is open (being autosaved): switch to another first.
        """
        self._existing(pid)
        if self.active(pid, slug) is not None:
            raise NaseviewError(f"{self.folders.simulation_file(pid, slug)}: the simulation "
                                "is open; switch to another simulation before deleting it")
        return sims.delete_simulation(self.folders, pid, slug)

    def close(self) -> None:
        """Write and stop every autosave (server shutdown)."""
        with self._lock:
            autos = list(self._active.values())
            self._active.clear()
        for a in autos:
            a.close()


__all__ = ["OpenedPatient", "PatientRecords"]
