"""The patients' work folder: where new patients live, and one id per patient.

Layout (the work folder is ``$NASEVIEW_WORK_DIR``, default ``~/naseview-patients``)::

    WORK/in-progress/<name>/   annotation.json + photos of an annotation (autosave)
    WORK/<id>/case/            the case directory "Reconstruct" writes (SPEC §3)
    WORK/<id>/report/          the consultation report

:class:`PatientFolders` is the one home of that layout and of the rule that a case id
belongs to one patient: a new patient gets a fresh folder (created exclusively, so two
servers cannot share one), an id that another patient already has is refused with a
one-line message (:meth:`PatientFolders.check_id`), and that patient can be found, to be
opened on purpose (:meth:`PatientFolders.find`). The last guard is
:meth:`~naseview.intake.session.AnnotationSession.write_case`, which never writes over a
case it did not write.

Example
-------
>>> import tempfile
>>> work = PatientFolders(tempfile.mkdtemp())
>>> a = work.new_session("P001")
>>> b = work.new_session()
>>> work.rename(b, "P001")
Traceback (most recent call last):
...
naseview.errors.NaseviewError: case id 'P001' is already used by another patient (the \
unfinished patient in in-progress/P001); choose a different id, or open that patient
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.fileio import one_line
from naseview.intake.annotation_file import safe_case_id
from naseview.intake.session import (
    AnnotationSession,
    InProgress,
    default_case_id,
    default_work_dir,
    list_in_progress,
)


@dataclass(frozen=True)
class ExistingPatient:
    """Where an existing patient with a given id is (:meth:`PatientFolders.find`).

    Attributes:
        case_id: the id.
        annotation: its unfinished annotation folder, or ``None``.
        case_dir: its case directory (``WORK/<id>/case`` holding ``case.json``), or
            ``None``.
    """

    case_id: str
    annotation: Path | None
    case_dir: Path | None


class PatientFolders:
    """The work folder of new patients (see the module docstring for the layout).

    Args:
        root: the work folder (default :func:`default_work_dir`).
    """

    def __init__(self, root: str | os.PathLike[str] | None = None) -> None:
        self.root = Path(root) if root is not None else default_work_dir()

    @property
    def in_progress(self) -> Path:
        """``WORK/in-progress``: the unfinished annotations."""
        return self.root / "in-progress"

    def patient_dir(self, case_id: str) -> Path:
        """``WORK/<id>``: the patient's folder (case, report)."""
        return self.root / case_id

    def case_dir(self, case_id: str) -> Path:
        """``WORK/<id>/case``: where "Reconstruct" writes the patient's case."""
        return self.patient_dir(case_id) / "case"

    def annotations(self) -> list[InProgress]:
        """The annotations under :attr:`in_progress`, newest first."""
        return list_in_progress(self.in_progress)

    def holder(self, case_id: str, session: AnnotationSession | None = None) -> str | None:
        """Who already has ``case_id``, other than ``session``: a phrase such as ``"the
        patient folder WORK/P001"``, or ``None`` when the id is free.

        An id is taken by a folder ``WORK/<id>`` (unless it holds only the case
        ``session`` wrote) and by an annotation of another folder with that id; ids that
        differ in case only count as the same (file systems that ignore case).
        """
        key = safe_case_id(case_id).casefold()
        try:
            names = [p.name for p in self.root.iterdir() if p.name != "in-progress"]
        except OSError:
            names = []
        for name in names:
            d = self.root / name
            if name.casefold() == key and not (
                    session is not None and self._holds_only_own_case(d, session)):
                return f"the patient folder {d}"
        for a in self.annotations():
            if a.case_id.casefold() == key and (
                    session is None or a.folder.resolve() != session.folder.resolve()):
                what = "patient annotated" if a.finished else "unfinished patient"
                return f"the {what} in {a.folder.relative_to(self.root)}"
        return None

    @staticmethod
    def _holds_only_own_case(d: Path, session: AnnotationSession) -> bool:
        entries = [p for p in d.iterdir() if not p.name.startswith(".")]
        return all(p.name in ("case", "report") for p in entries) and (
            session.owns(d / "case")) and (d / "case").exists()

    def check_id(self, case_id: str, session: AnnotationSession | None = None) -> str:
        """``case_id`` made file-name safe, if no other patient has it.

        Raises:
            NaseviewError: an empty id, or one another patient has (the message says
                where, and how to go on).
        """
        cid = safe_case_id(case_id)
        if not cid:
            raise NaseviewError(f"case id {case_id!r}: use letters, digits, '-', '_' "
                                "(no patient names)")
        who = self.holder(cid, session)
        if who is not None:
            raise NaseviewError(f"case id {cid!r} is already used by another patient "
                                f"({who}); choose a different id, or open that patient")
        return cid

    def rename(self, session: AnnotationSession, case_id: str) -> None:
        """Give ``session`` the id ``case_id`` if no other patient has it (see
        :meth:`check_id`); nothing changes otherwise."""
        session.set_case_id(self.check_id(case_id, session))

    def new_session(self, case_id: str | None = None) -> AnnotationSession:
        """A new patient in a fresh folder ``WORK/in-progress/<id>`` (``<id>-2``... when
        that name is in use; the folder is created exclusively).

        Args:
            case_id: the id; ``None`` for :func:`default_case_id` (made unique with
                ``-2``, ``-3``... when another patient has it).
        Raises:
            NaseviewError: ``case_id`` is given and another patient has it.
        """
        if case_id is not None:
            cid = self.check_id(case_id)
        else:
            base = default_case_id()
            cid, k = base, 2
            while self.holder(cid) is not None:
                cid, k = f"{base}-{k}", k + 1
        try:
            self.in_progress.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise NaseviewError(f"{self.in_progress}: cannot create the folder "
                                f"({one_line(e)}); choose a writable work folder "
                                "(NASEVIEW_WORK_DIR)") from None
        for k in range(1, 10_000):
            folder = self.in_progress / (cid if k == 1 else f"{cid}-{k}")
            try:
                folder.mkdir()
            except FileExistsError:
                continue
            except OSError as e:
                raise NaseviewError(f"{folder}: cannot create the folder ({one_line(e)}); "
                                    "choose a writable work folder (NASEVIEW_WORK_DIR)"
                                    ) from None
            return AnnotationSession.create(folder, cid)
        raise NaseviewError(f"{self.in_progress}: too many folders named {cid!r}")

    def find(self, case_id: str) -> ExistingPatient | None:
        """The existing patient with ``case_id`` (its newest readable unfinished
        annotation and its case directory), or ``None``."""
        cid = safe_case_id(case_id)
        annotation = next((a.folder for a in self.annotations()
                           if a.problem is None and not a.finished
                           and a.case_id.casefold() == cid.casefold()), None)
        case = self.case_dir(cid)
        case_dir = case if (case / "case.json").is_file() else None
        if annotation is None and case_dir is None:
            return None
        return ExistingPatient(cid, annotation, case_dir)


__all__ = ["ExistingPatient", "PatientFolders"]
