"""Shared fixtures. The ICT Face Model Light is read from ``../shared`` (never copied)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import setup_cache
import viser
from helpers import GaussianSolver, ict_baseline, wait_for

import naseview.app.face_look
import naseview.report.sources
from naseview.app.guard import guarded_viser_server
from naseview.app.naseview_app import NaseviewApp, demo_case_dir
from naseview.app.serve import start_app
from naseview.editing.baseline import Baseline
from naseview.editing.solver import NoseEditSolver

REPO = Path(__file__).resolve().parents[1]
collect_ignore = ["subprocess_hook"]  # a subprocess's sitecustomize, not for --doctest-modules
SHARED_ICT = REPO.parent / "shared" / "data" / "ict-face-model"

# Point naseview at the shared ICT model unless the caller chose one.
if (SHARED_ICT / "ict_face_light.npz").is_file():
    os.environ.setdefault("NASEVIEW_ICT_MODEL", str(SHARED_ICT / "ict_face_light.npz"))

# Never the real patients' work folder (~/naseview-patients or the user's
# NASEVIEW_WORK_DIR): every test and every server a test starts gets a fresh one unless
# the test sets its own.
os.environ["NASEVIEW_WORK_DIR"] = tempfile.mkdtemp(prefix="naseview-test-work-")


BROWSER_FILES = "*_browser.py"
"""Where the browser tests are (marked ``browser``), and only they."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The browser test files first (together they take the longest), the rest in their
    order: xdist hands its work out in this order (``--no-loadscope-reorder``), so the
    short files at the end even the workers out."""
    for item in items:
        if bool(item.get_closest_marker("browser")) != item.path.match(BROWSER_FILES):
            raise pytest.UsageError(f"{item.nodeid}: browser tests (marked 'browser') "
                                    f"live in files named {BROWSER_FILES}, and only they")
    items.sort(key=lambda item: not item.path.match(BROWSER_FILES))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """``--dist loadfile`` (pyproject's addopts): xdist's workers take whole test files
    (a file's module fixtures are made once), except that the browser test files are one
    unit: they run one after another on one worker while the others run the rest. Each
    holds a Chromium rendering the scene in software (about a core of its own); two at
    once slow each other and the other workers down more than they gain."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class BrowserFilesTogether(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            file = super()._split_scope(nodeid)
            return "browser tests" if Path(file).match(BROWSER_FILES) else file

    return BrowserFilesTogether(config, log)


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


@pytest.fixture(scope="session", autouse=True)
def bake_once() -> Iterator[None]:
    """The app's and the report's texture bake (``skin_texture``) runs once per version of
    the code and set of inputs (``setup_cache.cached_skin_texture``), not in every test
    that opens the same reconstruction with the same photos (a bake takes seconds). The
    cache's key is taken here, before any test changes the environment."""
    setup_cache.cache_dir()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(naseview.app.face_look, "skin_texture", setup_cache.cached_skin_texture)
        mp.setattr(naseview.report.sources, "skin_texture",
                   setup_cache.cached_skin_texture)
        yield


@pytest.fixture(scope="session")
def demo_served() -> Iterator[tuple[viser.ViserServer, NaseviewApp]]:
    """``naseview serve`` of the demo case (photos, mesh, landmarks), as the CLI starts it,
    once per test session; tests take it through ``served``."""
    server, app = start_app(demo_case_dir(), host="127.0.0.1", port=0, model="generic")
    assert app.wait_ready(120), "the demo case did not open"
    yield server, app
    app.close()
    server.stop()


def _demo_unchanged(app: NaseviewApp) -> None:
    """Assert that the shared demo app is as it opened: its tabs gone, no edit."""
    wait_for(lambda: not app.screens, 30, "the previous test's tabs to go")
    ctl = app.controller
    assert ctl is not None and ctl.wait_idle(30)
    assert ctl.history_length == 1 and not ctl.is_edited(), (
        "a test edited the shared demo app (served); give it a fresh app")


@pytest.fixture()
def served(demo_served: tuple[viser.ViserServer, NaseviewApp]
           ) -> Iterator[tuple[viser.ViserServer, NaseviewApp]]:
    """``(server, app)``: the demo case served (``demo_served``), shared by the tests that
    only read it: each starts with no tab open and no edit, and must leave it so."""
    _demo_unchanged(demo_served[1])
    yield demo_served
    _demo_unchanged(demo_served[1])


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
