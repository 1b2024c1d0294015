"""A patient's work is kept (issue 14, item 2), wired into the app, with a real viser
server and headless tabs (no browser): a case opened is saved in the patient's folder
(reconstruction + an autosaved simulation); opened again it is not reconstructed and
its simulation comes back with its edits and undo history; the surgeon's panel names,
duplicates and deletes simulations and lists the patients; an autosave that fails is one
line in the page and leaves the previous save; the demo is not kept."""

from __future__ import annotations

import errno
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import drag, landmarks_close, open_tab, wait_for

from naseview.app.guard import guarded_viser_server
from naseview.app.markdown_text import markdown_text
from naseview.app.naseview_app import NaseviewApp, demo_case_dir
from naseview.errors import NaseviewError

MOVE = np.array([0.0, 1.5, 2.0])


@pytest.fixture()
def case(tmp_path: Path) -> Path:
    """The demo case under another folder: a patient's case (the demo itself is not kept)."""
    out = tmp_path / "cases" / "p7"
    shutil.copytree(demo_case_dir(), out)
    return out


class Served:
    """Apps on one work folder, each on its own server (a restart is a new one)."""

    def __init__(self, work: Path) -> None:
        self.work = work
        self.running: list[tuple[object, NaseviewApp]] = []
        self.tabs: list = []

    def start(self) -> tuple[object, NaseviewApp]:
        server = guarded_viser_server("127.0.0.1", 0, verbose=False)
        app = NaseviewApp(server, model="generic", work_dir=self.work)
        self.running.append((server, app))
        return server, app

    def stop(self, app: NaseviewApp) -> None:
        for server, a in list(self.running):
            if a is app:
                app.close()
                server.stop()  # type: ignore[attr-defined]
                self.running.remove((server, a))


@pytest.fixture()
def served(tmp_path: Path):
    s = Served(tmp_path / "work")
    yield s
    for t in s.tabs:
        t.close()
    for _, app in list(s.running):
        s.stop(app)


def opened(app: NaseviewApp, path: Path | None) -> NaseviewApp:
    app.open(path)
    assert app.wait_ready(180), app.status
    return app


def edit(app: NaseviewApp) -> None:
    """A drag of the tip, saved (the autosave flushed as at the end of the debounce)."""
    ctl = app.controller
    assert ctl is not None
    drag(ctl, "prn", MOVE)
    assert ctl.wait_idle(60)
    assert app.work.autosave is not None and app.work.autosave.flush()


def test_a_case_is_kept_and_reopens_without_reconstructing(served, case, monkeypatch):
    _, app = served.start()
    opened(app, case)
    pid = app.work.patient_id
    folder = served.work / str(pid)
    assert (folder / "reconstruction" / "reconstruction.json").is_file()
    assert (folder / "reconstruction" / "face.ply").is_file()
    assert (folder / "simulations" / "simulation-1.json").is_file()
    edit(app)
    ctl = app.controller
    landmarks, V = dict(ctl.landmarks), ctl.simulation.V.copy()
    served.stop(app)                       # the server stops: nothing kept in memory

    def no_pipeline(*a, **k):
        raise AssertionError("the saved reconstruction should have been used")

    monkeypatch.setattr("naseview.app.naseview_app.reconstruct", no_pipeline)
    server, app2 = served.start()
    opened(app2, case)
    ctl2 = app2.controller
    assert app2.work.patient_id == pid and app2.work.slug == "simulation-1"
    assert landmarks_close(ctl2.landmarks, landmarks)
    np.testing.assert_allclose(ctl2.simulation.V, V, atol=1e-6)
    assert ctl2.can_undo
    ctl2.undo()
    assert ctl2.wait_idle(60)
    assert not ctl2.is_edited()
    tab, screen = open_tab(server, app2)
    served.tabs.append(tab)
    panel = app2.patients_panels[tab.client.client_id]
    assert "Simulation 1" in panel.status.content and "Saved" in panel.status.content
    assert markdown_text(str(pid)) in panel.status.content


