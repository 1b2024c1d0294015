"""State and controller of the live editor, without any viser code.

The app edits a reconstruction by moving its landmarks; a *solver* turns the landmark
positions into a deformed face, curves, ad-landmarks and measurements. This module keeps:

- :class:`Baseline` — the reconstruction being edited (never changes while editing);
- :class:`Simulation` — one solved state (what the page shows);
- :class:`EditController` — current landmarks, the drag protocol (``begin_drag`` /
  ``drag_to`` / ``end_drag``), symmetric mode, undo / redo (one entry per drag), reset,
  a *latest-request slot* with one worker thread that solves and drops stale requests,
  and error capture (a failing solve is reported, the worker keeps running);
- session files (``naseview.session/1`` JSON, written atomically) that reopen exactly.

Callbacks of the GUI may call the controller from any thread; every method is short and
never solves on the caller's thread.

Example
-------
>>> ctl = EditController(baseline, solver)                     # doctest: +SKIP
>>> ctl.begin_drag("prn"); ctl.drag_to("prn", p + [0, 2, 0]); ctl.end_drag()  # doctest: +SKIP
>>> ctl.wait_idle(); ctl.simulation.V                         # doctest: +SKIP
>>> ctl.undo()                                                 # doctest: +SKIP
"""

from __future__ import annotations

import logging
import os
import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_json, read_json
from naseview.landmarks import LANDMARKS
from naseview.reconstruction import Reconstruction

log = logging.getLogger(__name__)

SESSION_FORMAT = "naseview.session/1"

MIRROR = np.array([-1.0, 1.0, 1.0])
"""The midsagittal reflection of the SPEC frame, (x, y, z) -> (-x, y, z)."""

Landmarks = dict[str, np.ndarray]


def _copy_landmarks(lms: Mapping[str, Any]) -> Landmarks:
    return {k: np.array(v, dtype=np.float64).reshape(3) for k, v in lms.items()}


