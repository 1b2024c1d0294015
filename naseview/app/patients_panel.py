"""The surgeon's "Patient's work" section and the patient list, in one browser tab.

:class:`PatientsPanel` sits under "Patient" in a tab's panel: where the open patient's
work is kept and when it was last saved ("Saved 10:42"), an autosave error in one line
(disk full: the previous save is unchanged), the patient's simulations (choose one to
open it) with "New simulation", "Rename", "Duplicate" and "Delete" (to the patient's
trash, after a confirmation), and "All patients" (:class:`PatientList`). The app
(:class:`naseview.app.naseview_app.NaseviewApp`) builds one per tab and opens what is
chosen for every tab of the patient: the patient screen and the other tabs follow. The
section sees its tab through :class:`naseview.app.host.PatientsHost` only.

:class:`PatientList` is the list itself (newest patient first, each a folder with a
button per simulation; a click opens that patient and simulation), also shown on the
new-patient page's "Patients" tab. Names come from files: shown as plain text
(:func:`naseview.app.markdown_text.markdown_text` in markdown).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import viser

from naseview.app.gui_value import set_value
from naseview.app.host import PatientsHost
from naseview.app.markdown_text import markdown_text
from naseview.app.patient_work import clock
from naseview.app.scope import notify
from naseview.errors import NaseviewError
from naseview.intake.patients import PatientFolders
from naseview.records import PatientSummary

log = logging.getLogger(__name__)

MAX_PATIENTS = 40
"""Patients the list shows (the newest; the folder holds them all)."""

MAX_SIMULATIONS = 8
"""Simulations shown per patient in the list (the newest)."""

ERROR_STYLE = "color:#c0392b"


class PatientList:
    """The patient list in the current GUI container of ``gui`` (module docstring).

    Args:
        gui: a tab's (or the server's) GUI, inside the folder or tab to fill.
        patients: the patient list, newest first (:meth:`PatientRecords.list_patients`).
        folders: the work folder layout (paths of what a click opens).
        open_path: opens ``WORK/<id>`` (a patient) or ``WORK/<id>/simulations/<slug>.json``
            (that simulation); a ``NaseviewError`` it raises is shown under the list.
    """

    def __init__(self, gui: viser.GuiApi, patients: Callable[[], list[PatientSummary]],
                 folders: PatientFolders, open_path: Callable[[Path], None]) -> None:
        self.gui = gui
        self.patients = patients
        self.folders = folders
        self.open_path = open_path
        self.summary = gui.add_markdown("")
        self.error = gui.add_markdown("", visible=False)
        self.container = gui.add_folder(None)
        self._items: list[Any] = []
        self._lock = threading.Lock()
        self.shown: list[tuple[str, str | None]] = []
        """``(patient id, simulation slug or None)`` of each button, in order (tests)."""
        self.refresh()

    def refresh(self) -> None:
        """Rebuild the list from the work folder (newest patient first)."""
        try:
            items = self.patients()
        except Exception as e:  # never break the page over the list
            log.warning("naseview: patient list: %s", e)
            items = []
        with self._lock:
            for h in self._items:
                try:
                    h.remove()
                except Exception:
                    log.debug("naseview: list item of a closed tab", exc_info=True)
            self._items, self.shown = [], []
            n = len(items)
            where = markdown_text(str(self.folders.root))
            self.summary.content = (
                f"{n} patient{'s' if n != 1 else ''}, newest first, kept in {where}"
                + (f" (the {MAX_PATIENTS} newest shown)" if n > MAX_PATIENTS else "")
                if n else f"No patients yet. Their work will be kept in {where}.")
            with self.container:
                for p in items[:MAX_PATIENTS]:
                    self._add_patient(p)

    def _add_patient(self, p: PatientSummary) -> None:
        gui = self.gui
        sims = p.simulations
        label = f"{p.patient_id} · {clock(p.modified)}"
        folder = gui.add_folder(label, expand_by_default=False)
        self._items.append(folder)
        with folder:
            for s in sims[:MAX_SIMULATIONS]:
                text = f"{s.name} · {clock(s.modified)}"
                btn = gui.add_button(text if s.problem is None else f"{text} (as saved)",
                                     icon=viser.Icon.FILE_TEXT,
                                     hint=s.problem or "Open this simulation")
                btn.on_click(self._opener(p.patient_id, s.slug))
                self.shown.append((p.patient_id, s.slug))
            if not sims:
                btn = gui.add_button("Open", icon=viser.Icon.FOLDER_OPEN,
                                     hint="Open the patient (reconstructs if needed)")
                btn.on_click(self._opener(p.patient_id, None))
                self.shown.append((p.patient_id, None))
            if len(sims) > MAX_SIMULATIONS:
                gui.add_markdown(f"<small>{len(sims) - MAX_SIMULATIONS} older simulations "
                                 "not shown</small>")

    def _opener(self, pid: str, slug: str | None) -> Callable[[Any], None]:
        def run(event: Any) -> None:
            self.open(pid, slug)
        return run

    def open(self, pid: str, slug: str | None) -> None:
        """Open patient ``pid`` (simulation ``slug``) as a click does; an error shows
        under the list in one line."""
        try:
            path = (self.folders.simulation_file(pid, slug) if slug is not None
                    else self.folders.patient_dir(pid))
            self.error.visible = False
            self.open_path(path)
        except NaseviewError as e:
            self.error.content = f"<span style='{ERROR_STYLE}'>{markdown_text(str(e))}</span>"
            self.error.visible = True
        except Exception as e:
            log.exception("naseview: opening a patient failed")
            self.error.content = (f"<span style='{ERROR_STYLE}'>"
                                  f"{markdown_text(f'{type(e).__name__}: {e}')}</span>")
            self.error.visible = True


def current_name(work: Any) -> str | None:
    """The open simulation's name, or None."""
    auto = work.autosave
    return auto.name if auto is not None else None


