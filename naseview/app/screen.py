"""One browser tab of the app: its panels, 3D scene, patient mode, new-patient page, camera.

viser gives every tab (one websocket connection) a client scope; a :class:`Screen` builds
everything of that tab there (:mod:`naseview.app.scope`), so what one tab shows, selects or
presents never reaches another, and a reload is a new tab with fresh defaults. The case,
the editor and the background jobs are the patient's, held once by
:class:`naseview.app.naseview_app.NaseviewApp`, which a screen sees through
:class:`ScreenHost` only: every tab's :class:`FaceScene` subscribes to the one
:class:`EditController`, so an edit, Undo, Redo or Reset in any tab shows in all of them.
The pieces of the tab see the screen through their own protocols
(:mod:`naseview.app.host`).

The *patient screen* is a tab opened from the surgeon's link
(:func:`patient_screen_url`): it connects on :data:`PATIENT_SCREEN_PATH` and starts in
patient mode, following the surgeon's edits live with its own camera and turntable.

Lifecycle: the app creates a screen when a tab connects (``server.on_client_connect``)
and calls :meth:`Screen.close` when it goes (``on_client_disconnect``): its listeners
leave the controller and its turntable and page threads stop.
"""

from __future__ import annotations

import html
import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import viser

from naseview.app.annotate_page import AnnotatePage
from naseview.app.colormap import nice_limit, signed_displacement
from naseview.app.face_look import LookSource, face_look, look_export
from naseview.app.gui_value import set_options, set_value
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.panels import (
    Panels,
    annotate_photo,
    click_residuals,
    flag_threshold,
    residual_markdown,
)
from naseview.app.patient_mode import PatientMode
from naseview.app.patient_work import PatientWork
from naseview.app.photo_sim import PhotoSimulation, SimInputs, sim_inputs
from naseview.app.scene import NOSE, SKIN, FaceScene
from naseview.app.scope import NoticeColor, notify, run_action
from naseview.app.viewer import (
    DEFAULT_VIEW,
    SCALE_BAR_MM,
    camera_of_view,
    scale_bar_segments,
    view_camera,
    view_png,
    view_pose,
)
from naseview.case import Case
from naseview.editing.baseline import Baseline, Simulation
from naseview.editing.controller import EditController
from naseview.errors import NaseviewError
from naseview.landmarks import ALL_VIEWS, VIEWS
from naseview.measurements import Estimate
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams
from naseview.texture.bake import FaceTexture

log = logging.getLogger(__name__)

PATIENT_SCREEN_PATH = "/patient"
"""Websocket path of the patient screen (the page's own address stays ``/``)."""

SCALE_BAR_COLOR = (40, 40, 40)
PNG_HEIGHT = 900
"""Height (px) of "Save view as PNG"."""


def nose_view(baseline: Baseline) -> tuple[np.ndarray, np.ndarray, float]:
    """Default view of a face: ``(look_at (3,), eye (3,), vertical fov rad)``, SPEC frame
    (mm, +y up): the standard :data:`~naseview.app.viewer.DEFAULT_VIEW` (three-quarter
    from the subject's left), the nose centred and filling ~60 % of the view height."""
    target, eye, fov, _ = view_pose(baseline.V, baseline.nose_ids, DEFAULT_VIEW)
    return target, eye, fov


def _request_of(server: viser.ViserServer, client: viser.ClientHandle) -> Any:
    """The websocket handshake request of ``client``'s connection (None once gone).

    viser 1.1.1 (pinned) keeps the live connections in its websocket server and offers no
    public accessor; the handshake's path and ``Host`` are all naseview reads from it."""
    conns = getattr(server._websock_server, "_live_connections", {})
    return getattr(conns.get(client.client_id), "request", None)


def connection_path(server: viser.ViserServer, client: viser.ClientHandle) -> str:
    """Path of the websocket URL ``client`` connected to (``"/"`` for a normal tab,
    :data:`PATIENT_SCREEN_PATH` for the patient screen)."""
    request = _request_of(server, client)
    path = str(getattr(request, "path", "/") or "/")
    return path.partition("?")[0].rstrip("/") or "/"


