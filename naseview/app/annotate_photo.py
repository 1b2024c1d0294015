"""The new-patient page's photo view: one photo filling the 3D view, its markers, labels
and camera.

:class:`PhotoView` shows the photo being marked as a scene image on a plane far from the
face (:mod:`naseview.app.photo_plane`), seen straight on by a camera the page places
(:mod:`naseview.app.photo_camera`: whole photo, nose, a box drawn with a left-drag); the
placed clicks are green rings (a faint disc under each grabs it for dragging), the
landmark being clicked is yellow, the predicted place of the next one a magenta ring and
of the others small cyan dots, with their names. Pixels are the photo's stored pixels.
"""

from __future__ import annotations

import time
from collections.abc import Iterable

import numpy as np
import viser

from naseview.app.annotate_state import (
    ACTIVE_RGB,
    HINT_RGB,
    OTHER_HINT_RGB,
    PLACED_RGB,
    AnnotateState,
)
from naseview.app.landmark_names import display_name
from naseview.app.photo_camera import fit_photo, frame_pixels, nose_box, screen_box_pixels
from naseview.app.photo_plane import PhotoPlane, disc_mesh, ring_mesh
from naseview.app.scope import (
    clients_of,
)
from naseview.errors import NaseviewError
from naseview.intake.click_order import CLICK_ORDER
from naseview.landmarks import ALL_VIEWS


class PhotoView(AnnotateState):
    """The photo part of :class:`~naseview.app.annotate_page.AnnotatePage`."""

    def set_view(self, view: str, fit: bool = False) -> None:
        """Show the photo of ``view`` (worker thread)."""
        s = self._need_session()
        if view not in ALL_VIEWS:
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

    def _move_ring(self, plane: PhotoPlane, idx: int, uv: np.ndarray) -> None:
        """Show ring ``idx`` (and the disc that grabs it) at pixel ``uv`` (2,)."""
        for name, lift in (("clicks", 0.35), ("grab", 0.3)):
            h = self._handles.get(name)
            if h is not None:
                pos = np.array(h.batched_positions, dtype=np.float64)
                pos[idx] = plane.to_world(uv, lift)[0]
                h.batched_positions = pos


__all__ = ["PhotoView"]
