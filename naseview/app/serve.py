"""``naseview serve``: the browser app (viser) around an :class:`EditController`.

:class:`NaseviewApp` opens a case directory (reconstructed in the background by the
pipeline, stages 1-3 of the paper, with progress in every tab), a reconstruction directory
(``reconstruction.json`` + ``face.ply`` + ``nose.ply``) or a session file, and serves every
browser tab that connects. The case, its one editor (the patient's simulation) and the
background jobs are shared; each tab is a :class:`~naseview.app.screen.Screen` with its
own panels (:mod:`naseview.app.panels`), scene (:mod:`naseview.app.scene`), camera and
patient mode, so every tab sees the same simulation and each other's edits, never each
other's view. Dragging a landmark re-runs stage 3's ARAP deformation (paper §3.4) through
:mod:`naseview.editing`. ``naseview serve`` opens the page in the browser unless
``--no-browser``; ``--new`` opens nothing and starts every tab on the new-patient page.

Security: binds 127.0.0.1 unless ``--host`` says otherwise; the server
(:func:`naseview.app.guard.guarded_viser_server`) answers only its own page on its own host
names (another site's page, a DNS-rebinding name: 403) and refuses share-tunnel requests
whatever a client sends.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import re
import signal
import threading
import time
import traceback
import webbrowser
from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any, TypeVar

import cv2
import numpy as np
import viser

from naseview.app.export import (
    landmarks_csv,
    landmarks_json,
    measurements_csv,
    measurements_json,
    mesh_file,
)
from naseview.app.face_look import face_look
from naseview.app.guard import guarded_viser_server
from naseview.app.gui_value import set_value
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.landmark_names import display_name
from naseview.app.markdown_text import markdown_text
from naseview.app.memory import limit_malloc_arenas, release_freed_memory
from naseview.app.patient_work import PatientWork
from naseview.app.patients_panel import PatientsPanel
from naseview.app.screen import PATIENT_SCREEN_PATH, Screen, connection_path, nose_view
from naseview.camera import Camera
from naseview.case import Case, read_case
from naseview.editing.baseline import (
    Baseline,
    Solver,
    baseline_from_output_dir,
    baseline_from_pipeline,
)
from naseview.editing.controller import EditController
from naseview.editing.session import Session, is_session_file, load_session
from naseview.editing.solver import NoseEditSolver
from naseview.errors import NaseviewError
from naseview.facemodel import store
from naseview.facemodel.ict import ICT_CREDIT
from naseview.intake.patients import PatientFolders
from naseview.landmarks import LANDMARKS
from naseview.measurements import Estimate, calliper_inputs, estimated_measurements
from naseview.pipeline import PipelineParams, PipelineResult, reconstruct
from naseview.reconstruction import calliper_distances, output_case_dir
from naseview.stage1_landmarks import SfmResult
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams

log = logging.getLogger(__name__)

SolverFactory = Callable[[Baseline, RefineParams, int], tuple[Solver, list[str], np.ndarray]]
"""``(baseline, refine_params, interactive_iterations) -> (solver, editable landmark ids,
moving vertex ids)``."""

STAGE_LABELS: dict[int, str] = {1: "landmarks (bundle adjustment)", 2: "curves",
                                3: "mesh (ARAP)"}
"""What the progress line calls each pipeline stage while it runs."""

SHUTDOWN_WAIT_S = 60.0
"""Ctrl-C: how long ``naseview serve`` waits for a running reconstruction to finish."""

DRAG_ITERATIONS = 6
"""ARAP iterations per update during a drag (the panel's starting value)."""

_P = TypeVar("_P", CurveParams, RefineParams)


def demo_case_dir() -> Path:
    """The bundled demo case (``assets/demo-case`` beside the package)."""
    return Path(__file__).resolve().parents[2] / "assets" / "demo-case"


def _photo_thumb(image_bgr: np.ndarray, width: int = 320) -> np.ndarray:
    """(h, ``width``, 3) uint8 RGB thumbnail of a BGR photo (for the camera frustums)."""
    h, w = image_bgr.shape[:2]
    s = width / float(w)
    small = cv2.resize(image_bgr, (width, max(1, int(round(h * s)))),
                       interpolation=cv2.INTER_AREA)
    return small[:, :, ::-1].copy()


def _default_solver_factory(baseline: Baseline, refine_params: RefineParams,
                            interactive_iterations: int) -> tuple[Solver, list[str], np.ndarray]:
    """:class:`NoseEditSolver` on ``baseline``: its editable landmarks and moving region."""
    s = NoseEditSolver(baseline, refine_params, interactive_iterations=interactive_iterations)
    return s, s.editable, s.region_ids


def _typed(params: CurveParams | RefineParams, values: Mapping[str, Any]) -> dict[str, Any]:
    """Panel values with integers rounded where the parameter field is an ``int``."""
    out = {}
    for k, v in values.items():
        cur = getattr(params, k)
        out[k] = int(round(v)) if isinstance(cur, int) and not isinstance(cur, bool) else v
    return out


def _with_saved(params: _P, saved: Mapping[str, Any], where: str) -> _P:
    """``params`` with the values a session saved (fields it no longer has are logged and
    left out: a session outlives a renamed parameter)."""
    names = {f.name for f in fields(params)}
    unknown = sorted(set(saved) - names)
    if unknown:
        log.warning("naseview: %s: parameters %s are not fields of %s; left out", where,
                    ", ".join(unknown), type(params).__name__)
    return replace(params, **{k: v for k, v in saved.items() if k in names})


def _numbers(params: CurveParams | RefineParams) -> dict[str, int | float | str | bool]:
    """The plain-valued fields of a params object (what a session file stores)."""
    out: dict[str, int | float | str | bool] = {}
    for f in fields(params):
        v = getattr(params, f.name)
        if isinstance(v, (int, float, str, bool)):
            out[f.name] = v
    return out


def _credit(model: str | None, result: PipelineResult) -> str:
    """Attribution line of the face model used by stage 3."""
    refined = result.refined
    if refined is not None and refined.credit:
        return str(refined.credit)
    name = (refined.model_name if refined is not None else None) or model
    if name == "ict" or (name is None and store.find_ict_npz() is not None):
        return ICT_CREDIT
    return ""


def _suspect_messages(sfm: SfmResult | None) -> list[str]:
    """One line per click stage 1 flagged as suspect."""
    return [s.message() for s in sfm.suspect_clicks] if sfm is not None else []


def reconstruction_summary(case_id: str, seconds: float, rmse_px: float | None,
                           warnings: list[str], most: int = 6) -> str:
    """The status a surgeon reads after a reconstruction: a plain first line, then the
    pipeline's warnings as "notes to check" with landmarks named in words.

    >>> print(reconstruction_summary("P001", 1.23, 0.85,
    ...       ["landmark 'int_l' is clicked in photo 'left' only; click it in a second photo"]))
    **P001** is ready (reconstructed in 1.2 s; the clicks fit the photos to 0.85 px).
    <BLANKLINE>
    Notes to check (1):
    - landmark Alar groove, top (L) is clicked in photo 'left' only; click it in a second photo
    """
    fit = f"; the clicks fit the photos to {rmse_px:.2f} px" if rmse_px is not None else ""
    lines = [f"**{case_id}** is ready (reconstructed in {seconds:.1f} s{fit})."]
    if warnings:
        lines += ["", f"Notes to check ({len(warnings)}):"]
        lines += [f"- {_named(w.removeprefix('stage 3: '))}" for w in warnings[:most]]
    return "\n".join(lines)


def _named(text: str) -> str:
    """``text`` with each quoted landmark id (``'int_l'``) replaced by its readable name."""
    return re.sub(r"'([a-z]+(?:_[lr])?)'",
                  lambda m: display_name(m.group(1)) if m.group(1) in LANDMARKS
                  else m.group(0), text)


class NaseviewApp:
    """The served app: the patient's case, editor and background jobs, and one
    :class:`~naseview.app.screen.Screen` per browser tab.

    Every tab gets its own panels, scene, camera and patient mode (built when it connects,
    released when it goes); all of them show the one case and its one simulation, so an
    edit, Undo, Redo or Reset in any tab shows in every tab. Job progress and status
    reach every tab; a job's error is shown in the tab that started it.

    Args:
        server: a ``viser.ViserServer``.
        model: face model name for reconstruction (``None``: ICT if installed).
        solver_factory: ``(baseline, refine_params, interactive_iterations) -> (solver,
            editable ids, moving vertex ids)``; default :class:`NoseEditSolver`.
        work_dir: where new patients are kept (default ``$NASEVIEW_WORK_DIR`` or
            ``~/naseview-patients``).
    """

    def __init__(self, server: viser.ViserServer, model: str | None = None,
                 solver_factory: SolverFactory | None = None,
                 work_dir: str | Path | None = None) -> None:
        self.server = server
        self.model = model
        self.solver_factory: SolverFactory = solver_factory or _default_solver_factory
        self.controller: EditController | None = None
        self.case: Case | None = None
        self.case_id = "case"
        self.source: Path | None = None
        self.credit = ""
        self.curve_params = CurveParams()
        self.refine_params = RefineParams()
        self.interactive_iterations = DRAG_ITERATIONS
        self.suspect_messages: list[str] = []
        self.photos_note = "No photos: the case directory is not available."
        self.edit_help = ""
        # what every tab's scene is built from (set by an install)
        self.editable: list[str] = []
        self.moving = np.zeros(0, dtype=np.int64)
        self.cameras: dict[str, Camera] = {}
        self.photos: dict[str, np.ndarray] = {}
        self.start_new_patient = False
        """A tab that connects while no case is open starts on the new-patient page."""
        self.work_dir = PatientFolders(work_dir).root
        self.work = PatientWork(self.work_dir)
        """The open patient's kept work (reconstruction, autosaved simulation)."""
        self.patients_panels: dict[int, PatientsPanel] = {}
        self.diagrams = LandmarkDiagrams(model)
        self.screens: dict[int, Screen] = {}
        self.status = "Starting…"
        self.progress: float | None = None
        self._symmetric = False
        self._job_lock = threading.Lock()
        self._job_seq = 0
        self._param_timer: threading.Timer | None = None
        self._param_asker: Screen | None = None
        self._changed_stages: set[str] = set()
        self._fresh = True
        self._closed = False
        self._lock = threading.RLock()
        self._ready = threading.Event()
        server.scene.set_up_direction("+y")
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    # tabs
    def _connect(self, client: viser.ClientHandle) -> None:
        """A tab connected: its screen, showing the case (or the new-patient page)."""
        patient = connection_path(self.server, client) == PATIENT_SCREEN_PATH
        with self._lock:
            if self._closed:
                return
            try:
                screen = Screen(self, client, patient_screen=patient)
                screen.set_status(self.status)
                screen.set_progress(self.progress)
                if client.client_id not in self.server.get_clients():
                    screen.close()                    # it went while being built
                    return
                self.screens[client.client_id] = screen
                self.patients_panels[client.client_id] = PatientsPanel(screen)
                if self.controller is not None:
                    screen.show_case()
                elif self.start_new_patient and self.controller is None and not patient:
                    screen.show_new_patient()
            except Exception:  # a tab that vanished mid-build must not break the server
                log.warning("naseview: a tab could not be set up:\n%s",
                            traceback.format_exc())

    def _disconnect(self, client: viser.ClientHandle) -> None:
        """A tab went away: release its screen (listeners, turntable, page threads)."""
        with self._lock:
            screen = self.screens.pop(client.client_id, None)
            panel = self.patients_panels.pop(client.client_id, None)
        if panel is not None:
            panel.close()
        if screen is not None:
            screen.close()
        release_freed_memory()

    @property
    def calliper_inputs(self) -> set[str]:
        """Measurement names that are calliper distances typed at intake (the open case's
        ``scale_mm``, and the reconstruction's echo of it): labelled inputs, never
        findings."""
        keys = [f"{a}-{b}" for a, b in self.case.scale_mm] if self.case is not None else []
        ctl = self.controller
        rec = ctl.baseline.reconstruction if ctl is not None else None
        if rec is not None:
            keys += list(calliper_distances(rec))
        return calliper_inputs(keys)

    @property
    def estimated(self) -> dict[str, Estimate]:
        """Measurements of the open reconstruction to show as estimates with their
        uncertainty (:func:`naseview.measurements.estimated_measurements`: radix height
        when mf is seen in one photo); none without a reconstruction record."""
        ctl = self.controller
        rec = ctl.baseline.reconstruction if ctl is not None else None
        return estimated_measurements(rec.landmarks, rec.extra) if rec is not None else {}

    def screen_of(self, client: viser.ClientHandle | int) -> Screen | None:
        """The screen of a tab (a client or its id), None when it is gone."""
        cid = client if isinstance(client, int) else client.client_id
        return self.screens.get(cid)

    def _each_screen(self, fn: Callable[[Screen], None]) -> None:
        """``fn(screen)`` for every open tab; a tab that fails (gone) is skipped."""
        for screen in list(self.screens.values()):
            try:
                fn(screen)
            except Exception:
                log.debug("naseview: a tab did not take an update", exc_info=True)

    def set_status(self, text: str) -> None:
        """The status line of every tab (and of tabs that connect later)."""
        self.status = text
        self._each_screen(lambda s: s.set_status(text))

    def set_progress(self, fraction: float | None) -> None:
        """The progress bar of every tab (``None`` hides it)."""
        self.progress = fraction
        self._each_screen(lambda s: s.set_progress(fraction))

    def show_error(self, message: str | None, asker: Screen | None = None) -> None:
        """An error in the tab that asked (when it is still open), else in every tab;
        ``None`` clears the error line everywhere."""
        if message and asker is not None and not asker.closed:
            asker.show_error(message)
            return
        self._each_screen(lambda s: s.show_error(message))

    def annotated_elsewhere(self, folder: Path, screen: Screen) -> bool:
        """Whether a tab other than ``screen`` annotates the unfinished patient in
        ``folder`` (two tabs never write one annotation)."""
        for other in list(self.screens.values()):
            page = other.annotate
            if other is screen or page is None or page.session is None:
                continue
            if Path(page.session.folder).resolve() == Path(folder).resolve():
                return True
        return False

    # opening
    def open(self, path: Path | None, asker: Screen | None = None) -> None:
        """Open a case directory, a reconstruction directory or a session file
        (``None``: the bundled demo case) for every tab; ``asker`` is the tab that
        asked (it gets the errors). Case directories reconstruct in the background."""
        if path is None:
            path = demo_case_dir()
            if not (path / "case.json").is_file():
                raise NaseviewError(f"{path}: the bundled demo case is missing; pass a case "
                                    "directory: naseview serve CASE_DIR")
        path = Path(path)
        target = self.work.target_of(path)
        if target is not None:                 # a patient folder or one of its simulations
            self.open_patient(target[0], target[1], asker)
            return
        if (path / "case.json").is_file() and not _same_path(path, demo_case_dir()):
            self.open_patient(self.work.records.patient_for_case(path), None, asker)
            return
        self._fresh = True  # a new case: new editor (a recompute keeps the edits)
        self.work.forget()  # the demo, a session file, a reconstruction folder: not kept
        self.source = path
        if path.is_file() and is_session_file(path):
            self._open_session(path, asker)
        elif path.is_file():
            raise NaseviewError(f"{path}: not a naseview session file (format "
                                "'naseview.session/1'); pass a case directory, a "
                                "reconstruction directory or a session .json")
        elif (path / "reconstruction.json").is_file():
            self._open_reconstruction(path, asker)
        elif (path / "case.json").is_file():
            self.case = read_case(path)
            self.case_id = self.case.id
            self.reconstruct(asker)
        else:
            raise NaseviewError(f"{path}: no case.json, reconstruction.json or session "
                                "file here; pass a case directory (SPEC §3), a `naseview "
                                "reconstruct` output directory or a session file")

    def open_patient(self, pid: str, slug: str | None = None,
                     asker: Screen | None = None) -> None:
        """Open patient ``pid`` of the work folder for every tab: simulation ``slug``
        (default its latest), on its saved reconstruction when that was made from its
        case as it is now (no pipeline run), else reconstructed (and saved) first. The
        simulation open until now is saved first.

        Raises:
            NaseviewError: no such patient, an unreadable simulation, or a patient
                without a case or simulation.
        """
        plan = self.work.begin(pid, slug)
        self._fresh = True
        self.source = plan.case_dir or self.work.records.folders.patient_dir(pid)
        self.suspect_messages = []
        if plan.problems:
            self.show_error(" · ".join(plan.problems), asker)
        session = plan.session
        if plan.case_dir is not None:
            self._open_case_from(lambda: plan.case_dir)
        else:
            self._open_case_from(lambda: None)
        self.case_id = self.case.id if self.case is not None else pid
        if session is not None:
            self._apply_param_values(session.app.get("params", {}), str(session.path))
            self.credit = str(session.app.get("credit", self.credit))
            name = session.record.name if session.record else slug
            self.set_status(f"Patient **{pid}**: opening {name}…")
            self._start_job(lambda seq: self._install(session.baseline, session, seq),
                            "Opening the simulation", asker)
        elif plan.reconstruction_dir is not None:
            folder = plan.reconstruction_dir
            self.set_status(f"Patient **{pid}**: opening the saved reconstruction…")

            def job(seq: int) -> None:
                baseline = baseline_from_output_dir(folder)
                rec = baseline.reconstruction
                mesh = rec.extra.get("mesh", {}) if rec else {}
                self.credit = str(mesh.get("credit", "") if isinstance(mesh, dict) else "")
                self._install(baseline, None, seq)

            self._start_job(job, "Opening the patient", asker)
        else:
            self.reconstruct(asker)

    def new_simulation(self, asker: Screen | None = None) -> None:
        """A new simulation of the open patient: its reconstruction without edits,
        autosaved as "Simulation N" (the open one is saved first)."""
        ctl = self.controller
        self.work.require_open()
        if ctl is None:
            raise NaseviewError("nothing is open yet: wait for the reconstruction")
        self.work.stop_autosave()
        self._fresh = True
        baseline = ctl.baseline
        self._start_job(lambda seq: self._install(baseline, None, seq), "New simulation",
                        asker)

    def duplicate_simulation(self, asker: Screen | None = None) -> None:
        """A copy of the open simulation as it is now; the copy is opened."""
        pid, _ = self.work.require_open()
        info = self.work.duplicate()
        self.open_patient(pid, info.slug, asker)

    def delete_simulation(self, asker: Screen | None = None) -> Path:
        """Move the open simulation to the patient's trash and open the latest other one
        (a new one when there is none); returns where it went."""
        pid, auto = self.work.require_open()
        gone = auto.slug
        others = [i for i in self.work.simulations() if i.slug != gone and i.problem is None
                  and i.reconstruction_sha256 == self.work.reconstruction_sha256]
        if others:
            self.work.stop_autosave()
            where = self.work.delete(pid, gone)
            self.open_patient(pid, others[0].slug, asker)
        else:
            self.new_simulation(asker)
            where = self.work.delete(pid, gone)
        return where

    def _open_session(self, path: Path, asker: Screen | None) -> None:
        """A saved session: its baseline and edits exactly, photos from its case."""
        session = load_session(path)
        self._open_case_from(session.case_folder)
        self.case_id = str(session.app.get("case_id", path.stem))
        self.credit = str(session.app.get("credit", ""))
        self._apply_param_values(session.app.get("params", {}), str(path))
        self.set_status(f"Session **{path.name}** ({self.case_id})")
        self._start_job(lambda seq: self._install(session.baseline, session, seq),
                        "Opening session", asker)

    def _open_reconstruction(self, path: Path, asker: Screen | None) -> None:
        """``naseview reconstruct`` output: its baseline, photos from the case it names."""
        baseline = baseline_from_output_dir(path)
        rec = baseline.reconstruction
        self._open_case_from(lambda: output_case_dir(path, rec) or (
            path if (path / "case.json").is_file() else None))
        self.case_id = self.case.id if self.case is not None else path.name
        mesh = rec.extra.get("mesh", {}) if rec else {}
        self.credit = str(mesh.get("credit", "") if isinstance(mesh, dict) else "")
        self.set_status(f"Reconstruction **{path.name}**")
        self._start_job(lambda seq: self._install(baseline, None, seq), "Loading", asker)

    def open_baseline(self, baseline: Baseline, case: Case | None = None,
                      case_id: str = "case", credit: str = "") -> None:
        """Edit an in-memory :class:`Baseline` (tests, benchmarks, notebooks); ``case``
        optionally supplies the photos. Installs in the background like :meth:`open`."""
        self.work.forget()
        self.case = case
        self.case_id = case_id
        self.credit = credit
        self._fresh = True
        self._start_job(lambda seq: self._install(baseline, None, seq), "Loading")

    def wait_ready(self, timeout: float = 60.0) -> bool:
        """Block until the last background job (opening, reconstruction, recompute) has
        finished and the editor is idle; False on timeout or when nothing is open."""
        end = time.monotonic() + timeout
        if not self._ready.wait(timeout) or self.controller is None:
            return False
        return self.controller.wait_idle(max(0.1, end - time.monotonic()))

    def _open_case_from(self, find: Callable[[], Path | None]) -> None:
        """Photos of the case directory ``find()`` names, checked to stay inside its
        folder (optional for editing)."""
        self.case = None
        self.photos_note = "No photos: the case directory is not available."
        try:
            case_dir = find()
            if case_dir is not None:
                self.case = read_case(case_dir)
        except NaseviewError as e:  # photos are optional for editing
            log.warning("naseview: photos unavailable: %s", e)
            self.photos_note = f"Photos unavailable: {e}"

    # background jobs
    def _start_job(self, fn: Callable[[int], None], label: str,
                   asker: Screen | None = None) -> None:
        """Run ``fn(seq)`` on a background thread; a later job supersedes it. Progress
        goes to every tab, an error to ``asker`` (the tab that asked) when it is open."""
        with self._job_lock:
            self._job_seq += 1
            seq = self._job_seq
            self._ready.clear()

        def run() -> None:
            self.set_progress(0.02)
            self.set_status(f"{label}…")
            try:
                fn(seq)
            except Exception as e:
                log.error("naseview: %s failed:\n%s", label, traceback.format_exc())
                if seq == self._job_seq:
                    msg = str(e) if isinstance(e, NaseviewError) else f"{type(e).__name__}: {e}"
                    self.show_error(f"{label} failed: {msg}", asker)
                    self.set_status(f"{label} failed.")
            finally:
                if seq == self._job_seq:
                    self.set_progress(None)
                    self._ready.set()

        threading.Thread(target=run, name=f"naseview-{label}", daemon=True).start()

    def reconstruct(self, asker: Screen | None = None) -> None:
        """Run the pipeline on the case in the background (progress in every tab)."""
        if self.case is None:
            raise NaseviewError("no case directory is open; recompute needs the photos "
                                "and clicks (open the case directory)")
        self._start_job(self._reconstruct_job, "Reconstruction", asker)

    def _reconstruct_job(self, seq: int) -> None:
        assert self.case is not None
        stages = (1, 2, 3)
        done: list[str] = []

        def progress(stage: str, seconds: float) -> None:
            """``progress(stage_name, seconds)`` after each stage (pipeline contract)."""
            if seq != self._job_seq:
                return
            done.append(f"{stage} {seconds:.1f} s")
            self.set_progress(0.05 + 0.85 * len(done) / len(stages))
            nxt = STAGE_LABELS.get(len(done) + 1)
            self.set_status("Reconstruction: " + ", ".join(done)
                            + (f"; running {nxt}…" if nxt else "; building the editor…"))

        self.set_status(f"Reconstruction: running {STAGE_LABELS[1]}…")
        t0 = time.perf_counter()
        result = reconstruct(self.case, self.model, stages,
                             PipelineParams(curves=self.curve_params, refine=self.refine_params),
                             progress)
        if seq != self._job_seq:
            return
        self.suspect_messages = _suspect_messages(result.sfm)
        self.credit = _credit(self.model, result)
        try:
            self.work.reconstructed(result)    # kept in the patient folder (all or nothing)
        except NaseviewError as e:
            self.show_error(f"The reconstruction was not saved: {e}")
        baseline = baseline_from_pipeline(result)
        self.set_progress(0.92)
        self._install(baseline, None, seq)
        rmse = baseline.reconstruction.reprojection_rmse_px if baseline.reconstruction else None
        self.set_status(reconstruction_summary(self.case_id, time.perf_counter() - t0, rmse,
                                               list(result.warnings)))

    # installing
    def _install(self, baseline: Baseline, session: Session | None, seq: int) -> None:
        """Build the solver and controller for ``baseline``, then every tab's scene (job
        thread)."""
        solver, editable, moving = self.solver_factory(
            baseline, self.refine_params, int(self.interactive_iterations))
        if seq != self._job_seq:
            return
        with self._lock:
            previous = self.controller
            ctl = self._controller_for(baseline, session, solver)
            lim = self.refine_params.max_handle_displacement_mm
            ctl.max_displacement_mm = float(lim) if lim else None
            if session is not None:
                self._symmetric = ctl.symmetric
            else:
                ctl.set_symmetric(self._symmetric)
            self.editable = [i for i in editable if i in baseline.landmarks]
            self.moving = np.asarray(moving, dtype=np.int64)
            self.cameras = dict(baseline.reconstruction.cameras) \
                if baseline.reconstruction else {}
            self.photos = self._thumbnails(self.cameras)
            fixed = [k for k in baseline.landmarks if k not in self.editable]
            self.edit_help = ("Drag a **red** sphere to reshape the nose"
                              + (f" (grey = fixed: {', '.join(fixed)})" if fixed else "")
                              + "; the arrow on the selected sphere moves it in or out.")
            self._initial_camera(baseline)
            self._each_screen(lambda s: s.show_case())   # the editor now, in plain skin
        if ctl is not previous:          # a new editor: autosaved (a rebase keeps its own)
            try:
                self.work.attach(ctl, self.app_state)
            except NaseviewError as e:
                self.show_error(f"The simulation is not being saved: {e}")
        kept = self.work.autosave
        if kept is not None and ctl is not previous and (session is not None or
                                                          self.work.reconstruction_sha256):
            what = "reopened" if session is not None else "started on the saved reconstruction"
            self.set_status(f"**{markdown_text(self.case_id)}**: {markdown_text(kept.name)} "
                            f"{what}.")
        elif session is not None:
            self.set_status(f"Session **{self.case_id}** reopened.")
        elif self.case is None or self.source is not None and \
                (self.source / "reconstruction.json").is_file():
            self.set_status(f"**{self.case_id}** loaded.")
        self._bake_look(seq)

    def _bake_look(self, seq: int) -> None:
        """Bake the photo texture (once for every tab) after the editor is up, then show
        it in every tab, keeping each tab's view (job thread; the bake takes longer than
        everything else the install does, issue 27 item 6)."""
        if self.status.endswith("building the editor…"):
            self.set_status(self.status.replace(
                "building the editor…", "texturing the face from the photos (the editor "
                "is ready)…"))
        look = face_look(self)          # baked once here for every tab
        if seq != self._job_seq or look is None or look.texture is None:
            return                         # (untextured: the plain skin shown is it)
        with self._lock:
            self._each_screen(lambda s: s.show_case(keep_camera=True))

    def _controller_for(self, baseline: Baseline, session: Session | None,
                        solver: Solver) -> EditController:
        """A new controller (new case or session), or the current one rebased on a
        recomputed ``baseline`` so that the edits carry over."""
        fresh, self._fresh = self._fresh, False
        if self.controller is not None and session is None and not fresh:
            self.controller.rebase(baseline, solver)
            return self.controller
        if self.controller is not None:
            self.controller.close()
        ctl = (EditController.from_session(session, solver) if session is not None
               else EditController(baseline, solver))
        ctl.on_error.append(lambda message: self.show_error(message))
        self.controller = ctl
        return ctl

    def _thumbnails(self, cameras: Mapping[str, Camera]) -> dict[str, np.ndarray]:
        """Photo thumbnails of the reconstructed views (for the camera frustums)."""
        photos: dict[str, np.ndarray] = {}
        if self.case is not None:
            for v in cameras:
                try:
                    photos[v] = _photo_thumb(self.case.load_image(v))
                except NaseviewError:
                    pass
        return photos

    def _initial_camera(self, baseline: Baseline) -> None:
        """The view a new tab starts with (and its Reset View): the nose (tabs already
        open keep theirs; each screen frames its own)."""
        target, eye, fov = nose_view(baseline)
        cam = self.server.initial_camera
        cam.fov = fov
        cam.near = 1.0
        cam.far = 5000.0
        cam.look_at = (float(target[0]), float(target[1]), float(target[2]))
        cam.position = (float(eye[0]), float(eye[1]), float(eye[2]))
        cam.up = (0.0, 1.0, 0.0)

    # the patient's shared settings
    def set_symmetric(self, on: bool) -> None:
        """Symmetric mode of the patient's editor (every tab's checkbox follows)."""
        self._symmetric = bool(on)
        if self.controller is not None:
            self.controller.set_symmetric(on)

    def params_changed(self, stage: str, asker: Screen | None = None) -> None:
        """A parameter input changed in ``asker``'s panel (``stage``: ``"curves"``,
        ``"refine"`` or ``"app"``): recompute after a short pause (debounced); ``"app"``
        alone (drag iterations) rebuilds only the edit solver."""
        self._changed_stages.add(stage)
        self._param_asker = asker
        if self._param_timer is not None:
            self._param_timer.cancel()
        self._param_timer = threading.Timer(0.6, self._recompute_shown)
        self._param_timer.daemon = True
        self._param_timer.start()

    def _recompute_shown(self) -> None:
        """:meth:`recompute` from the debounce timer: an invalid value is shown in the
        tab that typed it (the parameters keep their last valid values)."""
        asker = self._param_asker
        try:
            self.recompute(asker)
        except NaseviewError as e:
            self.show_error(str(e), asker)

    def _apply_param_values(self, values: Mapping[str, Any], where: str) -> None:
        """The stage 2 / stage 3 parameters a session saved (``{"curves": {...},
        "refine": {...}}``), then every tab's parameter inputs rebuilt for them."""
        if values.get("curves"):
            self.curve_params = _with_saved(self.curve_params, values["curves"], where)
        if values.get("refine"):
            self.refine_params = _with_saved(self.refine_params, values["refine"], where)
        self._each_screen(lambda s: s.panels.build_params(self.curve_params,
                                                          self.refine_params))

    def recompute(self, asker: Screen | None = None) -> None:
        """Apply ``asker``'s parameter panel (default: the values already taken): re-run
        the pipeline (case open) or rebuild the edit solver (session / reconstruction
        without photos); the other tabs' inputs follow.

        Raises:
            NaseviewError: a panel value outside its parameter's range.
        """
        stages, self._changed_stages = self._changed_stages, set()
        if asker is not None and not asker.closed:
            v2, v3 = asker.panels.param_values()
            if v2:
                self.curve_params = replace(self.curve_params, **_typed(self.curve_params, v2))
            if v3:
                self.refine_params = replace(self.refine_params,
                                             **_typed(self.refine_params, v3))
            self.interactive_iterations = int(asker.panels.interactive_iters.value)
            self._mirror_params(asker)
        if self.case is not None and stages != {"app"}:
            self.reconstruct(asker)
            return
        ctl = self.controller
        if ctl is None:
            return

        def job(seq: int) -> None:
            solver, _, _ = self.solver_factory(ctl.baseline, self.refine_params,
                                               int(self.interactive_iterations))
            if seq == self._job_seq:
                ctl.set_solver(solver)
                self.set_status("Edit solver rebuilt with the new parameters.")

        self._start_job(job, "Recompute", asker)

    def _mirror_params(self, source: Screen) -> None:
        """Every other tab's parameter inputs show the values ``source`` set."""
        def mirror(s: Screen) -> None:
            if s is not source:
                s.panels.build_params(self.curve_params, self.refine_params)
                set_value(s.panels.interactive_iters, self.interactive_iterations)
        self._each_screen(mirror)

    # export
    def app_state(self) -> dict[str, Any]:
        """What a session file stores besides the editor state."""
        return {"case_id": self.case_id,
                "case_dir": str(self.case.root) if self.case is not None else None,
                "model": self.model, "credit": self.credit,
                "params": {"curves": _numbers(self.curve_params),
                           "refine": _numbers(self.refine_params)}}

    def file_for(self, kind: str, fmt: str, part: str = "face",
                 state: str = "simulated") -> tuple[str, bytes]:
        """(file name, content) of an export: ``kind`` ``"mesh"`` (``fmt`` a mesh type;
        ``part`` face or nose, ``state`` simulated or original), ``"landmarks"`` /
        ``"measurements"`` (json or csv) or ``"session"``."""
        ctl = self.controller
        if ctl is None:
            raise NaseviewError("nothing to export yet: the reconstruction is not ready")
        name = self.case_id.replace("/", "_") or "case"
        if kind == "mesh":
            return f"{name}-{part}-{state}.{fmt}", self._mesh_export(ctl, fmt, part, state)
        if kind == "landmarks":
            base = ctl.baseline
            lms = ctl.simulation.drawn(ctl.landmarks)   # on the simulated surface
            data = (landmarks_json(lms, base.landmarks, self.case_id) if fmt == "json"
                    else landmarks_csv(lms, base.landmarks))
            return f"{name}-landmarks.{fmt}", data
        if kind == "measurements":
            before, after = ctl.baseline.measurements, ctl.simulation.measurements
            data = (measurements_json(before, after, self.case_id) if fmt == "json"
                    else measurements_csv(before, after))
            return f"{name}-measurements.{fmt}", data
        if kind == "session":
            ctl.wait_idle(10.0)
            obj = ctl.session_json(self.app_state())
            data = json.dumps(obj, separators=(",", ":"), allow_nan=False).encode("utf-8")
            return f"{name}-session.json", data
        raise ValueError(f"unknown export {kind!r}")

    @staticmethod
    def _mesh_export(ctl: EditController, fmt: str, part: str, state: str) -> bytes:
        """Mesh file of the simulated or original face or nose."""
        base = ctl.baseline
        V = ctl.simulation.V if state == "simulated" else base.V
        return mesh_file(V, base.F, fmt, base.nose_ids if part == "nose" else None)

    def download(self, client: viser.ClientHandle | None, kind: str, fmt: str,
                 **kw: str) -> None:
        """Send an export (:meth:`file_for`) to ``client`` (``None``: every browser)."""
        fname, data = self.file_for(kind, fmt, **kw)
        target = client if client is not None else self.server
        target.send_file_download(fname, data, save_immediately=True)

    def close(self) -> None:
        """Release every tab's screen and the editor (the server is the caller's)."""
        with self._lock:
            self._closed = True
            screens, self.screens = list(self.screens.values()), {}
        for screen in screens:
            screen.close()
        if self._param_timer is not None:
            self._param_timer.cancel()
        try:
            self.work.close()                   # the last change is on disk
        except Exception:
            log.warning("naseview: saving on shutdown failed:\n%s", traceback.format_exc())
        if self.controller is not None:
            self.controller.close()


def _same_path(a: Path, b: Path) -> bool:
    """Whether two paths name the same folder (symbolic links followed)."""
    return Path(os.path.realpath(a)) == Path(os.path.realpath(b))


def start_app(path: Path | None, host: str = "127.0.0.1", port: int = 8080,
              model: str | None = None,
              solver_factory: SolverFactory | None = None,
              new_patient: bool = False) -> tuple[viser.ViserServer, NaseviewApp]:
    """Start the server and open ``path`` (``None``: the bundled demo case); returns
    ``(server, app)`` (non-blocking). With ``new_patient`` and no ``path`` nothing is
    opened: every tab starts on the new-patient page.

    Raises:
        NaseviewError: ``host``:``port`` cannot be listened on (busy port, port out of
            range, an address that is not this computer's).
    """
    limit_malloc_arenas()            # a tab's memory is reused by the next (app.memory)
    server = guarded_viser_server(host, port, verbose=False)
    try:
        app = NaseviewApp(server, model=model, solver_factory=solver_factory)
        app.start_new_patient = new_patient
        if path is not None or not new_patient:
            app.open(path)
        else:
            app.set_status("**New patient**: upload the four photos, then mark the "
                           "landmarks.")
    except BaseException:
        server.stop()
        raise
    return server, app


def open_browser(address: str) -> bool:
    """Open ``address`` (this server's own page) in the user's browser; False (and a
    line saying so) when no browser could be started."""
    try:
        opened = webbrowser.open(address)
    except Exception as e:  # a broken $BROWSER must not stop the server
        log.debug("naseview: webbrowser failed: %s", e)
        opened = False
    if not opened:
        print(f"naseview: could not open a browser; open {address} yourself", flush=True)
    return bool(opened)


def serve_command(args: argparse.Namespace) -> int:
    """``naseview serve [PATH] [--host H] [--port P] [--model M] [--new] [--no-browser]``:
    opens the page in the browser (unless ``--no-browser``) and blocks until Ctrl-C."""
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    host = str(getattr(args, "host", "127.0.0.1") or "127.0.0.1")
    port = int(getattr(args, "port", 8080))
    path = getattr(args, "path", None)
    if path is not None and not Path(path).exists():  # fail before a server starts
        raise NaseviewError(f"{path}: not found; pass a case directory (SPEC §3), a "
                            "`naseview reconstruct` output directory or a session file")
    new = bool(getattr(args, "new", False))
    server, app = start_app(path, host, port, getattr(args, "model", None), new_patient=new)
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    address = f"http://{shown}:{server.get_port()}/"
    what = app.source if app.source is not None else "the new-patient page"
    print(f"naseview: serving {what} at {address}", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"naseview: warning: bound to {host}; other computers on the network can open "
              "this page (patient data)", flush=True)
    if not getattr(args, "no_browser", False):
        open_browser(address)
    previous = _stop_on_signals()
    try:
        print("naseview: press Ctrl-C to stop", flush=True)
        while True:
            time.sleep(1.0)
    except (KeyboardInterrupt, _Stop):
        pass
    finally:
        _ignore_signals()  # a second SIGTERM / SIGHUP must not cut the last save short
        # a reconstruction or solve still in native code when the interpreter exits
        # aborts the process ("terminate called without an active exception"): let it end
        if app.source is not None or app.controller is not None:  # a job ever ran
            app.wait_ready(SHUTDOWN_WAIT_S)
        app.close()
        server.stop()
        _restore_signals(previous)
    return 0


STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))
"""Signals that stop ``naseview serve`` like Ctrl-C (SIGINT): ``kill``, closing the
terminal, logging out. Each ends the wait loop, so the open simulation's pending save is
written (:meth:`NaseviewApp.close`) before the process exits."""


class _Stop(Exception):
    """Raised in the main thread by a stop signal (:data:`STOP_SIGNALS`)."""


def _raise_stop(signum: int, frame: object) -> None:
    raise _Stop(signal.Signals(signum).name)


def _stop_on_signals() -> dict[int, Any]:
    """Install :func:`_raise_stop` for :data:`STOP_SIGNALS`; the previous handlers."""
    previous: dict[int, Any] = {}
    for sig in STOP_SIGNALS:
        try:
            previous[sig] = signal.signal(sig, _raise_stop)
        except ValueError:  # not the main thread (embedded): the caller stops us
            break
    return previous


def _ignore_signals() -> None:
    for sig in STOP_SIGNALS:
        try:
            signal.signal(sig, signal.SIG_IGN)
        except ValueError:
            break


def _restore_signals(previous: Mapping[int, Any]) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


__all__ = ["NaseviewApp", "SolverFactory", "demo_case_dir", "serve_command", "start_app"]
