"""``naseview serve``: the entry point of the browser app (viser) around an
:class:`~naseview.editing.controller.EditController`.

:func:`start_app` starts the guarded server and the app
(:class:`naseview.app.naseview_app.NaseviewApp`), which opens a case directory
(reconstructed in the background by the pipeline, stages 1-3 of the paper, with progress
in every tab), a reconstruction directory
(``reconstruction.json`` + ``face.ply`` + ``nose.ply``) or a session file, and serves every
browser tab that connects. The case, its one editor (the patient's simulation) and the
background jobs are shared; each tab is a :class:`~naseview.app.screen.Screen` with its
own panels (:mod:`naseview.app.panels`), scene (:mod:`naseview.app.scene`), camera and
patient mode, so every tab sees the same simulation and each other's edits, never each
other's view. Dragging a landmark re-runs stage 3's ARAP deformation (paper §3.4) through
:mod:`naseview.editing`. ``naseview serve`` opens the page in the browser unless
``--no-browser``; ``--new`` opens nothing and starts every tab on the new-patient page.

Security: binds 127.0.0.1 unless ``--host`` says otherwise; the server
(:func:`naseview.app.guard.guarded_viser_server`) answers only its own page on its own host
names (another site's page, a DNS-rebinding name: 403) and refuses share-tunnel requests
whatever a client sends.
"""

from __future__ import annotations

import argparse
import logging
import signal
import time
import webbrowser
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import viser

from naseview.app.guard import guarded_viser_server
from naseview.app.memory import limit_malloc_arenas
from naseview.app.naseview_app import NaseviewApp, SolverFactory
from naseview.errors import NaseviewError

log = logging.getLogger(__name__)

SHUTDOWN_WAIT_S = 60.0
"""Ctrl-C: how long ``naseview serve`` waits for a running reconstruction to finish."""


def start_app(path: Path | None, host: str = "127.0.0.1", port: int = 8080,
              model: str | None = None,
              solver_factory: SolverFactory | None = None,
              new_patient: bool = False) -> tuple[viser.ViserServer, NaseviewApp]:
    """Start the server and open ``path`` (``None``: the bundled demo case); returns
    ``(server, app)`` (non-blocking). With ``new_patient`` and no ``path`` nothing is
    opened: every tab starts on the new-patient page.

    Raises:
        NaseviewError: ``host``:``port`` cannot be listened on (busy port, port out of
            range, an address that is not this computer's).
    """
    limit_malloc_arenas()            # a tab's memory is reused by the next (app.memory)
    server = guarded_viser_server(host, port, verbose=False)
    try:
        app = NaseviewApp(server, model=model, solver_factory=solver_factory)
        app.start_new_patient = new_patient
        if path is not None or not new_patient:
            app.open(path)
        else:
            app.set_status("**New patient**: upload the four photos (the two "
                           "obliques optional), then mark the landmarks.")
    except BaseException:
        server.stop()
        raise
    return server, app


def open_browser(address: str) -> bool:
    """Open ``address`` (this server's own page) in the user's browser; False (and a
    line saying so) when no browser could be started."""
    try:
        opened = webbrowser.open(address)
    except Exception as e:  # a broken $BROWSER must not stop the server
        log.debug("naseview: webbrowser failed: %s", e)
        opened = False
    if not opened:
        print(f"naseview: could not open a browser; open {address} yourself", flush=True)
    return bool(opened)


def serve_command(args: argparse.Namespace) -> int:
    """``naseview serve [PATH] [--host H] [--port P] [--model M] [--new] [--no-browser]``:
    opens the page in the browser (unless ``--no-browser``) and blocks until Ctrl-C."""
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    host = str(getattr(args, "host", "127.0.0.1") or "127.0.0.1")
    port = int(getattr(args, "port", 8080))
    path = getattr(args, "path", None)
    if path is not None and not Path(path).exists():  # fail before a server starts
        raise NaseviewError(f"{path}: not found; pass a case directory (SPEC §3), a "
                            "`naseview reconstruct` output directory or a session file")
    new = bool(getattr(args, "new", False))
    server, app = start_app(path, host, port, getattr(args, "model", None), new_patient=new)
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    address = f"http://{shown}:{server.get_port()}/"
    what = app.source if app.source is not None else "the new-patient page"
    print(f"naseview: serving {what} at {address}", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"naseview: warning: bound to {host}; other computers on the network can open "
              "this page (patient data)", flush=True)
    if not getattr(args, "no_browser", False):
        open_browser(address)
    previous = _stop_on_signals()
    try:
        print("naseview: press Ctrl-C to stop", flush=True)
        while True:
            time.sleep(1.0)
    except (KeyboardInterrupt, _Stop):
        pass
    finally:
        _ignore_signals()  # a second SIGTERM / SIGHUP must not cut the last save short
        # a reconstruction or solve still in native code when the interpreter exits
        # aborts the process ("terminate called without an active exception"): let it end
        if app.source is not None or app.controller is not None:  # a job ever ran
            app.wait_ready(SHUTDOWN_WAIT_S)
        app.close()
        server.stop()
        _restore_signals(previous)
    return 0


STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))
"""Signals that stop ``naseview serve`` like Ctrl-C (SIGINT): ``kill``, closing the
terminal, logging out. Each ends the wait loop, so the open simulation's pending save is
written (:meth:`NaseviewApp.close`) before the process exits."""


class _Stop(Exception):
    """Raised in the main thread by a stop signal (:data:`STOP_SIGNALS`)."""


def _raise_stop(signum: int, frame: object) -> None:
    raise _Stop(signal.Signals(signum).name)


def _stop_on_signals() -> dict[int, Any]:
    """Install :func:`_raise_stop` for :data:`STOP_SIGNALS`; the previous handlers."""
    previous: dict[int, Any] = {}
    for sig in STOP_SIGNALS:
        try:
            previous[sig] = signal.signal(sig, _raise_stop)
        except ValueError:  # not the main thread (embedded): the caller stops us
            break
    return previous


def _ignore_signals() -> None:
    for sig in STOP_SIGNALS:
        try:
            signal.signal(sig, signal.SIG_IGN)
        except ValueError:
            break


def _restore_signals(previous: Mapping[int, Any]) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


__all__ = ["SHUTDOWN_WAIT_S", "STOP_SIGNALS", "open_browser", "serve_command", "start_app"]
