"""A new patient's case directory written all or nothing, and never over another
patient's: the last step of the "New patient" page
(:meth:`naseview.intake.session.AnnotationSession.write_case`).

The case (SPEC §3: photos copied byte for byte, ``case.json`` last,
:func:`naseview.case.write_case`) goes into a temporary folder beside its place and is
renamed there, under the patient folder's lock (:func:`naseview.fileio.folder_lock`), so a
reader sees the old case or the new one and two writers for one new id take turns.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from naseview.case import Case
from naseview.case import write_case as _write_case
from naseview.errors import NaseviewError
from naseview.fileio import folder_lock, one_line
from naseview.intake.annotation_file import new_uid


def _taken(out: Path) -> NaseviewError:
    return NaseviewError(f"{out}: patient {out.parent.name} exists (another patient's case "
                         "is already there); choose a different case id (nothing was "
                         "overwritten; this patient's photos and clicks are kept)")


def write_case_dir(case: Case, out: Path, owns: Callable[[Path], bool]) -> None:
    """Write ``case`` to ``out`` through a temporary sibling folder and a rename (see
    :meth:`naseview.intake.session.AnnotationSession.write_case`); ``owns(out)`` says
    whether ``out`` may be replaced.

    The whole check-and-write holds :func:`~naseview.fileio.folder_lock` of the patient
    folder (``out``'s parent): two "Reconstruct" presses for one new id (two tabs, two
    servers) take turns, so the second sees the first one's case and is refused instead
    of replacing it (or losing its temporary folder to the first one's clean-up)."""
    parent = out.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise NaseviewError(f"{out}: cannot write the case here ({one_line(e)}); choose "
                            "a writable work folder (NASEVIEW_WORK_DIR)") from None
    with folder_lock(parent):
        _write_case_dir_locked(case, out, owns)


def _write_case_dir_locked(case: Case, out: Path, owns: Callable[[Path], bool]) -> None:
    parent = out.parent
    try:
        for p in parent.iterdir():       # leftovers of an interrupted write of this case
            if re.fullmatch(rf"\.{re.escape(out.name)}\.\w+\.(tmp|old)", p.name) \
                    and p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
        if not owns(out):
            raise _taken(out)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=parent))
    except OSError as e:
        raise NaseviewError(f"{out}: cannot write the case here ({one_line(e)}); choose "
                            "a writable work folder (NASEVIEW_WORK_DIR)") from None
    try:
        _write_case(case, tmp)
        if out.exists():
            old = parent / f".{out.name}.{new_uid()}.old"
            os.rename(out, old)
            os.rename(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(tmp, out)          # fails if another writer just took ``out``
    except OSError as e:
        shutil.rmtree(tmp, ignore_errors=True)
        if out.exists() and not owns(out):
            raise _taken(out) from None
        raise NaseviewError(f"{out}: could not write the case ({one_line(e)}); free some "
                            "disk space and press Reconstruct again") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


__all__ = ["write_case_dir"]