def landmarks_equal(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> bool:
    """True when both dicts hold the same ids at bit-identical positions."""
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


@dataclass(frozen=True)
class Baseline:
    """The reconstruction being edited, in the SPEC frame (mm).

    Attributes:
        V: (N, 3) float64 face vertices (stage 3 result).
        F: (M, 3) int64 triangles.
        nose_ids: (K,) int64 vertices of the nose region (the part that deforms).
        landmarks: id -> (3,) the landmarks (21 when all could be placed).
        curves: SPEC §5 curve name -> (L, 3) polyline.
        ad_landmarks: (A, 3) ad-landmarks.
        measurements: name -> value (mm / degrees) of the reconstruction.
        reconstruction: the full :class:`Reconstruction` (cameras, residuals...), or None.
    """

    V: np.ndarray
    F: np.ndarray
    nose_ids: np.ndarray
    landmarks: Landmarks
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    ad_landmarks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    measurements: dict[str, float] = field(default_factory=dict)
    reconstruction: Reconstruction | None = None

    def to_json(self) -> dict[str, Any]:
        rec = self.reconstruction or Reconstruction(
            landmarks=self.landmarks, curves=self.curves, ad_landmarks=self.ad_landmarks,
            measurements=self.measurements)
        return {
            "reconstruction": rec.to_json(),
            "landmarks": {k: v.tolist() for k, v in self.landmarks.items()},
            "curves": {k: np.asarray(v).reshape(-1, 3).tolist() for k, v in self.curves.items()},
            "ad_landmarks": np.asarray(self.ad_landmarks).reshape(-1, 3).tolist(),
            "measurements": {k: float(v) for k, v in self.measurements.items()},
            "mesh": {"vertices": self.V.tolist(), "faces": self.F.tolist(),
                     "nose_vertex_ids": self.nose_ids.tolist()},
        }

    @staticmethod
    def from_json(obj: Mapping[str, Any], where: str = "session") -> Baseline:
        try:
            mesh = obj["mesh"]
            V = np.asarray(mesh["vertices"], dtype=np.float64).reshape(-1, 3)
            F = np.asarray(mesh["faces"], dtype=np.int64).reshape(-1, 3)
            nose = np.asarray(mesh["nose_vertex_ids"], dtype=np.int64).ravel()
            rec = Reconstruction.from_json(obj["reconstruction"], f"{where}: baseline")
            b = Baseline(
                V=V, F=F, nose_ids=nose, landmarks=_copy_landmarks(obj["landmarks"]),
                curves={k: np.asarray(c, dtype=np.float64).reshape(-1, 3)
                        for k, c in obj.get("curves", {}).items()},
                ad_landmarks=np.asarray(obj.get("ad_landmarks", []),
                                        dtype=np.float64).reshape(-1, 3),
                measurements={k: float(v) for k, v in obj.get("measurements", {}).items()},
                reconstruction=rec)
        except KeyError as e:
            raise NaseviewError(f"{where}: key 'baseline.{e.args[0]}' missing; the session "
                                "file is incomplete, save it again from the app") from None
        except (TypeError, ValueError):
            raise NaseviewError(f"{where}: key 'baseline': malformed arrays; save the "
                                "session again from the app") from None
        b.validate(where)
        return b

    def validate(self, where: str = "baseline") -> None:
        """Raise :class:`NaseviewError` if the arrays are inconsistent."""
        n = len(self.V)
        if self.F.size and (self.F.min() < 0 or self.F.max() >= n):
            raise NaseviewError(f"{where}: key 'mesh.faces': index outside 0..{n - 1}")
        if self.nose_ids.size and (self.nose_ids.min() < 0 or self.nose_ids.max() >= n):
            raise NaseviewError(f"{where}: key 'mesh.nose_vertex_ids': index outside "
                                f"0..{n - 1}")
        if not np.all(np.isfinite(self.V)):
            raise NaseviewError(f"{where}: key 'mesh.vertices': non-finite coordinates")


@dataclass(frozen=True)
class Solved:
    """What a solver returns for one set of landmark positions (SPEC frame, mm).

    Attributes:
        V: (N, 3) deformed face (only nose-region rows may differ from the baseline).
        curves: curve name -> (L, 3).
        ad_landmarks: (A, 3).
        measurements: name -> value.
        warnings: one line each (handle clamped, triangles folded...), shown in the page.
    """

    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]
    warnings: tuple[str, ...] = ()


class Solver(Protocol):
    """Landmark positions -> :class:`Solved`. Called from the worker thread only.

    ``interactive`` is True while a drag is in progress: the solver may trade accuracy
    for speed (fewer iterations); the controller asks for a full solve when the drag ends.
    """

    def __call__(self, landmarks: Mapping[str, np.ndarray],
                 interactive: bool = False) -> Solved: ...


@dataclass(frozen=True)
class Simulation:
    """A published state: the solved result for landmarks of request ``revision``.

    ``interactive``: solved during a drag (possibly fewer iterations than a final solve).
    """

    revision: int
    generation: int
    landmarks: Landmarks
    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]
    solve_seconds: float = 0.0
    warnings: tuple[str, ...] = ()
    interactive: bool = False


@dataclass
class _Entry:
    landmarks: Landmarks
    revision: int
    sim: Simulation | None = None


@dataclass
class _Request:
    revision: int
    generation: int
    landmarks: Landmarks
    ready: Simulation | None = None
    interactive: bool = False


@dataclass
class _Drag:
    landmark: str
    start: Landmarks


def baseline_simulation(baseline: Baseline, revision: int = 0,
                        generation: int = 0) -> Simulation:
    """The baseline itself as a :class:`Simulation` (what reset shows, exactly)."""
    return Simulation(revision, generation, _copy_landmarks(baseline.landmarks),
                      baseline.V, dict(baseline.curves), baseline.ad_landmarks,
                      dict(baseline.measurements))


