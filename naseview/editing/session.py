"""Session files of the live editor: ``naseview.session/1`` JSON that reopens exactly.

A session file holds the baseline as it was when saved (mesh, landmarks, curves,
ad-landmarks, measurements and the full reconstruction, never recomputed), the edit state
(current landmarks, the undo history, symmetric mode), the solved state shown when it was
saved (only the vertices that differ from the baseline are stored) and free-form app state
(source path, parameters). Floats are written with full precision, so a reopened editor
shows the same bits. Files are written atomically (:func:`naseview.fileio.atomic_write_json`).

The format is documented in ``docs/formats.md``; :data:`SESSION_FORMAT` is its ``format``
string.

Example
-------
>>> save_session("case.session.json", controller, {"case_id": "p1"})   # doctest: +SKIP
>>> s = load_session("case.session.json")                             # doctest: +SKIP
>>> EditController.from_session(s, solver)                            # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from naseview.editing.baseline import Baseline, Landmarks, copy_landmarks
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_json, read_json

SESSION_FORMAT = "naseview.session/1"


@dataclass(frozen=True)
class SavedSimulation:
    """The solved state stored in a session (SPEC frame, mm).

    Attributes:
        V: (N, 3) face (the baseline with the stored changed vertices).
        curves: curve name -> (L, 3).
        ad_landmarks: (A, 3).
        measurements: name -> value.
    """

    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]


@dataclass(frozen=True)
class Session:
    """A parsed session file (or a snapshot of an editor about to be saved).

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


class SessionSource(Protocol):
    """What :func:`save_session` saves: an editor that can snapshot itself
    (:class:`naseview.editing.controller.EditController`)."""

    def snapshot(self, app: Mapping[str, Any] | None = None) -> Session: ...


def _simulation_json(sim: SavedSimulation, base: Baseline) -> dict[str, Any]:
    """The ``edit.simulation`` object: only the vertices that differ from the baseline."""
    changed = np.flatnonzero(np.any(sim.V != base.V, axis=1))
    return {
        "changed_vertex_ids": changed.tolist(),
        "changed_vertices": sim.V[changed].tolist(),
        "curves": {k: np.asarray(c).reshape(-1, 3).tolist() for k, c in sim.curves.items()},
        "ad_landmarks": np.asarray(sim.ad_landmarks).reshape(-1, 3).tolist(),
        "measurements": {k: float(v) for k, v in sim.measurements.items()},
    }


def session_to_json(session: Session) -> dict[str, Any]:
    """The ``naseview.session/1`` JSON object of ``session`` (``path`` is not stored)."""
    base = session.baseline
    return {
        "format": SESSION_FORMAT,
        "units": "mm",
        "baseline": base.to_json(),
        "edit": {
            "landmarks": {k: v.tolist() for k, v in session.landmarks.items()},
            "history": [{k: v.tolist() for k, v in h.items()} for h in session.history],
            "history_index": session.history_index,
            "symmetric": session.symmetric,
            "simulation": (None if session.simulation is None
                           else _simulation_json(session.simulation, base)),
        },
        "app": dict(session.app),
    }


def save_session(path: str | os.PathLike[str], controller: SessionSource,
                 app: Mapping[str, Any] | None = None) -> Path:
    """Write the controller's state as a ``naseview.session/1`` JSON file, atomically.

    Floats are written with full precision, so :func:`load_session` restores the same
    bits.
    """
    return atomic_write_json(path, session_to_json(controller.snapshot(app)))


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


def _saved_simulation(s: Mapping[str, Any], baseline: Baseline) -> SavedSimulation:
    """Parse ``edit.simulation``: the baseline mesh with the stored changed vertices."""
    V = baseline.V.copy()
    ids = np.asarray(s.get("changed_vertex_ids", []), dtype=np.int64)
    if ids.size:
        V[ids] = np.asarray(s["changed_vertices"], dtype=np.float64).reshape(-1, 3)
    return SavedSimulation(
        V, {k: np.asarray(c, dtype=np.float64).reshape(-1, 3)
            for k, c in s.get("curves", {}).items()},
        np.asarray(s.get("ad_landmarks", []), dtype=np.float64).reshape(-1, 3),
        {k: float(v) for k, v in s.get("measurements", {}).items()})


def _check_header(obj: Mapping[str, Any], where: str) -> None:
    """The ``format`` string and the two required keys."""
    if obj.get("format") != SESSION_FORMAT:
        raise NaseviewError(f"{where}: key 'format': expected {SESSION_FORMAT!r}, found "
                            f"{obj.get('format')!r}; open a file saved by 'Save session'")
    if "baseline" not in obj or "edit" not in obj:
        raise NaseviewError(f"{where}: keys 'baseline' and 'edit' are required; save the "
                            "session again from the app")


def session_from_json(obj: Mapping[str, Any], where: str = "session",
                      path: Path | None = None) -> Session:
    """Parse a ``naseview.session/1`` object; ``where`` names the file in errors.

    Raises:
        NaseviewError: wrong format, a key is missing / malformed, or an edited landmark
            is not a landmark of the baseline.
    """
    _check_header(obj, where)
    baseline = Baseline.from_json(obj["baseline"], where)
    edit = obj["edit"]
    try:
        lms = copy_landmarks(edit.get("landmarks", baseline.landmarks))
        history = [copy_landmarks(h) for h in edit.get("history", [])]
        index = int(edit.get("history_index", len(history) - 1))
        symmetric = bool(edit.get("symmetric", False))
        s = edit.get("simulation")
        saved = None if s is None else _saved_simulation(s, baseline)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError):
        raise NaseviewError(f"{where}: key 'edit': malformed landmark or mesh arrays; save "
                            "the session again from the app") from None
    unknown = [k for k in lms if k not in baseline.landmarks]
    if unknown:
        raise NaseviewError(f"{where}: key 'edit.landmarks.{unknown[0]}': not a landmark "
                            "of the baseline")
    return Session(baseline, lms, history, index, symmetric, saved,
                   dict(obj.get("app", {})), path)