def connection_host(server: viser.ViserServer, client: viser.ClientHandle) -> str | None:
    """The ``Host`` ``client`` connected to (the guard let only this server's own names
    through), or None."""
    request = _request_of(server, client)
    headers = getattr(request, "headers", None)
    host = headers.get("Host") if headers is not None else None
    return str(host) if host else None


def patient_screen_url(host: str) -> str:
    """Address of the patient screen for a tab served as ``host`` (``name:port``): the
    page itself, told by viser's ``websocket`` parameter to connect on
    :data:`PATIENT_SCREEN_PATH`."""
    return f"/?screen=patient&websocket=ws://{host}{PATIENT_SCREEN_PATH}"


class ScreenHost(LookSource, Protocol):
    """What a :class:`Screen` needs from the served app: the patient's case, editor,
    settings and jobs, shared by every tab (read-only here), and the actions a tab asks
    for (``asker``: the tab that gets the errors)."""

    @property
    def server(self) -> viser.ViserServer: ...
    @property
    def case_id(self) -> str: ...
    @property
    def credit(self) -> str: ...
    @property
    def work(self) -> PatientWork: ...
    @property
    def work_dir(self) -> Path: ...
    @property
    def editable(self) -> list[str]: ...
    @property
    def photos(self) -> dict[str, np.ndarray]: ...
    @property
    def curve_params(self) -> CurveParams: ...
    @property
    def refine_params(self) -> RefineParams: ...
    @property
    def interactive_iterations(self) -> int: ...
    @property
    def edit_help(self) -> str: ...
    @property
    def photos_note(self) -> str: ...
    @property
    def suspect_messages(self) -> list[str]: ...
    @property
    def calliper_inputs(self) -> set[str]: ...
    @property
    def estimated(self) -> dict[str, Estimate]: ...
    @property
    def diagrams(self) -> LandmarkDiagrams: ...

    def open(self, path: Path | None, asker: Screen | None = None) -> None: ...
    def open_patient(self, pid: str, slug: str | None = None,
                     asker: Screen | None = None) -> None: ...
    def new_simulation(self, asker: Screen | None = None) -> None: ...
    def duplicate_simulation(self, asker: Screen | None = None) -> None: ...
    def delete_simulation(self, asker: Screen | None = None) -> Path: ...
    def annotated_elsewhere(self, folder: Path, screen: Screen) -> bool: ...
    def set_symmetric(self, on: bool) -> None: ...
    def recompute(self, asker: Screen | None = None) -> None: ...
    def params_changed(self, stage: str, asker: Screen | None = None) -> None: ...
    def download(self, client: viser.ClientHandle | None, kind: str, fmt: str,
                 **kw: str) -> None: ...


