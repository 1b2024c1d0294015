"""The served app: the patient's case, its one editor and the background jobs, shared by
every browser tab.

:class:`NaseviewApp` opens a case directory (reconstructed in the background by the
pipeline, stages 1-3 of the paper, with progress in every tab), a reconstruction directory
(``reconstruction.json`` + ``face.ply`` + ``nose.ply``), a session file or a patient of the
work folder, and serves every browser tab that connects: each tab is a
:class:`~naseview.app.screen.Screen` (which sees the app as
:class:`~naseview.app.screen.ScreenHost`) with its own panels, scene, camera and patient
mode, so every tab sees the same simulation and each other's edits, never each other's
view. Dragging a landmark re-runs stage 3's ARAP deformation (paper §3.4) through
:mod:`naseview.editing`. The jobs run on :class:`naseview.app.jobs.JobRunner`; the
downloads are :mod:`naseview.app.downloads`'; ``naseview serve`` (:mod:`naseview.app.serve`)
starts it.
"""

from __future__ import annotations

import logging
import os
import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import viser

from naseview.app.downloads import export_file
from naseview.app.face_look import face_look
from naseview.app.gui_value import set_value
from naseview.app.jobs import (
    STAGE_LABELS,
    JobRunner,
    model_credit,
    reconstruction_summary,
    suspect_messages,
)
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.markdown_text import markdown_text
from naseview.app.memory import release_freed_memory
from naseview.app.patient_work import PatientWork
from naseview.app.patients_panel import PatientsPanel
from naseview.app.scene import photo_thumbnails
from naseview.app.screen import PATIENT_SCREEN_PATH, Screen, connection_path, nose_view
from naseview.app.stage_params import plain_values, typed_values, with_saved
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
from naseview.intake.patients import PatientFolders
from naseview.measurements import Estimate, calliper_inputs, estimated_measurements
from naseview.pipeline import PipelineParams, reconstruct
from naseview.reconstruction import calliper_distances, output_case_dir
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams

log = logging.getLogger(__name__)

SolverFactory = Callable[[Baseline, RefineParams, int], tuple[Solver, list[str], np.ndarray]]
"""``(baseline, refine_params, interactive_iterations) -> (solver, editable landmark ids,
moving vertex ids)``."""

DRAG_ITERATIONS = 6
"""ARAP iterations per update during a drag (the panel's starting value)."""


def demo_case_dir() -> Path:
    """The bundled demo case (``assets/demo-case`` beside the package)."""
    return Path(__file__).resolve().parents[2] / "assets" / "demo-case"


def _default_solver_factory(baseline: Baseline, refine_params: RefineParams,
                            interactive_iterations: int) -> tuple[Solver, list[str], np.ndarray]:
    """:class:`NoseEditSolver` on ``baseline``: its editable landmarks and moving region."""
    s = NoseEditSolver(baseline, refine_params, interactive_iterations=interactive_iterations)
    return s, s.editable, s.region_ids


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
        self.jobs = JobRunner(self.set_progress, self.set_status)
        """The background jobs (opening, reconstruction, recompute)."""
        self._param_timer: threading.Timer | None = None
        self._param_asker: Screen | None = None
        self._changed_stages: set[str] = set()
        self._fresh = True
        self._closed = False
        self._lock = threading.RLock()
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
        if not self.jobs.ready.wait(timeout) or self.controller is None:
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
        """Run ``fn(seq)`` in the background (:class:`~naseview.app.jobs.JobRunner`); an
        error goes to ``asker`` (the tab that asked) when it is open."""
        self.jobs.start(fn, label, lambda message: self.show_error(message, asker))

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
            if not self.jobs.is_current(seq):
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
        if not self.jobs.is_current(seq):
            return
        self.suspect_messages = suspect_messages(result.sfm)
        self.credit = model_credit(self.model, result)
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
        if not self.jobs.is_current(seq):
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
            self.photos = photo_thumbnails(self.case, self.cameras)
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
        if not self.jobs.is_current(seq) or look is None or look.texture is None:
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
            self.curve_params = with_saved(self.curve_params, values["curves"], where)
        if values.get("refine"):
            self.refine_params = with_saved(self.refine_params, values["refine"], where)
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
                self.curve_params = replace(self.curve_params,
                                            **typed_values(self.curve_params, v2))
            if v3:
                self.refine_params = replace(self.refine_params,
                                             **typed_values(self.refine_params, v3))
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
            if self.jobs.is_current(seq):
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
                "params": {"curves": plain_values(self.curve_params),
                           "refine": plain_values(self.refine_params)}}

    def file_for(self, kind: str, fmt: str, part: str = "face",
                 state: str = "simulated") -> tuple[str, bytes]:
        """(file name, content) of an export (:func:`naseview.app.downloads.export_file`):
        ``kind`` ``"mesh"`` (``fmt`` a mesh type; ``part`` face or nose, ``state``
        simulated or original), ``"landmarks"`` / ``"measurements"`` (json or csv) or
        ``"session"``."""
        ctl = self.controller
        if ctl is None:
            raise NaseviewError("nothing to export yet: the reconstruction is not ready")
        return export_file(ctl, kind, fmt, self.case_id, self.app_state, part, state)

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


__all__ = ["DRAG_ITERATIONS", "NaseviewApp", "SolverFactory", "demo_case_dir"]
