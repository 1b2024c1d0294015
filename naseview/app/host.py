"""What the app's pieces need from the tab they live in: one narrow protocol each.

:class:`naseview.app.screen.Screen` (one browser tab of
:class:`naseview.app.naseview_app.NaseviewApp`) is the one implementation; the pieces see
it through these protocols, so that they do not import the module that builds them:

- :class:`AppHost`: the new-patient page (:mod:`naseview.app.annotate_page`) and patient
  mode (:mod:`naseview.app.patient_mode`);
- :class:`PatientsHost`: the "Patient's work" section
  (:class:`naseview.app.patients_panel.PatientsPanel`).

The editor, case and photos are the patient's (shared by every tab); the scene, display
toggles and camera are the tab's own. What the tab itself needs from the app is
:class:`naseview.app.screen.ScreenHost`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import viser

from naseview.app.patient_work import PatientWork
from naseview.app.scene import FaceScene
from naseview.case import Case
from naseview.editing.controller import EditController
from naseview.texture.bake import FaceTexture


class AppHost(Protocol):
    """One tab of the served app, as the new-patient page and patient mode use it."""

    @property
    def controller(self) -> EditController | None:
        """The editor of the open case, shared by every tab (None before one is open)."""

    @property
    def scene(self) -> FaceScene | None:
        """This tab's 3D scene of the open case (None before one is open)."""

    @property
    def case(self) -> Case | None:
        """The case directory with the photos, when available."""

    @property
    def case_id(self) -> str:
        """Anonymised id of the open case."""

    @property
    def credit(self) -> str:
        """Attribution line of the face model."""

    @property
    def patient_id(self) -> str | None:
        """The open patient's folder name in the work folder (None: not kept, e.g. the
        demo or a session file opened directly)."""

    @property
    def texture(self) -> FaceTexture | None:
        """The patient's skin baked from the photos for the open reconstruction (None
        without photos)."""

    def open(self, path: Path | None) -> None:
        """Open a case directory, reconstruction directory or session file for the
        patient (every tab shows it; errors are shown in this tab)."""

    def apply_display(self) -> None:
        """Show this tab's scene as its panel's display toggles say."""

    def reset_camera(self) -> None:
        """Frame the nose in this tab."""


class PatientsHost(Protocol):
    """One tab of the served app, as its "Patient's work" section uses it: the patient's
    kept work and the actions on it, for every tab of the patient (errors are shown in
    this tab)."""

    @property
    def client(self) -> viser.ClientHandle:
        """The tab (the section's widgets live in its scope)."""

    @property
    def work(self) -> PatientWork:
        """The open patient's kept work (shared by every tab)."""

    def open(self, path: Path | None) -> None:
        """Open a patient folder, one of its simulations, or a case directory."""

    def open_patient(self, pid: str, slug: str | None = None) -> None:
        """Open simulation ``slug`` (default the latest) of patient ``pid``."""

    def new_simulation(self) -> None:
        """A new simulation of the open patient: its reconstruction without edits."""

    def duplicate_simulation(self) -> None:
        """A copy of the open simulation as it is now; the copy is opened."""

    def delete_simulation(self) -> Path:
        """Move the open simulation to the patient's trash; returns where it went."""
