"""Replacing a photo is all or nothing with its clicks (issue 12, finding 4).

The replacement is interrupted at every file-system step in turn (each ``open``, write
sync, rename, removal...): once by an exception (a full disk, say), once by killing a
forked writer there (``os._exit``: no clean-up runs). Whatever the step, the session
resumes, and it holds either the old photo with its old clicks or the new photo with no
clicks for that view, never the new photo with the old clicks; the file an interruption
leaves behind is removed on resume; the other photos keep their clicks.
"""

from __future__ import annotations

import builtins
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from helpers import png_bytes

from naseview.intake.session import AnnotationSession

FS_STEPS = ("open", "fsync", "replace", "rename", "unlink", "remove", "rmdir", "mkdir",
            "chmod")
"""The ``os`` functions an interruption may hit (plus ``builtins.open`` for writing)."""


class Interrupted(BaseException):
    """Raised at the chosen step (a BaseException: like a kill signal, not caught as an
    error)."""


@contextmanager
def interrupt_at(step: int, action: Callable[[], None]) -> Iterator[list[str]]:
    """Run ``action()`` just before the ``step``-th file-system call (1-based); yields
    the list of calls made."""
    calls: list[str] = []
    saved: dict[str, Any] = {name: getattr(os, name) for name in FS_STEPS}
    real_open = builtins.open

    def hook(name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def run(*args: Any, **kw: Any) -> Any:
            calls.append(name)
            if len(calls) == step:
                action()
            return fn(*args, **kw)
        return run

    def write_open(file: Any, mode: str = "r", *args: Any, **kw: Any) -> Any:
        if any(c in mode for c in "wxa+"):
            return hook("open(write)", real_open)(file, mode, *args, **kw)
        return real_open(file, mode, *args, **kw)

    try:
        for name, fn in saved.items():
            setattr(os, name, hook(name, fn))
        builtins.open = write_open
        yield calls
    finally:
        for name, fn in saved.items():
            setattr(os, name, fn)
        builtins.open = real_open


def photo(shade: int, size: tuple[int, int] = (300, 240)) -> np.ndarray:
    img = np.full((size[0], size[1], 3), shade, np.uint8)
    img[10:20, 10:20] = 255 - shade
    return img


def jpeg_bytes(img: np.ndarray) -> bytes:
    return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()


OLD = photo(60)
NEW = photo(190, (320, 256))
OLD_CLICKS = {"g": [100.0, 50.0], "n": [101.0, 90.0], "k": [102.0, 120.0]}


def patient(folder: Path, old_kind: str) -> AnnotationSession:
    """A session whose front photo (``old_kind``) has three clicks and a skip and whose
    bottom photo has one click."""
    s = AnnotationSession.create(folder, "p1")
    s.add_photo("front", png_bytes(OLD) if old_kind == "png" else jpeg_bytes(OLD))
    for lid, xy in OLD_CLICKS.items():
        s.place("front", lid, xy)
    s.skip("front", "r")
    s.add_photo("bottom", png_bytes(photo(120)))
    s.place("bottom", "prn", (50.0, 60.0))
    return s


def outcome(folder: Path) -> str:
    """Resume ``folder`` and say what it holds: "old" (old photo, old clicks) or "new"
    (new photo, no front clicks); fail on any mix."""
    s = AnnotationSession.open(folder)             # always resumes
    img = s.image("front")
    clicks = {k: v.tolist() for k, v in s.clicks["front"].items()}
    assert s.clicks["bottom"]["prn"].tolist() == [50.0, 60.0]
    files = sorted(p.name for p in folder.iterdir())
    assert files == sorted(["annotation.json", s.photos["front"].file,
                            s.photos["bottom"].file]), files   # no leftovers
    if img.shape[:2] == OLD.shape[:2] and abs(int(img[150, 150, 0]) - 60) <= 3:
        assert clicks == OLD_CLICKS and s.skipped["front"] == {"r"}, "old photo lost clicks"
        return "old"
    assert img.shape[:2] == NEW.shape[:2] and abs(int(img[150, 150, 0]) - 190) <= 3
    assert clicks == {} and s.skipped["front"] == set(), "new photo with the old clicks"
    assert not s.can_undo or all(u.view != "front" for u in s._undo)
    return "new"


@pytest.mark.parametrize("old_kind", ["png", "jpeg"])   # same file type, or another one
def test_an_exception_at_any_step_leaves_the_old_or_the_new_photo(tmp_path: Path,
                                                                   old_kind: str):
    seen = set()
    for step in range(1, 60):
        folder = tmp_path / f"{step}"
        s = patient(folder, old_kind)

        def fail() -> None:
            raise Interrupted()

        with interrupt_at(step, fail) as calls:
            try:
                s.add_photo("front", png_bytes(NEW))
                interrupted = False
            except Interrupted:
                interrupted = True
        if not interrupted:
            assert outcome(folder) == "new" and step > len(calls)
            break
        # the session object itself is consistent with the disk and still usable
        assert outcome(folder) == ("new" if s.photos["front"].height == 320 else "old")
        s.place("bottom", "prn", (50.0, 60.0))
        seen.add(outcome(folder))
    else:
        pytest.fail("the replacement never completed")
    assert seen == {"old", "new"}, seen             # the steps spanned the commit


@pytest.mark.parametrize("old_kind", ["png", "jpeg"])
def test_a_kill_at_any_step_leaves_the_old_or_the_new_photo(tmp_path: Path, old_kind: str):
    seen = []
    for step in range(1, 60):
        folder = tmp_path / f"{step}"
        s = patient(folder, old_kind)
        data = png_bytes(NEW)
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:                                   # the writer, killed at ``step``
            os.close(r)
            code = 0
            try:
                with interrupt_at(step, lambda: os._exit(3)) as calls:
                    s.add_photo("front", data)
                os.write(w, str(len(calls)).encode())
            except BaseException:
                code = 4
            os._exit(code)
        os.close(w)
        _, status = os.waitpid(pid, 0)
        n_calls = os.read(r, 32)
        os.close(r)
        code = os.waitstatus_to_exitcode(status)
        assert code in (0, 3), f"the writer failed at step {step} (exit {code})"
        seen.append(outcome(folder))
        if code == 0:                                  # it ran to the end: all steps done
            assert int(n_calls) < step and seen[-1] == "new"
            break
    else:
        pytest.fail("the replacement never completed")
    assert seen[0] == "old" and "new" in seen[:-1], seen  # the kills spanned the commit
