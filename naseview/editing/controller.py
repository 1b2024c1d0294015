"""The live editor's controller: landmark drags in, solved simulations out; no viser here.

The app edits a reconstruction by moving its landmarks; a *solver*
(:class:`naseview.editing.baseline.Solver`, the ARAP deformation of paper §3.4 in
:mod:`naseview.editing.solver`) turns the landmark positions into a deformed face, curves,
ad-landmarks and measurements. :class:`EditController` keeps the current landmarks, the
drag protocol (``begin_drag`` / ``drag_to`` / ``end_drag``), symmetric mode, undo / redo
(one entry per drag), reset, a *latest-request slot* with one worker thread that solves and
drops stale requests, and error capture (a failing solve is reported, the worker keeps
running). Its state is saved and reopened through :mod:`naseview.editing.session`.

Callbacks of the GUI may call the controller from any thread; every method is short and
never solves on the caller's thread.

Example
-------
    ctl = EditController(baseline, solver)
    ctl.begin_drag("prn"); ctl.drag_to("prn", p + [0, 2, 0]); ctl.end_drag()
    ctl.wait_idle(); ctl.simulation.V
    ctl.undo()
"""

from __future__ import annotations

import logging
import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from naseview.editing.baseline import (
    Baseline,
    Landmarks,
    Manoeuvres,
    Simulation,
    Solver,
    baseline_simulation,
    copy_landmarks,
    landmarks_equal,
)
from naseview.editing.manoeuvres import check_amounts
from naseview.editing.session import SavedSimulation, Session, session_to_json
from naseview.errors import NaseviewError
from naseview.landmarks import LANDMARKS

log = logging.getLogger(__name__)

MIRROR = np.array([-1.0, 1.0, 1.0])
"""The midsagittal reflection of the SPEC frame, (x, y, z) -> (-x, y, z)."""


@dataclass
class _Entry:
    """One undo entry: landmarks and manoeuvres, the request revision that shows them, its
    cached solve."""

    landmarks: Landmarks
    revision: int
    sim: Simulation | None = None
    manoeuvres: Manoeuvres = field(default_factory=dict)


@dataclass
class _Request:
    """The latest-request slot: solve ``landmarks`` with ``manoeuvres`` (or publish
    ``ready`` as is)."""

    revision: int
    generation: int
    landmarks: Landmarks
    ready: Simulation | None = None
    interactive: bool = False
    manoeuvres: Manoeuvres = field(default_factory=dict)


@dataclass
class _Drag:
    """An open drag of ``landmark``, with every landmark where it started."""

    landmark: str
    start: Landmarks


