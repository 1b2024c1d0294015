"""The patients' work folder: where new patients live, and one id per patient.

Layout (the work folder is ``$NASEVIEW_WORK_DIR``, default ``~/naseview-patients``)::

    WORK/in-progress/<name>/            annotation.json + photos of an annotation (autosave)
    WORK/index.sqlite                   the patient list (a cache of the folders,
                                        :mod:`naseview.records.index`)
    WORK/<id>/case/                     the case directory "Reconstruct" writes (SPEC §3)
    WORK/<id>/patient.json              the patient record: when it was created and, for a
                                        case opened from elsewhere, the link to it (path +
                                        SHA-256 of its case.json; never copied)
    WORK/<id>/reconstruction/           the pipeline output set (SPEC §5, all or nothing)
    WORK/<id>/simulations/<slug>.json   named simulations (``naseview.session/1``)
    WORK/<id>/trash/                    deleted simulations
    WORK/<id>/report/                   the consultation report

Every path below ``WORK`` is derived here from a validated id (:meth:`PatientFolders.
patient_dir`: :func:`is_patient_id`) and a validated simulation slug
(:func:`is_simulation_slug`), never from a string read from a file or the index; and
:meth:`PatientFolders.inside` refuses a path that a symbolic link leads out of its
patient's folder.

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
import re
import stat
import threading
from dataclasses import dataclass
from pathlib import Path

from naseview.errors import NaseviewError
from naseview.fileio import one_line
from naseview.intake.annotation_file import safe_case_id
from naseview.intake.in_progress import InProgress, list_in_progress
from naseview.intake.session import AnnotationSession, default_case_id, default_work_dir

RESERVED_NAMES = frozenset({"in-progress", "index.sqlite", "index.sqlite-wal",
                            "index.sqlite-shm", "index.sqlite-journal"})
"""Names in ``WORK`` that are not patients (compared ignoring upper / lower case)."""

PATIENT_RECORD = "patient.json"
RECONSTRUCTION_FOLDER = "reconstruction"
SIMULATIONS_FOLDER = "simulations"
TRASH_FOLDER = "trash"
INDEX_FILE = "index.sqlite"
OWN_FOLDERS = ("case", "report", PATIENT_RECORD, RECONSTRUCTION_FOLDER, SIMULATIONS_FOLDER,
               TRASH_FOLDER)
"""What a patient folder holds (the entries :meth:`PatientFolders.holder` allows beside
an annotation's own case)."""

_SLUG_RE = re.compile(r"[a-z0-9](?:[a-z0-9-]{0,62}[a-z0-9])?")


def is_patient_id(name: str) -> bool:
    """Whether ``name`` is a patient folder name naseview makes: already file-name safe
    (:func:`~naseview.intake.annotation_file.safe_case_id` leaves it as it is: no ``/``,
    ``..``, NUL, leading dot; at most 64 characters) and not a reserved name.

    >>> is_patient_id("P001"), is_patient_id("../etc"), is_patient_id("in-progress")
    (True, False, False)
    """
    return (isinstance(name, str) and 0 < len(name) <= 64 and safe_case_id(name) == name
            and name.casefold() not in RESERVED_NAMES)


def is_simulation_slug(slug: str) -> bool:
    """Whether ``slug`` names a simulation file ``<slug>.json``: lower-case letters,
    digits and inner ``-``, at most 64 characters.

    >>> is_simulation_slug("simulation-2"), is_simulation_slug("../x"), is_simulation_slug("")
    (True, False, False)
    """
    return isinstance(slug, str) and _SLUG_RE.fullmatch(slug) is not None


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


_ISSUED: set[str] = set()
"""Default ids this process has given out (a lazy session's folder may not exist yet)."""
_ISSUED_LOCK = threading.Lock()


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
        """``WORK/<id>``: the patient's folder (case, reconstruction, simulations, report).

        Raises:
            NaseviewError: ``case_id`` is not a patient id (:func:`is_patient_id`: ``..``,
                ``/``, NUL, too long, reserved), so no path leaves ``WORK``.
        """
        if not is_patient_id(case_id):
            shown = case_id[:80] if isinstance(case_id, str) else type(case_id).__name__
            raise NaseviewError(f"patient id {shown!r}: not a patient folder name (use "
                                "letters, digits, '-', '_', '.', at most 64, as "
                                f"naseview writes them in {self.root})")
        return self.root / case_id

    def case_dir(self, case_id: str) -> Path:
        """``WORK/<id>/case``: where "Reconstruct" writes the patient's case."""
        return self.patient_dir(case_id) / "case"

    def record_file(self, case_id: str) -> Path:
        """``WORK/<id>/patient.json``: created time and the link to a case kept elsewhere."""
        return self.patient_dir(case_id) / PATIENT_RECORD

    def reconstruction_dir(self, case_id: str) -> Path:
        """``WORK/<id>/reconstruction``: the pipeline output set of the patient's case."""
        return self.patient_dir(case_id) / RECONSTRUCTION_FOLDER

    def simulations_dir(self, case_id: str) -> Path:
        """``WORK/<id>/simulations``: the named simulations."""
        return self.patient_dir(case_id) / SIMULATIONS_FOLDER

    def simulation_file(self, case_id: str, slug: str) -> Path:
        """``WORK/<id>/simulations/<slug>.json``.

        Raises:
            NaseviewError: ``slug`` is not a simulation slug (:func:`is_simulation_slug`).
        """
        if not is_simulation_slug(slug):
            raise NaseviewError(f"simulation {str(slug)[:80]!r}: not a simulation name "
                                "(lower-case letters, digits and '-', at most 64)")
        return self.simulations_dir(case_id) / f"{slug}.json"

    def report_dir(self, case_id: str) -> Path:
        """``WORK/<id>/report``: the consultation report."""
        return self.patient_dir(case_id) / "report"

    def trash_dir(self, case_id: str) -> Path:
        """``WORK/<id>/trash``: deleted simulations (move one back to restore it)."""
        return self.patient_dir(case_id) / TRASH_FOLDER

    @property
    def index_file(self) -> Path:
        """``WORK/index.sqlite``: the patient list (a cache of the folders)."""
        return self.root / INDEX_FILE

    def patient_ids(self) -> list[str]:
        """The ids of the patient folders in ``WORK`` (real folders with a valid name;
        symbolic links are not patients), sorted."""
        try:
            entries = list(os.scandir(self.root))
        except OSError:
            return []
        return sorted(e.name for e in entries
                      if is_patient_id(e.name) and e.is_dir(follow_symlinks=False))

    def inside(self, case_id: str, path: str | os.PathLike[str]) -> Path:
        """``path`` if it lies in ``WORK/<id>`` with no symbolic link on the way (the
        patient folder itself included), whether or not it exists yet.

        Raises:
            NaseviewError: a symbolic link (or a non-folder) on the way, naming it.
        """
        top = self.patient_dir(case_id)
        p = Path(path)
        try:
            rel = p.relative_to(top)
        except ValueError:
            raise NaseviewError(f"{p}: not inside the patient folder {top}") from None
        if ".." in rel.parts:
            raise NaseviewError(f"{p}: '..' in a path inside the patient folder {top}")
        here = top
        for part in ("", *rel.parts):
            here = here / part if part else here
            try:
                st = os.lstat(here)
            except FileNotFoundError:
                break
            except OSError as e:
                raise NaseviewError(f"{here}: cannot read ({one_line(e)})") from None
            if stat.S_ISLNK(st.st_mode):
                raise NaseviewError(f"{here}: is a symbolic link; naseview follows no link "
                                    f"inside the work folder {self.root} (replace it by "
                                    "the folder or file itself)")
        return p

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
        return all(p.name in OWN_FOLDERS for p in entries) and (
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
        if not is_patient_id(cid):
            raise NaseviewError(f"case id {cid!r}: a name naseview uses in the work "
                                "folder; choose a different id")
        who = self.holder(cid, session)
        if who is not None:
            raise NaseviewError(f"case id {cid!r} is already used by another patient "
                                f"({who}); choose a different id, or open that patient")
        return cid

    def rename(self, session: AnnotationSession, case_id: str) -> None:
        """Give ``session`` the id ``case_id`` if no other patient has it (see
        :meth:`check_id`); nothing changes otherwise."""
        session.set_case_id(self.check_id(case_id, session))

    def new_session(self, case_id: str | None = None, lazy: bool = False
                    ) -> AnnotationSession:
        """A new patient in a fresh folder ``WORK/in-progress/<id>`` (``<id>-2``... when
        that name is in use; the folder is created exclusively).

        Args:
            case_id: the id; ``None`` for :func:`default_case_id` (made unique with
                ``-2``, ``-3``... when another patient has it).
            lazy: create the folder only on the patient's first real input (a photo, a
                distance: :meth:`AnnotationSession.pending`), so that opening the page
                and leaving leaves nothing behind.
        Raises:
            NaseviewError: ``case_id`` is given and another patient has it.
        """
        cid = self.check_id(case_id) if case_id is not None else self._free_default_id()
        if lazy:
            return AnnotationSession.pending(self.in_progress / cid, cid,
                                             self._make_folder)
        return AnnotationSession.create(self._make_folder(cid), cid)

    def _free_default_id(self) -> str:
        """:func:`default_case_id`, with ``-2``, ``-3``... when another patient has it or
        this process gave it out already (two tabs opening the new-patient page in the
        same second: their lazy sessions have no folder yet to tell them apart)."""
        base = default_case_id()
        cid, k = base, 2
        with _ISSUED_LOCK:
            while self.holder(cid) is not None or cid in _ISSUED:
                cid, k = f"{base}-{k}", k + 1
            _ISSUED.add(cid)
        return cid

    def _make_folder(self, cid: str) -> Path:
        """Create ``WORK/in-progress/<cid>`` (``<cid>-2``... when taken) exclusively."""
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
            return folder
        raise NaseviewError(f"{self.in_progress}: too many folders named {cid!r}")

    def find(self, case_id: str) -> ExistingPatient | None:
        """The existing patient with ``case_id`` (its newest readable unfinished
        annotation and its case directory), or ``None``."""
        cid = safe_case_id(case_id)
        annotation = next((a.folder for a in self.annotations()
                           if a.problem is None and not a.finished
                           and a.case_id.casefold() == cid.casefold()), None)
        case = self.case_dir(cid) if is_patient_id(cid) else None
        case_dir = case if case is not None and (case / "case.json").is_file() else None
        if annotation is None and case_dir is None:
            return None
        return ExistingPatient(cid, annotation, case_dir)


__all__ = ["ExistingPatient", "PatientFolders", "is_patient_id", "is_simulation_slug"]
