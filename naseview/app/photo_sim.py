"""The simulation on the patient's own photos, in a tab's panel: before / after slider.

For the chosen photo (its stage-1 camera, SPEC §4) the edited face is composited into the
photo (:func:`naseview.texture.composite.composite_photo`: the patient's own skin moved
with the edit) and the panel shows a crop around the nose that blends from the photo
(before, slider 0) to the composite (after, slider 1).

Compositing takes a few tenths of a second, so it never runs during a drag: the tab asks
for it when a solve is final (:meth:`PhotoSimulation.request`), a worker thread of the
tab computes it (latest request wins), and the slider only re-blends the two cached
crops. One :class:`PhotoSimulation` per tab; it can show in several places of the tab
(the surgeon's panel, the patient-mode panel): each :class:`PhotoDisplay` has its own
photo choice and slider.

The worker is a daemon thread (a tab that never closed cannot hold the process), and a
composite runs in OpenCV's native code: one still running when the interpreter finalizes
aborts the process ("terminate called without an active exception", exit status 134,
after the server has stopped). So at exit every worker is closed and joined first
(:func:`join_workers`, registered with :mod:`atexit`).
"""

from __future__ import annotations

import atexit
import logging
import threading
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import cv2
import numpy as np
import viser

from naseview.app.gui_value import set_options
from naseview.camera import Camera
from naseview.texture.composite import blend, composite_photo

log = logging.getLogger(__name__)

DISPLAY_WIDTH = 480
"""Width (px) of the crop shown in the panel."""

CROP_FACTOR = 2.6
"""The crop is this many times the nose's extent in the photo (square, centred on it)."""


EXIT_JOIN_S = 30.0
"""Longest wait at interpreter exit for a worker's composite to finish (each)."""

_WORKERS: weakref.WeakSet[PhotoSimulation] = weakref.WeakSet()
"""Every :class:`PhotoSimulation` whose worker may still run."""


def join_workers(timeout: float = EXIT_JOIN_S) -> None:
    """Close every tab's photo worker and wait for a composite still in native code
    (at interpreter exit, :mod:`atexit`; after daemon threads stop being waited for)."""
    for sim in list(_WORKERS):
        sim.close(wait=timeout)


atexit.register(join_workers)


@dataclass(frozen=True)
class SimInputs:
    """What one composite needs: the photo (BGR, full size), its camera, the
    reconstruction ``V0`` and the simulation ``V1`` (n, 3) mm, the triangles, the moving
    vertices and the simulation's ``(generation, revision)`` (the cache key)."""

    photo: np.ndarray
    camera: Camera
    V0: np.ndarray
    V1: np.ndarray
    F: np.ndarray
    moving: np.ndarray
    generation: tuple[int, int]


def nose_crop(camera: Camera, P: np.ndarray, shape: tuple[int, int],
              factor: float = CROP_FACTOR) -> tuple[int, int, int, int]:
    """Square pixel box ``(x0, y0, x1, y1)`` of ``factor`` times the extent of the
    projected points ``P`` (k, 3) mm, centred on them and kept inside the image
    ``shape`` (H, W)."""
    H, W = shape
    z = camera.depth(P)
    uv = camera.project(P[z > 1.0]) if (z > 1.0).any() else np.array([[W / 2, H / 2]])
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    c = 0.5 * (lo + hi)
    half = 0.5 * factor * float(np.max(hi - lo))
    half = float(np.clip(half, 16.0, 0.5 * min(H, W)))
    x0 = int(np.clip(round(c[0] - half), 0, max(W - 2 * half, 0)))
    y0 = int(np.clip(round(c[1] - half), 0, max(H - 2 * half, 0)))
    s = int(round(2 * half))
    return x0, y0, min(x0 + s, W), min(y0 + s, H)


