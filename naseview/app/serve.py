"""``naseview serve``: the browser app (viser) around an :class:`EditController`.

:class:`NaseviewApp` opens a case directory (reconstructed in the background, progress in
the page), a reconstruction directory (``reconstruction.json`` + ``face.ply`` +
``nose.ply``) or a session file, builds the shared scene (:mod:`naseview.app.scene`) and
panels (:mod:`naseview.app.panels`), and serves every browser that connects; all of them
see the same case and each other's edits.

Security: binds 127.0.0.1 unless ``--host`` says otherwise, never requests a share URL
and hides the share button.
"""

from __future__ import annotations

import argparse
import json
import logging
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from naseview.app.export import (
    landmarks_csv,
    landmarks_json,
    measurements_csv,
    measurements_json,
    mesh_file,
)
from naseview.app.panels import (
    Panels,
    annotate_photo,
    click_residuals,
    flag_threshold,
    residual_markdown,
)
from naseview.app.scene import FaceScene, nice_limit, signed_displacement
from naseview.editing.baseline import (
    baseline_from_face_model,
    baseline_from_output_dir,
    baseline_from_pipeline,
)
from naseview.editing.state import (
    Baseline,
    EditController,
    Session,
    Simulation,
    baseline_simulation,
    is_session_file,
    load_session,
)
from naseview.errors import NaseviewError

log = logging.getLogger(__name__)

ICT_CREDIT = "ICT Face Model (USC Institute for Creative Technologies, MIT)"


def demo_case_dir() -> Path:
    """The bundled demo case (``assets/demo-case`` beside the package)."""
    import naseview

    return Path(naseview.__file__).resolve().parent.parent / "assets" / "demo-case"


def _photo_thumb(image_bgr: np.ndarray, width: int = 320) -> np.ndarray:
    import cv2

    h, w = image_bgr.shape[:2]
    s = width / float(w)
    small = cv2.resize(image_bgr, (width, max(1, int(round(h * s)))),
                       interpolation=cv2.INTER_AREA)
    return small[:, :, ::-1].copy()


