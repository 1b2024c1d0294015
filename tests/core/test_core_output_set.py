"""The output folder of `naseview reconstruct` is one set: readers (`report`, `serve OUT`,
`baseline_from_output_dir`) see the old set or the new one, never a mix, whatever step the
writer is killed at; a full disk or a bad folder is a one-line error that keeps the
previous result."""

from __future__ import annotations

import errno
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import write_projected_case

import naseview.pipeline
from naseview.cli import main
from naseview.editing.baseline import Baseline, baseline_from_output_dir
from naseview.errors import NaseviewError
from naseview.fileio import write_file_set
from naseview.measurements import clinical_measurements
from naseview.pipeline import PipelineResult, write_outputs
from naseview.reconstruction import Reconstruction

KILLED = 86  # exit status of a writer killed at its step k


def _result(shift: float) -> PipelineResult:
    """A tiny stage-3 result: a 5x5 grid face, its middle 3x3 the nose; ``shift`` (mm)
    tells two runs apart in every file."""
    xs, ys = np.meshgrid(np.arange(5.0), np.arange(5.0))
    V = np.column_stack([xs.ravel(), ys.ravel(), np.full(25, shift)])
    idx = np.arange(25).reshape(5, 5)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.column_stack([a.ravel(), c.ravel(), b.ravel()]),
                   np.column_stack([b.ravel(), c.ravel(), d.ravel()])])
    nose = idx[1:4, 1:4].ravel()
    lms = {"g": np.zeros(3), "prn": np.array([2.0, 2.0, shift])}
    # every measurement of today (as a reconstruction writes them), plus one that tells
    # the runs apart
    rec = Reconstruction(landmarks=lms, measurements={
        **clinical_measurements(lms, None, V, F), "n-prn": 40.0 + shift})
    return PipelineResult(reconstruction=rec, face_vertices=V, faces=F, nose_vertex_ids=nose)


OLD, NEW = _result(0.0), _result(7.0)


