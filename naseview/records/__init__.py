"""A patient's work is kept: the patient folder as the source of truth; no viser here.

- :mod:`~naseview.records.store`: :class:`PatientRecords`, what the app calls (patient
  list, open a patient, save a reconstruction, named simulations with autosave);
- :mod:`~naseview.records.patient`: ``WORK/<id>/patient.json`` (a case kept elsewhere is
  linked by path + SHA-256, never copied) and ``WORK/<id>/reconstruction``;
- :mod:`~naseview.records.simulations`: ``WORK/<id>/simulations/<slug>.json`` session
  files: create, rename, duplicate, delete (to the trash), open;
- :mod:`~naseview.records.autosave`: :class:`Autosave`, every committed edit written
  atomically, debounced on a worker thread;
- :mod:`~naseview.records.index`: ``WORK/index.sqlite``, the patient list, rebuilt from the
  folders whenever it is missing, damaged or stale.

The layout (every path) lives in :class:`naseview.intake.patients.PatientFolders`.
"""

from naseview.records.autosave import Autosave
from naseview.records.index import PatientIndex, PatientSummary, SimulationSummary
from naseview.records.patient import SavedReconstruction
from naseview.records.simulations import SimulationInfo
from naseview.records.store import OpenedPatient, PatientRecords

__all__ = ["Autosave", "OpenedPatient", "PatientIndex", "PatientRecords", "PatientSummary",
           "SavedReconstruction", "SimulationInfo", "SimulationSummary"]
