"""Shared fixtures. The ICT Face Model Light is read from ``../shared`` (never copied)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import viser
from helpers import GaussianSolver, ict_baseline

from naseview.app.guard import guarded_viser_server
from naseview.app.serve import NaseviewApp, demo_case_dir, start_app
from naseview.editing.baseline import Baseline
from naseview.editing.solver import NoseEditSolver

REPO = Path(__file__).resolve().parents[1]
SHARED_ICT = REPO.parent / "shared" / "data" / "ict-face-model"

# Point naseview at the shared ICT model unless the caller chose one.
if (SHARED_ICT / "ict_face_light.npz").is_file():
    os.environ.setdefault("NASEVIEW_ICT_MODEL", str(SHARED_ICT / "ict_face_light.npz"))

# Never the real patients' work folder (~/naseview-patients or the user's
# NASEVIEW_WORK_DIR): every test and every server a test starts gets a fresh one unless
# the test sets its own.
os.environ["NASEVIEW_WORK_DIR"] = tempfile.mkdtemp(prefix="naseview-test-work-")


@pytest.fixture(scope="session")
def ict_dir() -> Path:
    """``../shared/data/ict-face-model`` (fails loudly if absent: CI must provide it)."""
    assert (SHARED_ICT / "ict_face_light.npz").is_file(), (
        f"{SHARED_ICT} not found; the tests need ../shared beside the repository")
    return SHARED_ICT


@pytest.fixture()
def data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty user data dir, with NASEVIEW_ICT_MODEL unset."""
    d = tmp_path / "data"
    monkeypatch.setenv("NASEVIEW_DATA_DIR", str(d))
    monkeypatch.delenv("NASEVIEW_ICT_MODEL", raising=False)
    return d


@pytest.fixture(scope="module")
def baseline() -> Baseline:
    """The ICT mean face as an editable baseline (editing tests)."""
    return ict_baseline()


@pytest.fixture(scope="module")
def real_solver_factory(baseline: Baseline) -> Callable[[], NoseEditSolver]:
    return lambda: NoseEditSolver(baseline)


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[viser.ViserServer, NaseviewApp]]:
    """``naseview serve`` of the demo case (photos, mesh, landmarks), as the CLI starts it."""
    server, app = start_app(demo_case_dir(), host="127.0.0.1", port=0, model="generic")
    assert app.wait_ready(120), "the demo case did not open"
    yield server, app
    app.close()
    server.stop()


@pytest.fixture(scope="module")
def ict_served() -> Iterator[tuple[viser.ViserServer, NaseviewApp]]:
    """``(server, app)``: the app on the ICT mean face with its real solver (ARAP), as
    the browser tests drive it."""
    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    app = NaseviewApp(server)
    app.open_baseline(ict_baseline(), case_id="ict-mean")
    assert app.wait_ready(60)
    yield server, app
    app.close()
    server.stop()


@pytest.fixture()
def ict_app(baseline: Baseline, tmp_path: Path
            ) -> Iterator[tuple[viser.ViserServer, NaseviewApp, list[Any]]]:
    """``(server, app, tabs)``: an app on the ICT mean face with the quick test solver
    (``helpers.GaussianSolver``) and its own work folder; headless tabs a test appends to
    ``tabs`` are closed with it."""
    def factory(b: Baseline, params: object, iters: int) -> tuple[Any, list[str], Any]:
        return GaussianSolver(b), ["prn", "al_l", "al_r", "c"], b.nose_ids

    server = guarded_viser_server("127.0.0.1", 0, verbose=False)
    app = NaseviewApp(server, solver_factory=factory, work_dir=tmp_path / "work")
    tabs: list[Any] = []
    try:
        app.open_baseline(baseline, case_id="ict-mean")
        assert app.wait_ready(60)
        yield server, app, tabs
    finally:
        for t in tabs:
            t.close()
        app.close()
        server.stop()
