"""``naseview serve``: the browser app (viser) around an :class:`EditController`.

:class:`NaseviewApp` opens a case directory (reconstructed in the background by the
pipeline, stages 1-3 of the paper, with progress in the page), a reconstruction directory
(``reconstruction.json`` + ``face.ply`` + ``nose.ply``) or a session file, builds the shared
scene (:mod:`naseview.app.scene`) and panels (:mod:`naseview.app.panels`), and serves every
browser that connects; all of them see the same case and each other's edits. Dragging a
landmark re-runs stage 3's ARAP deformation (paper §3.4) through
:mod:`naseview.editing`.

Security: binds 127.0.0.1 unless ``--host`` says otherwise; the server
(:func:`naseview.app.guard.guarded_viser_server`) answers only its own page on its own host
names (another site's page, a DNS-rebinding name: 403) and refuses share-tunnel requests
whatever a client sends.
"""

from __future__ import annotations

import argparse
import json
import logging
import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any, TypeVar

import cv2
import numpy as np
import viser

from naseview.app.annotate_page import NewPatientHook, install_new_patient
from naseview.app.export import (
    landmarks_csv,
    landmarks_json,
    measurements_csv,
    measurements_json,
    mesh_file,
)
from naseview.app.guard import guarded_viser_server
from naseview.app.gui_value import set_value
from naseview.app.panels import (
    Panels,
    annotate_photo,
    click_residuals,
    flag_threshold,
    residual_markdown,
)
from naseview.app.scene import NOSE, SKIN, FaceScene, nice_limit, signed_displacement
from naseview.case import Case, read_case
from naseview.editing.baseline import (
    Baseline,
    Simulation,
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
from naseview.pipeline import PipelineParams, PipelineResult, reconstruct
from naseview.reconstruction import output_case_dir
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


class NaseviewApp:
    """The served app: one case, one editor, every browser.

    Args:
        server: a ``viser.ViserServer``.
        model: face model name for reconstruction (``None``: ICT if installed).
        solver_factory: ``(baseline, refine_params, interactive_iterations) -> (solver,
            editable ids, moving vertex ids)``; default :class:`NoseEditSolver`.
    """

    def __init__(self, server: viser.ViserServer, model: str | None = None,
                 solver_factory: SolverFactory | None = None) -> None:
        self.server = server
        self.model = model
        self.solver_factory: SolverFactory = solver_factory or _default_solver_factory
        self.controller: EditController | None = None
        self.scene: FaceScene | None = None
        self.case: Case | None = None
        self.case_id = "case"
        self.source: Path | None = None
        self.credit = ""
        self.curve_params = CurveParams()
        self.refine_params = RefineParams()
        self.suspect_messages: list[str] = []
        self._job_lock = threading.Lock()
        self._job_seq = 0
        self._param_timer: threading.Timer | None = None
        self._changed_stages: set[str] = set()
        self._fresh = True
        self._lock = threading.RLock()
        self._edit_help = ""
        self._ready = threading.Event()
        server.scene.set_up_direction("+y")
        self.panels = Panels(server, self)
        self.panels.build_params(self.curve_params, self.refine_params)
        self.new_patient: NewPatientHook = install_new_patient(server, self,
                                                               diagram_model=model)

    # opening
    def open(self, path: Path | None) -> None:
        """Open a case directory, a reconstruction directory or a session file
        (``None``: the bundled demo case). Case directories reconstruct in the
        background."""
        self._fresh = True  # a new case: new editor (a recompute keeps the edits)
        if path is None:
            path = demo_case_dir()
            if not (path / "case.json").is_file():
                raise NaseviewError(f"{path}: the bundled demo case is missing; pass a case "
                                    "directory: naseview serve CASE_DIR")
        path = Path(path)
        self.source = path
        if path.is_file() and is_session_file(path):
            self._open_session(path)
        elif path.is_file():
            raise NaseviewError(f"{path}: not a naseview session file (format "
                                "'naseview.session/1'); pass a case directory, a "
                                "reconstruction directory or a session .json")
        elif (path / "reconstruction.json").is_file():
            self._open_reconstruction(path)
        elif (path / "case.json").is_file():
            self.case = read_case(path)
            self.case_id = self.case.id
            self.reconstruct()
        else:
            raise NaseviewError(f"{path}: no case.json, reconstruction.json or session "
                                "file here; pass a case directory (SPEC §3), a `naseview "
                                "reconstruct` output directory or a session file")

    def _open_session(self, path: Path) -> None:
        """A saved session: its baseline and edits exactly, photos from its case."""
        session = load_session(path)
        self._open_case_from(session.case_folder)
        self.case_id = str(session.app.get("case_id", path.stem))
        self.credit = str(session.app.get("credit", ""))
        self._apply_param_values(session.app.get("params", {}), str(path))
        self.panels.set_status(f"Session **{path.name}** ({self.case_id})")
        self._start_job(lambda seq: self._install(session.baseline, session, seq),
                        "Opening session")

    def _open_reconstruction(self, path: Path) -> None:
        """``naseview reconstruct`` output: its baseline, photos from the case it names."""
        baseline = baseline_from_output_dir(path)
        rec = baseline.reconstruction
        self._open_case_from(lambda: output_case_dir(path, rec) or (
            path if (path / "case.json").is_file() else None))
        self.case_id = self.case.id if self.case is not None else path.name
        mesh = rec.extra.get("mesh", {}) if rec else {}
        self.credit = str(mesh.get("credit", "") if isinstance(mesh, dict) else "")
        self.panels.set_status(f"Reconstruction **{path.name}**")
        self._start_job(lambda seq: self._install(baseline, None, seq), "Loading")

    def open_baseline(self, baseline: Baseline, case: Case | None = None,
                      case_id: str = "case", credit: str = "") -> None:
        """Edit an in-memory :class:`Baseline` (tests, benchmarks, notebooks); ``case``
        optionally supplies the photos. Installs in the background like :meth:`open`."""
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
        try:
            case_dir = find()
            if case_dir is not None:
                self.case = read_case(case_dir)
        except NaseviewError as e:  # photos are optional for editing
            log.warning("naseview: photos unavailable: %s", e)
            self.panels.residuals.content = f"Photos unavailable: {e}"

    # background jobs
    def _start_job(self, fn: Callable[[int], None], label: str) -> None:
        """Run ``fn(seq)`` on a background thread; a later job supersedes it."""
        with self._job_lock:
            self._job_seq += 1
            seq = self._job_seq
            self._ready.clear()

        def run() -> None:
            self.panels.set_progress(0.02)
            self.panels.set_status(f"{label}…")
            try:
                fn(seq)
            except Exception as e:
                log.error("naseview: %s failed:\n%s", label, traceback.format_exc())
                if seq == self._job_seq:
                    msg = str(e) if isinstance(e, NaseviewError) else f"{type(e).__name__}: {e}"
                    self.panels.show_error(f"{label} failed: {msg}")
                    self.panels.set_status(f"{label} failed.")
            finally:
                if seq == self._job_seq:
                    self.panels.set_progress(None)
                    self._ready.set()

        threading.Thread(target=run, name=f"naseview-{label}", daemon=True).start()

    def reconstruct(self) -> None:
        """Run the pipeline on the case in the background (progress in the page)."""
        if self.case is None:
            raise NaseviewError("no case directory is open; recompute needs the photos "
                                "and clicks (open the case directory)")
        self._start_job(self._reconstruct_job, "Reconstruction")

    def _reconstruct_job(self, seq: int) -> None:
        assert self.case is not None
        stages = (1, 2, 3)
        done: list[str] = []

        def progress(stage: str, seconds: float) -> None:
            """``progress(stage_name, seconds)`` after each stage (pipeline contract)."""
            if seq != self._job_seq:
                return
            done.append(f"{stage} {seconds:.1f} s")
            self.panels.set_progress(0.05 + 0.85 * len(done) / len(stages))
            nxt = STAGE_LABELS.get(len(done) + 1)
            self.panels.set_status("Reconstruction: " + ", ".join(done)
                                   + (f"; running {nxt}…" if nxt else "; building the editor…"))

        self.panels.set_status(f"Reconstruction: running {STAGE_LABELS[1]}…")
        t0 = time.perf_counter()
        result = reconstruct(self.case, self.model, stages,
                             PipelineParams(curves=self.curve_params, refine=self.refine_params),
                             progress)
        if seq != self._job_seq:
            return
        self.suspect_messages = _suspect_messages(result.sfm)
        self.credit = _credit(self.model, result)
        baseline = baseline_from_pipeline(result)
        self.panels.set_progress(0.92)
        self._install(baseline, None, seq)
        took = time.perf_counter() - t0
        lines = [f"Reconstructed **{self.case_id}** in {took:.1f} s"]
        rmse = baseline.reconstruction.reprojection_rmse_px if baseline.reconstruction else None
        if rmse is not None:
            lines[0] += f", reprojection RMS {rmse:.2f} px"
        lines += [f"- {w}" for w in list(result.warnings)[:6]]
        self.panels.set_status("\n".join(lines))

    # installing
    def _install(self, baseline: Baseline, session: Session | None, seq: int) -> None:
        """Build the solver, controller and scene for ``baseline`` (job thread)."""
        solver, editable, moving = self.solver_factory(
            baseline, self.refine_params, int(self.panels.interactive_iters.value))
        if seq != self._job_seq:
            return
        with self._lock:
            if self.scene is not None:
                self.scene.remove()
                self.scene = None
            ctl = self._controller_for(baseline, session, solver)
            lim = self.refine_params.max_handle_displacement_mm
            ctl.max_displacement_mm = float(lim) if lim else None
            self.scene = self._build_scene(ctl, editable, moving)
            self.apply_display()
            if session is not None:
                set_value(self.panels.symmetric, session.symmetric)
            ctl.set_symmetric(self.panels.symmetric.value)
            self.reset_camera()
        self._show_installed(baseline, editable, session)

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
        ctl.on_simulation.append(self._on_simulation)
        ctl.on_history.append(self._on_history)
        ctl.on_error.append(self.panels.show_error)
        self.controller = ctl
        return ctl

    def _build_scene(self, ctl: EditController, editable: list[str],
                     moving: np.ndarray) -> FaceScene:
        """The 3D scene of ``ctl``'s baseline with the cameras and photo thumbnails."""
        baseline = ctl.baseline
        cams = baseline.reconstruction.cameras if baseline.reconstruction else {}
        photos = {}
        if self.case is not None:
            for v in cams:
                try:
                    photos[v] = _photo_thumb(self.case.load_image(v))
                except NaseviewError:
                    pass
        scene = FaceScene(self.server, ctl, editable, cams, photos, region=moving)
        if ctl.simulation.generation == ctl.generation:
            scene.update(ctl.simulation)
        return scene

    def _show_installed(self, baseline: Baseline, editable: list[str],
                        session: Session | None) -> None:
        """Panel texts, measurements, history buttons and photo once the editor is up."""
        ctl = self.controller
        assert ctl is not None
        fixed = [k for k in baseline.landmarks if k not in editable]
        self._edit_help = ("Drag a **red** sphere to reshape the nose"
                           + (f" (grey = fixed: {', '.join(fixed)})" if fixed else "") + ".")
        self.panels.edit_info.content = self._edit_help
        self.panels.show_error(None)
        self._on_simulation(ctl.simulation)
        self._on_history()
        self.show_photo(self.panels.photo_view.value)
        credit = self.credit or ""
        self.panels.credit.content = (f"<small>Face model: {credit}</small>" if credit else "")
        if session is not None:
            self.panels.set_status(f"Session **{self.case_id}** reopened.")
        elif self.case is None or self.source is not None and \
                (self.source / "reconstruction.json").is_file():
            self.panels.set_status(f"**{self.case_id}** loaded.")

    def apply_display(self) -> None:
        """Show the scene as the panel's display and before / after toggles say."""
        if self.scene is None:
            return
        p = self.panels
        self.scene.set_visible(labels=p.labels.value, curves=p.show_curves.value,
                               ad_landmarks=p.show_ad.value, cameras=p.show_cameras.value,
                               landmarks=p.show_landmarks.value, highlight=p.highlight.value)
        self.scene.set_view(colormap=p.colormap.value, original=p.show_original.value,
                            overlay=p.overlay.value)

    def reset_camera(self) -> None:
        """Three-quarter view of the nose from the subject's left, nose filling the view
        (every browser, and the initial camera of new ones)."""
        if self.controller is None:
            return
        baseline = self.controller.baseline
        nose = baseline.V[baseline.nose_ids] if len(baseline.nose_ids) else baseline.V
        target = nose.mean(axis=0)
        size = float(np.ptp(nose, axis=0).max()) if len(nose) else 60.0
        direction = np.array([0.5, 0.1, 1.0]) / np.linalg.norm([0.5, 0.1, 1.0])
        eye = target + direction * max(150.0, 5.0 * size)
        fov = float(np.radians(35.0))
        cam = self.server.initial_camera
        cam.fov = fov
        cam.near = 1.0
        cam.far = 5000.0
        cam.look_at = (float(target[0]), float(target[1]), float(target[2]))
        cam.position = (float(eye[0]), float(eye[1]), float(eye[2]))
        cam.up = (0.0, 1.0, 0.0)
        for client in self.server.get_clients().values():
            client.camera.fov = fov
            client.camera.near = 1.0
            client.camera.far = 5000.0
            # position first: viser moves look_at along with a position update
            client.camera.position = (float(eye[0]), float(eye[1]), float(eye[2]))
            client.camera.look_at = (float(target[0]), float(target[1]), float(target[2]))
            client.camera.up_direction = (0.0, 1.0, 0.0)

    # listeners
    def _on_simulation(self, sim: Simulation) -> None:
        ctl = self.controller
        if ctl is None:
            return
        self.panels.set_measurements(ctl.baseline.measurements, sim.measurements)
        if self.scene is not None and self.scene.show_colormap:
            self._update_colorbar(sim)
        if not sim.interactive:
            text = self._edit_help
            if sim.warnings:
                text += "\n\n⚠ " + " ".join(w.removeprefix("stage 3: ") for w in sim.warnings)
            self.panels.edit_info.content = text

    def _update_colorbar(self, sim: Simulation) -> None:
        sc = self.scene
        if sc is None:
            return
        ids = sc.nose_ids
        d = signed_displacement(sc.base.V[ids], sim.V[ids], sc.normals[ids])
        self.panels.set_colorbar(nice_limit(float(np.abs(d).max()) if len(d) else 0.0),
                                 max(0.0, float(d.max(initial=0.0))),
                                 max(0.0, float(-d.min(initial=0.0))),
                                 NOSE if sc.highlight else SKIN)

    def _on_history(self) -> None:
        ctl = self.controller
        if ctl is None:
            return
        self.panels.set_history(ctl.can_undo, ctl.can_redo, ctl.is_edited())

    # actions (panels)
    def undo(self) -> None:
        if self.controller is not None:
            self.controller.undo()

    def redo(self) -> None:
        if self.controller is not None:
            self.controller.redo()

    def reset(self) -> None:
        if self.controller is not None:
            self.controller.reset()

    def set_symmetric(self, on: bool) -> None:
        if self.controller is not None:
            self.controller.set_symmetric(on)

    def set_visible(self, **kw: bool) -> None:
        if self.scene is not None:
            self.scene.set_visible(**kw)

    def set_view(self, **kw: bool) -> None:
        if self.scene is None or self.controller is None:
            return
        self.scene.set_view(**kw)
        if self.scene.show_colormap:
            self._update_colorbar(self.controller.simulation)
        else:
            self.panels.set_colorbar(None)

    def show_photo(self, view: str) -> None:
        """Photo of ``view`` with clicks, reprojected landmarks / curves and residuals."""
        p = self.panels
        ctl = self.controller
        if self.case is None or ctl is None or view not in self.case.views:
            p.photo.visible = False
            if self.case is None:
                p.residuals.content = "No photos: the case directory is not available."
            return
        base = ctl.baseline
        cams = base.reconstruction.cameras if base.reconstruction else {}
        res = {v: click_residuals(vv.landmarks, cams[v], base.landmarks)
               for v, vv in self.case.views.items() if v in cams}
        flag = flag_threshold(res)
        p.photo.image = annotate_photo(self.case.load_image(view), cams.get(view),
                                       self.case.views[view].landmarks, base.landmarks,
                                       base.curves, flag_px=flag)
        p.photo.visible = True
        text = residual_markdown(res, flag)
        if self.suspect_messages:
            text += "\n\n**Stage 1 flagged:**\n\n" + "\n".join(
                f"- {m}" for m in self.suspect_messages)
        p.residuals.content = text

    def params_changed(self, stage: str) -> None:
        """A parameter input changed (``stage``: ``"curves"``, ``"refine"`` or ``"app"``):
        recompute after a short pause (debounced); ``"app"`` alone (drag iterations)
        rebuilds only the edit solver."""
        self._changed_stages.add(stage)
        if self._param_timer is not None:
            self._param_timer.cancel()
        self._param_timer = threading.Timer(0.6, self._recompute_shown)
        self._param_timer.daemon = True
        self._param_timer.start()

    def _recompute_shown(self) -> None:
        """:meth:`recompute` from the debounce timer: an invalid value is shown in the
        page (the parameters keep their last valid values)."""
        try:
            self.recompute()
        except NaseviewError as e:
            self.panels.show_error(str(e))

    def _apply_param_values(self, values: Mapping[str, Any], where: str) -> None:
        """The stage 2 / stage 3 parameters a session saved (``{"curves": {...},
        "refine": {...}}``), then the panel inputs rebuilt for them."""
        if values.get("curves"):
            self.curve_params = _with_saved(self.curve_params, values["curves"], where)
        if values.get("refine"):
            self.refine_params = _with_saved(self.refine_params, values["refine"], where)
        self.panels.build_params(self.curve_params, self.refine_params)

    def recompute(self) -> None:
        """Apply the parameter panel: re-run the pipeline (case open) or rebuild the
        edit solver (session / reconstruction without photos).

        Raises:
            NaseviewError: a panel value outside its parameter's range.
        """
        stages, self._changed_stages = self._changed_stages, set()
        v2, v3 = self.panels.param_values()
        if v2:
            self.curve_params = replace(self.curve_params, **_typed(self.curve_params, v2))
        if v3:
            self.refine_params = replace(self.refine_params, **_typed(self.refine_params, v3))
        if self.case is not None and stages != {"app"}:
            self.reconstruct()
            return
        ctl = self.controller
        if ctl is None:
            return

        def job(seq: int) -> None:
            solver, _, _ = self.solver_factory(ctl.baseline, self.refine_params,
                                               int(self.panels.interactive_iters.value))
            if seq == self._job_seq:
                ctl.set_solver(solver)
                self.panels.set_status("Edit solver rebuilt with the new parameters.")

        self._start_job(job, "Recompute")

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
            lms = ctl.landmarks
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
        self.new_patient.close()
        if self._param_timer is not None:
            self._param_timer.cancel()
        if self.controller is not None:
            self.controller.close()


def start_app(path: Path | None, host: str = "127.0.0.1", port: int = 8080,
              model: str | None = None,
              solver_factory: SolverFactory | None = None
              ) -> tuple[viser.ViserServer, NaseviewApp]:
    """Start the server and open ``path``; returns ``(server, app)`` (non-blocking).

    Raises:
        NaseviewError: ``host``:``port`` cannot be listened on (busy port, port out of
            range, an address that is not this computer's).
    """
    server = guarded_viser_server(host, port, verbose=False)
    try:
        app = NaseviewApp(server, model=model, solver_factory=solver_factory)
        app.open(path)
    except BaseException:
        server.stop()
        raise
    return server, app


def serve_command(args: argparse.Namespace) -> int:
    """``naseview serve [PATH] [--host H] [--port P] [--model M]``: blocks until Ctrl-C."""
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    host = str(getattr(args, "host", "127.0.0.1") or "127.0.0.1")
    port = int(getattr(args, "port", 8080))
    path = getattr(args, "path", None)
    if path is not None and not Path(path).exists():  # fail before a server starts
        raise NaseviewError(f"{path}: not found; pass a case directory (SPEC §3), a "
                            "`naseview reconstruct` output directory or a session file")
    server, app = start_app(path, host, port, getattr(args, "model", None))
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    print(f"naseview: serving {app.source} at http://{shown}:{server.get_port()}/", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"naseview: warning: bound to {host}; other computers on the network can open "
              "this page (patient data)", flush=True)
    if getattr(args, "new", False):  # start with the new-patient page
        app.new_patient.annotate.show_start()
    print("naseview: press Ctrl-C to stop", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        # a reconstruction or solve still in native code when the interpreter exits
        # aborts the process ("terminate called without an active exception"): let it end
        app.wait_ready(SHUTDOWN_WAIT_S)
        app.close()
        server.stop()
    return 0


__all__ = ["NaseviewApp", "SolverFactory", "demo_case_dir", "serve_command", "start_app"]
