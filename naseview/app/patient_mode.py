"""Patient mode: a clean presentation of the 3D nose for the consultation.

Technical overlays (landmark spheres, curves, ad-landmarks, cameras, labels, the nose
highlight, the colour map) are hidden and the control panel is folded away; what is
left is the face, a slow turntable (a +-40 degree swing about the vertical axis through
the nose, period 24 s), a before / after slider that blends the nose between the
reconstruction and the simulation, large 3D labels with the key measurements (before ->
after) and the sentence "A simulation is not a promised outcome." A button writes the
consultation report (:mod:`naseview.report`) and downloads it.

Patient mode belongs to one browser tab (its client scope, :mod:`naseview.app.scope`):
its panel, labels, slider and turntable camera never reach another tab. The face it shows
is the patient's one simulation, so a patient screen (a second tab in patient mode)
follows the surgeon's edits live (:meth:`PatientMode.refresh` after each solve).

Leaving patient mode restores the tab's display settings from its panel. The before /
after blend is linear between the reconstruction (stage 3, paper §3.4) and its edit.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import viser

from naseview.app.gui_value import set_value
from naseview.app.host import AppHost
from naseview.app.scene import FaceScene
from naseview.app.scene_geometry import blend
from naseview.app.scope import NoticeColor, Scope, clients_of, notify, run_action
from naseview.camera import DISTANCE_MM
from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController
from naseview.errors import NaseviewError
from naseview.intake.annotation_file import safe_case_id
from naseview.intake.patients import PatientFolders
from naseview.reconstruction import calliper_distances
from naseview.report import DISCLAIMER, ReportData, measurement_rows, write_report

log = logging.getLogger(__name__)

TURNTABLE_DEG = 40.0
TURNTABLE_PERIOD_S = 24.0
TURNTABLE_HZ = 25.0
TURNTABLE_DISTANCE_FACTOR = 1.5
"""Turntable distance as a multiple of the standard views' (:data:`DISTANCE_MM`)."""

KEY_MEASUREMENTS: tuple[tuple[str, str], ...] = (
    ("nasal_length", "Length n–prn"),
    ("nasal_width", "Width al–al"),
    ("nasofrontal_angle", "Nasofrontal angle"),
    ("tip_projection", "Tip projection"),
)
"""Measurements shown as large labels: (name, short title)."""


def turntable_yaw(seconds: float, amplitude_deg: float = TURNTABLE_DEG,
                  period_s: float = TURNTABLE_PERIOD_S) -> float:
    """The turntable's yaw (rad, 0 = front, > 0 = camera toward the subject's left) at
    time ``seconds``."""
    return math.radians(amplitude_deg) * math.sin(2.0 * math.pi * seconds / period_s)


def turntable_eye(target: np.ndarray, distance: float, seconds: float,
                  amplitude_deg: float = TURNTABLE_DEG,
                  period_s: float = TURNTABLE_PERIOD_S) -> np.ndarray:
    """(3,) camera position of the turntable at time ``seconds``: a sinusoidal swing of
    ``amplitude_deg`` about the vertical axis through ``target``, slightly from above."""
    a = turntable_yaw(seconds, amplitude_deg, period_s)
    d = np.array([math.sin(a), 0.12, math.cos(a)])
    return np.asarray(target, np.float64) + distance * d / np.linalg.norm(d)