def before_after(inputs: SimInputs, width: int = DISPLAY_WIDTH
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(before, after) RGB crops (h, ``width``, 3) uint8 around the nose of one photo."""
    after = composite_photo(inputs.photo, inputs.camera, inputs.V0, inputs.V1, inputs.F,
                            moving=inputs.moving)
    ids = inputs.moving if len(inputs.moving) else np.arange(len(inputs.V0))
    x0, y0, x1, y1 = nose_crop(inputs.camera, np.vstack([inputs.V0[ids], inputs.V1[ids]]),
                               inputs.photo.shape[:2])

    def show(img: np.ndarray) -> np.ndarray:
        c = img[y0:y1, x0:x1]
        h = max(1, int(round(c.shape[0] * width / max(c.shape[1], 1))))
        return np.ascontiguousarray(cv2.resize(c, (width, h),
                                               interpolation=cv2.INTER_AREA)[:, :, ::-1])

    return show(inputs.photo), show(after)


class PhotoDisplay:
    """One place in a tab showing the simulation on a photo: photo choice, slider, image.

    Built in the tab's current GUI container (a folder or a panel tab)."""

    def __init__(self, gui: viser.GuiApi, owner: PhotoSimulation, views: tuple[str, ...],
                 initial: str) -> None:
        self.owner = owner
        self.view = gui.add_dropdown("Photo", views, initial_value=initial)
        self.slider = gui.add_slider("Photo before/after", min=0.0, max=1.0, step=0.05,
                                     initial_value=1.0)
        self.image = gui.add_image(np.full((8, 8, 3), 255, np.uint8), visible=False,
                                   format="jpeg", jpeg_quality=88)
        self.note = gui.add_markdown("")
        self.view.on_update(lambda e: owner.guard(lambda: owner.request(self.view.value)))
        self.slider.on_update(lambda e: owner.guard(self.refresh))

    def refresh(self) -> None:
        """Show the cached crops of this display's photo at its slider's value."""
        pair = self.owner.cached(str(self.view.value))
        if pair is None:
            return
        before, after = pair
        self.image.image = blend(before, after, float(self.slider.value))
        self.image.visible = True
        self.note.content = ""


class PhotoSimulation:
    """The tab's composites (see the module doc).

    Args:
        inputs: ``view -> SimInputs | None`` of the current simulation (None: no photo or
            camera for that view, or nothing open).
        views: the photo views offered.
    """

    def __init__(self, inputs: Callable[[str], SimInputs | None], views: tuple[str, ...]
                 ) -> None:
        self.inputs = inputs
        self.views = views
        self.displays: list[PhotoDisplay] = []
        self._cache: dict[str, tuple[tuple[int, int], np.ndarray, np.ndarray]] = {}
        self._wanted: dict[str, int] = {}
        self._cond = threading.Condition()
        self._closed = False
        self.computed = threading.Event()
        """Set after every finished composite (tests wait on it)."""
        self._thread = threading.Thread(target=self._run, name="naseview-photo-sim",
                                        daemon=True)
        self._thread.start()
        _WORKERS.add(self)

    def set_views(self, views: tuple[str, ...]) -> None:
        """Offer ``views`` (the open case's photos, obliques included) in every display."""
        if not views or views == self.views:
            return
        self.views = views
        for d in self.displays:
            set_options(d.view, views)

    def add_display(self, gui: viser.GuiApi, initial: str = "front") -> PhotoDisplay:
        d = PhotoDisplay(gui, self, self.views,
                         initial if initial in self.views else self.views[0])
        self.displays.append(d)
        return d

    @staticmethod
    def guard(fn: Callable[[], object]) -> None:
        try:
            fn()
        except Exception:  # a panel callback never takes the server down
            log.exception("naseview: photo simulation failed")

    def cached(self, view: str) -> tuple[np.ndarray, np.ndarray] | None:
        hit = self._cache.get(view)
        return None if hit is None else (hit[1], hit[2])

    def request(self, view: str | None = None) -> None:
        """Recompute the composites the displays show (or ``view``) for the current
        simulation, in the background (a later request replaces an unfinished one)."""
        views = [view] if view else sorted({str(d.view.value) for d in self.displays})
        with self._cond:
            for v in views:
                self._wanted[v] = self._wanted.get(v, 0) + 1
            self._cond.notify()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._wanted and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                view = next(iter(self._wanted))
                self._wanted.pop(view)
            try:
                self._compute(view)
            except Exception:
                log.exception("naseview: photo composite of %s failed", view)
            self.computed.set()

    def _compute(self, view: str) -> None:
        inp = self.inputs(view)
        shown = [d for d in self.displays if d.view.value == view]
        if inp is None:
            for d in shown:
                d.image.visible = False
                d.note.content = f"No photo with a camera for the {view} view."
            return
        hit = self._cache.get(view)
        if hit is None or hit[0] != inp.generation:
            before, after = before_after(inp)
            self._cache[view] = (inp.generation, before, after)
        for d in shown:
            d.refresh()

    def close(self, wait: float = 0.0) -> None:
        """Stop the worker (a composite under way finishes; returns at once unless
        ``wait``: then at most ``wait`` seconds for it)."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        if wait > 0 and self._thread is not threading.current_thread():
            self._thread.join(wait)
        if not self._thread.is_alive():
            _WORKERS.discard(self)


def sim_inputs(photos: Mapping[str, np.ndarray], cameras: Mapping[str, Camera],
               V0: np.ndarray, V1: np.ndarray, F: np.ndarray, moving: np.ndarray,
               generation: tuple[int, int], view: str) -> SimInputs | None:
    """:class:`SimInputs` of ``view``, None without its photo or camera (or a photo that
    is not its camera's size)."""
    photo, cam = photos.get(view), cameras.get(view)
    if photo is None or cam is None or photo.shape[:2] != (cam.height, cam.width):
        return None
    return SimInputs(photo, cam, V0, V1, F, np.asarray(moving, np.int64), generation)


__all__ = ["CROP_FACTOR", "PhotoDisplay", "PhotoSimulation", "SimInputs", "before_after",
           "nose_crop", "sim_inputs"]
