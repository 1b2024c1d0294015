"""The "new patient" page: photo intake and guided landmark clicks in the browser.

One photo at a time fills the 3D view: the photo is a scene image (``scene.add_image``) on
a plane far away from the face, seen straight on by a camera the page places; a click
anywhere in the view is a ray (``scene.on_click``) that is intersected with the photo
plane to give pixels (:mod:`naseview.app.photo_plane`). The left panel
names the next landmark with a one-line description and a small diagram of where it is
(:mod:`naseview.app.landmark_diagrams`); a click places it and the next one follows
(:mod:`naseview.intake` holds the order and every rule, no viser).
Placed clicks are green rings that can be dragged; Undo and "Not visible" (skip) are one
button each. From the second click in a photo, the next landmark is pre-placed as a
magenta ring (:mod:`naseview.intake.predict`: a fit of the generic nose to the clicks so
far, and once enough clicks exist the reprojection of the already reconstructed landmarks,
quick stage 1, paper §3.2, in a background worker), the other remaining ones as small
cyan dots; "Accept the marker" places the landmark there in one click.

"Reconstruct" writes the SPEC §3 case directory (``WORK/<id>/case``, rerunnable with
``naseview reconstruct``) and opens it in the app (:class:`naseview.app.serve.NaseviewApp`),
which reconstructs with progress in its panel. Every change is autosaved in
``WORK/in-progress/<id>/`` and the page offers to resume it after a reload or restart.
A new patient always gets a fresh folder; an id typed that another patient has is refused
with one line, and "Open patient <id>" opens that patient instead, on purpose
(:class:`naseview.intake.patients.PatientFolders`).

Uploads: the photo buttons are limited while the file streams in
(:class:`naseview.app.upload_limit.UploadLimit`, ``MAX_UPLOAD_BYTES``): a larger photo is
dropped at its first message, never held in memory; a decompression bomb is refused by
the pixel check before decoding; either way the page shows one line.

Navigation: a left-drag on the photo draws a box and zooms into it (it does not orbit,
which would tilt the photo), the wheel zooms, a right-drag pans; "Whole photo" / "Nose"
re-frame. A click outside the photo is refused with a message.

Per tab: the app builds one page per browser tab that asks for it, in that tab's client
scope (:mod:`naseview.app.scope`): its panel, photo, rings and camera never reach another
tab. Two tabs never annotate the same unfinished patient (``in_use``); the landmark
diagrams are rendered once for all tabs (``diagrams``). Built on the server scope (no
``client``), the page reaches every tab.

Ordering: scene clicks arrive in an ``async`` callback (the event loop keeps their order)
and are queued to one worker thread, so fast clicking never reorders landmarks.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import viser

from naseview.app.gui_value import set_value
from naseview.app.host import AppHost
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.landmark_names import display_name
from naseview.app.markdown_text import markdown_text
from naseview.app.patients_panel import PatientList
from naseview.app.photo_camera import fit_photo, frame_pixels, nose_box, screen_box_pixels
from naseview.app.photo_plane import PhotoPlane, disc_mesh, ring_mesh
from naseview.app.scope import (
    NoticeColor,
    Scope,
    clients_of,
    notify,
    run_action,
)
from naseview.app.upload_limit import UploadLimit
from naseview.errors import NaseviewError
from naseview.facemodel import FaceModel
from naseview.intake.click_order import CLICK_ORDER, VIEW_ORDER, VIEW_TITLES, definition
from naseview.intake.guidance import Guidance
from naseview.intake.in_progress import InProgress
from naseview.intake.patients import PatientFolders
from naseview.intake.photo_check import photo_warning
from naseview.intake.predict import predict_next
from naseview.intake.session import AnnotationSession, default_case_id
from naseview.landmarks import VIEWS
from naseview.records import PatientRecords

log = logging.getLogger(__name__)

PLACED_RGB = (40, 220, 90)
ACTIVE_RGB = (255, 210, 0)
HINT_RGB = (255, 40, 200)
OTHER_HINT_RGB = (40, 200, 255)
VIEW_BUTTONS = {"Front": "front", "Bottom": "bottom", "Left": "left", "Right": "right"}
_UNSET = object()
PICK_NONE = "— choose a landmark —"
"""The landmark drop-down's entry while the landmark being clicked is in another photo."""


GuiEvent = viser.GuiEvent[Any]
"""A GUI callback's event (``event.client`` is None for values the server assigns)."""


def _view_of(label: str) -> str:
    """View of a button label such as ``"Front 8/21"``."""
    return VIEW_BUTTONS[label.split(" ", 1)[0]]