def _which(b: Baseline) -> str:
    """"old" or "new" when every part of the baseline comes from that run."""
    for name, res in (("old", OLD), ("new", NEW)):
        if (np.array_equal(b.V, res.face_vertices)
                and np.array_equal(b.landmarks["prn"], res.reconstruction.landmarks["prn"])
                and b.measurements == res.reconstruction.measurements):
            return name
    raise AssertionError("the reader saw a mix of two runs")


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _kill_writer_at(step: int, out: Path) -> int:
    """Run ``write_outputs(NEW, out, export=("obj",))`` in a forked child that dies
    (``os._exit``, no clean-up) just before its file-system call number ``step`` (0:
    never); returns the number of calls it made (when it finished) or -1 (killed)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: count (and maybe die at) every call that changes the disk
        try:
            os.close(r)
            calls = [0]

            def counted(fn):
                def call(*args, **kwargs):
                    calls[0] += 1
                    if calls[0] == step:
                        os._exit(KILLED)
                    return fn(*args, **kwargs)
                return call

            for name in ("mkdir", "rename", "replace", "unlink", "rmdir", "fsync"):
                setattr(os, name, counted(getattr(os, name)))
            write_outputs(NEW, out, export=("obj",))
            os.write(w, str(calls[0]).encode())
            os._exit(0)
        except BaseException:
            os._exit(3)
    os.close(w)
    end = time.monotonic() + 60
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > end:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            raise AssertionError(f"the writer hung at step {step}")
        time.sleep(0.005)
    with os.fdopen(r, "rb") as f:
        reported = f.read()
    code = os.waitstatus_to_exitcode(status)
    assert code in (0, KILLED), f"the writer failed at step {step} (exit {code})"
    return int(reported) if code == 0 else -1


def test_a_writer_killed_at_any_step_leaves_the_old_or_the_new_set(tmp_path: Path,
                                                                  monkeypatch):
    monkeypatch.setattr(os, "fsync", lambda fd: None)  # speed: no power cut here; the
    out = tmp_path / "out"                             # calls are still kill points
    write_outputs(OLD, out, export=("stl",))          # also imports trimesh before forking
    shutil.copytree(out, tmp_path / "old")
    old_files = {p.name: p.read_bytes() for p in out.iterdir()}
    assert _which(baseline_from_output_dir(out)) == "old"
    steps = _kill_writer_at(0, out)                    # a complete run: count its steps
    assert steps >= 10 and _which(baseline_from_output_dir(out)) == "new"
    new_names = {p.name for p in out.iterdir()}
    assert new_names == {"reconstruction.json", "face.ply", "nose.ply", "face.obj",
                         "nose.obj"}                   # the old run's .stl files are gone
    seen = set()
    for fresh in (False, True):                        # over an old set, then a first run
        for step in range(1, steps + 1):
            shutil.rmtree(out)
            if not fresh:
                shutil.copytree(tmp_path / "old", out)
                assert {p.name: p.read_bytes() for p in out.iterdir()} == old_files
            assert _kill_writer_at(step, out) == -1
            committed = out.is_dir() and ((out / "reconstruction.json").exists() or any(
                p.name.startswith(".naseview-commit-") for p in out.iterdir()))
            if fresh and not committed:
                with pytest.raises(NaseviewError, match="reconstruction.json: file not found"):
                    baseline_from_output_dir(out)
                seen.add("none")
            else:
                got = _which(baseline_from_output_dir(out))
                assert got == "new" or not fresh, f"a first run killed at step {step}"
                seen.add(got)
            # the next run cleans what the killed one left and writes the whole new set
            write_outputs(NEW, out, export=("obj",))
            assert _hidden(out) == [], f"leftovers after a kill at step {step}"
            assert {p.name for p in out.iterdir()} == new_names
            assert _which(baseline_from_output_dir(out)) == "new"
    assert seen == {"old", "new", "none"}              # every outcome was reached


@pytest.mark.parametrize("copied", ["reconstruction.json", "face.ply"])
def test_a_folder_mixing_two_runs_is_refused_in_one_line(tmp_path: Path, copied: str):
    write_outputs(OLD, tmp_path / "a")
    write_outputs(NEW, tmp_path / "b")
    shutil.copy(tmp_path / "b" / copied, tmp_path / "a" / copied)  # what a crash left
    with pytest.raises(NaseviewError) as e:
        baseline_from_output_dir(tmp_path / "a")
    msg = str(e.value)
    assert "\n" not in msg and "face.ply" in msg and "reconstruction.json" in msg
    assert "naseview reconstruct" in msg
    assert main(["report", str(tmp_path / "a")]) == 2
    assert not (tmp_path / "a" / "report.html").exists()


def test_a_full_disk_is_one_line_and_keeps_the_previous_set(tmp_path: Path, monkeypatch):
    out = tmp_path / "out"
    write_outputs(OLD, out, export=("stl",))
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = os.fsync

    def full_after_two(fd: int, calls=[0]) -> None:  # noqa: B006
        calls[0] += 1
        if calls[0] > 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd)

    monkeypatch.setattr(os, "fsync", full_after_two)
    with pytest.raises(NaseviewError) as e:
        write_outputs(NEW, out, export=("obj",))
    msg = str(e.value)
    assert "\n" not in msg and "disk is full" in msg and "unchanged" in msg
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before   # nothing left over
    assert _which(baseline_from_output_dir(out)) == "old"


def test_leftover_temporary_files_of_a_crash_are_removed(tmp_path: Path):
    out = tmp_path / "out"
    write_outputs(OLD, out)
    for junk in (".face.ply.k2j3h4.tmp", ".reconstruction.json.x8y7.tmp"):
        (out / junk).write_bytes(b"patient mesh")      # what older versions left behind
    staging = out / ".naseview-staging-abc"
    staging.mkdir()
    (staging / "face.ply").write_bytes(b"half")
    write_outputs(NEW, out)
    assert _hidden(out) == []


@pytest.mark.parametrize("blocked", ["nose.ply", "reconstruction.json", "nose.stl"])
def test_a_folder_in_the_way_of_one_file_keeps_the_whole_previous_set(tmp_path: Path,
                                                                      blocked: str):
    out = tmp_path / "out"
    write_outputs(OLD, out, export=("stl",))
    (out / blocked).unlink()
    (out / blocked).mkdir()                  # e.g. a folder a user made with that name
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    with pytest.raises(NaseviewError) as e:
        write_outputs(NEW, out, export=("stl",))
    msg = str(e.value)
    assert "\n" not in msg and f"out/{blocked}: is a folder" in msg and "unchanged" in msg
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert _hidden(out) == []                # no commit left to finish half-way
    (out / blocked).rmdir()                  # the fix the message names
    write_outputs(NEW, out, export=("stl",))
    assert _which(baseline_from_output_dir(out)) == "new"


def test_an_interrupted_commit_blocked_by_a_folder_names_the_folder(tmp_path: Path):
    out = tmp_path / "out"
    write_file_set(out, {"a.txt": b"old a", "b.txt": b"old b"})
    commit = out / ".naseview-commit-x1"
    commit.mkdir()                           # a writer killed after its commit point
    (commit / "a.txt").write_bytes(b"new a")
    (commit / "b.txt").write_bytes(b"new b")
    (commit / ".manifest.json").write_text(json.dumps({"files": ["a.txt", "b.txt"],
                                                       "remove": []}))
    (out / "b.txt").unlink()
    (out / "b.txt").mkdir()
    with pytest.raises(NaseviewError) as e:
        write_file_set(out, {"a.txt": b"third a", "b.txt": b"third b"})
    assert "out/b.txt: is a folder" in str(e.value) and "\n" not in str(e.value)
    assert (out / "a.txt").read_bytes() == b"old a"      # nothing moved half-way
    (out / "b.txt").rmdir()
    write_file_set(out, {"a.txt": b"third a", "b.txt": b"third b"})
    assert (out / "b.txt").read_bytes() == b"third b" and _hidden(out) == []


def test_write_file_set_refuses_names_with_folders(tmp_path: Path):
    with pytest.raises(NaseviewError, match="plain file names"):
        write_file_set(tmp_path, {"../escape.txt": b"x"})
    assert not (tmp_path.parent / "escape.txt").exists()


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory) -> Path:
    return write_projected_case(tmp_path_factory.mktemp("set") / "case", seed=81)


def test_reconstruct_checks_the_output_folder_before_running(case_dir: Path, tmp_path: Path,
                                                             monkeypatch, capsys):
    def never(*args, **kwargs):
        raise AssertionError("the pipeline ran before the output folder was checked")

    monkeypatch.setattr(naseview.pipeline, "reconstruct", never)
    a_file = tmp_path / "out.txt"
    a_file.write_text("not a folder")
    for target, needle in ((a_file, "is a file, not a folder"),
                           (a_file / "sub", "is a file, not a folder"),
                           (Path("/sys/naseview-out"), "not writable")):
        assert main(["reconstruct", str(case_dir), "-o", str(target), "--stages", "1"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("naseview: error:") and "\n" not in err, err
        assert needle in err and "internal error" not in err
    assert a_file.read_text() == "not a folder"
    foreign = tmp_path / "scans"
    foreign.mkdir()
    (foreign / "face.ply").write_bytes(b"the user's own scan")
    (foreign / "nose.stl").write_bytes(b"a printed model")
    other_case = tmp_path / "other-case"                   # another patient's case folder
    other_case.mkdir()
    (other_case / "case.json").write_text("{}")
    for target, needle in ((foreign, "holds face.ply, nose.stl, which no naseview result"),
                           (case_dir, "is the case folder"),
                           (other_case, "is another case's folder (it holds case.json)")):
        assert main(["reconstruct", str(case_dir), "-o", str(target), "--stages", "1"]) == 2
        err = capsys.readouterr().err.strip()
        assert needle in err and "\n" not in err, err
    assert (foreign / "face.ply").read_bytes() == b"the user's own scan"
    assert (foreign / "nose.stl").read_bytes() == b"a printed model"
    assert not (case_dir / "reconstruction.json").exists()
    assert sorted(p.name for p in other_case.iterdir()) == ["case.json"]


def test_a_first_run_killed_while_moving_in_is_finished_by_the_next(case_dir: Path,
                                                                   tmp_path: Path):
    out = tmp_path / "out"
    assert main(["reconstruct", str(case_dir), "-o", str(out), "--stages", "1"]) == 0
    commit = out / ".naseview-commit-k1"                # what a run killed after moving
    commit.mkdir()                                      # face.ply in, before the index
    (commit / ".manifest.json").write_text(json.dumps({"files": ["reconstruction.json"],
                                                       "remove": []}))
    (commit / "reconstruction.json").write_bytes((out / "reconstruction.json").read_bytes())
    (out / "reconstruction.json").unlink()
    (out / "face.ply").write_bytes(b"moved in by the killed run")
    assert main(["reconstruct", str(case_dir), "-o", str(out), "--stages", "1"]) == 0
    assert (out / "reconstruction.json").is_file() and _hidden(out) == []


def test_reconstruct_on_a_full_disk_is_one_line_and_keeps_the_result(case_dir: Path,
                                                                    tmp_path: Path,
                                                                    monkeypatch, capsys):
    out = tmp_path / "out"
    assert main(["reconstruct", str(case_dir), "-o", str(out), "--stages", "1"]) == 0
    capsys.readouterr()
    before = (out / "reconstruction.json").read_bytes()
    assert json.loads(before)["files"] == {}          # stage 1: no mesh in the set

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    assert main(["reconstruct", str(case_dir), "-o", str(out), "--stages", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("naseview: error:") and "\n" not in err
    assert "disk is full" in err and "internal error" not in err
    assert (out / "reconstruction.json").read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["reconstruction.json"]
