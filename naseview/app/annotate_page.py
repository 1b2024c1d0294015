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
``naseview reconstruct``) and opens it in the app
(:class:`naseview.app.naseview_app.NaseviewApp`), which reconstructs with progress in its
panel. Every change is autosaved in ``WORK/in-progress/<id>/`` and the page offers to
resume it after a reload or restart.
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

Parts, one module per job (their shared state: :mod:`naseview.app.annotate_state`): the
panel and its to-do list (:mod:`naseview.app.annotate_panel`), the photo view with its
markers (:mod:`naseview.app.annotate_photo`) and the click flow with its guidance
(:mod:`naseview.app.annotate_clicks`); this module holds the page itself: its worker,
showing and hiding it, the intake (photos, id, calliper distances, resuming) and
"Reconstruct".
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import viser

from naseview.app.annotate_clicks import ClickFlow
from naseview.app.annotate_panel import AnnotatePanel
from naseview.app.annotate_photo import PhotoView
from naseview.app.annotate_state import (
    PICK_NONE,
    VIEW_BUTTONS,
    GuiEvent,
)
from naseview.app.gui_value import set_value
from naseview.app.host import AppHost
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.markdown_text import markdown_text
from naseview.app.photo_plane import PhotoPlane, ring_mesh
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
from naseview.intake.click_order import VIEW_ORDER, VIEW_TITLES
from naseview.intake.guidance import Guidance
from naseview.intake.in_progress import InProgress
from naseview.intake.patients import PatientFolders
from naseview.intake.photo_check import photo_warning
from naseview.intake.session import AnnotationSession

log = logging.getLogger(__name__)


def _view_of(label: str) -> str:
    """View of a button label such as ``"Front 8/21"``."""
    return VIEW_BUTTONS[label.split(" ", 1)[0]]


class AnnotatePage(ClickFlow, PhotoView, AnnotatePanel):
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
        self._wire()
        # the server's limit holds on every connection; these buttons are the uploads
        self.upload_limit = UploadLimit.of(server)
        for btn in self.uploads.values():
            self.upload_limit.watch(btn, self._on_upload_refused)
        threading.Thread(target=self.diagrams.warm, name="naseview-diagrams",
                         daemon=True).start()

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


__all__ = ["PICK_NONE", "AnnotatePage", "LandmarkDiagrams", "PhotoPlane", "ring_mesh"]