class NaseviewApp:
    """The served app: one case, one editor, every browser.

    Args:
        server: a ``viser.ViserServer``.
        model: face model name for reconstruction (``None``: ICT if installed).
        solver_factory: ``(baseline, refine_params, interactive_iterations) -> (solver,
            editable ids, moving vertex ids)``; default :class:`NoseEditSolver`.
    """

    def __init__(self, server: Any, model: str | None = None,
                 solver_factory: Callable[..., tuple[Any, list[str], np.ndarray]] | None
                 = None) -> None:
        self.server = server
        self.model = model
        self.solver_factory = solver_factory or _default_solver_factory
        self.controller: EditController | None = None
        self.scene: FaceScene | None = None
        self.case: Any = None
        self.case_id = "case"
        self.source: Path | None = None
        self.credit = ""
        self.sfm: Any = None
        self.curve_params: Any = _default_params("curves")
        self.refine_params: Any = _default_params("refine")
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
        # [NEW] new patient (photo intake, guided landmark clicks), patient mode, report
        from naseview.app.annotate_page import install_new_patient

        self.new_patient = install_new_patient(server, self, diagram_model=model)

    # ------------------------------------------------------------------ opening
    def open(self, path: Path | None) -> None:
        """Open a case directory, a reconstruction directory or a session file
        (``None``: the bundled demo case). Case directories reconstruct in the
        background."""
        from naseview.case import read_case

        self._fresh = True  # a new case: new editor (a recompute keeps the edits)
        if path is None:
            path = demo_case_dir()
            if not (path / "case.json").is_file():
                raise NaseviewError(f"{path}: the bundled demo case is missing; pass a case "
                                    "directory: naseview serve CASE_DIR")
        path = Path(path)
        self.source = path
        if path.is_file() and is_session_file(path):
            session = load_session(path)
            self._open_case_from(session.app.get("case_dir"))
            self.case_id = str(session.app.get("case_id", path.stem))
            self.credit = str(session.app.get("credit", ""))
            self._apply_param_values(session.app.get("params", {}))
            self.panels.set_status(f"Session **{path.name}** ({self.case_id})")
            self._start_job(lambda seq: self._install(session.baseline, session, seq),
                            "Opening session")
            return
        if path.is_file():
            raise NaseviewError(f"{path}: not a naseview session file (format "
                                "'naseview.session/1'); pass a case directory, a "
                                "reconstruction directory or a session .json")
        if (path / "reconstruction.json").is_file():
            baseline = baseline_from_output_dir(path)
            rec = baseline.reconstruction
            self._open_case_from((rec.extra.get("case_dir") if rec else None)
                                 or (path if (path / "case.json").is_file() else None))
            self.case_id = self.case.id if self.case is not None else path.name
            mesh = rec.extra.get("mesh", {}) if rec else {}
            self.credit = str(mesh.get("credit", "") if isinstance(mesh, dict) else "")
            self.panels.set_status(f"Reconstruction **{path.name}**")
            self._start_job(lambda seq: self._install(baseline, None, seq), "Loading")
            return
        if (path / "case.json").is_file():
            self.case = read_case(path)
            self.case_id = self.case.id
            self.reconstruct()
            return
        raise NaseviewError(f"{path}: no case.json, reconstruction.json or session file "
                            "here; pass a case directory (SPEC §3), a `naseview reconstruct` "
                            "output directory or a session file")

    def open_baseline(self, baseline: Baseline, case: Any = None, case_id: str = "case",
                      credit: str = "") -> None:
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

    def _open_case_from(self, case_dir: Any) -> None:
        from naseview.case import read_case

        self.case = None
        if not case_dir:
            return
        try:
            self.case = read_case(Path(case_dir))
        except NaseviewError as e:  # photos are optional for editing
            log.warning("naseview: photos unavailable: %s", e)
            self.panels.residuals.content = f"Photos unavailable: {e}"

    # ------------------------------------------------------------------ background jobs
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
        from naseview.pipeline import reconstruct

        names = {1: "landmarks (bundle adjustment)", 2: "curves", 3: "mesh (ARAP)"}
        stages = (1, 2, 3)
        done: list[str] = []

        def progress(stage: str, seconds: float, *rest: Any) -> None:
            """``progress(stage_name, seconds)`` after each stage (pipeline contract)."""
            if seq != self._job_seq:
                return
            done.append(f"{stage} {seconds:.1f} s")
            self.panels.set_progress(0.05 + 0.85 * len(done) / len(stages))
            nxt = names.get(len(done) + 1)
            self.panels.set_status("Reconstruction: " + ", ".join(done)
                                   + (f"; running {nxt}…" if nxt else "; building the editor…"))

        self.panels.set_status(f"Reconstruction: running {names[1]}…")
        t0 = time.perf_counter()
        result = reconstruct(self.case, self.model, stages,
                             _pipeline_params(self.curve_params, self.refine_params),
                             progress)
        if seq != self._job_seq:
            return
        self.sfm = getattr(result, "sfm", None)
        self.suspect_messages = [s.message() if hasattr(s, "message") else str(s)
                                 for s in getattr(self.sfm, "suspect_clicks", []) or []]
        self.credit = _credit(self.model, result)
        baseline = baseline_from_pipeline(result)
        warnings = list(getattr(result, "warnings", []) or [])
        self.panels.set_progress(0.92)
        self._install(baseline, None, seq)
        took = time.perf_counter() - t0
        lines = [f"Reconstructed **{self.case_id}** in {took:.1f} s"]
        rmse = baseline.reconstruction.reprojection_rmse_px if baseline.reconstruction else None
        if rmse is not None:
            lines[0] += f", reprojection RMS {rmse:.2f} px"
        lines += [f"- {w}" for w in warnings[:6]]
        self.panels.set_status("\n".join(lines))

    # ------------------------------------------------------------------ installing
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
            fresh, self._fresh = self._fresh, False
            if self.controller is None or session is not None or fresh:
                if self.controller is not None:
                    self.controller.close()
                ctl = (EditController.from_session(session, solver) if session is not None
                       else EditController(baseline, solver))
                ctl.on_simulation.append(self._on_simulation)
                ctl.on_history.append(self._on_history)
                ctl.on_error.append(self.panels.show_error)
                self.controller = ctl
            else:
                self.controller.rebase(baseline, solver)
            ctl = self.controller
            lim = getattr(self.refine_params, "max_handle_displacement_mm", None)
            ctl.max_displacement_mm = float(lim) if lim else None
            cams = baseline.reconstruction.cameras if baseline.reconstruction else {}
            photos = {}
            if self.case is not None:
                for v in cams:
                    try:
                        photos[v] = _photo_thumb(self.case.load_image(v))
                    except NaseviewError:
                        pass
            self.scene = FaceScene(self.server, ctl, editable, cams, photos, region=moving)
            if ctl.simulation.generation == ctl.generation:
                self.scene.update(ctl.simulation)
            p = self.panels
            self.scene.set_visible(labels=p.labels.value, curves=p.show_curves.value,
                                   ad_landmarks=p.show_ad.value, cameras=p.show_cameras.value,
                                   landmarks=p.show_landmarks.value,
                                   highlight=p.highlight.value)
            self.scene.set_view(colormap=p.colormap.value, original=p.show_original.value,
                                overlay=p.overlay.value)
            if session is not None:
                p.symmetric.value = session.symmetric
            ctl.set_symmetric(p.symmetric.value)
            self._set_camera(baseline)
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

    def _set_camera(self, baseline: Baseline) -> None:
        """Three-quarter view of the nose from the subject's left, nose filling the view."""
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
        cam.look_at = tuple(float(x) for x in target)
        cam.position = tuple(float(x) for x in eye)
        cam.up = (0.0, 1.0, 0.0)
        for client in self.server.get_clients().values():
            client.camera.fov = fov
            client.camera.near = 1.0
            client.camera.far = 5000.0
            # [NEW] position first: viser moves look_at along with a position update
            client.camera.position = tuple(float(x) for x in eye)
            client.camera.look_at = tuple(float(x) for x in target)
            client.camera.up_direction = (0.0, 1.0, 0.0)

    # ------------------------------------------------------------------ listeners
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
        from naseview.app.scene import NOSE, SKIN

        self.panels.set_colorbar(nice_limit(float(np.abs(d).max()) if len(d) else 0.0),
                                 max(0.0, float(d.max(initial=0.0))),
                                 max(0.0, float(-d.min(initial=0.0))),
                                 NOSE if sc.highlight else SKIN)

    def _on_history(self) -> None:
        ctl = self.controller
        if ctl is None:
            return
        self.panels.set_history(ctl.can_undo, ctl.can_redo, ctl.is_edited())

    # ------------------------------------------------------------------ actions (panels)
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
        cam = cams.get(view)
        res = {}
        for v, vv in self.case.views.items():
            c = cams.get(v)
            if c is not None:
                res[v] = click_residuals(vv.landmarks, c, base.landmarks)
        flag = flag_threshold(res)
        clicks = self.case.views[view].landmarks
        img = annotate_photo(self.case.load_image(view), cam, clicks, base.landmarks,
                             base.curves, flag_px=flag)
        p.photo.image = img
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
        self._param_timer = threading.Timer(0.6, self.recompute)
        self._param_timer.daemon = True
        self._param_timer.start()

    def _apply_param_values(self, values: dict[str, Any]) -> None:
        for key, attr in (("curves", "curve_params"), ("refine", "refine_params")):
            obj = getattr(self, attr)
            given = values.get(key) or {}
            if obj is None or not given:
                continue
            names = {f.name for f in fields(obj)}
            setattr(self, attr, replace(obj, **{k: v for k, v in given.items()
                                               if k in names}))
        self.panels.build_params(self.curve_params, self.refine_params)

    def recompute(self) -> None:
        """Apply the parameter panel: re-run the pipeline (case open) or rebuild the
        edit solver (session / reconstruction without photos)."""
        stages, self._changed_stages = self._changed_stages, set()
        v2, v3 = self.panels.param_values()
        if self.curve_params is not None and v2:
            self.curve_params = replace(self.curve_params, **_typed(self.curve_params, v2))
        if self.refine_params is not None and v3:
            self.refine_params = replace(self.refine_params, **_typed(self.refine_params, v3))
        if self.case is not None and _pipeline_available() and stages != {"app"}:
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

    # ------------------------------------------------------------------ export
    def app_state(self) -> dict[str, Any]:
        """What a session file stores besides the editor state."""
        params: dict[str, Any] = {}
        for key, obj in (("curves", self.curve_params), ("refine", self.refine_params)):
            if obj is not None:
                params[key] = {f.name: getattr(obj, f.name) for f in fields(obj)
                               if isinstance(getattr(obj, f.name), (int, float, str, bool))}
        return {"case_id": self.case_id,
                "case_dir": str(self.case.root) if self.case is not None else None,
                "model": self.model, "credit": self.credit, "params": params}

    def file_for(self, kind: str, fmt: str, part: str = "face",
                 state: str = "simulated") -> tuple[str, bytes]:
        """(file name, content) of an export."""
        ctl = self.controller
        if ctl is None:
            raise NaseviewError("nothing to export yet: the reconstruction is not ready")
        base = ctl.baseline
        sim = ctl.simulation
        name = self.case_id.replace("/", "_") or "case"
        if kind == "mesh":
            V = sim.V if state == "simulated" else base.V
            ids = base.nose_ids if part == "nose" else None
            return f"{name}-{part}-{state}.{fmt}", mesh_file(V, base.F, fmt, ids)
        if kind == "landmarks":
            lms = ctl.landmarks
            data = (landmarks_json(lms, base.landmarks, self.case_id) if fmt == "json"
                    else landmarks_csv(lms, base.landmarks))
            return f"{name}-landmarks.{fmt}", data
        if kind == "measurements":
            data = (measurements_json(base.measurements, sim.measurements, self.case_id)
                    if fmt == "json" else measurements_csv(base.measurements,
                                                           sim.measurements))
            return f"{name}-measurements.{fmt}", data
        if kind == "session":
            ctl.wait_idle(10.0)
            obj = ctl.session_json(self.app_state())
            data = json.dumps(obj, separators=(",", ":"), allow_nan=False).encode("utf-8")
            return f"{name}-session.json", data
        raise ValueError(f"unknown export {kind!r}")

    def download(self, client: Any, kind: str, fmt: str, **kw: str) -> None:
        fname, data = self.file_for(kind, fmt, **kw)
        target = client if client is not None else self.server
        target.send_file_download(fname, data, save_immediately=True)

    def close(self) -> None:
        self.new_patient.close()  # [NEW]
        if self._param_timer is not None:
            self._param_timer.cancel()
        if self.controller is not None:
            self.controller.close()