def label_anchors(V: np.ndarray, nose_ids: np.ndarray, L: Mapping[str, np.ndarray],
                  before: dict[str, float], after: dict[str, float] | None,
                  yaw_rad: float = 0.0) -> list[tuple[str, str, np.ndarray]]:
    """``(name, text, anchor (3,))`` of each key measurement's label: beside the face,
    just off its outline on the image left (from the front: the subject's right, the
    empty side between the patient panel and the face) seen by the turntable at
    ``yaw_rad`` (:func:`turntable_yaw`), at the height of what it measures, at least
    8 mm apart; the label's text ends at the anchor (``center-right``). Issue 27: labels
    8 mm beside the nose floated over the eye and the cheek."""
    V = np.asarray(V, np.float64)
    nose = V[nose_ids] if len(nose_ids) else V
    centre_x = float(0.5 * (nose[:, 0].min() + nose[:, 0].max()))

    def anchor(name: str) -> np.ndarray | None:
        ys = {"nasofrontal_angle": ("n",), "nasal_length": ("n", "prn"),
              "tip_projection": ("prn",), "nasal_width": ("al_l", "al_r")}[name]
        if not all(i in L for i in ys):
            return None
        y = float(np.mean([L[i][1] for i in ys]))
        return np.array([centre_x, y, 0.0])

    placed: list[tuple[str, str, np.ndarray]] = []
    for name, title in KEY_MEASUREMENTS:
        text = label_text(name, title, before, after)
        p = anchor(name)
        if text is not None and p is not None:
            placed.append((name, text, p))
    placed.sort(key=lambda t: -t[2][1])          # top to bottom, at least 8 mm apart
    for k in range(1, len(placed)):
        if placed[k - 1][2][1] - placed[k][2][1] < 8.0:
            placed[k][2][1] = placed[k - 1][2][1] - 8.0
    right = np.array([math.cos(yaw_rad), 0.0, -math.sin(yaw_rad)])   # image right
    for _, _, p in placed:                       # off the outline at that height
        band = V[np.abs(V[:, 1] - p[1]) < 6.0]
        band = band if len(band) else V
        i = int(np.argmin(band @ right))
        p[[0, 2]] = (band[i] - 6.0 * right)[[0, 2]]
    return placed


def label_text(name: str, title: str, before: dict[str, float],
               after: dict[str, float] | None) -> str | None:
    """``"Length n–prn  47.1 → 45.3 mm"`` (or just the value without a simulation)."""
    rows = {r["name"]: r for r in measurement_rows(before, after)}
    r = rows.get(name)
    if r is None:
        return None
    unit = {"mm": " mm", "deg": "°"}.get(r["unit"], "")
    digits = 2 if r["unit"] == "" else 1
    b = f"{r['before']:.{digits}f}"
    if r["after"] is None or abs(r["after"] - r["before"]) < 0.05:
        return f"{title}  {b}{unit}"
    return f"{title}  {b} → {r['after']:.{digits}f}{unit}"


