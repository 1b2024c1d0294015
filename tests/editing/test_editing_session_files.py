"""Session files are validated like case.json (vertex ids in the mesh, finite numbers,
right shapes), store the case folder relative to themselves and never follow one that
leaves their folder."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController
from naseview.editing.session import (
    SavedSimulation,
    Session,
    SessionRecord,
    load_session,
    save_session,
    session_from_json,
    session_to_json,
)
from naseview.errors import NaseviewError
from naseview.reconstruction import Reconstruction

INF = 424242.5  # written as 1e999 (JSON for infinity once parsed) by _write


def _baseline() -> Baseline:
    xs, ys = np.meshgrid(np.arange(4.0), np.arange(4.0))
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(16)])
    idx = np.arange(16).reshape(4, 4)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.column_stack([a.ravel(), c.ravel(), b.ravel()]),
                   np.column_stack([b.ravel(), c.ravel(), d.ravel()])])
    lms = {"g": V[0].copy(), "prn": V[5].copy()}
    rec = Reconstruction(landmarks=lms, measurements={"n-prn": 1.0})
    return Baseline(V, F, idx[1:3, 1:3].ravel(), lms, measurements={"n-prn": 1.0},
                    reconstruction=rec)


def _session_obj() -> dict[str, Any]:
    b = _baseline()
    V = b.V.copy()
    V[[5, 6]] += [0.0, 0.0, 1.0]
    lms = dict(b.landmarks, prn=b.landmarks["prn"] + [0.0, 0.0, 1.0])
    sim = SavedSimulation(V, {}, np.zeros((0, 3)), {"n-prn": 1.2})
    return session_to_json(Session(b, lms, [b.landmarks, lms], 1, False, sim, {}))


def _write(path: Path, obj: dict[str, Any]) -> Path:
    path.write_text(json.dumps(obj).replace(str(INF), "1e999"))
    return path


def _set(*keys: str | int, value: Any) -> Callable[[dict[str, Any]], None]:
    def edit(obj: dict[str, Any]) -> None:
        for k in keys[:-1]:
            obj = obj[k]
        obj[keys[-1]] = value
    return edit


BAD: list[tuple[str, Callable[[dict[str, Any]], None], str]] = [
    ("negative vertex id", _set("edit", "simulation", "changed_vertex_ids", value=[-1, 6]),
     "edit.simulation.changed_vertex_ids': vertex id -1 is outside [0, 15]"),
    ("vertex id past the mesh", _set("edit", "simulation", "changed_vertex_ids",
                                     value=[5, 16]), "vertex id 16 is outside [0, 15]"),
    ("fractional vertex id", _set("edit", "simulation", "changed_vertex_ids", value=[5.5, 6]),
     "integer vertex ids"),
    ("infinite vertex", _set("edit", "simulation", "changed_vertices",
                             value=[[0, 0, INF], [1, 1, 1]]), "finite"),
    ("vertex count", _set("edit", "simulation", "changed_vertices", value=[[0, 0, 1]]),
     "expected 2 points"),
    ("landmark shape", _set("edit", "landmarks", "prn", value=[1, 2]), "edit.landmarks.prn"),
    ("infinite landmark", _set("edit", "landmarks", "prn", value=[INF, 0, 0]), "finite"),
    ("unknown landmark", _set("edit", "landmarks", "zz", value=[0, 0, 0]), "edit.landmarks.zz"),
    ("history landmark", _set("edit", "history", 1, "prn", value=[0, INF, 0]),
     "edit.history.1.prn"),
    ("history index", _set("edit", "history_index", value=7), "[0, 1]"),
    ("face id", _set("baseline", "mesh", "faces", value=[[0, 1, 99]]),
     "baseline.mesh.faces': vertex id 99 is outside [0, 15]"),
    ("nose id", _set("baseline", "mesh", "nose_vertex_ids", value=[-3]),
     "baseline.mesh.nose_vertex_ids"),
    ("vertex shape", _set("baseline", "mesh", "vertices", value=[[0, 0]] * 16),
     "baseline.mesh.vertices"),
    ("baseline landmark", _set("baseline", "landmarks", "g", value=[0, 0, INF]),
     "baseline.landmarks.g"),
    ("reconstruction landmark", _set("baseline", "reconstruction", "landmarks", "prn",
                                     value=[INF, 0, 0]), "landmarks.prn"),
    ("measurement", _set("edit", "simulation", "measurements", "n-prn", value="long"),
     "edit.simulation.measurements.n-prn"),
    ("case folder type", _set("app", "case_dir", value=7), "app.case_dir"),
]


@pytest.mark.parametrize(("what", "edit", "needle"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_session_file_is_one_line_naming_the_key(tmp_path: Path, what, edit, needle):
    obj = _session_obj()
    load_session(_write(tmp_path / "ok.json", obj))          # the untouched file opens
    edit(obj)
    path = _write(tmp_path / "s.json", obj)
    with pytest.raises(NaseviewError) as e:
        load_session(path)
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg and needle in msg, msg


def _saved(folder: Path, app: dict[str, Any]) -> Path:
    b = _baseline()
    ctl = EditController(b, None)
    try:
        return save_session(folder / "s.json", ctl, app)
    finally:
        ctl.close()


def test_the_case_folder_is_stored_relative_to_the_session(tmp_path: Path):
    patient = tmp_path / "Jane Doe"
    (patient / "case").mkdir(parents=True)
    path = _saved(patient, {"case_id": "P1", "case_dir": str(patient / "case")})
    text = path.read_text()
    assert json.loads(text)["app"]["case_dir"] == "case"
    assert str(tmp_path) not in text                      # no absolute path in the file
    assert load_session(path).case_folder() == (patient / "case").resolve()
    # a case elsewhere is not written at all (the file would not be allowed to follow it)
    elsewhere = _saved(tmp_path / "Jane Doe" / "case",
                       {"case_dir": str(tmp_path / "John Roe")})
    assert json.loads(elsewhere.read_text())["app"]["case_dir"] is None
    assert load_session(elsewhere).case_folder() is None


def test_a_session_beside_case_json_finds_its_case(tmp_path: Path):
    (tmp_path / "case.json").write_text("{}")
    path = _saved(tmp_path, {"case_dir": None})
    assert load_session(path).case_folder() == tmp_path.resolve()


@pytest.mark.parametrize("how", ["absolute", "dotdot", "symlink"])
def test_a_case_folder_outside_the_session_folder_is_refused(tmp_path: Path, how: str):
    folder = tmp_path / "sessions"
    folder.mkdir()
    other = tmp_path / "other-patient"
    other.mkdir()
    (folder / "link").symlink_to(other)
    value = {"absolute": str(other), "dotdot": "../other-patient", "symlink": "link"}[how]
    obj = _session_obj()
    obj["app"]["case_dir"] = value
    path = _write(folder / "s.json", obj)
    session = load_session(path)                           # the edits still open
    with pytest.raises(NaseviewError) as e:
        session.case_folder()
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg and "'app.case_dir'" in msg
    assert "outside" in msg


def test_an_old_session_with_an_absolute_case_folder_still_opens(tmp_path: Path):
    (tmp_path / "case").mkdir()
    obj = _session_obj()
    obj["app"]["case_dir"] = str(tmp_path / "case")       # what older versions wrote
    session = load_session(_write(tmp_path / "s.json", obj))
    assert session.case_folder() == (tmp_path / "case").resolve()


def test_the_record_of_a_kept_simulation_round_trips(tmp_path: Path):
    """The optional ``record`` object (name, times, reconstruction) is read back; a file
    without it (a download, an older version) opens as before."""
    obj = _session_obj()
    assert "record" not in obj
    assert load_session(_write(tmp_path / "old.json", obj)).record is None
    sha = "ab" * 32
    rec = SessionRecord("Tip up 2 mm", "2026-01-02T03:04:05+01:00", None, sha)
    s = session_from_json(obj)
    obj2 = session_to_json(dataclasses.replace(s, record=rec))
    assert list(obj2)[:3] == ["format", "units", "record"]
    assert load_session(_write(tmp_path / "new.json", obj2)).record == rec


RECORD_BAD = [
    ("name type", {"name": 7}, "record.name"),
    ("name empty", {"name": "  "}, "record.name"),
    ("name long", {"name": "x" * 81}, "record.name"),
    ("name control", {"name": "a\nb"}, "record.name"),
    ("time type", {"name": "a", "created": 5}, "record.created"),
    ("sha", {"name": "a", "reconstruction_sha256": "zz"}, "record.reconstruction_sha256"),
    ("not an object", "x", "'record'"),
]


@pytest.mark.parametrize(("what", "record", "needle"), RECORD_BAD,
                         ids=[b[0] for b in RECORD_BAD])
def test_a_bad_record_is_one_line(tmp_path: Path, what, record, needle):
    obj = dict(_session_obj(), record=record)
    with pytest.raises(NaseviewError) as e:
        load_session(_write(tmp_path / "s.json", obj))
    assert needle in str(e.value) and "\n" not in str(e.value)
