"""Session files of the live editor: ``naseview.session/1`` JSON that reopens exactly.

A session file holds the baseline as it was when saved (mesh, landmarks, curves,
ad-landmarks, measurements and the full reconstruction, never recomputed), the edit state
(current landmarks, the undo history, symmetric mode), the solved state shown when it was
saved (only the vertices that differ from the baseline are stored) and free-form app state
(source path, parameters). Floats are written with full precision, so a reopened editor
shows the same bits. Files are written atomically (:func:`naseview.fileio.atomic_write_json`).

A session file is validated like ``case.json`` when it is opened: every array has its
shape, every number is finite, every vertex id lies in the mesh and every landmark is one
of the baseline's. The case folder it names (``app.case_dir``, where the photos are) is
stored relative to the session file and must lie in the session file's folder
(:meth:`Session.case_folder`); a session saved beside ``case.json`` finds it there.

A session kept in a patient folder (:mod:`naseview.records`) also carries an optional
``record`` object (:class:`SessionRecord`: the simulation's name, when it was created and
last saved, and the SHA-256 of the ``reconstruction.json`` it was made on); files without
it are read as before.

The format is documented in ``docs/formats.md``; :data:`SESSION_FORMAT` is its ``format``
string.

Example
-------
    save_session("case.session.json", controller, {"case_id": "p1"})
    s = load_session("case.session.json")
    EditController.from_session(s, solver)
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from naseview.editing.baseline import Baseline, Landmarks, Manoeuvres
from naseview.editing.manoeuvres import check_amounts
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_json, read_json, resolve_stored_path, stored_path
from naseview.reconstruction import CASE_DIR_KEY, index_array, numbers_dict, points_array

SESSION_FORMAT = "naseview.session/1"


@dataclass(frozen=True)
class SavedSimulation:
    """The solved state stored in a session (SPEC frame, mm).

    Attributes:
        V: (N, 3) face (the baseline with the stored changed vertices).
        curves: curve name -> (L, 3).
        ad_landmarks: (A, 3).
        measurements: name -> value.
        surface_landmarks: id -> (3,) where the landmarks sit on ``V`` when manoeuvres
            moved them, or None.
    """

    V: np.ndarray
    curves: dict[str, np.ndarray]
    ad_landmarks: np.ndarray
    measurements: dict[str, float]
    surface_landmarks: Landmarks | None = None


MAX_NAME_LENGTH = 80
"""Longest simulation name (characters) a session file may hold."""


@dataclass(frozen=True)
class SessionRecord:
    """The optional ``record`` object of a session kept in a patient folder.

    Attributes:
        name: the simulation's name as the surgeon sees it ("Simulation 2").
        created: when the simulation was started (ISO 8601, local time with offset).
        modified: when it was last saved (ISO 8601).
        reconstruction_sha256: SHA-256 (64 hex digits) of the ``reconstruction.json``
            whose result is the baseline, or None when unknown.
    """

    name: str
    created: str | None = None
    modified: str | None = None
    reconstruction_sha256: str | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``record`` object."""
        return {"name": self.name, "created": self.created, "modified": self.modified,
                "reconstruction_sha256": self.reconstruction_sha256}


def check_name(name: object, where: str = "simulation", key: str = "record.name") -> str:
    """``name`` if it is a simulation name: a string of 1 to :data:`MAX_NAME_LENGTH`
    printable characters, stripped.

    Raises:
        NaseviewError: naming ``where`` and ``key``.
    """
    if not isinstance(name, str):
        raise NaseviewError(f"{where}: key {key!r}: expected a name (text)")
    text = name.strip()
    if not text or len(text) > MAX_NAME_LENGTH or not text.isprintable():
        raise NaseviewError(f"{where}: key {key!r}: a name is 1 to {MAX_NAME_LENGTH} "
                            "printable characters; choose a shorter, plain name")
    return text


