"""What the app's pages (new patient, patient mode) need from the tab they live in.

:class:`naseview.app.screen.Screen` (one browser tab of
:class:`naseview.app.serve.NaseviewApp`) is the one implementation; the pages see it
through :class:`AppHost`, so that they do not import the module that builds them. The
editor, case and photos are the patient's (shared by every tab); the scene, display
toggles and camera are the tab's own.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

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
