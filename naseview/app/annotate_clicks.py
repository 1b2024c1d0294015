"""The new-patient page's click flow: place, accept, skip, undo, choose and drag landmarks,
and the guidance that pre-places the next one.

:class:`ClickFlow` turns a click on the photo into a landmark of the session
(:class:`naseview.intake.session.AnnotationSession`): the guided target, or the one
chosen in the list; "Accept the marker" places it on its prediction
(:func:`naseview.intake.predict.predict_next`), a finished photo moves on to the next.
Scene clicks arrive in order on the event loop and are queued to the page's worker, so
fast clicking never reorders landmarks. The guidance (a quick stage 1, paper §3.2) runs
on its own thread after every change and redraws the hints when it is done.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import viser

from naseview.app.annotate_state import (
    AnnotateState,
)
from naseview.app.landmark_names import display_name
from naseview.intake.click_order import CLICK_ORDER, VIEW_TITLES
from naseview.intake.predict import predict_next

log = logging.getLogger(__name__)


class ClickFlow(AnnotateState):
    """The click part of :class:`~naseview.app.annotate_page.AnnotatePage`."""

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

    def _move(self, view: str, lid: str, uv: np.ndarray) -> None:
        s = self.session
        if s is None or view != self.view:
            return
        s.move(view, lid, uv)
        self.events.append((time.monotonic(), f"move {view} {lid}"))
        self._redraw()
        self._request_hints()

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


__all__ = ["ClickFlow"]