def _record(value: object, where: str) -> SessionRecord | None:
    """Parse the optional ``record`` object."""
    if value is None:
        return None
    obj = _object(value, where, "record")
    name = check_name(obj.get("name"), where, "record.name")
    times: list[str | None] = []
    for key in ("created", "modified"):
        t = obj.get(key)
        if t is not None and (not isinstance(t, str) or len(t) > 40):
            raise NaseviewError(f"{where}: key 'record.{key}': expected an ISO 8601 time "
                                "or null")
        times.append(t)
    digest = obj.get("reconstruction_sha256")
    if digest is not None and not (isinstance(digest, str) and len(digest) == 64 and all(
            c in "0123456789abcdef" for c in digest)):
        raise NaseviewError(f"{where}: key 'record.reconstruction_sha256': expected 64 hex "
                            "digits or null")
    return SessionRecord(name, times[0], times[1], digest)


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
        record: name, times and reconstruction of a simulation kept in a patient folder
            (the ``record`` object), or None.
        manoeuvres: current manoeuvre amounts (name -> mm / degrees, non-zero only).
        history_manoeuvres: the manoeuvre amounts of each undo entry (same length as
            ``history``), or None (none in any entry: a file written before manoeuvres).
    """

    baseline: Baseline
    landmarks: Landmarks
    history: list[Landmarks]
    history_index: int
    symmetric: bool
    simulation: SavedSimulation | None
    app: dict[str, Any]
    path: Path | None = None
    record: SessionRecord | None = None
    manoeuvres: Manoeuvres = field(default_factory=dict)
    history_manoeuvres: list[Manoeuvres] | None = None

    def case_folder(self) -> Path | None:
        """The case folder holding the photos: ``app.case_dir`` resolved against the
        session file's folder, else that folder itself when it holds ``case.json``, else
        None (no photos).

        Raises:
            NaseviewError: ``app.case_dir`` points outside the session file's folder
                (absolute elsewhere, ``..`` or a symlink leaving it), naming the file and
                the key.
        """
        if self.path is None:
            return None
        folder = Path(os.path.realpath(self.path)).parent
        value = self.app.get(CASE_DIR_KEY)
        if value is None:
            return folder if (folder / "case.json").is_file() else None
        return resolve_stored_path(value, folder, folder, self.path, f"app.{CASE_DIR_KEY}",
                                   allow_absolute=True)


class SessionSource(Protocol):
    """What :func:`save_session` saves: an editor that can snapshot itself
    (:class:`naseview.editing.controller.EditController`)."""

    def snapshot(self, app: Mapping[str, Any] | None = None) -> Session: ...


def _simulation_json(sim: SavedSimulation, base: Baseline) -> dict[str, Any]:
    """The ``edit.simulation`` object: only the vertices that differ from the baseline."""
    changed = np.flatnonzero(np.any(sim.V != base.V, axis=1))
    out: dict[str, Any] = {
        "changed_vertex_ids": changed.tolist(),
        "changed_vertices": sim.V[changed].tolist(),
        "curves": {k: np.asarray(c).reshape(-1, 3).tolist() for k, c in sim.curves.items()},
        "ad_landmarks": np.asarray(sim.ad_landmarks).reshape(-1, 3).tolist(),
        "measurements": {k: float(v) for k, v in sim.measurements.items()},
    }
    if sim.surface_landmarks is not None:
        out["surface_landmarks"] = {k: np.asarray(v).tolist()
                                    for k, v in sim.surface_landmarks.items()}
    return out


def _app_json(app: Mapping[str, Any], folder: Path | None) -> dict[str, Any]:
    """The ``app`` object to store: ``case_dir`` relative to the session's ``folder``
    (None when there is no folder or the case does not lie in it: an absolute path is
    never written)."""
    out = dict(app)
    case_dir = out.get(CASE_DIR_KEY)
    if case_dir is not None:
        out[CASE_DIR_KEY] = (stored_path(case_dir, folder, folder) if folder is not None
                             and isinstance(case_dir, (str, os.PathLike)) else None)
    return out


def session_to_json(session: Session, folder: str | os.PathLike[str] | None = None
                    ) -> dict[str, Any]:
    """The ``naseview.session/1`` JSON object of ``session`` (``path`` is not stored).

    Args:
        session: what to store.
        folder: the folder the file will be written to: ``app.case_dir`` is stored
            relative to it if the case lies inside it, else (and without a folder, e.g. a
            download) left out. No absolute path is ever written.
    """
    base = session.baseline
    baseline = base.to_json()
    baseline["reconstruction"].pop(CASE_DIR_KEY, None)  # relative to another folder
    head: dict[str, Any] = {"format": SESSION_FORMAT, "units": "mm"}
    if session.record is not None:
        head["record"] = session.record.to_json()
    return {
        **head,
        "baseline": baseline,
        "edit": {
            "landmarks": {k: v.tolist() for k, v in session.landmarks.items()},
            "history": [{k: v.tolist() for k, v in h.items()} for h in session.history],
            "history_index": session.history_index,
            "symmetric": session.symmetric,
            "manoeuvres": dict(session.manoeuvres),
            "history_manoeuvres": (None if session.history_manoeuvres is None
                                   else [dict(m) for m in session.history_manoeuvres]),
            "simulation": (None if session.simulation is None
                           else _simulation_json(session.simulation, base)),
        },
        "app": _app_json(session.app, None if folder is None else Path(folder)),
    }


def save_session(path: str | os.PathLike[str], controller: SessionSource,
                 app: Mapping[str, Any] | None = None) -> Path:
    """Write the controller's state as a ``naseview.session/1`` JSON file, atomically.

    Floats are written with full precision, so :func:`load_session` restores the same
    bits.
    """
    path = Path(path)
    return atomic_write_json(path, session_to_json(controller.snapshot(app), path.parent))


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


def _object(value: object, where: str, key: str) -> Mapping[str, Any]:
    """``value``, which must be a JSON object."""
    if not isinstance(value, Mapping):
        raise NaseviewError(f"{where}: key {key!r}: expected an object; save the session "
                            "again from the app")
    return value


def _landmarks(value: object, baseline: Baseline, where: str, key: str) -> Landmarks:
    """id -> finite (3,) positions, every id a landmark of the baseline."""
    out: Landmarks = {}
    for lid, p in _object(value, where, key).items():
        if lid not in baseline.landmarks:
            raise NaseviewError(f"{where}: key '{key}.{lid}': not a landmark of the "
                                "baseline")
        out[lid] = points_array([p], where, f"{key}.{lid}", 1)[0]
    return out


def _saved_simulation(value: object, baseline: Baseline, where: str) -> SavedSimulation:
    """Parse ``edit.simulation``: the baseline mesh with the stored changed vertices (ids
    in the mesh, finite coordinates), curves, ad-landmarks and measurements."""
    key = "edit.simulation"
    s = _object(value, where, key)
    V = baseline.V.copy()
    ids = index_array(s.get("changed_vertex_ids", []), where, f"{key}.changed_vertex_ids",
                      len(V))
    V[ids] = points_array(s.get("changed_vertices", []), where, f"{key}.changed_vertices",
                          len(ids))
    curves = {k: points_array(c, where, f"{key}.curves.{k}")
              for k, c in _object(s.get("curves", {}), where, f"{key}.curves").items()}
    shown = s.get("surface_landmarks")
    return SavedSimulation(
        V, curves, points_array(s.get("ad_landmarks", []), where, f"{key}.ad_landmarks"),
        numbers_dict(s.get("measurements", {}), where, f"{key}.measurements"),
        None if shown is None else _landmarks(shown, baseline, where,
                                              f"{key}.surface_landmarks"))


def _plans(edit: Mapping[str, Any], n_history: int, where: str
           ) -> tuple[Manoeuvres, list[Manoeuvres] | None]:
    """``edit.manoeuvres`` (current amounts) and ``edit.history_manoeuvres`` (one per
    history entry), each checked against the manoeuvres' clinical ranges."""
    value = edit.get("manoeuvres")
    current = {} if value is None else check_amounts(value, f"{where}: key 'edit.manoeuvres'")
    hist = edit.get("history_manoeuvres")
    if hist is None:
        return current, None
    if not isinstance(hist, list) or len(hist) != n_history:
        raise NaseviewError(f"{where}: key 'edit.history_manoeuvres': expected a list of "
                            f"{n_history} objects (one per edit.history entry); save the "
                            "session again from the app")
    plans = [check_amounts(m, f"{where}: key 'edit.history_manoeuvres.{i}'")
             for i, m in enumerate(hist)]
    if plans and plans[0]:
        raise NaseviewError(f"{where}: key 'edit.history_manoeuvres.0': the first entry is "
                            "the reconstruction itself and has no manoeuvres; expected {}")
    return current, plans


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
    baseline = Baseline.from_json(_object(obj["baseline"], where, "baseline"), where)
    edit = _object(obj["edit"], where, "edit")
    lms = _landmarks(edit.get("landmarks", {k: v.tolist() for k, v in
                                            baseline.landmarks.items()}),
                     baseline, where, "edit.landmarks")
    hist = edit.get("history", [])
    if not isinstance(hist, list):
        raise NaseviewError(f"{where}: key 'edit.history': expected a list of landmark "
                            "objects")
    history = [_landmarks(h, baseline, where, f"edit.history.{i}")
               for i, h in enumerate(hist)]
    index = edit.get("history_index", max(len(history) - 1, 0))
    last = max(len(history) - 1, 0)
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= last:
        raise NaseviewError(f"{where}: key 'edit.history_index': {index!r} is outside "
                            f"[0, {last}]; expected an entry of edit.history")
    symmetric = edit.get("symmetric", False)
    if not isinstance(symmetric, bool):
        raise NaseviewError(f"{where}: key 'edit.symmetric': expected true or false")
    s = edit.get("simulation")
    saved = None if s is None else _saved_simulation(s, baseline, where)
    app = dict(_object(obj.get("app", {}), where, "app"))
    case_dir = app.get(CASE_DIR_KEY)
    if case_dir is not None and not isinstance(case_dir, str):
        raise NaseviewError(f"{where}: key 'app.{CASE_DIR_KEY}': expected a path relative "
                            "to the session file, or null")
    record = _record(obj.get("record"), where)
    manoeuvres, plans = _plans(edit, len(history), where)
    return Session(baseline, lms, history, index, symmetric, saved, app, path, record,
                   manoeuvres, plans)