class EditController:
    """Landmark edits, undo / redo, symmetric mode and the solve worker.

    Listeners (plain lists of callables, called outside the lock):

    - ``on_simulation(sim)`` from the worker thread whenever a solve (or an undo / redo /
      reset that needs none) is published, in order;
    - ``on_landmarks(landmarks)`` from the caller's thread as soon as landmarks change (so
      spheres follow the pointer before the solve finishes);
    - ``on_history()`` when undo / redo availability or the symmetric flag changes;
    - ``on_error(message | None)`` when a solve fails (``None``: the next one succeeded).

    Args:
        baseline: the reconstruction being edited.
        solver: landmarks -> :class:`Solved`; ``None`` until one is available (edits are
            then recorded but not solved).
        history_limit: undo entries kept (oldest dropped, the baseline always kept).
    """

    def __init__(self, baseline: Baseline, solver: Solver | None,
                 history_limit: int = 500) -> None:
        self._lock = threading.RLock()
        self._cond = threading.Condition(self._lock)
        self._baseline = baseline
        self._solver = solver
        self._generation = 0
        self._rev = 0
        base = baseline_simulation(baseline)
        self._landmarks = _copy_landmarks(baseline.landmarks)
        self._history: list[_Entry] = [_Entry(_copy_landmarks(baseline.landmarks), 0, base)]
        self._index = 0
        self._history_limit = max(2, int(history_limit))
        self._published = base
        self._pending: _Request | None = None
        self._busy = False
        self._min_rev = 0
        self._drag: _Drag | None = None
        self._symmetric = False
        self._error: str | None = None
        self._closed = False
        self.max_displacement_mm: float | None = None
        """Drags stop this far (mm) from a landmark's reconstructed position (None: no
        limit); the app sets it to the solver's handle limit so spheres stay on the
        surface."""
        self.on_simulation: list[Callable[[Simulation], None]] = []
        self.on_landmarks: list[Callable[[Landmarks], None]] = []
        self.on_history: list[Callable[[], None]] = []
        self.on_error: list[Callable[[str | None], None]] = []
        self.solve_seconds: list[float] = []
        self._worker = threading.Thread(target=self._run, name="naseview-solver", daemon=True)
        self._worker.start()

    # ------------------------------------------------------------------ read access
    @property
    def baseline(self) -> Baseline:
        return self._baseline

    @property
    def simulation(self) -> Simulation:
        """The last published :class:`Simulation`."""
        return self._published

    @property
    def landmarks(self) -> Landmarks:
        """Copy of the current landmark positions (may be ahead of :attr:`simulation`)."""
        with self._lock:
            return _copy_landmarks(self._landmarks)

    @property
    def generation(self) -> int:
        """Incremented by :meth:`rebase` / :meth:`set_solver`."""
        return self._generation

    @property
    def symmetric(self) -> bool:
        return self._symmetric

    @property
    def error(self) -> str | None:
        """Message of the last failed solve, ``None`` after a successful one."""
        return self._error

    @property
    def can_undo(self) -> bool:
        return self._index > 0

    @property
    def can_redo(self) -> bool:
        return self._index < len(self._history) - 1

    @property
    def history_index(self) -> int:
        return self._index

    @property
    def history_length(self) -> int:
        return len(self._history)

    @property
    def dragging(self) -> str | None:
        d = self._drag
        return d.landmark if d is not None else None

    def is_edited(self) -> bool:
        """True when the current landmarks differ from the baseline."""
        with self._lock:
            return not landmarks_equal(self._landmarks, self._baseline.landmarks)

    # ------------------------------------------------------------------ editing
    def set_symmetric(self, on: bool) -> None:
        """Symmetric mode: a drag moves the left/right partner by the mirrored
        displacement (x component negated) and keeps midline landmarks at their x."""
        with self._lock:
            self._symmetric = bool(on)
        self._notify(self.on_history)

    def begin_drag(self, landmark: str) -> None:
        """Start a drag of ``landmark`` (ends a drag still open, as one undo entry)."""
        self._check_landmark(landmark)
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            self._drag = _Drag(landmark, _copy_landmarks(self._landmarks))

    def drag_to(self, landmark: str, position: np.ndarray) -> Landmarks:
        """Move the dragged landmark to ``position`` (3,) mm; queue a solve.

        Starts a drag implicitly if none is open for ``landmark``. Returns the new
        landmark positions (the partner moved too in symmetric mode).
        """
        self._check_landmark(landmark)
        p = np.asarray(position, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(p)):
            raise ValueError(f"drag_to({landmark!r}): non-finite position {p}")
        with self._lock:
            if self._drag is None or self._drag.landmark != landmark:
                self.begin_drag(landmark)
            assert self._drag is not None
            start = self._drag.start
            d = p - start[landmark]
            new = _copy_landmarks(self._landmarks)
            info = LANDMARKS.get(landmark)
            if self._symmetric and info is not None:
                if info.partner is None:
                    d[0] = 0.0
                elif info.partner in start:
                    new[info.partner] = start[info.partner] + d * MIRROR
            new[landmark] = start[landmark] + d
            lim = self.max_displacement_mm
            if lim is not None:
                for k in (landmark, info.partner if info is not None else None):
                    if k is None or k not in new or k not in self._baseline.landmarks:
                        continue
                    dk = new[k] - self._baseline.landmarks[k]
                    n = float(np.linalg.norm(dk))
                    if n > lim:
                        new[k] = self._baseline.landmarks[k] + dk * (lim / n)
            self._landmarks = new
            self._submit_locked(interactive=True)
            out = _copy_landmarks(new)
        self._notify(self.on_landmarks, out)
        return out

    def end_drag(self) -> None:
        """Close the drag: one undo entry if anything moved."""
        with self._lock:
            self._commit_locked()
        self._notify(self.on_history)

    def move_landmarks(self, positions: Mapping[str, np.ndarray]) -> None:
        """Set several landmarks at once as one undo entry (no symmetric mirroring)."""
        for k in positions:
            self._check_landmark(k)
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            new = _copy_landmarks(self._landmarks)
            new.update(_copy_landmarks(positions))
            self._landmarks = new
            self._submit_locked()
            self._push_locked()
            out = _copy_landmarks(new)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)

    def undo(self) -> bool:
        """Go back one entry; the mesh shown is exactly the one solved for it."""
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            if self._index == 0:
                return False
            self._index -= 1
            self._goto_locked(self._history[self._index])
            out = _copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)
        return True

    def redo(self) -> bool:
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            if self._index >= len(self._history) - 1:
                return False
            self._index += 1
            self._goto_locked(self._history[self._index])
            out = _copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)
        return True

    def reset(self) -> None:
        """Back to the reconstruction (an undoable entry); shows the baseline exactly."""
        with self._lock:
            self._drag = None
            if landmarks_equal(self._landmarks, self._baseline.landmarks):
                return
            sim = self._history[0].sim
            self._landmarks = _copy_landmarks(self._baseline.landmarks)
            self._rev += 1
            self._truncate_redo_locked()
            entry = _Entry(_copy_landmarks(self._landmarks), self._rev, None)
            self._history.append(entry)
            self._index = len(self._history) - 1
            self._trim_locked()
            self._goto_locked(entry, ready=sim)
            out = _copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)

    def rebase(self, baseline: Baseline, solver: Solver | None) -> None:
        """Swap in a recomputed reconstruction (e.g. after a parameter change).

        Every history entry keeps its landmark *displacements* from the old baseline,
        applied to the new one; cached solves are dropped and the current entry re-solved.
        """
        with self._lock:
            old = self._baseline
            self._drag = None
            self._generation += 1
            self._baseline = baseline
            self._solver = solver

            def carry(lms: Landmarks) -> Landmarks:
                out = _copy_landmarks(baseline.landmarks)
                for k, v in lms.items():
                    if k in out and k in old.landmarks and not np.array_equal(
                            v, old.landmarks[k]):
                        out[k] = out[k] + (v - old.landmarks[k])
                return out

            for i, e in enumerate(self._history):
                e.landmarks = carry(e.landmarks)
                e.sim = None if i else baseline_simulation(baseline, e.revision,
                                                           self._generation)
            self._landmarks = _copy_landmarks(self._history[self._index].landmarks)
            self._rev += 1
            self._history[self._index].revision = self._rev
            self._min_rev = self._rev
            entry = self._history[self._index]
            self._pending = _Request(self._rev, self._generation,
                                     _copy_landmarks(self._landmarks), entry.sim)
            self._cond.notify_all()
            out = _copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)

    def set_solver(self, solver: Solver | None) -> None:
        """Replace the solver for the same baseline (e.g. new ARAP iterations); re-solve."""
        self.rebase(self._baseline, solver)

    def resolve(self) -> None:
        """Queue a solve of the current landmarks (e.g. after a failed solve)."""
        with self._lock:
            self._submit_locked()

    # ------------------------------------------------------------------ waiting / closing
    def wait_idle(self, timeout: float = 30.0) -> bool:
        """Block until no request is pending or running. Returns False on timeout."""
        end = time.monotonic() + timeout
        with self._cond:
            while self._pending is not None or self._busy:
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
        return True

    def close(self) -> None:
        """Stop the worker thread."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._worker.join(timeout=5.0)

    # ------------------------------------------------------------------ sessions
    def session_json(self, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Everything needed to reopen this editor exactly (see :func:`save_session`)."""
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            sim = self._published
            lms = _copy_landmarks(self._landmarks)
            history = [{k: v.tolist() for k, v in e.landmarks.items()} for e in self._history]
            index = self._index
            symmetric = self._symmetric
        base = self._baseline
        state: dict[str, Any] | None = None
        if landmarks_equal(sim.landmarks, lms):
            changed = np.flatnonzero(np.any(sim.V != base.V, axis=1))
            state = {
                "changed_vertex_ids": changed.tolist(),
                "changed_vertices": sim.V[changed].tolist(),
                "curves": {k: np.asarray(c).reshape(-1, 3).tolist()
                           for k, c in sim.curves.items()},
                "ad_landmarks": np.asarray(sim.ad_landmarks).reshape(-1, 3).tolist(),
                "measurements": {k: float(v) for k, v in sim.measurements.items()},
            }
        return {
            "format": SESSION_FORMAT,
            "units": "mm",
            "baseline": base.to_json(),
            "edit": {
                "landmarks": {k: v.tolist() for k, v in lms.items()},
                "history": history,
                "history_index": index,
                "symmetric": symmetric,
                "simulation": state,
            },
            "app": dict(extra or {}),
        }

    @classmethod
    def from_session(cls, session: Session, solver: Solver | None) -> EditController:
        """A controller in exactly the saved state (the saved mesh is shown as is)."""
        ctl = cls(session.baseline, solver)
        with ctl._lock:
            hist = session.history or [session.baseline.landmarks]
            ctl._history = [_Entry(_copy_landmarks(h), i) for i, h in enumerate(hist)]
            ctl._history[0].sim = baseline_simulation(session.baseline)
            ctl._index = min(max(0, session.history_index), len(ctl._history) - 1)
            ctl._rev = len(ctl._history)
            ctl._landmarks = _copy_landmarks(session.landmarks)
            ctl._symmetric = session.symmetric
            entry = ctl._history[ctl._index]
            if not landmarks_equal(entry.landmarks, ctl._landmarks):
                ctl._rev += 1
                entry = _Entry(_copy_landmarks(ctl._landmarks), ctl._rev)
                ctl._history.insert(ctl._index + 1, entry)
                ctl._index += 1
            if session.simulation is not None:
                s = session.simulation
                sim = Simulation(entry.revision, 0, _copy_landmarks(ctl._landmarks), s.V,
                                 s.curves, s.ad_landmarks, s.measurements)
                entry.sim = sim
                ctl._published = sim
            elif landmarks_equal(ctl._landmarks, session.baseline.landmarks):
                ctl._published = baseline_simulation(session.baseline)
            else:
                ctl._submit_locked()
        return ctl

    # ------------------------------------------------------------------ internals
    def _check_landmark(self, landmark: str) -> None:
        if landmark not in self._baseline.landmarks:
            raise KeyError(f"unknown landmark {landmark!r}")

    def _submit_locked(self, ready: Simulation | None = None,
                       interactive: bool = False) -> None:
        self._rev += 1
        self._pending = _Request(self._rev, self._generation,
                                 _copy_landmarks(self._landmarks), ready, interactive)
        self._cond.notify_all()

    def _commit_locked(self) -> None:
        """End the open drag: a final (non-interactive) solve and one undo entry."""
        if self._drag is None:
            return
        self._drag = None
        if not landmarks_equal(self._landmarks, self._history[self._index].landmarks):
            self._submit_locked(interactive=False)
            self._push_locked()

    def _truncate_redo_locked(self) -> None:
        del self._history[self._index + 1:]

    def _push_locked(self) -> None:
        self._truncate_redo_locked()
        entry = _Entry(_copy_landmarks(self._landmarks), self._rev)
        p = self._published
        if p.revision == self._rev and p.generation == self._generation \
                and not p.interactive:
            entry.sim = p
        self._history.append(entry)
        self._index = len(self._history) - 1
        self._trim_locked()

    def _trim_locked(self) -> None:
        excess = len(self._history) - self._history_limit
        if excess > 0:
            del self._history[1:1 + excess]
            self._index -= excess

    def _goto_locked(self, entry: _Entry, ready: Simulation | None = None) -> None:
        """Show ``entry``: publish its cached solve, or solve it; drop results in flight."""
        self._landmarks = _copy_landmarks(entry.landmarks)
        sim = ready or entry.sim
        if sim is not None and sim.generation != self._generation:
            sim = None
        self._rev += 1
        self._min_rev = self._rev
        entry.revision = self._rev
        if sim is not None:
            sim = Simulation(self._rev, self._generation, _copy_landmarks(entry.landmarks),
                             sim.V, sim.curves, sim.ad_landmarks, sim.measurements,
                             sim.solve_seconds, sim.warnings)
            entry.sim = sim
        self._pending = _Request(self._rev, self._generation,
                                 _copy_landmarks(self._landmarks), sim)
        self._cond.notify_all()

    def _notify(self, listeners: list[Callable[..., None]], *args: Any) -> None:
        for cb in list(listeners):
            try:
                cb(*args)
            except Exception:  # a broken view must not break the editor
                log.exception("naseview app listener %r failed", cb)

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                req = self._pending
                self._pending = None
                self._busy = True
                solver = self._solver
            assert req is not None
            sim: Simulation | None = req.ready
            err: str | None = None
            if sim is None and solver is not None:
                t0 = time.perf_counter()
                try:
                    out = solver(req.landmarks, interactive=req.interactive)
                    V = np.asarray(out.V, dtype=np.float64)
                    if V.shape != self._baseline.V.shape or not np.all(np.isfinite(V)):
                        raise NaseviewError(
                            f"the solver returned {V.shape} vertices with non-finite or "
                            f"missing values (expected {self._baseline.V.shape})")
                    dt = time.perf_counter() - t0
                    sim = Simulation(req.revision, req.generation, req.landmarks, V,
                                     dict(out.curves), np.asarray(out.ad_landmarks),
                                     dict(out.measurements), dt,
                                     tuple(getattr(out, "warnings", ()) or ()),
                                     req.interactive)
                    self.solve_seconds.append(dt)
                except Exception as e:  # report, keep serving
                    log.error("naseview: solve failed:\n%s", traceback.format_exc())
                    err = (f"Simulation failed ({type(e).__name__}: {e}). The last good "
                           "result is shown; undo, or change the landmark again.")
            publish = False
            error_changed = False
            with self._cond:
                if err is not None:
                    error_changed = True
                    self._error = err
                elif sim is not None and req.generation == self._generation \
                        and req.revision >= self._min_rev:
                    publish = True
                    self._published = sim
                    if not sim.interactive:
                        for e in self._history:
                            if e.revision == req.revision and e.sim is None:
                                e.sim = sim
                    if self._error is not None:
                        self._error = None
                        error_changed = True
            if publish and sim is not None:
                self._notify(self.on_simulation, sim)
            if error_changed:
                self._notify(self.on_error, err)
            with self._cond:
                self._busy = False
                self._cond.notify_all()