class PatientMode:
    """The presentation view of the app's current case.

    Args:
        scope: the tab (``viser.ClientHandle``) whose view it takes over, or the server
            (every tab).
        app: the tab (:class:`~naseview.app.screen.Screen`) whose scene and editor are
            shown.
        work_dir: where reports are written (``<work_dir>/<case id>/report/``).
    """

    def __init__(self, scope: Scope, app: AppHost, work_dir: str | Path) -> None:
        self.scope = scope
        self.app = app
        self.work_dir = Path(work_dir)
        self.active = False
        self.t = 1.0
        self._labels: list[viser.LabelHandle] = []
        self._label_values: tuple[dict[str, float], dict[str, float] | None] | None = None
        self._yaw = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.RLock()
        self.gui = gui = scope.gui
        self.panel = gui.add_panel(visible=False)
        self.panel.dock_left()
        self.panel.set_width(340)
        with self.panel.add_tab("Patient view", icon=viser.Icon.PRESENTATION):
            self.title = gui.add_html("")
            self.slider = gui.add_slider("Before ↔ After", min=0.0, max=1.0, step=0.05,
                                         initial_value=1.0)
            self.turntable = gui.add_checkbox("Turntable", True)
            self.table = gui.add_html("")
            self.disclaimer = gui.add_html(
                f"<p style='font-size:15px;color:#333;margin:6px 0'><b>{DISCLAIMER}</b>"
                "</p>")
            with gui.add_folder("Report", expand_by_default=False):
                self.surgeon = gui.add_text("Surgeon", "",
                                            hint="Printed on the report (not in the "
                                                 "de-identified version)")
                self.clinic = gui.add_text("Clinic", "")
                self.patient_name = gui.add_text(
                    "Patient name", "", hint="Title of the report; never in the "
                                            "de-identified version nor saved elsewhere")
            self.deid = gui.add_checkbox("De-identified report (no photos)", False)
            self.report_btn = gui.add_button("Consultation report",
                                             icon=viser.Icon.FILE_TEXT)
            self.exit_btn = gui.add_button("Exit patient mode", icon=viser.Icon.X)
        self.slider.on_update(lambda e: self._guard(lambda: self.set_blend(self.slider.value)))
        self.turntable.on_update(lambda e: self._guard(self._turntable_changed))
        self.report_btn.on_click(lambda e: self._guard(lambda: self.download_report(e.client)))
        self.exit_btn.on_click(lambda e: self._guard(self.exit))

    # helpers
    def _guard(self, fn: Callable[[], object]) -> None:
        run_action(fn, lambda message: self._notify(message, "red"), "patient mode action")

    def _notify(self, body: str, color: NoticeColor = "blue",
                client: viser.ClientHandle | None = None) -> None:
        notify(self.scope, "naseview", body, color, client=client)

    def _state(self) -> tuple[EditController, FaceScene, Baseline]:
        """The app's editor, scene and baseline (raises when no case is open)."""
        ctl = self.app.controller
        scene = self.app.scene
        if ctl is None or scene is None:
            raise NaseviewError("no reconstruction is open yet; open a case (or finish a "
                                "new patient) before patient mode")
        return ctl, scene, ctl.baseline

    def _measurements(self) -> tuple[dict[str, float], dict[str, float] | None]:
        ctl, _, base = self._state()
        sim = ctl.simulation
        edited = not np.array_equal(sim.V, base.V)
        return dict(base.measurements), (dict(sim.measurements) if edited else None)

    # enter / exit
    def enter(self) -> None:
        """Hide the technical overlays and the panel; show the presentation."""
        ctl, scene, base = self._state()
        with self._lock:
            self.active = True
            scene.set_visible(labels=False, curves=False, ad_landmarks=False, cameras=False,
                              landmarks=False, highlight=False)
            scene.set_view(colormap=False, original=False, overlay=False)
            self.gui.main_panel.minimize()
            self.panel.visible = True
            self.panel.expand()
            self._present()
            self.t = 1.0
            set_value(self.slider, 1.0)
        self.set_blend(1.0)
        try:
            self.app.reset_camera()          # the standard lens the turntable uses
        except Exception:
            log.debug("naseview: camera reset failed", exc_info=True)
        self._turntable_changed()

    def refresh(self) -> None:
        """After a solve (an edit in any tab): the title, measurements and labels of the
        new simulation; the face itself follows through the scene."""
        with self._lock:
            if self.active and self.app.scene is not None:
                self._present()

    def _present(self) -> None:
        """Title, slider state, measurement table and 3D labels of the current state."""
        before, after = self._measurements()
        cid = self.app.case_id
        self.title.content = (f"<div style='font-size:20px;font-weight:600'>{cid}</div>"
                              + ("<div style='color:#666'>Drag the slider to compare "
                                 "before and after</div>" if after else
                                 "<div style='color:#666'>No simulation yet: showing the "
                                 "reconstruction</div>"))
        self.slider.disabled = after is None
        self.table.content = self._table_html(before, after)
        self._make_labels(before, after)

    def exit(self) -> None:
        """Back to the editor with its display settings."""
        with self._lock:
            if not self.active:
                return
            self.active = False
            self._stop_turntable()
            self._remove_labels()
            self.panel.visible = False
            self.gui.main_panel.expand()
            scene = self.app.scene
            if scene is not None:
                scene.set_blend(1.0)
        self.app.apply_display()
        try:
            self.app.reset_camera()
        except Exception:
            log.debug("naseview: camera reset failed", exc_info=True)

    # before / after
    def set_blend(self, t: float) -> None:
        """Show the nose ``t`` of the way from before (0) to after (1) in this tab (the
        scene keeps ``t`` while edits arrive from other tabs)."""
        _, scene, _ = self._state()
        self.t = float(np.clip(t, 0.0, 1.0))
        if abs(float(self.slider.value) - self.t) > 1e-9:
            set_value(self.slider, self.t)  # its callback calls back here: same t, no-op
        scene.set_blend(self.t)

    def close(self) -> None:
        """The tab went away: stop the turntable (its labels went with the tab)."""
        with self._lock:
            self.active = False
            self._stop_turntable()
            self._labels = []

    # labels
    def _table_html(self, before: dict[str, float], after: dict[str, float] | None) -> str:
        rows = []
        for name, title in KEY_MEASUREMENTS:
            text = label_text(name, title, before, after)
            if text is None:
                continue
            head, _, value = text.partition("  ")
            rows.append(f"<tr><td style='padding:4px 8px 4px 0;color:#555'>{head}</td>"
                        f"<td style='padding:4px 0;font-size:20px;font-weight:600'>{value}"
                        "</td></tr>")
        return "<table style='font-size:16px;border-collapse:collapse'>" + "".join(rows) \
            + "</table>"

    def _remove_labels(self) -> None:
        for h in self._labels:
            try:
                h.remove()
            except Exception:  # the scene it was in was rebuilt
                log.debug("naseview: label already gone", exc_info=True)
        self._labels = []

    def _make_labels(self, before: dict[str, float], after: dict[str, float] | None) -> None:
        _, scene, base = self._state()
        self._remove_labels()
        L = base.landmarks
        self._label_values = (before, after)
        placed = label_anchors(base.V, base.nose_ids, L, before, after, self._yaw)
        for i, (_, text, p) in enumerate(placed):
            self._labels.append(scene.scene.add_label(
                f"/patient/label{i}", text, position=tuple(p), font_screen_scale=1.5,
                anchor="center-right"))

    def _follow_yaw(self, yaw: float) -> None:
        """Keep the labels beside the face's outline as the turntable turns."""
        with self._lock:
            self._yaw = yaw
            if not self._labels or self._label_values is None:
                return
            ctl = self.app.controller
            if ctl is None:
                return
            base = ctl.baseline
            placed = label_anchors(base.V, base.nose_ids, base.landmarks,
                                   *self._label_values, yaw)
            for h, (_, _, p) in zip(self._labels, placed, strict=False):
                h.position = np.asarray(p, np.float64)

    # turntable
    def _turntable_changed(self) -> None:
        if self.active and self.turntable.value:
            self._start_turntable()
        else:
            self._stop_turntable()

    def _start_turntable(self) -> None:
        if self._thread is not None and self._thread.is_alive():
            return
        _, scene, base = self._state()
        nose = base.V[base.nose_ids] if len(base.nose_ids) else base.V
        target = 0.5 * (nose.min(axis=0) + nose.max(axis=0))
        # the standard views' distance and lens (the tab's camera was reset to one on
        # entering), a little farther so the measurement labels beside the nose fit
        distance = TURNTABLE_DISTANCE_FACTOR * DISTANCE_MM
        self._stop.clear()

        def run() -> None:
            t0 = time.monotonic()
            while not self._stop.wait(1.0 / TURNTABLE_HZ):
                t = time.monotonic() - t0
                eye = turntable_eye(target, distance, t)
                for c in clients_of(self.scope):   # this tab only
                    try:
                        with c.atomic():
                            c.camera.position = tuple(eye)   # then look_at (viser
                            c.camera.look_at = tuple(target)  # shifts it with position)
                            c.camera.up_direction = (0.0, 1.0, 0.0)
                    except Exception:  # the tab closed: close() stops this thread
                        log.debug("naseview: turntable camera not set", exc_info=True)
                try:
                    self._follow_yaw(turntable_yaw(t))
                except Exception:
                    log.debug("naseview: labels not moved", exc_info=True)

        self._thread = threading.Thread(target=run, name="naseview-turntable", daemon=True)
        self._thread.start()

    def _stop_turntable(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    # report
    def report_data(self) -> ReportData:
        """The consultation report of the current case (before = reconstruction, after =
        the simulation when it differs)."""
        ctl, _, base = self._state()
        sim = ctl.simulation
        edited = not np.array_equal(sim.V, base.V)
        app = self.app
        photos: dict[str, np.ndarray] = {}
        case = app.case
        if case is not None:
            for v in case.views:
                try:
                    photos[v] = case.load_image(v)
                except NaseviewError:
                    pass
        rec = base.reconstruction
        return ReportData(
            case_id=str(app.case_id), V_before=base.V, F=base.F,
            nose_ids=base.nose_ids, measurements_before=dict(base.measurements),
            V_after=sim.V if edited else None,
            measurements_after=dict(sim.measurements) if edited else None,
            photos=photos, notes="",
            credit=str(app.credit or ""), texture=app.texture,
            manoeuvres=dict(sim.manoeuvres),
            calliper=calliper_distances(rec) if rec is not None else {},
            surgeon=_line(self.surgeon.value), clinic=_line(self.clinic.value),
            patient_name=_line(self.patient_name.value))

    def write_report(self, deidentified: bool | None = None) -> Path:
        """Write ``WORK/<patient>/report/report[-deidentified].html`` (+ PNGs): the open
        patient's folder (two cases with the same case id are two patients), or, for a
        case that is not kept (the demo), ``WORK/.reports/<case id>/``: a report makes
        no patient folder (:data:`LOOSE_REPORTS`).

        Raises:
            NaseviewError: a symbolic link on the way (a report, photos included, is never
                written out of the work folder through a link).
        """
        data = self.report_data()
        deid = self.deid.value if deidentified is None else deidentified
        name = "report-deidentified.html" if deid else "report.html"
        folders = PatientFolders(self.work_dir)
        pid = self.app.patient_id
        if pid:
            report_dir = folders.inside(pid, folders.report_dir(pid))
        else:
            report_dir = _no_link(folders.root, Path(LOOSE_REPORTS)
                                  / (safe_case_id(data.case_id) or "case"))
        return write_report(data, report_dir / name, deidentified=bool(deid))

    def download_report(self, client: viser.ClientHandle | None = None) -> None:
        """Write the report in the background and send the HTML to the browser."""
        self._state()
        self._notify("Preparing the consultation report…", "blue", client)

        def job() -> None:
            try:
                path = self.write_report()
                target = client if client is not None else self.scope
                target.send_file_download(path.name, path.read_bytes(),
                                          save_immediately=True)
                self._notify(f"Report saved: {path}", "green", client)
            except Exception as e:
                log.exception("naseview: report failed")
                self._notify(f"Report failed: {e}", "red", client)

        threading.Thread(target=job, name="naseview-report", daemon=True).start()


LOOSE_REPORTS = ".reports"
"""Folder of the work folder for the reports of cases that are not patients (the demo):
a leading dot is never a patient id, so it is never listed as a patient."""


def _no_link(root: Path, rel: Path) -> Path:
    """``root / rel`` when no part of it below ``root`` is a symbolic link.

    Raises:
        NaseviewError: a symbolic link on the way, naming it and the fix.
    """
    here = root
    for part in rel.parts:
        here = here / part
        if here.is_symlink():
            raise NaseviewError(f"{here}: is a symbolic link; naseview follows no link "
                                f"inside the work folder {root} (replace it by the folder "
                                "itself)")
    return root / rel


def _line(text: object, limit: int = 120) -> str:
    """A typed field as one printable line of at most ``limit`` characters."""
    out = " ".join(str(text or "").split())
    return "".join(c for c in out if c.isprintable())[:limit]


__all__ = ["KEY_MEASUREMENTS", "PatientMode", "blend", "label_anchors", "label_text",
           "turntable_eye", "turntable_yaw"]
