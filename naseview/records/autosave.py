"""Autosave of a simulation: every committed edit is written to the patient's folder.

:class:`Autosave` listens to an :class:`~naseview.editing.controller.EditController`'s
``on_history`` (end of a drag, undo, redo, reset, symmetric toggle, several landmarks
moved, a rebase). The listener only counts the change and wakes a worker thread; the
worker waits until :attr:`Autosave.delay` seconds pass without another change (a burst
of undos is one write), waits for the solve to finish (so the file holds the mesh on
screen), and writes the session file ``WORK/<id>/simulations/<slug>.json`` atomically
(:func:`naseview.fileio.atomic_write_bytes`: a crash mid-write leaves the previous file).
A write is a compare-and-swap under :func:`naseview.fileio.folder_lock` of the
simulations folder: if the file changed since this window last wrote or read it (another
tab's server, another window), nothing is written and the window is told in one line.
Nothing is written during a drag; a state equal to the one last written is not written
again. A parameter change is written as soon as it is committed, without the debounce:
the controller rebased on the new reconstruction (a new ``generation``) is saved at once,
with the reconstruction's SHA-256 given by :meth:`Autosave.set_reconstruction` (which
waits for that rebase, so a file never pairs the new SHA-256 with the old baseline).
A failed write (disk full) is kept as :attr:`Autosave.error` (one line) and sent to
``on_error``; the next change tries again. :meth:`Autosave.close` writes what is pending.

Example
-------
    auto = Autosave(folders, "p1", "simulation-1", controller, name="Simulation 1",
                    reconstruction_sha256=saved.sha256)
    ...                          # the surgeon drags, undoes, toggles symmetric mode
    auto.close()                 # on closing the patient: the last state is on disk
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from naseview.editing.controller import EditController
from naseview.editing.session import Session, SessionRecord, check_name, session_to_json
from naseview.errors import NaseviewError
from naseview.fileio import atomic_write_bytes, folder_lock, one_line
from naseview.intake.patients import PatientFolders
from naseview.records.patient import now_iso
from naseview.records.simulations import session_bytes

log = logging.getLogger(__name__)

DEFAULT_DELAY = 0.5
"""Seconds without a change before the simulation is written."""


class Autosave:
    """Keeps one simulation file up to date with a controller (module docstring).

    Args:
        folders: the work folder layout.
        patient_id: the patient; slug: the simulation (``<slug>.json``).
        controller: the editor whose committed changes are saved.
        name: the simulation's name; created: when it was started (default now).
        reconstruction_sha256: SHA-256 of the ``reconstruction.json`` the controller's
            baseline is (:class:`~naseview.records.patient.SavedReconstruction`).
        app_state: called on the worker thread for the session's ``app`` object
            (parameters, face model...); default none.
        delay: debounce, seconds without a change before writing.
        on_disk: the file already holds the controller's current state (just created or
            opened): it is not written again until something changes.
    """

    def __init__(self, folders: PatientFolders, patient_id: str, slug: str,
                 controller: EditController, *, name: str, created: str | None = None,
                 reconstruction_sha256: str | None = None,
                 app_state: Callable[[], Mapping[str, Any]] | None = None,
                 delay: float = DEFAULT_DELAY, on_disk: bool = False) -> None:
        self.folders = folders
        self.patient_id = patient_id
        self.slug = slug
        self.path: Path = folders.inside(patient_id, folders.simulation_file(patient_id,
                                                                             slug))
        self.controller = controller
        self.delay = float(delay)
        self._record = SessionRecord(check_name(name), created or now_iso(), None,
                                     reconstruction_sha256)
        self._next_sha: tuple[int, str | None] | None = None
        """(controller generation when it was set, SHA-256) of a reconstruction the
        controller is about to be rebased on (:meth:`set_reconstruction`)."""
        self._written_generation = controller.generation
        self._app_state = app_state
        self._cond = threading.Condition()
        self._save_lock = threading.Lock()
        self._changes = 0           # changes seen (the listener counts)
        self._saved_changes = 0     # changes the last write covered
        self._last_key: str | None = None
        self._closed = False
        self._failed = False
        self.saves = 0
        """Files written so far."""
        self.error: str | None = None
        """The last failed write (one line), None after a successful one."""
        self.on_saved: list[Callable[[Path], None]] = []
        self.on_error: list[Callable[[str], None]] = []
        if on_disk:
            self._last_key = self._state(self._record)[2]
        self._stamp = _file_stamp(self.path)
        """The file as this window last wrote or read it: another window's (or another
        server's) write since then is refused, never silently overwritten."""
        controller.on_history.append(self._changed)
        self._worker = threading.Thread(target=self._run, name="naseview-autosave",
                                        daemon=True)
        self._worker.start()

    @property
    def name(self) -> str:
        return self._record.name

    @property
    def reconstruction_sha256(self) -> str | None:
        return self._record.reconstruction_sha256

    @property
    def closed(self) -> bool:
        """:meth:`close` was called."""
        return self._closed

    @property
    def pending(self) -> bool:
        """A change is not on disk yet."""
        with self._cond:
            return self._changes != self._saved_changes or self._failed

    def changed(self) -> None:
        """Something to save (the ``on_history`` listener; call it for other changes,
        e.g. the app state). Returns at once."""
        self._changed()

    def _changed(self) -> None:
        with self._cond:
            self._changes += 1
            self._cond.notify_all()

    def rename(self, name: str) -> None:
        """A new name for this simulation, written with the next save (now)."""
        with self._cond:
            self._record = dataclasses.replace(self._record, name=check_name(name))
            self._last_key = None
        self._changed()
        self.flush()

    def set_reconstruction(self, sha256: str | None) -> None:
        """The controller is about to be rebased on a new reconstruction (its SHA-256,
        just saved): recorded with the first save after the controller's ``generation``
        moves on (the rebase), which is written without waiting for the debounce. Until
        then saves keep the old SHA-256, which goes with the baseline they hold."""
        with self._cond:
            self._next_sha = (self.controller.generation, sha256)
        self._changed()

    def _record_now(self) -> tuple[SessionRecord, int]:
        """(the record to write, the controller's generation it goes with); under
        ``_cond``. A pending :meth:`set_reconstruction` applies once the rebase is done."""
        gen = self.controller.generation
        if self._next_sha is not None and gen != self._next_sha[0]:
            self._record = dataclasses.replace(self._record,
                                               reconstruction_sha256=self._next_sha[1])
            self._next_sha = None
            self._last_key = None
        return self._record, gen

    # the worker
    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed and self._changes == self._saved_changes:
                    self._cond.wait()
                if self._closed:
                    return
                seen = self._changes
                deadline = time.monotonic() + self.delay
                while not self._closed and not self._rebased():
                    left = deadline - time.monotonic()
                    if left <= 0:
                        break
                    self._cond.wait(left)
                    if self._changes != seen and not self._rebased():  # wait again
                        seen = self._changes
                        deadline = time.monotonic() + self.delay
                if self._closed:
                    return
            if not self._save():
                with self._cond:  # a drag is open: its end is the next change
                    while not self._closed and self._changes == seen:
                        self._cond.wait()

    def _rebased(self) -> bool:
        """The controller was rebased since the last write (a parameter change): it is
        written at once."""
        return self.controller.generation != self._written_generation

    def _save(self, timeout: float = 30.0, during_drag: bool = False) -> bool:
        """Write the current state if it changed. False when a drag is open (nothing is
        written: its end triggers the next save), unless ``during_drag`` (closing: the
        open drag is committed and written)."""
        with self._save_lock:
            ctl = self.controller
            if ctl.dragging is not None and not during_drag:
                return False
            ctl.wait_idle(timeout)
            with self._cond:
                upto = self._changes
                record, generation = self._record_now()
            if ctl.dragging is not None and not during_drag:  # begun while solving
                return False
            try:
                obj, key = self._state(record, commit_drag=during_drag)[1:]
                if key != self._last_key:
                    out: dict[str, Any] = {"format": obj["format"], "units": obj["units"],
                                           "record": dataclasses.replace(
                                               record, modified=now_iso()).to_json()}
                    out.update(obj)
                    data = session_bytes(out)
                    with folder_lock(self.path.parent):  # compare and swap, across servers
                        if _file_stamp(self.path) != self._stamp:
                            raise NaseviewError(
                                f"{self.path}: changed by another naseview window since "
                                "this one opened it; not overwritten (the other edits are "
                                "kept). Reopen the simulation, or duplicate it to keep both")
                        atomic_write_bytes(self.path, data)
                        self._stamp = _file_stamp(self.path)
                    self.saves += 1
                    self._last_key = key
                    self._notify_saved()
                self._written_generation = generation
                self.error = None
            except Exception as e:  # noqa: BLE001 - a failed save never stops the editor
                msg = str(e) if isinstance(e, NaseviewError) else (
                    f"{self.path}: cannot save the simulation ({one_line(e)}); the "
                    "previous save is unchanged")
                log.warning("autosave: %s", msg)
                self.error = msg
                with self._cond:  # tried again at the next change or flush
                    self._saved_changes = max(self._saved_changes, upto)
                    self._failed = True
                for fn in list(self.on_error):
                    try:
                        fn(msg)
                    except Exception:  # noqa: BLE001
                        log.exception("autosave on_error listener failed")
                return True
            with self._cond:
                self._saved_changes = max(self._saved_changes, upto)
                self._failed = False
                self._cond.notify_all()
            return True

    def _state(self, record: SessionRecord, commit_drag: bool = False
               ) -> tuple[Session, dict[str, Any], str]:
        """The controller's snapshot (an open drag committed only when ``commit_drag``),
        its session JSON and the key that tells whether it differs from the last write
        (edits, app state, record, baseline generation)."""
        app = dict(self._app_state()) if self._app_state is not None else {}
        app.pop("case_dir", None)  # the patient folder says where the case is
        snap = self.controller.snapshot(app, commit_drag=commit_drag)
        obj = session_to_json(snap)
        key = json.dumps([self.controller.generation, record.to_json(), obj["edit"],
                          obj["app"]], default=str)
        return snap, obj, key

    def _notify_saved(self) -> None:
        for fn in list(self.on_saved):
            try:
                fn(self.path)
            except Exception:  # noqa: BLE001
                log.exception("autosave on_saved listener failed")

    def flush(self, timeout: float = 30.0, during_drag: bool = False) -> bool:
        """Write now what is pending, on the caller's thread (an open drag is written only
        ``during_drag``, committing it). Returns True when nothing is pending afterwards."""
        if self.pending:
            self._save(timeout, during_drag)
        return not self.pending

    def close(self, timeout: float = 30.0) -> bool:
        """Stop listening, write what is pending, stop the worker. Returns
        :meth:`flush`'s result."""
        with self._cond:
            if self.controller.on_history.count(self._changed):
                self.controller.on_history.remove(self._changed)
            self._closed = True
            self._cond.notify_all()
        self._worker.join(timeout=5.0)
        return self.flush(timeout, during_drag=True)


__all__ = ["DEFAULT_DELAY", "Autosave"]


def _file_stamp(path: Path) -> tuple[int, int, int] | None:
    """(inode, size, modification time in ns) of ``path``, or None when it is absent."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return (st.st_ino, st.st_size, st.st_mtime_ns)
