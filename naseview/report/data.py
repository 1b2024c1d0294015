"""What a consultation report shows, the sentences every report carries, and the rule
for which free-text notes a report may print.

Example
-------
>>> surgeon_notes("synthetic case: naseview synth --model generic --seed 7")
''
>>> surgeon_notes("Discussed a small hump reduction; review in 3 months.")
'Discussed a small hump reduction; review in 3 months.'
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from naseview.measurements import Estimate
from naseview.texture.bake import FaceTexture

DISCLAIMER = "A simulation is not a promised outcome."
"""The sentence every report carries (also in the de-identified version)."""

DISCLAIMER_DETAIL = (
    "The pictures after the simulation show a computer model of your nose changed by the "
    "planned steps. Healing, skin thickness and cartilage behave differently in every "
    "person, so the result of an operation can differ from these pictures.")
"""The plain-language explanation under :data:`DISCLAIMER`."""

ACCURACY_STATEMENT = (
    "How accurate is the 3D model? Tested on photos of a real face scan (two photo sets "
    "of one person), the 3D nose surface was on average 0.65-0.86 mm from the scan, and "
    "95 % of it within 1.6-2.2 mm. Faces differ, and your result may be less accurate.")
"""The accuracy the report claims, from the real-scan benchmark
``benchmarks/bench_real.py`` (issue 11 figures, ICT base face model, nose surface to the
scan: james-a mean 0.653 mm / 95th percentile 1.646 mm, james-b 0.859 mm / 2.217 mm).
Two photo sets of one person: update this sentence when the benchmark has more faces."""

_MACHINE_NOTES = re.compile(
    r"^\s*synthetic case\b"          # written by `naseview synth`
    r"|\bnaseview\s+[a-z]+\b"        # a naseview command line
    r"|(^|\s)(--[a-z][\w-]*|-[a-z](\s|$))",   # a command-line option (--seed, -o)
    re.IGNORECASE)


def surgeon_notes(notes: str) -> str:
    """The notes a report prints: ``notes`` stripped, or ``""`` when it is machine text.

    Rule: notes are machine text (and never printed) when they start with "synthetic
    case", name a ``naseview <command>``, or contain a command-line option (``--seed``,
    ``-o``); everything else is taken as typed by the surgeon and printed as it is.
    """
    text = (notes or "").strip()
    return "" if not text or _MACHINE_NOTES.search(text) else text


@dataclass
class ReportData:
    """What a report shows (SPEC frame, mm).

    Attributes:
        case_id: the case's id (``case.json`` ``id``); the title of the full report when
            there is no ``patient_name``, never the folder name.
        V_before: (N, 3) face mesh of the reconstruction.
        F: (M, 3) triangles.
        nose_ids: (K,) vertices of the nose region.
        measurements_before: name -> value of the reconstruction.
        V_after: (N, 3) simulated mesh, or ``None`` (no simulation: "before" only).
        measurements_after: name -> value after the simulation, or ``None``.
        photos: view -> (H, W, 3) uint8 BGR photo (may be empty).
        notes: the surgeon's free text; printed only when it is not machine text
            (:func:`surgeon_notes`), never in the de-identified version.
        credit: face model credit line.
        date: date shown in the header (default today).
        texture: the patient's own skin baked from the photos for ``V_before``'s mesh
            (:func:`naseview.texture.bake.bake_texture`), or ``None`` (plain skin colour).
            Never used in the de-identified version.
        manoeuvres: the planned surgical manoeuvres, name -> amount (mm or degrees,
            :data:`naseview.editing.manoeuvres.MANOEUVRES`); empty: none planned.
        surgeon, clinic: who wrote the report (full version only).
        patient_name: the patient's name, the title of the full report ("" : the case id).
        calliper: the case's calliper distances, ``"<id>-<id>"`` -> mm (``case.json``
            ``scale_mm``, e.g. ``{"al_l-al_r": 34.5}``, as echoed by
            :func:`naseview.reconstruction.calliper_distances`): the measurements equal
            to them are labelled as measured with a calliper at the visit, not as
            findings.
        estimated: measurement name -> :class:`~naseview.measurements.Estimate`: the
            values shown as estimates with their uncertainty
            (:func:`naseview.measurements.estimated_measurements` of the
            reconstruction; radix height when mf is seen in one photo).
    """

    case_id: str
    V_before: np.ndarray
    F: np.ndarray
    nose_ids: np.ndarray
    measurements_before: dict[str, float]
    V_after: np.ndarray | None = None
    measurements_after: dict[str, float] | None = None
    photos: dict[str, np.ndarray] = field(default_factory=dict)
    notes: str = ""
    credit: str = ""
    date: str = ""
    texture: FaceTexture | None = None
    manoeuvres: dict[str, float] = field(default_factory=dict)
    surgeon: str = ""
    clinic: str = ""
    patient_name: str = ""
    calliper: dict[str, float] = field(default_factory=dict)
    estimated: dict[str, Estimate] = field(default_factory=dict)