class Screen:
    """One browser tab of ``app``: panels, scene, patient mode and new-patient page in the
    tab's client scope; the editor and case are ``app``'s.

    Args:
        app: the served app (case, editor, jobs shared by every tab), as
            :class:`ScreenHost`.
        client: the tab.
        patient_screen: the tab is the patient screen (starts in patient mode).
    """

    def __init__(self, app: ScreenHost, client: viser.ClientHandle,
                 patient_screen: bool = False) -> None:
        self.app = app
        self.client = client
        self.patient_screen = patient_screen
        self.scene: FaceScene | None = None
        self.annotate: AnnotatePage | None = None
        self.closed = False
        self.released = threading.Event()
        """Set once :meth:`close` has released everything the tab held."""
        self._lock = threading.RLock()
        self._subscribed: EditController | None = None
        self.shown = threading.Event()
        """Set once this tab shows the open case (scene, panel texts, patient mode)."""
        client.scene.set_up_direction("+y")
        self.panels = Panels(client, self)
        self.panels.build_params(app.curve_params, app.refine_params)
        set_value(self.panels.interactive_iters, app.interactive_iterations)
        self.patient = PatientMode(client, self, app.work_dir)
        self._build_patient_folder()
        self.view_name = DEFAULT_VIEW
        self._scale_bar: list[viser.SceneNodeHandle] = []
        self.photo_sim = PhotoSimulation(self._sim_inputs, VIEWS)
        with self.panels.photo_sim_folder:
            self.client.gui.add_markdown("The simulated nose on the patient's photo "
                                         "(updated when a drag ends).")
            self.photo_sim.add_display(self.client.gui)
        with self.patient.panel.add_tab("On the photos", icon=viser.Icon.PHOTO):
            self.photo_sim.add_display(self.client.gui)
        self._label_timer: threading.Timer | None = None
        client.camera.on_update(lambda _: self._camera_moved())

    def _camera_moved(self) -> None:
        """The tab's view changed: lay the landmark labels out again once it rests
        (0.2 s), for what this view sees (:func:`naseview.app.scene_geometry.label_layout`)."""
        if self._label_timer is not None:
            self._label_timer.cancel()
        t = threading.Timer(0.2, self._layout_labels)
        t.daemon = True
        self._label_timer = t
        t.start()

    def _layout_labels(self) -> None:
        scene = self.scene
        if scene is None or self.closed:
            return
        try:
            c = self.client.camera
            cam = camera_of_view(c.position, c.look_at, c.up_direction, c.fov, c.aspect,
                                 600)
            with self._lock:
                if self.scene is scene:
                    scene.set_label_camera(cam)
        except Exception:  # the tab went away mid-layout
            log.debug("naseview: label layout skipped", exc_info=True)

    def _build_patient_folder(self) -> None:
        """"Patient" at the top of the panel: new patient, patient mode and screen,
        consultation report."""
        gui = self.client.gui
        with gui.add_folder("Patient", order=-100.0, expand_by_default=True):
            new = gui.add_button("New patient: photos and landmarks",
                                 icon=viser.Icon.USER_PLUS, color="green")
            pm = gui.add_button("Patient mode (presentation)", icon=viser.Icon.PRESENTATION)
            host = connection_host(self.app.server, self.client)
            self.patient_link = gui.add_html(
                "" if host is None else
                f"<a href='{html.escape(patient_screen_url(host), quote=True)}' "
                "target='_blank' rel='noopener'>Open the patient screen</a> — a second "
                "tab (or window on the patient's monitor) that follows your edits with its "
                "own view", visible=host is not None)
            rep = gui.add_button("Consultation report", icon=viser.Icon.FILE_TEXT)
        new.on_click(lambda e: self._run(self.show_new_patient))
        pm.on_click(lambda e: self._run(self.patient.enter))
        rep.on_click(lambda e: self._run(lambda: self.patient.download_report(e.client)))

    def _run(self, fn: Callable[[], object]) -> None:
        """Run a button action; errors become a red notification in this tab."""
        run_action(fn, lambda message: self.notify(message, "red"))

    def notify(self, body: str, color: NoticeColor = "blue") -> None:
        notify(self.client, "naseview", body, color, seconds=8.0)

    # what the pages read (AppHost)
    @property
    def controller(self) -> EditController | None:
        return self.app.controller

    @property
    def case(self) -> Case | None:
        return self.app.case

    @property
    def patient_id(self) -> str | None:
        return self.app.work.patient_id

    @property
    def texture(self) -> FaceTexture | None:
        look = face_look(self.app)
        return look.texture if look is not None else None

    @property
    def case_id(self) -> str:
        return self.app.case_id

    @property
    def credit(self) -> str:
        return self.app.credit

    def open(self, path: Path | None) -> None:
        """Open ``path`` for the patient (every tab follows); errors show here."""
        self.app.open(path, asker=self)

    # what the "Patient's work" section reads (PatientsHost)
    @property
    def work(self) -> PatientWork:
        return self.app.work

    def open_patient(self, pid: str, slug: str | None = None) -> None:
        self.app.open_patient(pid, slug, asker=self)

    def new_simulation(self) -> None:
        self.app.new_simulation(asker=self)

    def duplicate_simulation(self) -> None:
        self.app.duplicate_simulation(asker=self)

    def delete_simulation(self) -> Path:
        return self.app.delete_simulation(asker=self)

    # the case
    def show_case(self, keep_camera: bool = False) -> None:
        """Build this tab's scene of the app's editor (after an install, or when the tab
        connects) and bring the panel up to date. The face is textured when the photo
        texture is baked, else in plain skin (the app bakes it after the editor is up
        and then calls this again with ``keep_camera``: the tab's view is kept)."""
        app = self.app
        ctl = app.controller
        if ctl is None or self.closed:
            return
        with self._lock:
            self.shown.clear()
            self._drop_scene()
            look = face_look(app, bake=False)
            scene = FaceScene(self.client, ctl, app.editable, app.cameras, app.photos,
                              region=app.moving,
                              parts=look.parts if look is not None else None)
            if ctl.simulation.generation == ctl.generation:
                scene.update(ctl.simulation)
            self.scene = scene
            ctl.on_simulation.append(self._on_simulation)
            ctl.on_history.append(self._on_history)
            self._subscribed = ctl
            self.apply_display()
            annotating = self.annotate is not None and self.annotate.active
            if not annotating and not keep_camera:   # the page frames its photo
                self.reset_camera()
            self._camera_moved()
        self._show_texts()
        self.photo_sim.request()
        if self.patient_screen or self.patient.active:
            self.patient.enter()
        self.shown.set()

    def _drop_scene(self) -> None:
        """Remove this tab's scene and its listeners from the controller it showed."""
        ctl, self._subscribed = self._subscribed, None
        if ctl is not None:
            if self._on_simulation in ctl.on_simulation:
                ctl.on_simulation.remove(self._on_simulation)
            if self._on_history in ctl.on_history:
                ctl.on_history.remove(self._on_history)
        self._remove_scale_bar()
        scene, self.scene = self.scene, None
        if scene is not None:
            try:
                scene.remove()            # also detaches the scene's own listeners
            except Exception:  # the tab went away meanwhile
                log.debug("naseview: scene of a closed tab", exc_info=True)

    def _show_texts(self) -> None:
        """Edit help, measurements, history buttons, photo and credit of the case."""
        ctl = self.app.controller
        if ctl is None:
            return
        p = self.panels
        p.edit_info.content = self.app.edit_help
        p.show_error(None)
        self._on_simulation(ctl.simulation)
        self._on_history()
        self._offer_views()
        self.show_photo(p.photo_view.value)
        credit = self.app.credit or ""
        p.credit.content = f"<small>Face model: {credit}</small>" if credit else ""

    def _offer_views(self) -> None:
        """The photo dropdowns list the open case's photos (the obliques when it has them)."""
        case = self.app.case
        views = tuple(v for v in ALL_VIEWS if case is not None and v in case.views) or VIEWS
        set_options(self.panels.photo_view, views)
        self.photo_sim.set_views(views)

    # listeners (controller worker thread)
    def _on_simulation(self, sim: Simulation) -> None:
        ctl = self.app.controller
        if ctl is None or self.closed:
            return
        p = self.panels
        p.set_measurements(ctl.baseline.measurements, sim.measurements,
                           self.app.calliper_inputs, self.app.estimated)
        if self.scene is not None and self.scene.show_colormap:
            self._update_colorbar(sim)
        if not sim.interactive:
            text = self.app.edit_help
            if sim.warnings:
                text += "\n\n⚠ " + " ".join(w.removeprefix("stage 3: ") for w in sim.warnings)
            p.edit_info.content = text
            self.photo_sim.request()          # a final solve: recomposite the photos
            if self.patient.active:
                self.patient.refresh()

    def _on_history(self) -> None:
        ctl = self.app.controller
        if ctl is None or self.closed:
            return
        self.panels.set_history(ctl.can_undo, ctl.can_redo, ctl.is_edited())
        self.panels.set_plan(ctl.manoeuvres)
        if bool(self.panels.symmetric.value) != ctl.symmetric:   # set in another tab
            set_value(self.panels.symmetric, ctl.symmetric)

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

    # messages from the app (status of the patient's jobs)
    def set_status(self, text: str) -> None:
        self.panels.set_status(text)

    def set_progress(self, fraction: float | None) -> None:
        self.panels.set_progress(fraction)

    def show_error(self, message: str | None) -> None:
        """The error line (and a notification, except on a screen the patient sees)."""
        self.panels.show_error(message, notify_tab=not self.patient.active)

    # this tab's view
    def apply_display(self) -> None:
        """Show the scene as this tab's display and before / after toggles say."""
        if self.scene is None:
            return
        p = self.panels
        self.scene.set_visible(construction=p.show_construction.value,
                               labels=p.labels.value, curves=p.show_curves.value,
                               ad_landmarks=p.show_ad.value, cameras=p.show_cameras.value,
                               landmarks=p.show_landmarks.value, highlight=p.highlight.value)
        self.scene.set_view(colormap=p.colormap.value, original=p.show_original.value,
                            overlay=p.overlay.value)

    def reset_camera(self) -> None:
        """This tab's camera on the default view of the nose (:func:`nose_view`)."""
        self.show_standard_view(DEFAULT_VIEW)

    def show_standard_view(self, view: str) -> None:
        """This tab's camera on a standard view of the nose
        (:data:`naseview.camera.STANDARD_VIEWS`), the scale bar facing it."""
        ctl = self.app.controller
        if ctl is None:
            return
        base = ctl.baseline
        target, eye, fov, R = view_pose(base.V, base.nose_ids, view)
        self.view_name = view
        cam = self.client.camera
        with self.client.atomic():
            cam.fov = fov
            cam.near = 5.0
            cam.far = 5000.0
            # position first: viser moves look_at along with a position update
            cam.position = (float(eye[0]), float(eye[1]), float(eye[2]))
            cam.look_at = (float(target[0]), float(target[1]), float(target[2]))
            cam.up_direction = (0.0, 1.0, 0.0)
        self._place_scale_bar(ctl.simulation.V, base.F, base.nose_ids, view)

    def _aspect(self) -> float:
        """Width / height of this tab's 3D view (1 before the browser reported it)."""
        try:
            a = float(self.client.camera.aspect)
        except Exception:  # no camera message yet
            return 1.0
        return a if np.isfinite(a) and a > 0 else 1.0

    def _remove_scale_bar(self) -> None:
        for h in self._scale_bar:
            try:
                h.remove()
            except Exception:  # the tab went away
                log.debug("naseview: scale bar already gone", exc_info=True)
        self._scale_bar = []

    def _place_scale_bar(self, V: np.ndarray, F: np.ndarray, nose_ids: np.ndarray,
                         view: str) -> None:
        """A 10 mm bar beside the face in the plane facing the standard ``view`` (none in
        patient mode: the turntable would carry it across the face)."""
        self._remove_scale_bar()
        if self.patient_screen or self.patient.active:
            return
        cam = view_camera(V, nose_ids, view, self._aspect())
        segs, label_at = scale_bar_segments(V, F, nose_ids, cam)
        left_side = float(np.dot(label_at - segs[0, 0], cam.R[0])) < 0
        scene = self.client.scene
        self._scale_bar = [
            scene.add_line_segments("/scale_bar/bar", segs, SCALE_BAR_COLOR, thickness=3.0,
                                    thickness_units="screen"),
            scene.add_label("/scale_bar/label", f"{SCALE_BAR_MM:g} mm",
                            position=np.asarray(label_at, np.float64),
                            font_screen_scale=1.2,
                            anchor="center-right" if left_side else "center-left")]

    def save_view_png(self, client: viser.ClientHandle | None = None) -> None:
        """A PNG of this tab's current view (software renderer through its camera,
        textured when photos exist), sent as a download (in the background)."""
        ctl = self.app.controller
        if ctl is None:
            raise NaseviewError("nothing to save yet: the reconstruction is not ready")
        c = self.client.camera
        cam = camera_of_view(c.position, c.look_at, c.up_direction, c.fov, c.aspect,
                             PNG_HEIGHT)
        V, F = ctl.simulation.V.copy(), ctl.baseline.F
        look = face_look(self.app)
        name = (self.app.case_id.replace("/", "_") or "case") + f"-{self.view_name}.png"
        target = client or self.client

        def job() -> None:
            try:
                data = view_png(V, F, cam, look.texture if look is not None else None,
                                nose_ids=ctl.baseline.nose_ids)
                target.send_file_download(name, data, save_immediately=True)
            except Exception as e:
                log.exception("naseview: view PNG failed")
                self.notify(f"Saving the view failed: {e}", "red")

        threading.Thread(target=job, name="naseview-view-png", daemon=True).start()

    def _sim_inputs(self, view: str) -> SimInputs | None:
        """What the photo composite of ``view`` needs now (None: nothing to show)."""
        app = self.app
        ctl = app.controller
        look = face_look(app) if ctl is not None else None
        if ctl is None or look is None:
            return None
        sim = ctl.simulation
        return sim_inputs(look.photos, app.cameras, ctl.baseline.V, sim.V, ctl.baseline.F,
                          app.moving if len(app.moving) else ctl.baseline.nose_ids,
                          (sim.generation, sim.revision), view)

    def show_photo(self, view: str) -> None:
        """Photo of ``view`` with clicks, reprojected landmarks / curves and residuals."""
        p = self.panels
        app = self.app
        ctl = app.controller
        case = app.case
        if case is None or ctl is None or view not in case.views:
            p.photo.visible = False
            if case is None:
                p.residuals.content = app.photos_note
            return
        base = ctl.baseline
        cams = base.reconstruction.cameras if base.reconstruction else {}
        res = {v: click_residuals(vv.landmarks, cams[v], base.landmarks)
               for v, vv in case.views.items() if v in cams}
        flag = flag_threshold(res)
        p.photo.image = annotate_photo(case.load_image(view), cams.get(view),
                                       case.views[view].landmarks, base.landmarks,
                                       base.curves, flag_px=flag)
        p.photo.visible = True
        text = residual_markdown(res, flag)
        if app.suspect_messages:
            text += "\n\n**Stage 1 flagged:**\n\n" + "\n".join(
                f"- {m}" for m in app.suspect_messages)
        p.residuals.content = text

    def show_new_patient(self) -> None:
        """This tab's new-patient page (built the first time it is asked for)."""
        if self.annotate is None:
            self.annotate = AnnotatePage(
                self.app.server, self, self.app.work_dir, client=self.client,
                diagrams=self.app.diagrams,
                in_use=lambda folder: self.app.annotated_elsewhere(folder, self))
        self.annotate.show_start()

    # panel actions (PanelActions)
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
        self.app.set_symmetric(on)

    def set_manoeuvre(self, name: str, amount: float) -> None:
        """One manoeuvre of the patient's plan (every tab's slider follows)."""
        if self.controller is not None:
            self.controller.set_manoeuvre(name, amount)

    def clear_plan(self) -> None:
        if self.controller is not None:
            self.controller.set_manoeuvres({})

    def set_visible(self, **kw: bool) -> None:
        if self.scene is not None:
            self.scene.set_visible(**kw)

    def set_view(self, **kw: bool) -> None:
        ctl = self.app.controller
        if self.scene is None or ctl is None:
            return
        self.scene.set_view(**kw)
        if self.scene.show_colormap:
            self._update_colorbar(ctl.simulation)
        else:
            self.panels.set_colorbar(None)

    def recompute(self) -> None:
        self.app.recompute(asker=self)

    def params_changed(self, stage: str) -> None:
        self.app.params_changed(stage, asker=self)

    def download(self, client: viser.ClientHandle | None, kind: str, fmt: str,
                 **kw: str) -> None:
        """An export: ``kind`` "textured" / "solid" here (:func:`look_export`), the
        others through the app."""
        if kind in ("textured", "solid"):
            fname, data = look_export(self.app, kind, fmt, **kw)
            (client or self.client).send_file_download(fname, data, save_immediately=True)
            return
        self.app.download(client or self.client, kind, fmt, **kw)

    # lifecycle
    def close(self) -> None:
        """The tab went away: leave the controller, stop the turntable and the page's
        threads (never raises: the client is gone)."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            if self._label_timer is not None:
                self._label_timer.cancel()
            for step in (self.patient.close, self.photo_sim.close, self._drop_scene,
                         self.annotate.close if self.annotate is not None else None):
                if step is None:
                    continue
                try:
                    step()
                except Exception:
                    log.debug("naseview: closing a tab", exc_info=True)
            self.released.set()


__all__ = ["PATIENT_SCREEN_PATH", "Screen", "ScreenHost", "connection_host", "connection_path",
           "nose_view", "patient_screen_url"]
