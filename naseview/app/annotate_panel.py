"""The new-patient page's panel: its widgets and the to-do list they show.

:class:`AnnotatePanel` builds the docked "New patient" panel (patient and photos, the
landmark being clicked with its description and diagram, Accept / Skip / Undo, the photo
buttons with each photo's progress, what still blocks "Reconstruct") and brings it up to
date with the session after every change, sending only the properties that changed
(each assignment is a message and a re-render in every browser). The rules (click order,
problems, cautions) are :mod:`naseview.intake`'s; the page is
:class:`naseview.app.annotate_page.AnnotatePage`.
"""

from __future__ import annotations

import time

import numpy as np
import viser

from naseview.app.annotate_state import (
    PICK_NONE,
    VIEW_BUTTONS,
    AnnotateState,
)
from naseview.app.landmark_names import display_name
from naseview.app.patients_panel import PatientList
from naseview.intake.click_order import CLICK_ORDER, VIEW_TITLES, definition
from naseview.intake.session import AnnotationSession, default_case_id
from naseview.landmarks import OBLIQUE_VIEWS
from naseview.records import PatientRecords

_UNSET = object()


def upload_label(name: str, view: str, loaded: bool) -> str:
    """Text of a photo's upload button: the obliques say they are optional."""
    if loaded:
        return f"{name} photo ✓"
    return f"{name} photo (optional)" if view in OBLIQUE_VIEWS else f"{name} photo"


class AnnotatePanel(AnnotateState):
    """The panel part of :class:`~naseview.app.annotate_page.AnnotatePage`."""

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
                            upload_label(label, view, False), icon=viser.Icon.UPLOAD,
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
                      "(front, bottom, left and right profile) and, if you have them, the "
                      "two ¾ obliques (optional), then mark the landmarks.")
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
        full = bool(s.missing_photos()) or self._intake_open or recent
        for h in (self.case_id, self.other, self.photo_info, self.f_uploads):
            S(h, "visible", full)
        S(self.change_btn, "visible", not s.missing_photos())
        S(self.change_btn, "label", "Done" if self._intake_open
          else "Change photos, id or distances")
        S(self.intake_md, "visible", not full)
        for view, btn in self.uploads.items():
            S(btn, "label", upload_label(names[view], view, view in s.photos))
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


__all__ = ["AnnotatePanel"]