# ---------------------------------------------------------------------------- helpers
def _default_solver_factory(baseline: Baseline, refine_params: Any,
                            interactive_iterations: int) -> tuple[Any, list[str], np.ndarray]:
    from naseview.editing.solver import NoseEditSolver

    s = NoseEditSolver(baseline, refine_params, interactive_iterations=interactive_iterations)
    return s, s.editable, s.region_ids


def _default_params(stage: str) -> Any:
    try:
        if stage == "curves":
            from naseview.stage2_curves.params import CurveParams

            return CurveParams()
        from naseview.stage3_mesh.solve import RefineParams

        return RefineParams()
    except ImportError:
        return None


def _typed(obj: Any, values: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in values.items():
        cur = getattr(obj, k, None)
        out[k] = int(round(v)) if isinstance(cur, int) and not isinstance(cur, bool) else v
    return out


def _pipeline_available() -> bool:
    try:
        import naseview.pipeline  # noqa: F401
    except ImportError:
        return False
    return True


def _pipeline_params(curve_params: Any, refine_params: Any) -> Any:
    """The ``params`` argument of :func:`naseview.pipeline.reconstruct`."""
    from naseview import pipeline

    cls = getattr(pipeline, "PipelineParams", None)
    if cls is None:
        return None
    names = {f.name for f in fields(cls)}
    kw = {}
    for key, obj in (("curves", curve_params), ("refine", refine_params)):
        if key in names and obj is not None:
            kw[key] = obj
    return cls(**kw)


def _credit(model: str | None, result: Any) -> str:
    """Attribution line of the face model used by stage 3."""
    refined = getattr(result, "refined", None)
    credit = getattr(refined, "credit", None) or ""
    if credit:
        return str(credit)
    name = getattr(refined, "model_name", None) or model
    if name in (None, "ict"):
        try:
            from naseview.facemodel import store

            if name == "ict" or store.find_ict_npz() is not None:
                return ICT_CREDIT
        except ImportError:
            return ""
    return ""


def start_app(path: Path | None, host: str = "127.0.0.1", port: int = 8080,
              model: str | None = None, verbose: bool = True,
              solver_factory: Callable[..., Any] | None = None) -> tuple[Any, NaseviewApp]:
    """Start the server and open ``path``; returns ``(server, app)`` (non-blocking)."""
    import viser

    server = viser.ViserServer(host=host, port=port, verbose=False)
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
    server, app = start_app(getattr(args, "path", None), host, port,
                            getattr(args, "model", None))
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    print(f"naseview: serving {app.source} at http://{shown}:{server.get_port()}/", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"naseview: warning: bound to {host}; other computers on the network can open "
              "this page (patient data)", flush=True)
    if getattr(args, "new", False):  # [NEW] start with the new-patient page
        app.new_patient.annotate.show_start()
    print("naseview: press Ctrl-C to stop", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        app.close()
        server.stop()
    return 0


__all__ = ["NaseviewApp", "baseline_from_face_model", "baseline_from_output_dir",
           "baseline_from_pipeline",
           "baseline_simulation", "demo_case_dir", "serve_command", "start_app"]