class EditController:
    """Landmark edits and surgical manoeuvres, undo / redo, symmetric mode and the solve
    worker.

    The edit state is the landmark positions plus the manoeuvre amounts
    (:data:`naseview.editing.manoeuvres.MANOEUVRES`, e.g. ``{"hump_reduction": 2.0}``);
    undo / redo / reset and session files cover both. A drag is one undo entry; changes
    of one manoeuvre in a row (a slider moved, a value retyped) are one entry too.

    Listeners (plain lists of callables, called outside the lock):

    - ``on_simulation(sim)`` from the worker thread whenever a solve (or an undo / redo /
      reset that needs none) is published, in order;
    - ``on_landmarks(landmarks)`` from the caller's thread as soon as landmarks change (so
      spheres follow the pointer before the solve finishes);
    - ``on_history()`` when undo / redo availability or the symmetric flag changes;
    - ``on_error(message | None)`` when a solve fails (``None``: the next one succeeded).

    Args:
        baseline: the reconstruction being edited.
        solver: landmarks -> :class:`~naseview.editing.baseline.Solved`; ``None`` until one
            is available (edits are then recorded but not solved).
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
        self._landmarks = copy_landmarks(baseline.landmarks)
        self._manoeuvres: Manoeuvres = {}
        self._last_tag: str | None = None
        """The manoeuvre whose control made the newest undo entry, while that entry is
        current and nothing else was edited (its next change joins that entry); any other
        edit, undo, redo or reset clears it."""
        self._history: list[_Entry] = [_Entry(copy_landmarks(baseline.landmarks), 0, base)]
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

    # read access
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
            return copy_landmarks(self._landmarks)

    @property
    def manoeuvres(self) -> Manoeuvres:
        """Copy of the current manoeuvre amounts (name -> mm / degrees, non-zero only)."""
        with self._lock:
            return dict(self._manoeuvres)

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
        """True when the current landmarks differ from the baseline or a manoeuvre is set."""
        with self._lock:
            return bool(self._manoeuvres) or not landmarks_equal(self._landmarks,
                                                                 self._baseline.landmarks)

    # editing
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
            self._drag = _Drag(landmark, copy_landmarks(self._landmarks))

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
            new = self._dragged_positions(self._drag.start, landmark, p)
            self._clamp_to_limit(new, landmark)
            self._landmarks = new
            self._submit_locked(interactive=True)
            out = copy_landmarks(new)
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
            new = copy_landmarks(self._landmarks)
            new.update(copy_landmarks(positions))
            self._landmarks = new
            self._submit_locked()
            self._push_locked()
            out = copy_landmarks(new)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)

    def set_manoeuvre(self, name: str, amount: float) -> None:
        """Set one manoeuvre's amount (0 removes it) and queue a solve.

        Successive calls for the same manoeuvre with nothing else in between update one
        undo entry (a slider dragged, a value retyped); a call that brings the state back
        to the previous entry removes that entry.

        Raises:
            NaseviewError: unknown manoeuvre or an amount outside its clinical range.
        """
        amounts = check_amounts({name: amount}, "manoeuvre")
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            new = dict(self._manoeuvres)
            new.pop(name, None)
            new.update(amounts)
            if new == self._manoeuvres:
                return
            self._manoeuvres = new
            self._submit_locked()
            top = self._history[self._index]
            coalesce = self._last_tag == name and self._index == len(self._history) - 1 \
                and self._index > 0
            if coalesce and _same_state(self._history[self._index - 1], self._landmarks, new):
                del self._history[self._index]       # back where the slide started
                self._index -= 1
                self._last_tag = None
            elif coalesce:
                top.manoeuvres = dict(new)
                top.revision = self._rev
                top.sim = None
            else:
                self._push_locked(tag=name)
        self._notify(self.on_history)

    def set_manoeuvres(self, amounts: Mapping[str, float]) -> None:
        """Replace every manoeuvre amount at once (``{}`` clears them), one undo entry.

        Raises:
            NaseviewError: an unknown manoeuvre or an amount outside its range.
        """
        new = check_amounts(dict(amounts), "manoeuvres")
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            if new == self._manoeuvres:
                return
            self._manoeuvres = new
            self._submit_locked()
            self._push_locked()
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
            out = copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)
        return True

    def redo(self) -> bool:
        """Go forward one entry (after :meth:`undo`); False when there is none."""
        with self._lock:
            if self._drag is not None:
                self._commit_locked()
            if self._index >= len(self._history) - 1:
                return False
            self._index += 1
            self._goto_locked(self._history[self._index])
            out = copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)
        return True

    def reset(self) -> None:
        """Back to the reconstruction (an undoable entry); shows the baseline exactly."""
        with self._lock:
            self._drag = None
            if not self._manoeuvres and landmarks_equal(self._landmarks,
                                                        self._baseline.landmarks):
                return
            sim = self._history[0].sim
            self._landmarks = copy_landmarks(self._baseline.landmarks)
            self._manoeuvres = {}
            self._rev += 1
            self._truncate_redo_locked()
            entry = _Entry(copy_landmarks(self._landmarks), self._rev, None)
            self._history.append(entry)
            self._index = len(self._history) - 1
            self._trim_locked()
            self._goto_locked(entry, ready=sim)
            out = copy_landmarks(self._landmarks)
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
            for i, e in enumerate(self._history):
                e.landmarks = _carry(e.landmarks, old, baseline)
                e.sim = None if i else baseline_simulation(baseline, e.revision,
                                                           self._generation)
            self._landmarks = copy_landmarks(self._history[self._index].landmarks)
            self._manoeuvres = dict(self._history[self._index].manoeuvres)
            self._rev += 1
            self._history[self._index].revision = self._rev
            self._min_rev = self._rev
            entry = self._history[self._index]
            self._pending = _Request(self._rev, self._generation,
                                     copy_landmarks(self._landmarks), entry.sim,
                                     manoeuvres=dict(self._manoeuvres))
            self._cond.notify_all()
            out = copy_landmarks(self._landmarks)
        self._notify(self.on_landmarks, out)
        self._notify(self.on_history)

    def set_solver(self, solver: Solver | None) -> None:
        """Replace the solver for the same baseline (e.g. new ARAP iterations); re-solve."""
        self.rebase(self._baseline, solver)

    # waiting / closing
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

    # sessions (the file format: naseview.editing.session)
    def snapshot(self, app: Mapping[str, Any] | None = None,
                 commit_drag: bool = True) -> Session:
        """Everything needed to reopen this editor exactly; ``app`` is stored as the
        session's free-form app state.

        An open drag is committed first (``commit_drag``), or left alone and the last
        committed state taken instead (``commit_drag=False``: a background save never
        splits the surgeon's drag into two undo entries)."""
        with self._lock:
            if self._drag is not None and commit_drag:
                self._commit_locked()
            sim = self._published
            lms = copy_landmarks(self._landmarks if self._drag is None
                                 else self._history[self._index].landmarks)
            history = [copy_landmarks(e.landmarks) for e in self._history]
            plans = [dict(e.manoeuvres) for e in self._history]
            index = self._index
            symmetric = self._symmetric
            manoeuvres = dict(self._manoeuvres)
        saved = (SavedSimulation(sim.V, sim.curves, sim.ad_landmarks, sim.measurements,
                                 sim.surface_landmarks)
                 if landmarks_equal(sim.landmarks, lms) and sim.manoeuvres == manoeuvres
                 else None)
        return Session(self._baseline, lms, history, index, symmetric, saved,
                       dict(app or {}), manoeuvres=manoeuvres, history_manoeuvres=plans)

    def session_json(self, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The ``naseview.session/1`` JSON object of :meth:`snapshot`."""
        return session_to_json(self.snapshot(extra))

    @classmethod
    def from_session(cls, session: Session, solver: Solver | None) -> EditController:
        """A controller in exactly the saved state (the saved mesh is shown as is)."""
        ctl = cls(session.baseline, solver)
        with ctl._lock:
            ctl._restore_locked(session)
        return ctl

    # internals
    def _restore_locked(self, session: Session) -> None:
        """Take the history, landmarks and symmetric flag of ``session``; publish its
        saved simulation, the baseline, or queue a solve."""
        hist = session.history or [session.baseline.landmarks]
        plans = session.history_manoeuvres or [{} for _ in hist]
        self._history = [_Entry(copy_landmarks(h), i, manoeuvres=dict(m))
                         for i, (h, m) in enumerate(zip(hist, plans, strict=True))]
        self._history[0].sim = baseline_simulation(session.baseline)
        self._index = min(max(0, session.history_index), len(self._history) - 1)
        self._rev = len(self._history)
        self._landmarks = copy_landmarks(session.landmarks)
        self._manoeuvres = dict(session.manoeuvres)
        self._symmetric = session.symmetric
        entry = self._history[self._index]
        if not _same_state(entry, self._landmarks, self._manoeuvres):
            self._rev += 1
            entry = _Entry(copy_landmarks(self._landmarks), self._rev,
                           manoeuvres=dict(self._manoeuvres))
            self._history.insert(self._index + 1, entry)
            self._index += 1
        if session.simulation is not None:
            s = session.simulation
            sim = Simulation(entry.revision, 0, copy_landmarks(self._landmarks), s.V,
                             s.curves, s.ad_landmarks, s.measurements,
                             manoeuvres=dict(self._manoeuvres),
                             surface_landmarks=s.surface_landmarks)
            entry.sim = sim
            self._published = sim
        elif not self._manoeuvres and landmarks_equal(self._landmarks,
                                                      session.baseline.landmarks):
            self._published = baseline_simulation(session.baseline)
        else:
            self._submit_locked()

    def _check_landmark(self, landmark: str) -> None:
        if landmark not in self._baseline.landmarks:
            raise KeyError(f"unknown landmark {landmark!r}")

    def _dragged_positions(self, start: Landmarks, landmark: str, p: np.ndarray
                           ) -> Landmarks:
        """Landmarks with ``landmark`` moved to ``p`` (3,) from the drag's ``start``; in
        symmetric mode the partner moves mirrored and a midline landmark keeps its x."""
        d = p - start[landmark]
        new = copy_landmarks(self._landmarks)
        info = LANDMARKS.get(landmark)
        if self._symmetric and info is not None:
            if info.partner is None:
                d[0] = 0.0
            elif info.partner in start:
                new[info.partner] = start[info.partner] + d * MIRROR
        new[landmark] = start[landmark] + d
        return new

    def _clamp_to_limit(self, new: Landmarks, landmark: str) -> None:
        """Pull ``landmark`` and its partner back to :attr:`max_displacement_mm` from
        their baseline positions (in place)."""
        lim = self.max_displacement_mm
        if lim is None:
            return
        info = LANDMARKS.get(landmark)
        base = self._baseline.landmarks
        for k in (landmark, info.partner if info is not None else None):
            if k is None or k not in new or k not in base:
                continue
            dk = new[k] - base[k]
            n = float(np.linalg.norm(dk))
            if n > lim:
                new[k] = base[k] + dk * (lim / n)

    def _submit_locked(self, ready: Simulation | None = None,
                       interactive: bool = False) -> None:
        self._rev += 1
        self._pending = _Request(self._rev, self._generation,
                                 copy_landmarks(self._landmarks), ready, interactive,
                                 dict(self._manoeuvres))
        self._cond.notify_all()

    def _commit_locked(self) -> None:
        """End the open drag: a final (non-interactive) solve and one undo entry."""
        if self._drag is None:
            return
        self._drag = None
        if not _same_state(self._history[self._index], self._landmarks, self._manoeuvres):
            self._submit_locked(interactive=False)
            self._push_locked()

    def _truncate_redo_locked(self) -> None:
        del self._history[self._index + 1:]

    def _push_locked(self, tag: str | None = None) -> None:
        self._truncate_redo_locked()
        entry = _Entry(copy_landmarks(self._landmarks), self._rev,
                       manoeuvres=dict(self._manoeuvres))
        self._last_tag = tag
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
        self._landmarks = copy_landmarks(entry.landmarks)
        self._manoeuvres = dict(entry.manoeuvres)
        self._last_tag = None
        sim = ready or entry.sim
        if sim is not None and sim.generation != self._generation:
            sim = None
        self._rev += 1
        self._min_rev = self._rev
        entry.revision = self._rev
        if sim is not None:
            sim = Simulation(self._rev, self._generation, copy_landmarks(entry.landmarks),
                             sim.V, sim.curves, sim.ad_landmarks, sim.measurements,
                             sim.solve_seconds, sim.warnings,
                             manoeuvres=dict(entry.manoeuvres),
                             surface_landmarks=sim.surface_landmarks)
            entry.sim = sim
        self._pending = _Request(self._rev, self._generation,
                                 copy_landmarks(self._landmarks), sim,
                                 manoeuvres=dict(self._manoeuvres))
        self._cond.notify_all()

    def _notify(self, listeners: list[Callable[..., None]], *args: Any) -> None:
        for cb in list(listeners):
            try:
                cb(*args)
            except Exception:  # a broken view must not break the editor
                log.exception("naseview app listener %r failed", cb)

    # the worker thread
    def _run(self) -> None:
        """Worker loop: take the latest request, solve it, publish it if still current."""
        while (job := self._next_request()) is not None:
            req, solver = job
            sim: Simulation | None = req.ready
            err: str | None = None
            if sim is None and solver is not None:
                sim, err = self._solve(req, solver)
            publish, error_changed = self._publish(req, sim, err)
            if publish and sim is not None:
                self._notify(self.on_simulation, sim)
            if error_changed:
                self._notify(self.on_error, err)
            with self._cond:
                self._busy = False
                self._cond.notify_all()

    def _next_request(self) -> tuple[_Request, Solver | None] | None:
        """Wait for a request and take it (marking the worker busy); None once closed."""
        with self._cond:
            while self._pending is None and not self._closed:
                self._cond.wait()
            if self._closed or self._pending is None:
                return None
            req = self._pending
            self._pending = None
            self._busy = True
            return req, self._solver

    def _solve(self, req: _Request, solver: Solver) -> tuple[Simulation | None, str | None]:
        """Run the solver outside the lock: (simulation, None) or (None, error line)."""
        t0 = time.perf_counter()
        try:
            extra = {"manoeuvres": dict(req.manoeuvres)} if req.manoeuvres else {}
            out = solver(req.landmarks, interactive=req.interactive, **extra)
            V = np.asarray(out.V, dtype=np.float64)
            if V.shape != self._baseline.V.shape or not np.all(np.isfinite(V)):
                raise NaseviewError(
                    f"the solver returned {V.shape} vertices with non-finite or "
                    f"missing values (expected {self._baseline.V.shape})")
            dt = time.perf_counter() - t0
            shown = getattr(out, "surface_landmarks", None)
            sim = Simulation(req.revision, req.generation, req.landmarks, V,
                             dict(out.curves), np.asarray(out.ad_landmarks),
                             dict(out.measurements), dt, tuple(out.warnings), req.interactive,
                             dict(req.manoeuvres),
                             None if shown is None else copy_landmarks(shown))
            self.solve_seconds.append(dt)
            return sim, None
        except Exception as e:  # report, keep serving
            log.error("naseview: solve failed:\n%s", traceback.format_exc())
            return None, (f"Simulation failed ({type(e).__name__}: {e}). The last good "
                          "result is shown; undo, or change the landmark again.")

    def _publish(self, req: _Request, sim: Simulation | None, err: str | None
                 ) -> tuple[bool, bool]:
        """Record the outcome of ``req`` under the lock: (published, error changed).

        A result is published only when it belongs to the current generation and is not
        older than the last undo / redo / reset; a final solve is cached in its entry.
        """
        with self._cond:
            if err is not None:
                self._error = err
                return False, True
            if sim is None or req.generation != self._generation \
                    or req.revision < self._min_rev:
                return False, False
            self._published = sim
            if not sim.interactive:
                for entry in self._history:
                    if entry.revision == req.revision and entry.sim is None:
                        entry.sim = sim
            if self._error is not None:
                self._error = None
                return True, True
            return True, False


def _same_state(entry: _Entry, landmarks: Landmarks, manoeuvres: Manoeuvres) -> bool:
    """True when ``entry`` holds exactly these landmarks and manoeuvre amounts."""
    return entry.manoeuvres == manoeuvres and landmarks_equal(entry.landmarks, landmarks)


def _carry(lms: Landmarks, old: Baseline, new: Baseline) -> Landmarks:
    """``new``'s landmarks plus the displacement of each of ``lms`` from ``old``'s."""
    out = copy_landmarks(new.landmarks)
    for k, v in lms.items():
        if k in out and k in old.landmarks and not np.array_equal(v, old.landmarks[k]):
            out[k] = out[k] + (v - old.landmarks[k])
    return out