def test_simulations_are_named_duplicated_and_deleted_to_the_trash(served, case):
    server, app = served.start()
    opened(app, case)
    pid = str(app.work.patient_id)
    sims = served.work / pid / "simulations"
    edit(app)
    app.work.rename("Narrower tip")
    assert app.work.autosave.name == "Narrower tip"
    saved = json.loads((sims / "simulation-1.json").read_text())
    assert saved["record"]["name"] == "Narrower tip"
    with pytest.raises(NaseviewError, match="name"):
        app.work.rename("   ")
    app.duplicate_simulation()             # continue in a copy: it is opened
    assert app.wait_ready(60)
    copy = app.work.slug
    assert copy != "simulation-1" and (sims / f"{copy}.json").is_file()
    assert app.controller.is_edited()      # the copy has the edits
    app.new_simulation()
    assert app.wait_ready(60)
    fresh = app.work.slug
    assert fresh not in ("simulation-1", copy) and not app.controller.is_edited()
    where = app.delete_simulation()         # the open one: another opens, this one goes
    assert app.wait_ready(60)
    assert where.is_file() and where.parent == served.work / pid / "trash"
    assert not (sims / f"{fresh}.json").exists()
    assert app.work.slug in ("simulation-1", copy)


def test_the_patient_list_opens_a_patient_and_simulation_in_every_tab(served, case,
                                                                       tmp_path):
    server, app = served.start()
    opened(app, case)
    pid = str(app.work.patient_id)
    edit(app)
    first = dict(app.controller.landmarks)
    app.new_simulation()
    assert app.wait_ready(60)
    other = shutil.copytree(demo_case_dir(), tmp_path / "cases" / "q8")
    data = json.loads((other / "case.json").read_text())
    data["id"] = "q8"
    (other / "case.json").write_text(json.dumps(data))
    opened(app, other)                    # a second patient, the newest
    assert app.work.patient_id == "q8"
    tab_a, a = open_tab(server, app)
    tab_b, b = open_tab(server, app)
    served.tabs += [tab_a, tab_b]
    lst = app.patients_panels[tab_a.client.client_id].list
    assert [p for p, _ in lst.shown][0] == "q8"          # newest first
    assert (pid, "simulation-1") in lst.shown and (pid, "simulation-2") in lst.shown
    lst.open(pid, "simulation-1")
    assert app.wait_ready(60)
    assert app.work.patient_id == pid and app.work.slug == "simulation-1"
    assert landmarks_close(app.controller.landmarks, first)
    for screen in (a, b):                 # both tabs follow
        wait_for(lambda s=screen: s.shown.is_set() and s.scene is not None
                 and s._subscribed is app.controller, 30, "the tab follows")
    panel_b = app.patients_panels[tab_b.client.client_id]
    wait_for(lambda: "Simulation 1" in panel_b.status.content, 10, "tab B's status")
    assert panel_b.simulation.value == "Simulation 1"
    lst.open("../etc", None)              # a hand-made id never becomes a path
    assert lst.error.visible and "patient id" in lst.error.content


def test_a_failed_autosave_is_one_line_and_the_previous_save_stays(served, case,
                                                                   monkeypatch):
    server, app = served.start()
    opened(app, case)
    tab, _ = open_tab(server, app)
    served.tabs.append(tab)
    panel = app.patients_panels[tab.client.client_id]
    path = app.work.autosave.path
    before = path.read_bytes()

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("naseview.records.autosave.atomic_write_bytes", full)
    ctl = app.controller
    drag(ctl, "prn", MOVE)
    assert ctl.wait_idle(60)
    app.work.autosave.flush()
    wait_for(lambda: panel.error.visible, 10, "the autosave error in the page")
    text = panel.error.content
    assert "No space left" in text and "previous save is unchanged" in text
    assert "\n" not in text and "Traceback" not in text
    assert path.read_bytes() == before
    monkeypatch.undo()                    # space again: the next change is saved
    drag(ctl, "prn", MOVE)
    assert ctl.wait_idle(60) and app.work.autosave.flush()
    wait_for(lambda: not panel.error.visible, 10, "the error line cleared")
    assert path.read_bytes() != before


def test_the_demo_is_not_kept_and_paths_outside_the_work_folder_are_not_patients(
        served, tmp_path):
    _, app = served.start()
    opened(app, None)
    assert app.work.patient_id is None and app.work.autosave is None
    assert not served.work.exists() or not any(served.work.iterdir())
    assert "Not kept" in app.work.status_markdown()
    w = app.work
    assert w.target_of(tmp_path) is None
    assert w.target_of(served.work / "in-progress") is None
    assert w.target_of(served.work / "p7" / "simulations" / "../../x.json") is None
    (served.work / "p7" / "simulations").mkdir(parents=True)
    assert w.target_of(served.work / "p7") == ("p7", None)
    assert w.target_of(served.work / "p7" / "simulations" / "a-b.json") == ("p7", "a-b")
    assert w.target_of(served.work / "p7" / "simulations" / "A B.json") is None