# ---------------------------------------------------------------------- session files
@dataclass
class SavedSimulation:
    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]


@dataclass
class Session:
    """A parsed session file.

    Attributes:
        baseline: the reconstruction as it was when saved (not recomputed).
        landmarks: current landmark positions.
        history: undo entries (landmark dicts), entry 0 the baseline.
        history_index: current entry.
        symmetric: symmetric mode.
        simulation: the saved solved state, or None (then re-solved on open).
        app: free-form app state (source path, parameters, view toggles).
        path: the file it came from.
    """

    baseline: Baseline
    landmarks: Landmarks
    history: list[Landmarks]
    history_index: int
    symmetric: bool
    simulation: SavedSimulation | None
    app: dict[str, Any]
    path: Path | None = None


def save_session(path: str | os.PathLike[str], controller: EditController,
                 app: Mapping[str, Any] | None = None) -> Path:
    """Write the controller's state as a ``naseview.session/1`` JSON file, atomically.

    Floats are written with full precision, so :func:`load_session` restores the same
    bits.
    """
    return atomic_write_json(path, controller.session_json(app))


def is_session_file(path: str | os.PathLike[str]) -> bool:
    """True if ``path`` is a file whose JSON ``format`` is a naseview session."""
    p = Path(path)
    if not p.is_file() or p.suffix.lower() != ".json":
        return False
    try:
        with open(p, encoding="utf-8") as f:
            head = f.read(4096)
    except OSError:
        return False
    return SESSION_FORMAT in head


