"""The unfinished annotations of the work folder, listed for the "New patient" page's
resume list: one :class:`InProgress` per ``annotation.json`` under the in-progress folder,
validated like :meth:`naseview.intake.session.AnnotationSession.open` (a damaged one is
listed with its problem, never opened).
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from naseview.errors import NaseviewError
from naseview.fileio import read_json
from naseview.intake.annotation_file import ANNOTATION_FILE, parse_annotation, safe_case_id


@dataclass(frozen=True)
class InProgress:
    """An annotation found under the in-progress folder (:func:`list_in_progress`).

    Attributes:
        folder: its folder.
        case_id: its case id (the folder name when the file does not give one).
        clicks: number of clicks.
        updated: time of the last change (ISO 8601), ``""`` if unknown.
        finished: its case was written (``case_dir`` set).
        problem: ``None``, or the one-line error that :meth:`AnnotationSession.open`
            raises for it (damaged or hand-edited out of range).
    """

    folder: Path
    case_id: str
    clicks: int
    updated: str
    finished: bool
    problem: str | None = None


def list_in_progress(root: str | os.PathLike[str]) -> list[InProgress]:
    """The annotations under ``root`` (folders holding ``annotation.json``), newest first;
    each is validated like :meth:`AnnotationSession.open` (a damaged one is listed with
    its :attr:`InProgress.problem`)."""
    root = Path(root)
    out: list[InProgress] = []
    if not root.is_dir():
        return out
    for p in sorted(root.iterdir()):
        f = p / ANNOTATION_FILE
        if not f.is_file():
            continue
        try:
            st = parse_annotation(read_json(f), f, p)
        except NaseviewError as e:
            obj: Any = None
            with contextlib.suppress(NaseviewError):
                obj = read_json(f)
            cid = obj.get("id") if isinstance(obj, dict) else None
            if not (isinstance(cid, str) and cid and safe_case_id(cid) == cid):
                cid = p.name
            out.append(InProgress(p, cid, 0, "", False, str(e)))
            continue
        out.append(InProgress(p, st.case_id, sum(len(c) for c in st.clicks.values()),
                              st.updated, st.case_dir is not None))
    out.sort(key=lambda a: a.updated, reverse=True)
    return out


__all__ = ["InProgress", "list_in_progress"]
