"""What the parts of the new-patient page share: its state, colours and the actions each
part calls on the others.

:class:`naseview.app.annotate_page.AnnotatePage` is one page made of three parts, each in
a module of its own job: the panel and its to-do list (:mod:`naseview.app.annotate_panel`),
the photo view with its markers (:mod:`naseview.app.annotate_photo`) and the click flow
with its guidance (:mod:`naseview.app.annotate_clicks`). :class:`AnnotateState` declares
what they share (set by the page's constructor) and, for the type checker only, the
methods one part calls on another; it holds no behaviour.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import viser

from naseview.app.host import AppHost
from naseview.app.landmark_diagrams import LandmarkDiagrams
from naseview.app.photo_plane import PhotoPlane
from naseview.app.scope import NoticeColor, Scope
from naseview.intake.guidance import Guidance
from naseview.intake.patients import PatientFolders
from naseview.intake.session import AnnotationSession

PLACED_RGB = (40, 220, 90)
"""Colour of a placed click's ring."""
ACTIVE_RGB = (255, 210, 0)
"""Colour of the ring of the landmark being clicked (when it was placed before)."""
HINT_RGB = (255, 40, 200)
"""Colour of the marker where the landmark being clicked probably is."""
OTHER_HINT_RGB = (40, 200, 255)
"""Colour of the dots where the other landmarks of the photo probably are."""
VIEW_BUTTONS = {"Front": "front", "Bottom": "bottom", "Left": "left", "Right": "right",
                "Left-oblique": "oblique_left", "Right-oblique": "oblique_right"}
"""Photo button label -> view."""
PICK_NONE = "— choose a landmark —"
"""The landmark drop-down's entry while the landmark being clicked is in another photo."""

GuiEvent = viser.GuiEvent[Any]
"""A GUI callback's event (``event.client`` is None for values the server assigns)."""


class AnnotateState:
    """The state the new-patient page's parts share (set by
    :class:`~naseview.app.annotate_page.AnnotatePage`; see its docstring)."""

    server: viser.ViserServer
    client: viser.ClientHandle | None
    scope: Scope
    gui: viser.GuiApi
    app: AppHost | None
    in_use: Callable[[Path], bool]
    folders: PatientFolders
    work_dir: Path
    diagrams: LandmarkDiagrams
    session: AnnotationSession | None
    view: str
    """The view whose photo is shown."""
    target: tuple[str, str] | None
    """(view, landmark) being clicked, None when nothing is left."""
    override: str | None
    """A landmark chosen in the list (clicked next instead of the guided one)."""
    active: bool
    plane: PhotoPlane | None
    """The photo's plane in the scene (None without a photo)."""
    guidance: Guidance | None
    events: list[tuple[float, str]]
    """(monotonic time, what happened): every place, skip, move and reconstruct."""
    labels_cb: viser.GuiCheckboxHandle
    pick: viser.GuiDropdownHandle[Any]
    _lock: threading.RLock
    _hint_cond: threading.Condition
    _hint_request: int
    _handles: dict[str, Any]
    """scene node name -> viser handle (photo, rings, hints, labels)."""
    _drag: dict[int, tuple[str, np.ndarray]]
    _drag_time: float
    _sent: dict[tuple[int, str], object]
    _intake_open: bool
    _last_pred: dict[str, np.ndarray]
    """The predicted places drawn last (id -> (2,) px)."""
    _photo_warnings: dict[str, str]
    _last_upload: float

    if TYPE_CHECKING:  # what one part calls on another (defined in the page or a part)
        def submit(self, fn: Callable[[], None]) -> None: ...
        def show_error(self, message: str | None,
                       client: viser.ClientHandle | None = None) -> None: ...
        def notify(self, title: str, body: str, client: viser.ClientHandle | None = None,
                   color: NoticeColor = "blue") -> None: ...
        def _need_session(self) -> AnnotationSession: ...
        def _open_patient(self, path: Path) -> None: ...
        def _update_panel(self) -> None: ...
        def _redraw(self) -> None: ...
        def set_view(self, view: str, fit: bool = False) -> None: ...
        def fit_camera(self, clients: Iterable[viser.ClientHandle] | None = None
                       ) -> None: ...
        def zoom_nose(self) -> None: ...
        def _current_target(self) -> tuple[str, str] | None: ...
        def _predicted(self) -> dict[str, np.ndarray]: ...
        def _request_hints(self) -> None: ...
        def _move_ring(self, plane: PhotoPlane, idx: int, uv: np.ndarray) -> None: ...
        async def _on_drag(self, event: viser.SceneNodeDragEvent[viser.BatchedMeshHandle]
                           ) -> None: ...


__all__ = ["ACTIVE_RGB", "HINT_RGB", "OTHER_HINT_RGB", "PICK_NONE", "PLACED_RGB",
           "VIEW_BUTTONS", "AnnotateState", "GuiEvent"]
