"""The open patient's kept work, as the app uses it: which patient, its autosave, "Saved".

:class:`PatientWork` is what :class:`naseview.app.naseview_app.NaseviewApp` holds
over :class:`naseview.records.PatientRecords` (no viser here): a case opened with
``naseview serve CASE`` or from the new-patient page is a patient of the work folder
(``$NASEVIEW_WORK_DIR``); opening it finds its saved reconstruction (no pipeline run when
it was made from the case as it is now) and its latest simulation, reopened with its edits
and undo history; every reconstruction the app runs is saved
(:meth:`PatientWork.reconstructed`) and every committed edit autosaved
(:class:`~naseview.records.Autosave`). The bundled demo case is a sandbox: it is not kept.

Paths inside the work folder name what to open: ``WORK/<id>`` (or its
``reconstruction``) is that patient, ``WORK/<id>/simulations/<slug>.json`` that simulation
(:meth:`PatientWork.target_of`); the patient list opens patients this way.

Example
-------
    work = PatientWork(work_dir)
    plan = work.begin(work.records.patient_for_case(case_dir))  # the previous one is saved
    ...                                # reconstruct unless plan.reconstruction_dir; install
    work.attach(controller, app_state)  # resumes plan.session or starts "Simulation N"
"""

from __future__ import annotations

import datetime as _dt
import logging
import os
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from naseview.app.markdown_text import markdown_text
from naseview.editing.controller import EditController
from naseview.editing.session import Session
from naseview.errors import NaseviewError
from naseview.intake.patients import (
    RECONSTRUCTION_FOLDER,
    SIMULATIONS_FOLDER,
    is_patient_id,
    is_simulation_slug,
)
from naseview.pipeline import PipelineResult
from naseview.records import Autosave, PatientRecords, PatientSummary, SimulationInfo

log = logging.getLogger(__name__)

AppState = Callable[[], Mapping[str, Any]]
"""The app's ``app_state`` (what a session stores besides the edits)."""


def summarise(problems: list[str]) -> str:
    """Several problems as one short line: the count and the first one (a moved case
    folder makes every simulation report the same problem; joined, they were one line of
    1,776 characters).

    >>> summarise(["a.json: case folder not found"])
    'a.json: case folder not found'
    >>> summarise(["a.json: x", "b.json: x", "c.json: x"])
    '3 problems; the first: a.json: x'
    >>> summarise([])
    ''
    """
    if len(problems) <= 1:
        return problems[0] if problems else ""
    return f"{len(problems)} problems; the first: {problems[0]}"


@dataclass(frozen=True)
class OpenPlan:
    """How to open a patient (:meth:`PatientWork.begin`).

    Attributes:
        patient_id: the patient.
        case_dir: its case folder (photos), or None.
        reconstruction_dir: its saved reconstruction of that case, or None (reconstruct).
        session: the simulation to reopen exactly, or None (a new one is started).
        problems: one line each for what could not be used.
    """

    patient_id: str
    case_dir: Path | None
    reconstruction_dir: Path | None
    session: Session | None
    problems: tuple[str, ...]


def clock(iso: str | None) -> str:
    """``"10:42"`` of an ISO 8601 time (today), ``"2 Dec 10:42"`` of an earlier day."""
    if not iso:
        return ""
    try:
        t = _dt.datetime.fromisoformat(iso)
    except ValueError:
        return iso[:16]
    now = _dt.datetime.now(t.tzinfo)
    return t.strftime("%H:%M") if t.date() == now.date() else \
        f"{t.day} {t.strftime('%b')} {t.strftime('%H:%M')}"


