"""GUI panels of the app: one control panel per browser tab (its client scope).

:class:`Panels` builds the controls of one tab and forwards every action to that tab
(:class:`PanelActions`, i.e. :class:`naseview.app.screen.Screen`): status and progress,
editing (undo / redo / reset, symmetric mode), the measurements table, before / after,
display toggles, parameters of stages 2 and 3 (paper §3.3-3.4), the photos with
reprojected landmarks and residuals (stage 1, paper §3.2, eq. 1), and exports. Rendering
helpers (:func:`annotate_photo`, :func:`residual_markdown`) are pure.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection, Mapping
from dataclasses import fields
from typing import Any, Protocol

import cv2
import numpy as np
import viser

from naseview.app.colormap import colorbar_image
from naseview.app.export import measurements_markdown
from naseview.app.gui_value import set_value
from naseview.app.scope import Scope, notify
from naseview.app.viewer import VIEW_BUTTONS
from naseview.camera import Camera
from naseview.editing.manoeuvres import MANOEUVRES
from naseview.errors import NaseviewError
from naseview.landmarks import VIEWS
from naseview.measurements import Estimate
from naseview.stage1_landmarks import SfmParams
from naseview.stage2_curves import CurveParams
from naseview.stage3_mesh import RefineParams
from naseview.texture.mesh_files import MESH_TYPES

log = logging.getLogger(__name__)

PHOTO_FLAG_MIN_PX = 5.0
"""The photo panel's own floor (px) for marking a click with a yellow ring: a click is
marked when its residual exceeds this and :data:`PHOTO_FLAG_FACTOR` x the median
residual. Deliberately not stage 1's suspect rule (floor
:attr:`naseview.stage1_landmarks.SfmParams.suspect_min_px`, 3 px): the panel lists stage
1's suspect clicks separately ("Stage 1 flagged"), and marks on the photo only the larger
residuals worth checking by eye."""

PHOTO_FLAG_FACTOR = SfmParams().suspect_factor
"""Multiple of the median residual above which a click is marked: stage 1's
:attr:`~naseview.stage1_landmarks.SfmParams.suspect_factor` (4)."""


def flag_threshold(residuals: Mapping[str, Mapping[str, float]],
                   floor_px: float = PHOTO_FLAG_MIN_PX,
                   factor: float = PHOTO_FLAG_FACTOR) -> float:
    """Residual (px) above which a click is flagged: max(floor, factor x median)."""
    vals = [v for r in residuals.values() for v in r.values()]
    return max(floor_px, factor * float(np.median(vals))) if vals else floor_px


BRAND = (52, 108, 170)
"""Calm blue of routine actions (viser's primary colour); red marks only the destructive
"Reset all"."""

STAGE2_FIELDS: tuple[tuple[str, str], ...] = (
    ("side_w_ratio", "side-curve w2/w1"), ("side_h_ratio", "side-curve h2/h1"),
    ("hue_tol", "background hue tol."), ("sat_tol", "background sat. tol."),
    ("val_tol", "background value tol."), ("dark_ratio", "nostril dark ratio"),
    ("closing_px", "nostril closing (px)"), ("corridor_frac", "edge corridor frac."),
    ("lift_weight", "lift weight"),
)
"""Stage 2 (:class:`naseview.stage2_curves.params.CurveParams`) fields in the parameter panel."""

STAGE3_FIELDS: tuple[tuple[str, str], ...] = (
    ("arap_iterations", "ARAP iterations"), ("smooth_iterations", "smoothing iterations"),
    ("smooth_step", "smoothing step"), ("handle_clearance_mm", "region clearance (mm)"),
    ("margin_mm", "pinned margin (mm)"),
    ("max_handle_displacement_mm", "max. handle move (mm)"),
    ("fit_sigma_mm", "fit landmark sigma (mm)"),
)
"""Stage 3 (:class:`naseview.stage3_mesh.RefineParams`) fields in the parameter panel."""


def click_residuals(clicks: Mapping[str, np.ndarray], cam: Camera,
                    landmarks: Mapping[str, np.ndarray]) -> dict[str, float]:
    """Reprojection residual (px) of each click of one view whose landmark is in 3D."""
    ids = [k for k in clicks if k in landmarks]
    if not ids:
        return {}
    proj = cam.project(np.array([landmarks[k] for k in ids]))
    return {k: float(np.linalg.norm(proj[i] - np.asarray(clicks[k])))
            for i, k in enumerate(ids)}


def annotate_photo(image_bgr: np.ndarray, cam: Camera | None,
                   clicks: Mapping[str, np.ndarray], landmarks: Mapping[str, np.ndarray],
                   curves: Mapping[str, np.ndarray], width: int = 560,
                   flag_px: float = PHOTO_FLAG_MIN_PX, crop: bool = True) -> np.ndarray:
    """A photo with the clicks (white rings), the reprojected landmarks (red dots, yellow
    ring + id when the residual exceeds ``flag_px``), the residual vectors and the
    reprojected curves (green); cropped to the clicks (``crop``) and returned as
    (h, ``width``, 3) uint8 RGB."""
    img = image_bgr.copy()
    h0, w0 = img.shape[:2]
    s = width / float(w0) * (2.0 if crop else 1.0)
    lw = max(1, int(round(1.5 / s)))
    r = max(3, int(round(5 / s)))
    font = 0.45 / s
    if cam is not None:
        for c in curves.values():
            c = np.asarray(c, dtype=np.float64).reshape(-1, 3)
            if len(c) < 2:
                continue
            front = cam.depth(c) > 0
            uv = cam.project(c[front])
            pts = np.round(uv).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(img, [pts], False, (60, 190, 40), lw, cv2.LINE_AA)
    res = click_residuals(clicks, cam, landmarks) if cam is not None else {}
    for k, xy in clicks.items():
        p = tuple(int(round(v)) for v in xy)
        cv2.circle(img, p, r, (255, 255, 255), lw, cv2.LINE_AA)
        if cam is None or k not in landmarks:
            continue
        q = cam.project(np.asarray(landmarks[k]).reshape(1, 3))[0]
        qi = (int(round(q[0])), int(round(q[1])))
        cv2.line(img, p, qi, (0, 220, 255), lw, cv2.LINE_AA)
        cv2.circle(img, qi, max(2, r // 2), (40, 40, 230), -1, cv2.LINE_AA)
        if res.get(k, 0.0) > flag_px:
            cv2.circle(img, p, 3 * r, (0, 220, 255), 2 * lw, cv2.LINE_AA)
            cv2.putText(img, f"{k} {res[k]:.0f}px", (p[0] + 3 * r, p[1]),
                        cv2.FONT_HERSHEY_SIMPLEX, font, (0, 220, 255), 2 * lw, cv2.LINE_AA)
    if crop and len(clicks) >= 2:
        P = np.array([np.asarray(v, dtype=np.float64) for v in clicks.values()])
        lo, hi = P.min(axis=0), P.max(axis=0)
        c, half = (lo + hi) / 2.0, (hi - lo).max() * 0.5 * 1.35 + 20.0
        x0, y0 = (int(max(0, c[0] - half)), int(max(0, c[1] - half)))
        x1, y1 = (int(min(w0, c[0] + half)), int(min(h0, c[1] + half)))
        if x1 - x0 > 16 and y1 - y0 > 16:
            img = img[y0:y1, x0:x1]
    h1, w1 = img.shape[:2]
    out = cv2.resize(img, (width, max(1, int(round(h1 * width / w1)))),
                     interpolation=cv2.INTER_AREA)
    return out[:, :, ::-1].copy()


def residual_markdown(residuals: Mapping[str, Mapping[str, float]],
                      flag_px: float | None = None) -> str:
    """Markdown list of the click residuals (px) per view, worst first, flagged above
    ``flag_px`` (default :func:`flag_threshold`)."""
    if flag_px is None:
        flag_px = flag_threshold(residuals)
    lines = []
    for view, res in residuals.items():
        if not res:
            lines.append(f"**{view}**: no reconstructed clicks")
            continue
        items = sorted(res.items(), key=lambda kv: -kv[1])
        parts = [f"**{k} {v:.1f}**⚠" if v > flag_px else f"{k} {v:.1f}" for k, v in items]
        rms = float(np.sqrt(np.mean([v * v for v in res.values()])))
        lines.append(f"**{view}** (RMS {rms:.1f} px): " + ", ".join(parts))
    lines.append("")
    lines.append(f"Residual = distance (px) between a click and its reprojected 3D "
                 f"landmark; ⚠ above {flag_px:g} px: check that click.")
    return "\n\n".join(lines)


class PanelActions(Protocol):
    """What the panel's controls call (:class:`naseview.app.screen.Screen`)."""

    def undo(self) -> None: ...
    def redo(self) -> None: ...
    def reset(self) -> None: ...
    def set_symmetric(self, on: bool) -> None: ...
    def set_manoeuvre(self, name: str, amount: float) -> None: ...
    def clear_plan(self) -> None: ...
    def set_visible(self, **kw: bool) -> None: ...
    def set_view(self, **kw: bool) -> None: ...
    def show_standard_view(self, view: str) -> None: ...
    def save_view_png(self, client: viser.ClientHandle | None) -> None: ...
    def show_photo(self, view: str) -> None: ...
    def recompute(self) -> None: ...
    def params_changed(self, stage: str) -> None: ...
    def download(self, client: viser.ClientHandle | None, kind: str, fmt: str,
                 **kw: str) -> None: ...


class Panels:
    """The control panel of ``scope`` (one tab's client, or the server for every tab);
    ``app`` provides the actions (:class:`PanelActions`)."""

    def __init__(self, scope: Scope, app: PanelActions) -> None:
        self.scope = scope
        self.app = app
        self.gui = gui = scope.gui
        gui.configure_theme(show_share_button=False, control_width="large",
                            brand_color=BRAND)
        gui.main_panel.dock_right()
        gui.main_panel.set_width(400)
        self.title = gui.add_markdown("**naseview** — 3D nose reconstruction")
        self.status = gui.add_markdown("Starting…")
        self.progress = gui.add_progress_bar(0.0, visible=False, animated=True)
        self.error = gui.add_markdown("", visible=False)

        with gui.add_folder("View", expand_by_default=True):
            self.views = gui.add_button_group(
                "Views", tuple(label for label, _ in VIEW_BUTTONS),
                hint="Standard clinical views, framed on the nose")
            self.show_construction = gui.add_checkbox(
                "Show construction", False,
                hint="Curves, ad-landmarks, nose outline, fixed landmarks and cameras")
            self.labels = gui.add_checkbox("Landmark labels", False,
                                           hint="Names of the landmarks you can drag")
            self.save_png = gui.add_button("Save view as PNG", icon=viser.Icon.PHOTO,
                                           hint="This view, for the patient's chart")
        with gui.add_folder("Edit", expand_by_default=True):
            self.undo = gui.add_button("Undo", icon=viser.Icon.ARROW_BACK_UP, disabled=True,
                                       hint="Undo the last drag")
            self.redo = gui.add_button("Redo", icon=viser.Icon.ARROW_FORWARD_UP,
                                       disabled=True)
            self.reset = gui.add_button("Reset all (back to the reconstruction)",
                                        icon=viser.Icon.RESTORE, disabled=True, color="red")
            self.symmetric = gui.add_checkbox(
                "Symmetric", False,
                hint="Move the left/right partner mirrored across the midsagittal plane; "
                     "midline landmarks keep their x")
            self.edit_info = gui.add_markdown(
                "Drag a red sphere to reshape the nose (grey: fixed).")
        with gui.add_folder("Surgical plan", expand_by_default=True):
            gui.add_markdown("<small>Type an amount or slide: the nose follows live, "
                             "manoeuvres combine, Undo takes back one change.</small>")
            self.manoeuvres: dict[str, viser.GuiSliderHandle[float]] = {
                name: gui.add_slider(
                    m.control_label, min=m.low,
                    max=m.high, step=m.step, initial_value=0.0, hint=m.definition)
                for name, m in MANOEUVRES.items()}
            self.clear_plan = gui.add_button("Clear the plan", icon=viser.Icon.ERASER,
                                             disabled=True,
                                             hint="Every manoeuvre back to 0 (undoable)")
        with gui.add_folder("Measurements", expand_by_default=True):
            self.measurements = gui.add_markdown("")
            with gui.add_folder("Landmark distances (paper Table 1)",
                                expand_by_default=False):
                self.distances = gui.add_markdown("")
        with gui.add_folder("Before / after", expand_by_default=True):
            self.show_original = gui.add_checkbox(
                "Show original (before)", False, hint="Toggle before / after")
            self.overlay = gui.add_checkbox("Ghost of the original", False,
                                            hint="Contour lines of the original nose")
            self.colormap = gui.add_checkbox("Displacement colour map", False)
            self.colorbar = gui.add_image(colorbar_image(1.0), visible=False)
            self.displacement = gui.add_markdown("", visible=False)
        self.photo_sim_folder = gui.add_folder("On the photos", expand_by_default=True)
        """Where the tab shows the simulation on the patient's photos
        (:mod:`naseview.app.photo_sim`)."""
        with gui.add_folder("Construction", expand_by_default=False):
            self.show_landmarks = gui.add_checkbox("Draggable landmarks", True)
            self.show_curves = gui.add_checkbox("Curves", True)
            self.show_ad = gui.add_checkbox("Ad-landmarks", True)
            self.show_cameras = gui.add_checkbox("Cameras and photos", False)
            self.highlight = gui.add_checkbox("Nose region outline", True)
            gui.add_markdown("<small>Shown with “Show construction” (View).</small>")
        with gui.add_folder("Advanced", expand_by_default=False):
            self.param_info = gui.add_markdown(
                "Engineering parameters of the reconstruction; changing a value "
                "recomputes it in the background.")
            self.params2: dict[str, viser.GuiNumberHandle[Any]] = {}
            self.params3: dict[str, viser.GuiNumberHandle[Any]] = {}
            self.interactive_iters = gui.add_number(
                "drag ARAP iterations", 6, min=1, max=100, step=1,
                hint="ARAP iterations per update during a drag (a full solve follows)")
            self.param_folder2 = gui.add_folder("Stage 2: curves")
            self.param_folder3 = gui.add_folder("Stage 3: ARAP and smoothing")
            self.recompute = gui.add_button("Recompute now", icon=viser.Icon.REFRESH)
        with gui.add_folder("Photos", expand_by_default=False):
            self.photo_view = gui.add_dropdown("View", VIEWS)
            self.photo = gui.add_image(np.full((8, 8, 3), 255, np.uint8), visible=False)
            self.residuals = gui.add_markdown("No photos.")
        with gui.add_folder("Export", expand_by_default=False):
            self.export_part = gui.add_dropdown("Mesh", ("face", "nose"))
            self.export_state = gui.add_dropdown("State", ("simulated", "original"))
            self.mesh_buttons = {t: gui.add_button(f"Mesh .{t}", icon=viser.Icon.DOWNLOAD)
                                 for t in MESH_TYPES}
            self.textured_glb = gui.add_button(
                "Face with photo texture .glb", icon=viser.Icon.DOWNLOAD,
                hint="glTF in metres, the patient's skin embedded")
            self.textured_obj = gui.add_button(
                "Face with photo texture .obj (zip)", icon=viser.Icon.DOWNLOAD,
                hint="OBJ (mm) + MTL + PNG")
            self.solid_stl = gui.add_button(
                "Watertight solid .stl (3D print)", icon=viser.Icon.DOWNLOAD,
                hint="Holes and the open border closed (mm)")
            self.lm_json = gui.add_button("Landmarks .json", icon=viser.Icon.DOWNLOAD)
            self.lm_csv = gui.add_button("Landmarks .csv", icon=viser.Icon.DOWNLOAD)
            self.meas_json = gui.add_button("Measurements .json", icon=viser.Icon.DOWNLOAD)
            self.meas_csv = gui.add_button("Measurements .csv", icon=viser.Icon.DOWNLOAD)
            self.session = gui.add_button("Session file", icon=viser.Icon.DEVICE_FLOPPY,
                                          hint="Reopen with: naseview serve SESSION.json")
        self.credit = gui.add_markdown("")
        self._wire()

    # wiring
    def _wire(self) -> None:
        app = self.app

        def safe(fn: Callable[[viser.GuiEvent[Any]], None]
                 ) -> Callable[[viser.GuiEvent[Any]], None]:
            def run(event: viser.GuiEvent[Any]) -> None:
                try:
                    fn(event)
                except NaseviewError as e:  # the user's mistake: one line, no traceback
                    log.info("naseview: %s", e)
                    self.show_error(str(e))
                except Exception as e:  # a bug: keep the server up, show the error
                    log.exception("naseview: action failed")
                    self.show_error(f"{type(e).__name__}: {e}")
            return run

        def user(fn: Callable[[viser.GuiEvent[Any]], None]
                 ) -> Callable[[viser.GuiEvent[Any]], None]:
            """Only changes made in the browser: a value the app assigns (to mirror the
            patient's shared settings, ``client`` None) must not act again."""
            inner = safe(fn)

            def run(event: viser.GuiEvent[Any]) -> None:
                if event.client is not None:
                    inner(event)
            return run

        self.views.on_click(safe(lambda e: app.show_standard_view(
            dict(VIEW_BUTTONS)[str(e.target.value)])))
        self.show_construction.on_update(
            safe(lambda e: app.set_visible(construction=self.show_construction.value)))
        self.save_png.on_click(safe(lambda e: app.save_view_png(e.client)))
        self.undo.on_click(safe(lambda e: app.undo()))
        self.redo.on_click(safe(lambda e: app.redo()))
        self.reset.on_click(safe(lambda e: app.reset()))
        self.symmetric.on_update(user(lambda e: app.set_symmetric(self.symmetric.value)))
        def manoeuvre(name: str) -> Callable[[viser.GuiEvent[Any]], None]:
            return user(lambda e: app.set_manoeuvre(name, float(e.target.value)))

        for name, h in self.manoeuvres.items():
            h.on_update(manoeuvre(name))
        self.clear_plan.on_click(safe(lambda e: app.clear_plan()))
        self.labels.on_update(safe(lambda e: app.set_visible(labels=self.labels.value)))
        self.show_landmarks.on_update(
            safe(lambda e: app.set_visible(landmarks=self.show_landmarks.value)))
        self.show_curves.on_update(safe(lambda e: app.set_visible(curves=self.show_curves.value)))
        self.show_ad.on_update(safe(lambda e: app.set_visible(ad_landmarks=self.show_ad.value)))
        self.show_cameras.on_update(
            safe(lambda e: app.set_visible(cameras=self.show_cameras.value)))
        self.highlight.on_update(safe(lambda e: app.set_visible(highlight=self.highlight.value)))
        self.show_original.on_update(
            safe(lambda e: app.set_view(original=self.show_original.value)))
        self.overlay.on_update(safe(lambda e: app.set_view(overlay=self.overlay.value)))
        self.colormap.on_update(safe(lambda e: app.set_view(colormap=self.colormap.value)))
        self.photo_view.on_update(safe(lambda e: app.show_photo(self.photo_view.value)))
        self.recompute.on_click(safe(lambda e: app.recompute()))
        self.interactive_iters.on_update(user(lambda e: app.params_changed("app")))

        def mesh_download(file_type: str) -> Callable[[viser.GuiEvent[Any]], None]:
            return lambda e: app.download(e.client, "mesh", file_type,
                                          part=self.export_part.value,
                                          state=self.export_state.value)

        for t, b in self.mesh_buttons.items():
            b.on_click(safe(mesh_download(t)))
        self.lm_json.on_click(safe(lambda e: app.download(e.client, "landmarks", "json")))
        self.lm_csv.on_click(safe(lambda e: app.download(e.client, "landmarks", "csv")))
        self.meas_json.on_click(safe(lambda e: app.download(e.client, "measurements", "json")))
        self.meas_csv.on_click(safe(lambda e: app.download(e.client, "measurements", "csv")))
        self.session.on_click(safe(lambda e: app.download(e.client, "session", "json")))
        self.textured_glb.on_click(safe(lambda e: app.download(
            e.client, "textured", "glb", part=self.export_part.value,
            state=self.export_state.value)))
        self.textured_obj.on_click(safe(lambda e: app.download(
            e.client, "textured", "obj", part=self.export_part.value,
            state=self.export_state.value)))
        self.solid_stl.on_click(safe(lambda e: app.download(
            e.client, "solid", "stl", part=self.export_part.value,
            state=self.export_state.value)))

    def build_params(self, curve_params: CurveParams, refine_params: RefineParams) -> None:
        """Number inputs bound to the stage 2 / stage 3 parameter dataclasses.

        Raises:
            NaseviewError: a field of :data:`STAGE2_FIELDS` / :data:`STAGE3_FIELDS` that
                the params class does not have.
        """
        for store, folder, obj, spec, stage in (
                (self.params2, self.param_folder2, curve_params, STAGE2_FIELDS, "curves"),
                (self.params3, self.param_folder3, refine_params, STAGE3_FIELDS, "refine")):
            for h in store.values():
                h.remove()
            store.clear()
            with folder:
                store.update(self._param_inputs(obj, spec, stage))

    def _param_inputs(self, obj: CurveParams | RefineParams,
                      spec: tuple[tuple[str, str], ...], stage: str
                      ) -> dict[str, viser.GuiNumberHandle[Any]]:
        """One number input per numeric field of ``spec`` (name, label) of ``obj``; a
        change calls ``app.params_changed(stage)``."""
        names = {f.name for f in fields(obj)}
        unknown = [name for name, _ in spec if name not in names]
        if unknown:
            raise NaseviewError(f"panel parameters {', '.join(unknown)}: not fields of "
                                f"{type(obj).__name__}; fix the panel's field table")
        out: dict[str, viser.GuiNumberHandle[Any]] = {}
        for name, label in spec:
            v = getattr(obj, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                continue
            step = 1 if isinstance(v, int) else _step(float(v))
            h = self.gui.add_number(label, v, min=0, step=step,
                                    hint=f"{type(obj).__name__}.{name}")
            h.on_update(lambda e: self.app.params_changed(stage))
            out[name] = h
        return out

    def param_values(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """Current values of the stage 2 and stage 3 inputs."""
        return ({k: h.value for k, h in self.params2.items()},
                {k: h.value for k, h in self.params3.items()})

    # status
    def set_status(self, text: str) -> None:
        self.status.content = text

    def set_progress(self, fraction: float | None) -> None:
        """Show the progress bar at ``fraction`` (0..1); ``None`` hides it."""
        if fraction is None:
            self.progress.visible = False
            return
        set_value(self.progress, float(np.clip(fraction * 100.0, 0.0, 100.0)))
        self.progress.visible = True

    def show_error(self, message: str | None, notify_tab: bool = True) -> None:
        """A red error line in the page (``None`` clears it), and a notification unless
        ``notify_tab`` is False."""
        if not message:
            self.error.visible = False
            return
        self.error.content = f"<span style='color:#c0392b'>**Error:** {message}</span>"
        self.error.visible = True
        if notify_tab:
            notify(self.scope, "naseview", message, color="red", seconds=8.0)

    def set_history(self, can_undo: bool, can_redo: bool, edited: bool) -> None:
        self.undo.disabled = not can_undo
        self.redo.disabled = not can_redo
        self.reset.disabled = not edited

    def set_plan(self, amounts: Mapping[str, float]) -> None:
        """Show the patient's manoeuvre amounts (an undo, another tab) on the sliders."""
        for name, h in self.manoeuvres.items():
            v = float(amounts.get(name, 0.0))
            if abs(float(h.value) - v) > 1e-9:
                set_value(h, v)
        self.clear_plan.disabled = not amounts

    def set_measurements(self, original: Mapping[str, float],
                         simulated: Mapping[str, float],
                         inputs: Collection[str] = (),
                         estimated: Mapping[str, Estimate] | None = None) -> None:
        """The tables of the reconstruction's and the simulation's measurements;
        ``inputs``: names that are calliper distances typed at intake; ``estimated``:
        the values shown as estimates with their uncertainty."""
        self.measurements.content = measurements_markdown(original, simulated, "clinical",
                                                          inputs, estimated)
        self.distances.content = measurements_markdown(original, simulated, "distances",
                                                       inputs)

    def set_colorbar(self, limit: float | None, max_out: float = 0.0,
                     max_in: float = 0.0, neutral: tuple[int, int, int] | None = None) -> None:
        if limit is None:
            self.colorbar.visible = False
            self.displacement.visible = False
            return
        self.colorbar.image = colorbar_image(limit, neutral=neutral)
        self.colorbar.visible = True
        self.displacement.content = (f"Largest displacement: **{max_out:.1f} mm** outwards, "
                                     f"**{max_in:.1f} mm** inwards (along the surface "
                                     "normal).")
        self.displacement.visible = True


def _step(v: float) -> float:
    if v == 0:
        return 0.01
    return float(10 ** np.floor(np.log10(abs(v)) - 1))