class PatientsPanel:
    """"Patient's work" in one tab's panel (module docstring).

    Args:
        host: the tab (its patient's :class:`~naseview.app.patient_work.PatientWork`
            and the actions on it).
    """

    def __init__(self, host: PatientsHost) -> None:
        self.app = host
        self.client = host.client
        self.closed = False
        gui = self.client.gui
        self._slugs: dict[str, str] = {}
        self._listed: tuple[str | None, str | None, str | None] | None = None
        self._sims: list[Any] = []
        with gui.add_folder("Patient's work", order=-99.0, expand_by_default=True):
            self.status = gui.add_markdown("")
            self.error = gui.add_markdown("", visible=False)
            self.simulation = gui.add_dropdown("Simulation", ("—",), disabled=True,
                                               hint="Choose a simulation to open it")
            self.new_btn = gui.add_button("New simulation", icon=viser.Icon.PLUS,
                                          disabled=True,
                                          hint="Start again from the reconstruction")
            with gui.add_folder("Rename, duplicate, delete", expand_by_default=False):
                self.name = gui.add_text("Name", "", disabled=True,
                                         hint="A new name for this simulation")
                self.rename_btn = gui.add_button("Rename", icon=viser.Icon.PENCIL,
                                                 disabled=True)
                self.dup_btn = gui.add_button("Duplicate", icon=viser.Icon.COPY,
                                              disabled=True,
                                              hint="Continue in a copy of this simulation")
                self.del_btn = gui.add_button("Delete…", icon=viser.Icon.TRASH,
                                              disabled=True,
                                              hint="Move this simulation to the patient's "
                                                   "trash")
            with gui.add_folder("All patients", expand_by_default=False):
                work = self.app.work
                self.list = PatientList(gui, work.patients, work.records.folders,
                                        self._open_path)
        self.simulation.on_update(self._user(self._on_choose))
        self.rename_btn.on_click(self._user(lambda e: self.rename(str(self.name.value))))
        self.new_btn.on_click(self._user(lambda e: self.app.new_simulation()))
        self.dup_btn.on_click(self._user(lambda e: self.duplicate()))
        self.del_btn.on_click(self._user(lambda e: self.confirm_delete()))
        self.app.work.on_change.append(self.refresh)
        self.app.work.on_list.append(self.refresh_list)
        self.refresh()

    def _user(self, fn: Callable[[Any], object]) -> Callable[[Any], None]:
        """A browser action (values the server sets fire too: ignored); errors are one
        red line in this tab."""
        def run(event: Any) -> None:
            if event.client is None:
                return
            try:
                fn(event)
            except NaseviewError as e:
                self.notify(str(e), "red")
            except Exception as e:
                log.exception("naseview: patient action failed")
                self.notify(f"{type(e).__name__}: {e}", "red")
        return run

    def notify(self, body: str, color: Any = "blue") -> None:
        notify(self.client, "naseview", body, color, seconds=8.0)

    def _open_path(self, path: Path) -> None:
        self.app.open(path)

    # actions
    def _on_choose(self, event: Any) -> None:
        slug = self._slugs.get(str(self.simulation.value))
        work = self.app.work
        if slug is None or work.patient_id is None or slug == work.slug:
            return
        self.app.open_patient(work.patient_id, slug)

    def rename(self, name: str) -> None:
        info = self.app.work.rename(name)
        self.notify(f"Renamed to {info.name}.")

    def duplicate(self) -> None:
        name = self.app.work.autosave.name if self.app.work.autosave else ""
        self.app.duplicate_simulation()
        self.notify(f"Continuing in a copy of {name}.")

    def confirm_delete(self) -> None:
        """Ask, in a dialog, before moving the open simulation to the trash."""
        work = self.app.work
        _, auto = work.require_open()
        gui = self.client.gui
        with gui.add_modal("Delete this simulation?") as modal:
            gui.add_markdown(f"**{markdown_text(auto.name)}** of patient "
                             f"**{markdown_text(str(work.patient_id))}** goes to the "
                             "patient's trash folder (move it back to restore it).")
            yes = gui.add_button("Move to trash", icon=viser.Icon.TRASH, color="red")
            no = gui.add_button("Cancel")

        def delete(event: Any) -> None:
            modal.close()
            where = self.app.delete_simulation()
            self.notify(f"{auto.name} moved to {where.parent}.")

        yes.on_click(self._user(delete))
        no.on_click(lambda e: modal.close())

    # what the section shows
    def refresh(self) -> None:
        """Status, error line and the simulation choice, from the app's patient work."""
        if self.closed:
            return
        work = self.app.work
        try:
            self.status.content = work.status_markdown()
            err = work.error
            self.error.content = (f"<span style='{ERROR_STYLE}'>Not saved: "
                                  f"{markdown_text(err)}</span>" if err else "")
            self.error.visible = bool(err)
            open_ = work.autosave is not None
            key = (work.patient_id, work.slug, current_name(work))
            if key != self._listed:   # read the files only when the choice changed
                self._sims = [i for i in work.simulations() if i.problem is None] \
                    if open_ else []
                self._listed = key
            sims = self._sims
            self._slugs = {i.name: i.slug for i in sims}
            current = work.autosave.name if work.autosave is not None else None
            names = tuple(self._slugs) or ("—",)
            if current is not None and current not in self._slugs:
                names = (current, *names)
                self._slugs[current] = str(work.slug)
            self.simulation.options = names
            set_value(self.simulation, current or names[0])
            set_value(self.name, current or "")
            for h in (self.simulation, self.name, self.rename_btn, self.new_btn,
                      self.dup_btn, self.del_btn):
                h.disabled = not open_
        except Exception:  # the tab went away meanwhile
            log.debug("naseview: patient panel of a closed tab", exc_info=True)

    def refresh_list(self) -> None:
        """The patient list and the simulation choice read again (something was added,
        renamed or removed)."""
        if not self.closed:
            self._listed = None
            self.list.refresh()
            self.refresh()

    def close(self) -> None:
        """The tab went away: stop following the patient's work."""
        self.closed = True
        work = self.app.work
        for lst, fn in ((work.on_change, self.refresh), (work.on_list, self.refresh_list)):
            if fn in lst:
                lst.remove(fn)


__all__ = ["MAX_PATIENTS", "MAX_SIMULATIONS", "PatientList", "PatientsPanel"]