def load_session(path: str | os.PathLike[str]) -> Session:
    """Parse a session file written by :func:`save_session`.

    Raises:
        NaseviewError: not a session file, or a key is missing / malformed.
    """
    path = Path(path)
    obj = read_json(path)
    return session_from_json(obj, str(path), path)


def session_from_json(obj: Mapping[str, Any], where: str = "session",
                      path: Path | None = None) -> Session:
    if obj.get("format") != SESSION_FORMAT:
        raise NaseviewError(f"{where}: key 'format': expected {SESSION_FORMAT!r}, found "
                            f"{obj.get('format')!r}; open a file saved by 'Save session'")
    if "baseline" not in obj or "edit" not in obj:
        raise NaseviewError(f"{where}: keys 'baseline' and 'edit' are required; save the "
                            "session again from the app")
    baseline = Baseline.from_json(obj["baseline"], where)
    edit = obj["edit"]
    try:
        lms = _copy_landmarks(edit.get("landmarks", baseline.landmarks))
        history = [_copy_landmarks(h) for h in edit.get("history", [])]
        index = int(edit.get("history_index", len(history) - 1))
        symmetric = bool(edit.get("symmetric", False))
        saved = None
        s = edit.get("simulation")
        if s is not None:
            V = baseline.V.copy()
            ids = np.asarray(s.get("changed_vertex_ids", []), dtype=np.int64)
            if ids.size:
                V[ids] = np.asarray(s["changed_vertices"], dtype=np.float64).reshape(-1, 3)
            saved = SavedSimulation(
                V, {k: np.asarray(c, dtype=np.float64).reshape(-1, 3)
                    for k, c in s.get("curves", {}).items()},
                np.asarray(s.get("ad_landmarks", []), dtype=np.float64).reshape(-1, 3),
                {k: float(v) for k, v in s.get("measurements", {}).items()})
    except (TypeError, ValueError, KeyError, IndexError, AttributeError):
        raise NaseviewError(f"{where}: key 'edit': malformed landmark or mesh arrays; save "
                            "the session again from the app") from None
    unknown = [k for k in lms if k not in baseline.landmarks]
    if unknown:
        raise NaseviewError(f"{where}: key 'edit.landmarks.{unknown[0]}': not a landmark "
                            "of the baseline")
    return Session(baseline, lms, history, index, symmetric, saved,
                   dict(obj.get("app", {})), path)