class PatientWork:
    """The open patient's records (module docstring); one per server.

    Args:
        work_dir: the work folder (default ``$NASEVIEW_WORK_DIR`` or
            ``~/naseview-patients``).

    ``on_change`` listeners run (on any thread) when the patient, its simulation, its
    "Saved" time or its error changed; ``on_list`` when the patient list changed.
    """

    def __init__(self, work_dir: str | os.PathLike[str] | None = None) -> None:
        self.records = PatientRecords(work_dir)
        self.root = self.records.folders.root
        self.patient_id: str | None = None
        self.reconstruction_sha256: str | None = None
        self.autosave: Autosave | None = None
        self.saved_at: str | None = None
        """When the open simulation was last written (ISO 8601)."""
        self.error: str | None = None
        """The last failed save (one line; the previous save is unchanged), or None."""
        self.problems: tuple[str, ...] = ()
        self.on_change: list[Callable[[], None]] = []
        self.on_list: list[Callable[[], None]] = []
        self._resume: tuple[str, Session] | None = None
        self._lock = threading.RLock()

    # what a path names
    def target_of(self, path: str | os.PathLike[str]) -> tuple[str, str | None] | None:
        """``(patient id, simulation slug or None)`` when ``path`` is a patient folder,
        its reconstruction or one of its simulation files in the work folder; else None."""
        real = Path(os.path.realpath(path))
        root = Path(os.path.realpath(self.root))
        if real.parent == root and is_patient_id(real.name) and real.is_dir():
            return real.name, None
        top = real.parent.parent
        if top == root and real.name == RECONSTRUCTION_FOLDER and \
                is_patient_id(real.parent.name):
            return real.parent.name, None
        if top.parent == root and real.parent.name == SIMULATIONS_FOLDER and \
                real.suffix == ".json" and is_patient_id(top.name) and \
                is_simulation_slug(real.stem):
            return top.name, real.stem
        return None

    # opening
    def begin(self, pid: str, slug: str | None = None) -> OpenPlan:
        """Save and stop the open simulation, then find how to open patient ``pid``
        (simulation ``slug``, default its latest usable one, or the newest one as saved
        when a stop came between a new reconstruction and its autosave).

        Raises:
            NaseviewError: no such patient, or its simulation ``slug`` cannot be read.
        """
        opened = self.records.open_patient(pid)
        problems = list(opened.problems)
        session: Session | None = None
        if slug is None:
            slug = _interrupted(opened.simulations, opened.simulation, opened.stale)
        if slug is not None:
            stale = slug in opened.stale
            session = self.records.load_simulation(pid, slug, allow_stale=stale)
            if stale:
                problems = [p for p in problems if p != opened.stale[slug]]
                problems.append(f"{session.record.name if session.record else slug}: made "
                                "on an earlier reconstruction; opened as it was saved")
        elif opened.simulation is not None:
            try:
                session = self.records.load_simulation(pid, opened.simulation.slug)
                slug = opened.simulation.slug
            except NaseviewError as e:
                problems.append(str(e))
        if opened.case_dir is None and session is None:
            raise NaseviewError(summarise(problems) or (
                f"{opened.folder}: the patient has no case and no simulation to open; "
                "open its case folder (naseview serve CASE_DIR)"))
        with self._lock:
            self._stop_autosave()
            self.patient_id = pid
            self.reconstruction_sha256 = opened.reconstruction_sha256 \
                if opened.reconstruction_dir is not None else None
            self._resume = (slug, session) if session is not None and slug else None
            self.saved_at = None
            self.error = None
            self.problems = tuple(problems)
        self._changed()
        return OpenPlan(pid, opened.case_dir, opened.reconstruction_dir, session,
                        tuple(problems))

    def forget(self) -> None:
        """Open something that is not kept (demo, a session file, a baseline): the open
        simulation is saved and stopped first."""
        with self._lock:
            self._stop_autosave()
            self.patient_id = None
            self.reconstruction_sha256 = None
            self._resume = None
            self.saved_at = self.error = None
            self.problems = ()
        self._changed()

    def _stop_autosave(self) -> None:
        auto, self.autosave = self.autosave, None
        if auto is not None:
            if not auto.close():
                log.warning("naseview: %s: the last change could not be saved (%s)",
                            auto.path, auto.error)

    def stop_autosave(self) -> None:
        """Save and stop the open simulation (before deleting it, or a new one)."""
        with self._lock:
            self._stop_autosave()
            self._resume = None

    def reconstructed(self, result: PipelineResult) -> str | None:
        """Keep a reconstruction of the open patient's case (all or nothing); the open
        simulation is then recorded as made on it. Returns its SHA-256 (None: no patient
        is open).

        Raises:
            NaseviewError: it could not be written (the previous one is unchanged).
        """
        pid = self.patient_id
        if pid is None:
            return None
        saved = self.records.save_reconstruction(pid, result)
        with self._lock:
            self.reconstruction_sha256 = saved.sha256
            if self.autosave is not None:
                self.autosave.set_reconstruction(saved.sha256)
        self._listed()
        return saved.sha256

    def attach(self, controller: EditController, app_state: AppState | None = None) -> None:
        """Autosave ``controller`` (just built for the open patient): as the simulation
        :meth:`begin` found, else as a new one ("Simulation N"). A save that fails shows
        as :attr:`error`."""
        with self._lock:
            pid = self.patient_id
            if pid is None:
                return
            self._stop_autosave()
            resume, self._resume = self._resume, None
            if resume is not None:
                slug, session = resume
                auto = self.records.resume_simulation(pid, slug, controller, session,
                                                      app_state=app_state)
                self.saved_at = session.record.modified if session.record else None
            else:
                auto = self.records.start_simulation(
                    pid, controller, reconstruction_sha256=self.reconstruction_sha256,
                    app_state=app_state)
                self.saved_at = _dt.datetime.now().astimezone().isoformat(
                    timespec="seconds")
            auto.on_saved.append(self._saved)
            auto.on_error.append(self._failed)
            self.autosave = auto
        self._changed()
        self._listed()

    def _saved(self, path: Path) -> None:
        self.saved_at = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
        self.error = None
        self._changed()

    def _failed(self, message: str) -> None:
        self.error = message
        self._changed()

    # the open patient's simulations
    @property
    def slug(self) -> str | None:
        """The open simulation, or None."""
        auto = self.autosave
        return auto.slug if auto is not None else None

    def simulations(self) -> list[SimulationInfo]:
        """The open patient's simulations, newest first ([] when none is open)."""
        pid = self.patient_id
        return self.records.simulations(pid) if pid is not None else []

    def require_open(self) -> tuple[str, Autosave]:
        """``(patient id, autosave)`` of the open simulation.

        Raises:
            NaseviewError: nothing kept is open.
        """
        pid, auto = self.patient_id, self.autosave
        if pid is None or auto is None:
            raise NaseviewError("no kept simulation is open (the demo case and session "
                                "files are not kept); open a patient first")
        return pid, auto

    def rename(self, name: str) -> SimulationInfo:
        """Rename the open simulation (written now).

        Raises:
            NaseviewError: an empty or taken name.
        """
        pid, auto = self.require_open()
        info = self.records.rename_simulation(pid, auto.slug, name.strip())
        self._changed()
        self._listed()
        return info

    def duplicate(self) -> SimulationInfo:
        """A copy of the open simulation as it is now (``"<name> (copy)"``-style name)."""
        pid, auto = self.require_open()
        info = self.records.duplicate_simulation(pid, auto.slug)
        self._listed()
        return info

    def delete(self, pid: str, slug: str) -> Path:
        """Move a simulation that is not open to the patient's trash; where it went."""
        where = self.records.delete_simulation(pid, slug)
        self._listed()
        return where

    def patients(self) -> list[PatientSummary]:
        """Every patient, newest first, with its simulations."""
        return self.records.list_patients()

    # what the page says
    def status_markdown(self) -> str:
        """One line: the open patient and simulation, where it is kept, when saved."""
        pid, auto = self.patient_id, self.autosave
        if pid is None:
            return ("Not kept: the demo case, a session file or a reconstruction folder "
                    f"opened directly. Patients are kept in {markdown_text(str(self.root))}.")
        where = markdown_text(str(self.records.folders.patient_dir(pid)))
        if auto is None:
            return f"Patient **{markdown_text(pid)}** — kept in {where}"
        saved = f" · Saved {clock(self.saved_at)}" if self.saved_at else ""
        return (f"Patient **{markdown_text(pid)}** · **{markdown_text(auto.name)}**{saved} — "
                f"kept in {where}")

    def _changed(self) -> None:
        _call_each(self.on_change, "patient-work")

    def _listed(self) -> None:
        _call_each(self.on_list, "patient-list")

    def close(self) -> None:
        """Write and stop every autosave (server shutdown)."""
        with self._lock:
            self._stop_autosave()
        self.records.close()


def _interrupted(listed: tuple[SimulationInfo, ...], latest: SimulationInfo | None,
                 stale: Mapping[str, str]) -> str | None:
    """The simulation to reopen as saved after a stop between two commits, or None.

    A parameter change commits the new reconstruction first and the simulation follows
    with its next autosave; a crash (or kill) in between leaves the newest simulation
    recorded on the previous reconstruction. It is still the surgeon's latest work: it
    reopens on its own saved baseline (edits and parameters as last saved) rather than
    an empty "Simulation N" being started."""
    newest = next((i for i in listed if i.problem is None), None)
    if newest is None or newest.slug not in stale or newest.reconstruction_sha256 is None:
        return None
    if latest is not None and latest.modified_ns >= newest.modified_ns:
        return None
    return newest.slug


def _call_each(listeners: list[Callable[[], None]], what: str) -> None:
    """Call every listener; one that fails is logged and never stops the others."""
    for fn in list(listeners):
        try:
            fn()
        except Exception:
            log.debug("naseview: a %s listener failed", what, exc_info=True)


__all__ = ["AppState", "OpenPlan", "PatientWork", "clock"]