class AnnotatePage:
    """Intake and guided annotation of a new patient, in its own docked panel.

    Args:
        server: the ``viser.ViserServer`` (shared by the app).
        app: the tab (:class:`~naseview.app.screen.Screen`) that opens the result, or
            ``None`` (then "Reconstruct" only writes the case directory).
        work_dir: where patients are kept (default :func:`default_work_dir`).
        diagram_model: face model for the landmark diagrams (``None``: default model).
        client: the tab the page lives in (``None``: every tab, on the server scope).
        diagrams: landmark diagrams shared with other tabs' pages (default: new ones of
            ``diagram_model``).
        in_use: ``in_use(folder)`` is True when another tab annotates that unfinished
            patient (never resumed here then).
    """

    def __init__(self, server: viser.ViserServer, app: AppHost | None = None,
                 work_dir: str | Path | None = None,
                 diagram_model: FaceModel | str | None = None, *,
                 client: viser.ClientHandle | None = None,
                 diagrams: LandmarkDiagrams | None = None,
                 in_use: Callable[[Path], bool] | None = None) -> None:
        self.server = server
        self.client = client
        self.scope: Scope = client if client is not None else server
        self.gui = self.scope.gui
        self.app = app
        self.in_use: Callable[[Path], bool] = in_use or (lambda folder: False)
        self.folders = PatientFolders(work_dir)
        self.work_dir = self.folders.root
        self.diagrams = diagrams if diagrams is not None else LandmarkDiagrams(diagram_model)
        self.session: AnnotationSession | None = None
        self.view = VIEW_ORDER[0]
        self.target: tuple[str, str] | None = None
        self.override: str | None = None
        self.active = False
        self.plane: PhotoPlane | None = None
        self.guidance: Guidance | None = None
        self.events: list[tuple[float, str]] = []
        self._lock = threading.RLock()
        self._queue: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._worker = threading.Thread(target=self._run, name="naseview-annotate",
                                        daemon=True)
        self._worker.start()
        self._hint_cond = threading.Condition()
        self._hint_request = -1
        self._hint_thread = threading.Thread(target=self._hint_run, name="naseview-hints",
                                             daemon=True)
        self._hint_thread.start()
        self._handles: dict[str, Any] = {}  # scene node name -> viser handle
        self._drag: dict[int, tuple[str, np.ndarray]] = {}
        self._click_cb: Callable[[viser.SceneClickEvent], Any] | None = None
        self._rect_cb: Callable[[viser.SceneRectSelectEvent], Any] | None = None
        self._drag_time = 0.0
        self._sent: dict[tuple[int, str], object] = {}
        self._intake_open = False
        self._last_pred: dict[str, np.ndarray] = {}   # the markers drawn last
        self._photo_warnings: dict[str, str] = {}      # view -> photo_warning at upload
        self._last_upload = 0.0
        self._taken_id: str | None = None      # an id typed that another patient has
        self._build_gui()
        # the server's limit holds on every connection; these buttons are the uploads
        self.upload_limit = UploadLimit.of(server)
        for btn in self.uploads.values():
            self.upload_limit.watch(btn, self._on_upload_refused)
        threading.Thread(target=self.diagrams.warm, name="naseview-diagrams",
                         daemon=True).start()

    # GUI
    def _build_gui(self) -> None:
        gui = self.gui
        self.panel = gui.add_panel(visible=False)
        self.panel.dock_left()
        self.panel.set_width(370)
        with self.panel.add_tab("New patient", icon=viser.Icon.USER_PLUS):
            self.status = gui.add_markdown("", order=0.1)
            self.error = gui.add_markdown("", visible=False, order=0.2)
            # marking comes first once a photo is there; intake below, reconstruct last
            # intake on top, but it shrinks to one line once the four photos are in, so
            # that the landmark section sits right under it without scrolling
            with gui.add_folder("Patient and photos", order=1.0) as self.f_intake:
                self.resume_dd = gui.add_dropdown("Annotated", ("—",), visible=False,
                                                  hint="Annotations saved automatically; "
                                                  "✓ reconstructed: its case was written")
                self.resume_btn = gui.add_button("Resume this patient", visible=False,
                                                 icon=viser.Icon.PLAYER_PLAY)
                self.alal = gui.add_number("al_l-al_r (mm)", 0.0, min=0.0, max=80.0,
                                           step=0.1, hint="Alar width measured with a "
                                           "calliper: sets the scale of the 3D result")
                self.intake_md = gui.add_markdown("", visible=False)
                self.change_btn = gui.add_button("Change photos, id or distances",
                                                 visible=False, icon=viser.Icon.PENCIL)
                self.case_id = gui.add_text("Case id", default_case_id(),
                                            hint="Anonymised id: no patient names")
                self.open_btn = gui.add_button("Open that patient", visible=False,
                                               icon=viser.Icon.FOLDER_OPEN,
                                               hint="Open the patient who has this id")
                self.other = gui.add_text("Other distances", "",
                                          hint="Optional calliper distances, e.g. "
                                               "n-prn=45.2, mf_l-mf_r=18")
                self.uploads = {}
                # upload buttons ignore `visible` (viser 1.1.1): hide their folder instead
                with gui.add_folder(None) as self.f_uploads:
                    for label, view in VIEW_BUTTONS.items():
                        self.uploads[view] = gui.add_upload_button(
                            f"{label} photo", icon=viser.Icon.UPLOAD,
                            mime_type="image/jpeg,image/png",
                            hint=f"{VIEW_TITLES[view]}: JPEG or PNG")
                self.photo_info = gui.add_markdown("")
            with gui.add_folder("Landmarks", order=2.0, visible=False) as self.f_marks:
                self.view_group = gui.add_button_group("Photo", tuple(VIEW_BUTTONS))
                self.target_md = gui.add_markdown("")
                self.diagram = gui.add_image(np.full((8, 8, 3), 245, np.uint8),
                                             format="jpeg", jpeg_quality=88, visible=False)
                self.accept_btn = gui.add_button(
                    "Accept the marker", icon=viser.Icon.CHECK, color="pink",
                    disabled=True, hint="Place the landmark on the pink marker, which is "
                    "where the clicks so far put it; click on the photo instead if it is off")
                self.skip_btn = gui.add_button("Not visible — skip",
                                               icon=viser.Icon.PLAYER_SKIP_FORWARD,
                                               hint="This landmark cannot be seen here")
                self.undo_btn = gui.add_button("Undo", icon=viser.Icon.ARROW_BACK_UP,
                                               disabled=True)
                self.progress = gui.add_progress_bar(0.0, color="green")
                self.hint_md = gui.add_markdown("")
                self.zoom = gui.add_button_group("Zoom", ("Whole photo", "Nose"))
                self.pick = gui.add_dropdown("Landmark", (PICK_NONE,),
                                             hint="Choose a landmark to click (again)")
                self.labels_cb = gui.add_checkbox("Labels on clicks", True)
            with gui.add_folder("Reconstruct", order=3.0) as self.f_rec:
                self.problems_md = gui.add_markdown("")
                self.rec_btn = gui.add_button("Reconstruct", icon=viser.Icon.CUBE,
                                              color="green", disabled=True)
                self.rec_md = gui.add_markdown("")
            self.close_btn = gui.add_button("Close (back to the 3D view)",
                                            icon=viser.Icon.X, order=4.0)
        self.patient_list: PatientList | None = None
        """Earlier patients (when the page opens what it makes: ``app`` given)."""
        if self.app is not None:
            with self.panel.add_tab("Patients", icon=viser.Icon.USERS):
                self.patient_list = PatientList(
                    gui, PatientRecords(self.work_dir).list_patients, self.folders,
                    self._open_patient)
        self._wire()

    def _wire(self) -> None:
        def safe(fn: Callable[[GuiEvent], object]) -> Callable[[GuiEvent], None]:
            def run(event: GuiEvent) -> None:
                try:
                    fn(event)
                except NaseviewError as e:
                    self.show_error(str(e), event.client)
                except Exception as e:  # keep the server up, show the error
                    log.exception("naseview: annotation action failed")
                    self.show_error(f"{type(e).__name__}: {e}", event.client)
            return run

        def user(fn: Callable[[GuiEvent], object]) -> Callable[[GuiEvent], None]:
            """Only events from a browser: values the server assigns (``client`` None)
            also fire ``on_update`` and must not act again."""
            inner = safe(fn)

            def run(event: GuiEvent) -> None:
                if event.client is not None:
                    inner(event)
            return run

        def upload_to(view: str) -> Callable[[GuiEvent], object]:
            return lambda e: self._on_upload(view, e)

        for view, btn in self.uploads.items():
            btn.on_upload(safe(upload_to(view)))
        self.alal.on_update(user(lambda e: self._on_scale()))
        self.other.on_update(user(lambda e: self._on_scale()))
        self.case_id.on_update(user(lambda e: self._on_case_id()))
        self.view_group.on_click(user(lambda e: self._on_view_button(str(e.target.value))))
        self.zoom.on_click(user(lambda e: self.submit(
            self.fit_camera if e.target.value == "Whole photo" else self.zoom_nose)))
        self.skip_btn.on_click(safe(lambda e: self.submit(self._skip)))
        self.accept_btn.on_click(safe(lambda e: self.submit(self._accept)))
        self.undo_btn.on_click(safe(lambda e: self.submit(self._undo)))
        self.pick.on_update(user(lambda e: self._on_pick(str(e.target.value))))
        self.labels_cb.on_update(user(lambda e: self.submit(self._redraw)))
        self.rec_btn.on_click(safe(lambda e: self.reconstruct()))
        self.close_btn.on_click(safe(lambda e: self.hide()))
        self.resume_btn.on_click(safe(lambda e: self._on_resume()))
        self.open_btn.on_click(safe(lambda e: self._on_open_existing()))
        self.change_btn.on_click(safe(lambda e: self._toggle_intake()))

    # worker
    def submit(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the page's worker thread, in submission order."""
        self._queue.put(fn)

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until every submitted action ran (tests)."""
        done = threading.Event()
        self._queue.put(done.set)
        return done.wait(timeout)

    def _run(self) -> None:
        while True:
            fn = self._queue.get()
            if fn is None:
                return
            run_action(fn, self.show_error, "annotation step")

    # lifecycle
    def start(self, case_id: str | None = None) -> AnnotationSession:
        """Show the page with a new patient in a fresh folder (``in-progress/<id>`` under
        the work dir, :meth:`PatientFolders.new_session`).

        Raises:
            NaseviewError: ``case_id`` is given and another patient has it.
        """
        session = self.folders.new_session(case_id, lazy=True)
        self._attach(session)
        return session

    def resume(self, folder: str | Path) -> AnnotationSession:
        """Show the page with the annotation autosaved in ``folder``."""
        session = AnnotationSession.open(folder)
        self._attach(session)
        return session

    def show_start(self) -> None:
        """Show the page: the patient being annotated, else the newest unfinished one
        (the list offers the others), else a new patient. A patient whose case was
        already reconstructed is not reopened: "New patient" then starts a new one. The
        "Patients" tab lists the patients kept so far."""
        if self.patient_list is not None:
            self.patient_list.refresh()
        if self.session is not None and self.session.case_dir is None:
            self._attach(self.session)
            return
        found = [a for a in self.folders.annotations()
                 if not a.finished and a.problem is None and not self.in_use(a.folder)]
        if found:
            self.resume(found[0].folder)
        else:
            self.start()

    def _attach(self, session: AnnotationSession) -> None:
        with self._lock:
            self.session = session
            self._photo_warnings = {}
            self.override = None
            self.guidance = None
            self._offer_open(None)
            set_value(self.case_id, session.case_id)
            al = session.scale_mm.get(("al_l", "al_r"))
            set_value(self.alal, float(al) if al else 0.0)
            set_value(self.other, ", ".join(f"{a}-{b}={d:g}" for (a, b), d in
                                            session.scale_mm.items()
                                            if (a, b) != ("al_l", "al_r")))
            self.view = session.active_view
        self._refresh_resume_list()
        self.show()
        self.submit(lambda: self.set_view(self.view, fit=True))
        self._request_hints()

    def show(self) -> None:
        """Make the page the active view: its panel, the photo, the click handler."""
        with self._lock:
            if self.active:
                return
            self.active = True
            self.panel.visible = True
            self.panel.expand()
            self.gui.main_panel.minimize()
            scene = self.scope.scene

            # async: the event loop keeps the clicks in order (viser runs coroutine
            # callbacks too, though it declares plain ones)
            @scene.on_click()  # type: ignore[arg-type]
            async def _click(event: viser.SceneClickEvent) -> None:
                self._on_scene_click(event)

            # a left-drag on the photo draws a box to zoom into instead of orbiting the
            # camera (which would tilt the photo); right-drag pans, the wheel zooms
            @scene.on_rect_select()
            def _rect(event: viser.SceneRectSelectEvent) -> None:
                try:
                    self.zoom_rect(event.client, event.screen_min, event.screen_max)
                except Exception:
                    log.exception("naseview: zoom failed")

            self._click_cb = _click
            self._rect_cb = _rect
            for h in self._handles.values():
                h.visible = True

    def hide(self) -> None:
        """Back to the 3D app: hide the photo, stop taking clicks, restore its panel."""
        with self._lock:
            if not self.active:
                return
            self.active = False
            if self._click_cb is not None:
                self.scope.scene.remove_click_callback(self._click_cb)
                self._click_cb = None
            if self._rect_cb is not None:
                self.scope.scene.remove_rect_select_callback(self._rect_cb)
                self._rect_cb = None
            for h in self._handles.values():
                h.visible = False
            self.panel.visible = False
            self.gui.main_panel.expand()
        # Bring the cameras back to the face first: from 100 m away, viser's separate
        # look_at / position updates of the app's camera placement end up misaligned.
        eye, target = (0.0, -40.0, 450.0), (0.0, -40.0, 0.0)
        if self.client is None:             # a page on the server scope: new tabs' view
            cam0 = self.server.initial_camera
            cam0.position, cam0.look_at, cam0.up = eye, target, (0.0, 1.0, 0.0)
            cam0.near, cam0.far = 1.0, 5000.0
        for client in clients_of(self.scope):
            with client.atomic():
                client.camera.position = eye
                client.camera.look_at = target
                client.camera.up_direction = (0.0, 1.0, 0.0)
                client.camera.near = 1.0
                client.camera.far = 5000.0
        app = self.app
        if app is not None:
            try:
                app.reset_camera()
            except Exception:
                log.debug("naseview: could not reset the app camera", exc_info=True)

    def close(self) -> None:
        for btn in self.uploads.values():
            self.upload_limit.unwatch(btn)
        self._queue.put(None)
        with self._hint_cond:
            self._hint_request = -2
            self._hint_cond.notify_all()

    # intake
    def _toggle_intake(self) -> None:
        self._intake_open = not self._intake_open
        self.submit(self._update_panel)

    def _on_view_button(self, label: str) -> None:
        view = _view_of(label)
        self.submit(lambda: self.set_view(view, fit=True))

    def _on_upload(self, view: str, event: GuiEvent) -> None:
        f = event.target.value
        self.upload(view, f.content, f.name)

    def upload(self, view: str, data: bytes, name: str = "") -> None:
        """Take a photo for ``view`` (raises :class:`NaseviewError` with one line)."""
        s = self._need_session()
        had = len(s.clicks[view])
        info = s.add_photo(view, data, name)
        self._photo_warnings.pop(view, None)
        warning = photo_warning(view, s.image(view))
        if warning is not None:       # taken all the same: the surgeon decides; one
            self._photo_warnings[view] = warning    # line in the panel (a toast would sit
            # over the photo's midline, where the first landmarks are clicked)
        self._last_upload = time.monotonic()
        timer = threading.Timer(2.2, lambda: self.submit(self._update_panel))
        timer.daemon = True
        timer.start()
        self.show_error(None)
        # The upload button turning green and the panel's photo line say it was loaded
        # (and downscaled); a toast each would stack over the photo's midline, where the
        # first landmarks are clicked, on a small window. Only lost clicks get one.
        if had:
            clicks = "1 click" if had == 1 else f"{had} clicks"
            self.notify(f"{VIEW_TITLES[view]} replaced",
                        f"{info.width}x{info.height} px. The {clicks} on the previous "
                        f"{view} photo {'was' if had == 1 else 'were'} removed.")
        if view == self.view or self.plane is None or not s.photos.get(self.view):
            self.submit(lambda: self.set_view(view, fit=True))
        else:
            self.submit(self._update_panel)

    def _on_scale(self) -> None:
        s = self._need_session()
        v = float(self.alal.value or 0.0)
        s.set_scale("al_l", "al_r", v if v > 0 else None)
        s.set_scale_text(self.other.value)
        self.show_error(None)
        self.submit(self._update_panel)

    def _on_upload_refused(self, client: viser.ClientHandle | None, message: str) -> None:
        """:class:`UploadLimit`: an upload was refused while streaming (``message``)."""
        self.submit(lambda: self.show_error(message, client))

    def _on_case_id(self) -> None:
        """The typed id becomes the patient's, unless another patient has it: then the
        id stays as it was, the page says so and offers to open that patient."""
        s = self._need_session()
        typed = str(self.case_id.value)
        try:
            self.folders.rename(s, typed)
        except NaseviewError:
            found = self.folders.find(typed)
            self._offer_open(found.case_id if found is not None else None)
            raise
        self._offer_open(None)
        self.show_error(None)
        self.submit(self._update_panel)

    def _offer_open(self, case_id: str | None) -> None:
        """Show (or with ``None`` hide) the button that opens the patient ``case_id``."""
        self._taken_id = case_id
        if case_id is not None:
            self.open_btn.label = f"Open patient {case_id}"
        self.open_btn.visible = case_id is not None

    def _on_open_existing(self) -> None:
        """Open, on purpose, the patient whose id was typed: its unfinished annotation,
        else its case in the 3D app."""
        cid = self._taken_id
        found = self.folders.find(cid) if cid else None
        if found is None:
            self._offer_open(None)
            raise NaseviewError(f"no patient {cid!r} to open any more; type the id again")
        if found.annotation is not None:
            if self.in_use(found.annotation):
                raise NaseviewError(f"{cid} is being annotated in another tab; continue "
                                    "there, or close that tab first")
            self.hide()
            self.resume(found.annotation)
        elif found.case_dir is not None and self.app is not None:
            self.hide()
            self.app.open(found.case_dir)
        else:
            raise NaseviewError(f"{found.case_dir}: open it with naseview serve "
                                f"{found.case_dir}")

    def _open_patient(self, path: Path) -> None:
        """A patient or simulation chosen in the "Patients" tab: opened in the app."""
        if self.app is None:
            return
        self.hide()
        self.app.open(path)

    def _on_resume(self) -> None:
        name = self.resume_dd.value
        for a in self.folders.annotations():
            if self._resume_label(a) == name:
                if a.problem is not None:
                    raise NaseviewError(a.problem)
                if self.in_use(a.folder):
                    raise NaseviewError(f"{a.case_id} is being annotated in another tab; "
                                        "continue there, or close that tab first")
                self.hide()
                self.resume(a.folder)
                return
        if name.startswith("New patient"):
            self.hide()
            self.start()

    @staticmethod
    def _resume_label(a: InProgress) -> str:
        if a.problem is not None:
            return f"{a.case_id} · damaged ({a.folder.name})"
        if a.finished:    # its case was written: marked, so it is not taken for unfinished
            return f"{a.case_id} · ✓ reconstructed · {a.clicks} clicks · {a.updated[:16]}"
        return f"{a.case_id} · {a.clicks} clicks · {a.updated[:16]}"

    def _refresh_resume_list(self) -> None:
        items = self.folders.annotations()
        items.sort(key=lambda a: a.finished)     # unfinished first, newest first (stable)
        labels = [self._resume_label(a) for a in items
                  if self.session is None or a.folder != self.session.folder]
        if labels:
            self.resume_dd.options = tuple(labels) + ("New patient (empty)",)
            self.resume_dd.visible = True
            self.resume_btn.visible = True
        else:
            self.resume_dd.visible = False
            self.resume_btn.visible = False

    def _need_session(self) -> AnnotationSession:
        if self.session is None:
            self.start()
        assert self.session is not None
        return self.session

    # photo view
    def set_view(self, view: str, fit: bool = False) -> None:
        """Show the photo of ``view`` (worker thread)."""
        s = self._need_session()
        if view not in VIEWS:
            raise NaseviewError(f"unknown view {view!r}")
        changed = view != self.view or self.plane is None
        self.view = view
        s.set_active_view(view)
        self.override = None
        scene = self.scope.scene
        if view in s.photos:
            info = s.photos[view]
            plane = PhotoPlane(info.width, info.height)
            img = s.image(view)[:, :, ::-1]
            self._handles["photo"] = scene.add_image(
                "/annotate/photo", img, plane.width_u, plane.height_u, format="jpeg",
                jpeg_quality=92, wxyz=plane.wxyz, position=tuple(plane.centre),
                cast_shadow=False, receive_shadow=False, visible=self.active)
            self.plane = plane
        else:
            self.plane = None
            h = self._handles.pop("photo", None)
            if h is not None:
                h.remove()
        self._make_markers()
        self._redraw()
        if fit or changed:
            self.fit_camera()

    def fit_camera(self, clients: Iterable[viser.ClientHandle] | None = None) -> None:
        """Point every browser's camera straight at the photo, fitted to its window."""
        # a tab's page leaves the other tabs' initial view ("Reset View") alone
        fit_photo(self.server if self.client is None else None,
                  self.plane or PhotoPlane(4, 3),
                  clients or clients_of(self.scope))

    def zoom_nose(self) -> None:
        """Frame the clicks and hints of this photo (the nose) with a margin; before
        three points exist, the central 60 % of the photo."""
        plane = self.plane
        s = self.session
        if plane is None or s is None:
            return
        pts = list(s.clicks[self.view].values())
        if self.guidance is not None:
            pts += list(self.guidance.hints(self.view).values())
        lo, hi = nose_box(plane, pts)
        frame_pixels(plane, lo, hi, clients_of(self.scope))

    def zoom_rect(self, client: viser.ClientHandle, screen_min: tuple[float, float],
                  screen_max: tuple[float, float]) -> None:
        """Zoom ``client``'s view onto a rectangle drawn on the photo (screen 0..1)."""
        plane = self.plane
        if plane is None or time.monotonic() - self._drag_time < 0.6:
            return                      # the pointer was dragging a click, not a box
        box = screen_box_pixels(client.camera, plane, screen_min, screen_max)
        if box is not None:
            frame_pixels(plane, box[0], box[1], [client])

    # markers
    def _make_markers(self) -> None:
        """(Re)create the ring meshes for the photo shown (one instance per landmark)."""
        for key in ("clicks", "grab", "hint", "hints"):
            h = self._handles.pop(key, None)
            if h is not None:
                h.remove()
        for key in [k for k in self._handles if k.startswith("label:")]:
            self._handles.pop(key).remove()
        if self.plane is None:
            return
        scene = self.scope.scene
        r = self.plane.marker_radius()
        order = CLICK_ORDER[self.view]
        n = len(order)
        far = np.tile(self.plane.centre + np.array([0.0, 0.0, -50.0]), (n, 1))
        unit = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        V, F = ring_mesh(0.55 * r, r)
        self._handles["clicks"] = scene.add_batched_meshes_simple(
            "/annotate/clicks", V, F, batched_wxyzs=unit, batched_positions=far,
            batched_colors=np.tile(np.array(PLACED_RGB, np.uint8), (n, 1)),
            material="toon3", side="double", cast_shadow=False, receive_shadow=False,
            visible=self.active)
        # a faint disc under each ring is what the pointer grabs to drag a click
        Vg, Fg = disc_mesh(r)
        self._handles["grab"] = h = scene.add_batched_meshes_simple(
            "/annotate/grab", Vg, Fg, batched_wxyzs=unit, batched_positions=far,
            batched_colors=np.tile(np.array(PLACED_RGB, np.uint8), (n, 1)),
            opacity=0.07, material="toon3", side="double", cast_shadow=False,
            receive_shadow=False, visible=self.active)
        h.on_drag(self._on_drag)
        Vh, Fh = ring_mesh(1.25 * r, 1.6 * r)
        self._handles["hint"] = scene.add_mesh_simple(
            "/annotate/hint", Vh, Fh, color=HINT_RGB, material="toon3", side="double",
            cast_shadow=False, receive_shadow=False, visible=False,
            position=tuple(far[0]))
        Vd, Fd = disc_mesh(0.3 * r)
        self._handles["hints"] = scene.add_batched_meshes_simple(
            "/annotate/hints", Vd, Fd, batched_wxyzs=unit, batched_positions=far,
            batched_colors=np.tile(np.array(OTHER_HINT_RGB, np.uint8), (n, 1)),
            material="toon3", side="double", cast_shadow=False, receive_shadow=False,
            visible=self.active)

    def _redraw(self) -> None:
        """Positions of rings, hints and labels for the current state (worker thread)."""
        s = self.session
        plane = self.plane
        if s is None:
            return
        self.target = self._current_target()
        self._last_pred = {}
        if plane is not None and "clicks" in self._handles:
            order = CLICK_ORDER[self.view]
            far = plane.centre + np.array([0.0, 0.0, -50.0])
            clicks = s.clicks[self.view]
            pos = np.array([plane.to_world(clicks[i], 0.35)[0] if i in clicks else far
                            for i in order])
            grab = np.array([plane.to_world(clicks[i], 0.3)[0] if i in clicks else far
                             for i in order])
            tgt = self.target[1] if self.target and self.target[0] == self.view else None
            cols = np.array([ACTIVE_RGB if i == tgt else PLACED_RGB for i in order],
                            np.uint8)
            hints = self._predicted()
            self._last_pred = hints
            hpos = np.array([plane.to_world(hints[i], 0.2)[0]
                             if i in hints and i != tgt else far for i in order])
            with self.scope.atomic():
                self._handles["clicks"].batched_positions = pos
                self._handles["clicks"].batched_colors = cols
                self._handles["grab"].batched_positions = grab
                self._handles["hints"].batched_positions = hpos
                hint = self._handles["hint"]
                if tgt is not None and tgt in hints:
                    hint.position = tuple(plane.to_world(hints[tgt], 0.25)[0])
                    hint.visible = self.active
                else:
                    hint.visible = False
                self._update_labels(clicks, tgt, hints)
        self._update_panel()

    def _update_labels(self, clicks: dict[str, np.ndarray], target: str | None,
                       hints: dict[str, np.ndarray]) -> None:
        plane = self.plane
        assert plane is not None
        scene = self.scope.scene
        want: dict[str, tuple[str, np.ndarray]] = {}
        if self.labels_cb.value:
            for i, xy in clicks.items():
                want[f"label:{i}"] = (display_name(i), xy)
        if target is not None and target in hints:
            want[f"label:{target}"] = (display_name(target) + " ?", hints[target])
        r = plane.marker_radius()
        for key in [k for k in self._handles if k.startswith("label:") and k not in want]:
            self._handles.pop(key).remove()
        for key, (text, xy) in want.items():
            p = plane.to_world(xy, 0.4)[0] + np.array([1.2 * r, 1.2 * r, 0.0])
            h = self._handles.get(key)
            if h is None:
                self._handles[key] = scene.add_label(
                    f"/annotate/labels/{key[6:]}", text, position=tuple(p),
                    font_screen_scale=1.15, anchor="bottom-left", visible=self.active)
            else:
                h.text = text
                h.position = tuple(p)

    def _current_target(self) -> tuple[str, str] | None:
        s = self.session
        if s is None:
            return None
        if self.override is not None and self.override in CLICK_ORDER[self.view]:
            return self.view, self.override
        self.override = None
        if self.view not in s.photos:
            return None
        return s.next_target(self.view)

    def _set(self, handle: object, attr: str, value: object) -> None:
        """Assign a GUI property only when it changed (each assignment is a message and
        a re-render in every browser)."""
        key = (id(handle), attr)
        if self._sent.get(key, _UNSET) == value:
            return
        self._sent[key] = value
        setattr(handle, attr, value)

    def _update_panel(self) -> None:
        """Bring every panel element up to date with the session (worker thread); only
        the properties that changed are sent (:meth:`_set`)."""
        s = self.session
        if s is None:
            return
        t = self.target
        self._panel_status(s)
        self._panel_intake(s)
        self._panel_target(t)
        self._panel_marks(s, t)
        self._panel_hints()
        self._panel_reconstruct(s)
        self._panel_views(s)

    def _panel_status(self, s: AnnotationSession) -> None:
        """Progress bar and the status line (case, photo, clicks done)."""
        done, total = s.progress()
        self._set(self.progress, "value", round(100.0 * done / max(total, 1), 1))
        view_done, view_total = s.progress(self.view)
        if not s.photos:
            self._set(self.status, "content", "**New patient** — upload the four photos "
                      "(front, bottom, left and right profile), then mark the landmarks.")
        else:
            self._set(self.status, "content", f"**{s.case_id}** · {VIEW_TITLES[self.view]} · "
                      f"{view_done}/{view_total} here, {done}/{total} overall")

    def _panel_intake(self, s: AnnotationSession) -> None:
        """The intake folder: full while photos are missing (or opened on purpose), one
        line once the four photos are in."""
        S = self._set
        names = {v: k for k, v in VIEW_BUTTONS.items()}
        # keep the upload buttons a moment after the last upload: hiding them while the
        # browser still shows its upload notification leaves that notification spinning
        recent = time.monotonic() - self._last_upload < 2.0
        full = len(s.photos) < len(VIEWS) or self._intake_open or recent
        for h in (self.case_id, self.other, self.photo_info, self.f_uploads):
            S(h, "visible", full)
        S(self.change_btn, "visible", len(s.photos) == len(VIEWS))
        S(self.change_btn, "label", "Done" if self._intake_open
          else "Change photos, id or distances")
        S(self.intake_md, "visible", not full)
        for view, btn in self.uploads.items():
            S(btn, "label", f"{names[view]} photo ✓" if view in s.photos
              else f"{names[view]} photo")
            S(btn, "color", "green" if view in s.photos else None)
        S(self.photo_info, "content", "  \n".join(
            [f"⚠ {w}" for v, w in self._photo_warnings.items() if v in s.photos]
            + [f"{v}: downscaled from {p.original_width}×{p.original_height} to "
               f"{p.width}×{p.height} px" for v, p in s.photos.items() if p.downscaled])
          or ("JPEG or PNG; EXIF removed on upload." if len(s.photos) < 4 else ""))
        S(self.intake_md, "content", f"Four photos loaded · case **{s.case_id}**" + "".join(
            f"  \n⚠ {w}" for v, w in self._photo_warnings.items() if v in s.photos))

    def _panel_target(self, t: tuple[str, str] | None) -> None:
        """What to click next, with its description and diagram (or why nothing)."""
        s = self.session
        assert s is not None
        if t is None:
            if self.view not in s.photos:
                self._set(self.target_md, "content",
                          f"Upload the **{self.view}** photo to mark it.")
            else:
                self._set(self.target_md, "content", "All landmarks are done. Check them, "
                                                     "then **Reconstruct**.")
            self._set(self.diagram, "visible", False)
            return
        v, lid = t
        where = "" if v == self.view else f" (in the {v} photo)"
        self._set(self.target_md, "content", f"### Click **{display_name(lid)}**{where}\n"
                                             f"{definition(lid, v)}")
        img = self.diagrams.get(v, lid)
        if img is None:
            self._set(self.diagram, "visible", False)
            return
        if self._sent.get((id(self.diagram), "key")) != t:
            self._sent[(id(self.diagram), "key")] = t
            self.diagram.image = img
        self._set(self.diagram, "visible", True)

    def _panel_marks(self, s: AnnotationSession, t: tuple[str, str] | None) -> None:
        """The landmark list of this photo (done / skipped / to do), Undo and Skip."""
        marks = {"placed": "✓", "skipped": "–", "todo": "·"}
        opts = tuple(f"{marks[s.status(self.view, i)]} {display_name(i)}"
                     for i in CLICK_ORDER[self.view])
        self._set(self.pick, "options", (PICK_NONE, *opts))
        # the entry shown is the landmark being clicked in this photo, else none: an
        # entry shown is never stale, so choosing any landmark is a change the page sees
        self._set(self.pick, "value", opts[CLICK_ORDER[self.view].index(t[1])]
                  if t is not None and t[0] == self.view else PICK_NONE)
        self._set(self.undo_btn, "disabled", not s.can_undo)
        self._set(self.accept_btn, "disabled", t is None or t[0] != self.view
                  or t[1] not in self._last_pred)
        self._set(self.skip_btn, "disabled", t is None)

    def _panel_hints(self) -> None:
        """The guidance message, up to three suspect clicks and the notes (mf asked for
        in a profile photo)."""
        g = self.guidance
        lines = [g.message] if g is not None and g.message else []
        if g is not None and g.suspect:
            lines += [f"⚠ **{i}** in the {v} photo is {r:.0f} px from where the other "
                      "photos put it: check that click" for v, i, r in g.suspect[:3]]
        lines += list(g.notes) if g is not None else []     # mf in a profile photo
        self._set(self.hint_md, "content", "  \n".join(lines))

    def _panel_reconstruct(self, s: AnnotationSession) -> None:
        """The Reconstruct button, enabled once nothing is missing, and what is."""
        probs = s.problems()
        self._set(self.rec_btn, "disabled", bool(probs))
        text = "Ready." if not probs else "To do:  \n" + "  \n".join(
            f"- {p}" for p in probs[:6])
        text += "".join(f"  \n⚠ {c}" for c in s.cautions())
        self._set(self.problems_md, "content", text)

    def _panel_views(self, s: AnnotationSession) -> None:
        """The photo buttons with each photo's progress; the landmark folder."""
        names = {v: k for k, v in VIEW_BUTTONS.items()}

        def label(v: str) -> str:
            if v not in s.photos:
                return names[v]
            done, asked = s.progress(v)
            return f"{names[v]} {'✓' if done == asked else f'{done}/{asked}'}"

        self._set(self.view_group, "options", tuple(label(v) for v in VIEW_BUTTONS.values()))
        self._set(self.f_marks, "visible", self.view in s.photos)

    # clicks
    def _on_scene_click(self, event: viser.SceneClickEvent) -> None:
        """Event loop: turn the ray into pixels and queue the placement (keeps order)."""
        plane = self.plane
        if not self.active:
            return
        if plane is None:
            self.show_error("Upload the photo first, then click on it.", event.client)
            return
        uv = plane.intersect(event.ray_origin, event.ray_direction)
        view = self.view
        self.submit(lambda: self._place_click(view, uv, event.client))

    def _place_click(self, view: str, uv: np.ndarray | None,
                     client: viser.ClientHandle | None = None) -> None:
        s = self.session
        if s is None or view != self.view or self.plane is None:
            return
        if uv is None or not self.plane.inside(uv):
            self.show_error("That click is outside the photo; click on the photo (the "
                            "landmark was not placed).", client)
            return
        t = self._current_target()
        if t is None:
            self.notify("All done here", "Every landmark of this photo is placed; drag a "
                        "ring to correct it or choose one under Landmark.", client)
            return
        v, lid = t
        if v != self.view:
            return
        s.place(v, lid, uv)
        self.events.append((time.monotonic(), f"place {v} {lid}"))
        chosen = self.override is not None
        self.override = None
        self.show_error(None)
        self._after_change(stay=chosen)

    def _predicted(self) -> dict[str, np.ndarray]:
        """id -> (2,) px: where the landmarks not clicked in this photo probably are
        (:func:`naseview.intake.predict.predict_next`: the guidance reprojection, else
        the template fit of the clicks so far)."""
        s = self.session
        if s is None or self.view not in s.photos:
            return {}
        clicks = s.clicks[self.view]
        g = self.guidance
        pred = predict_next(self.view, s.clicks,
                            g.hints(self.view, set(clicks)) if g is not None else None)
        plane = self.plane
        if plane is None:
            return pred
        return {i: p for i, p in pred.items() if plane.inside(p)}

    def _accept(self) -> None:
        """Place the landmark being clicked on its pre-placed marker (one click)."""
        t = self._current_target()
        if t is None or t[0] != self.view:
            return
        p = self._predicted().get(t[1])
        if p is None:
            return
        self._place_click(self.view, np.asarray(p, np.float64))

    def _skip(self) -> None:
        s = self.session
        t = self._current_target()
        if s is None or t is None:
            return
        s.skip(*t)
        self.events.append((time.monotonic(), f"skip {t[0]} {t[1]}"))
        chosen = self.override is not None
        self.override = None
        self._after_change(stay=chosen)

    def _undo(self) -> None:
        s = self.session
        if s is None:
            return
        r = s.undo()
        if r is None:
            return
        self.override = r[1] if s.status(*r) != "placed" else None
        if r[0] != self.view:
            self.set_view(r[0], fit=True)
            self.override = r[1] if s.status(*r) != "placed" else None
        self._after_change()

    def _on_pick(self, value: str) -> None:
        """The user chose a landmark in the list: it becomes the target; its old click
        stays until the new one is placed (undo restores it)."""
        name = value.split(" ", 1)[-1]
        self._sent.pop((id(self.pick), "value"), None)  # the browser changed it

        def pick() -> None:
            lid = next((i for i in CLICK_ORDER[self.view] if display_name(i) == name), None)
            if lid is not None and self.target != (self.view, lid):
                self.override = lid      # also when the guided target is the same id in
                self._redraw()           # another photo (g, n... are in several)
        self.submit(pick)

    def _after_change(self, stay: bool = False) -> None:
        """Redraw after a click, skip or undo; once the guided flow finishes a photo,
        go on to the next one, unless ``stay`` (a landmark the user chose was clicked
        again: the page stays on its photo until the user moves on)."""
        s = self.session
        assert s is not None
        self.show_error(None)
        nxt = s.next_target(self.view)
        if nxt is not None and nxt[0] != self.view and self.override is None and not stay:
            done_view = self.view
            self.set_view(nxt[0], fit=True)
            self.notify(f"{done_view.capitalize()} photo done",
                        f"Now the {VIEW_TITLES[nxt[0]].lower()}.")
        else:
            self._redraw()
        self._request_hints()

    async def _on_drag(self, event: viser.SceneNodeDragEvent[viser.BatchedMeshHandle]
                       ) -> None:
        """Drag a placed ring: follow the pointer, commit one move at the end."""
        plane = self.plane
        idx = event.instance_index
        order = CLICK_ORDER[self.view]
        s = self.session
        if plane is None or s is None or idx is None or not 0 <= idx < len(order):
            return
        lid = order[idx]
        self._drag_time = time.monotonic()
        if lid not in s.clicks[self.view]:
            return
        key = int(event.client_id)
        end = np.asarray(event.end_position, dtype=np.float64)
        if event.phase == "start":
            centre = plane.to_world(s.clicks[self.view][lid], 0.3)[0]
            self._drag[key] = (lid, centre - np.asarray(event.start_position, dtype=float))
            return
        d = self._drag.get(key)
        if d is None or d[0] != lid:
            return
        uv = plane.to_pixel(end + d[1])
        uv = np.clip(uv, [-0.5, -0.5], [plane.width_px - 0.5, plane.height_px - 0.5])
        self._move_ring(plane, idx, uv)
        if event.phase == "end":
            self._drag.pop(key, None)
            view = self.view
            self.submit(lambda: self._move(view, lid, uv))

    def _move_ring(self, plane: PhotoPlane, idx: int, uv: np.ndarray) -> None:
        """Show ring ``idx`` (and the disc that grabs it) at pixel ``uv`` (2,)."""
        for name, lift in (("clicks", 0.35), ("grab", 0.3)):
            h = self._handles.get(name)
            if h is not None:
                pos = np.array(h.batched_positions, dtype=np.float64)
                pos[idx] = plane.to_world(uv, lift)[0]
                h.batched_positions = pos

    def _move(self, view: str, lid: str, uv: np.ndarray) -> None:
        s = self.session
        if s is None or view != self.view:
            return
        s.move(view, lid, uv)
        self.events.append((time.monotonic(), f"move {view} {lid}"))
        self._redraw()
        self._request_hints()

    # hints
    def _request_hints(self) -> None:
        s = self.session
        if s is None:
            return
        with self._hint_cond:
            self._hint_request = s.revision
            self._hint_cond.notify_all()

    def _hint_run(self) -> None:
        done = -1
        while True:
            with self._hint_cond:
                while self._hint_request == done:
                    self._hint_cond.wait()
                if self._hint_request == -2:
                    return
                done = self._hint_request
            s = self.session
            if s is None:
                continue
            try:
                g = s.guidance()
            except Exception:
                log.exception("naseview: guidance failed")
                continue
            if s is self.session:
                self.guidance = g
                self.submit(self._redraw)

    # reconstruct
    def reconstruct(self) -> Path:
        """Write the case directory and open it in the app (which reconstructs it)."""
        s = self._need_session()
        self.wait_idle(10.0)
        out = self.folders.case_dir(s.case_id)
        path = s.write_case(out)       # never over another patient's case
        self.rec_md.content = (f"Case saved in `{out}`  \nRerun: `naseview reconstruct "
                               f"{out} -o {out.parent / 'reconstruction'}`")
        self.events.append((time.monotonic(), "reconstruct"))
        if self.app is not None:
            self.hide()
            self.app.open(out)
        return path

    # messages
    def show_error(self, message: str | None,
                   client: viser.ClientHandle | None = None) -> None:
        """A red line in the panel (``None`` clears it) and a notification."""
        if not message:
            self.error.visible = False
            return
        self.error.content = f"<span style='color:#c0392b'>**{markdown_text(message)}**</span>"
        self.error.visible = True
        self.notify("naseview", message, client, color="red")

    def notify(self, title: str, body: str, client: viser.ClientHandle | None = None,
               color: NoticeColor = "blue") -> None:
        notify(self.scope, title, body, color, seconds=5.0, client=client)


__all__ = ["AnnotatePage", "LandmarkDiagrams", "PhotoPlane", "ring_mesh"]
