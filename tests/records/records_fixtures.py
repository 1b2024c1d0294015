"""Helpers of the records tests (the fixtures are in this folder's conftest.py): a small
work folder with one patient whose case and reconstruction are on disk, and an editable
grid baseline of that reconstruction."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from helpers import GaussianSolver

from naseview.editing.baseline import Baseline
from naseview.editing.controller import EditController
from naseview.pipeline import PipelineResult
from naseview.reconstruction import Reconstruction
from naseview.records import PatientRecords, SavedReconstruction


def grid_result(case_root: Path, lift: float = 0.0) -> PipelineResult:
    """A 6 x 6 vertex face (mm, 2 mm spacing) with four landmarks, as stage 3 returns it
    for ``case_root``; ``lift`` moves the face up (another reconstruction)."""
    xs, ys = np.meshgrid(np.arange(-5.0, 6.0, 2.0), np.arange(-5.0, 6.0, 2.0))
    V = np.column_stack([xs.ravel(), ys.ravel() + lift, np.zeros(36)])
    idx = np.arange(36).reshape(6, 6)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.column_stack([a.ravel(), c.ravel(), b.ravel()]),
                   np.column_stack([b.ravel(), c.ravel(), d.ravel()])])
    lms = {"g": V[2].copy(), "prn": V[14].copy(), "al_l": V[15].copy(), "al_r": V[13].copy()}
    rec = Reconstruction(landmarks=lms, measurements={"n-prn": 4.0})
    return PipelineResult(reconstruction=rec, face_vertices=V, faces=F,
                          nose_vertex_ids=idx[1:5, 1:5].ravel(), case_root=case_root)


def write_case_json(folder: Path, case_id: str, note: str = "") -> Path:
    """A ``case.json`` (the records only hash it and read its id)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "case.json").write_text(json.dumps(
        {"format": "naseview.case/1", "id": case_id, "views": {}, "notes": note}))
    return folder


@dataclass
class Patient:
    """A patient in a work folder with its case, saved reconstruction and baseline."""

    records: PatientRecords
    pid: str
    saved: SavedReconstruction
    baseline: Baseline

    def controller(self) -> EditController:
        return EditController(self.baseline, GaussianSolver(self.baseline))

    def first_simulation(self) -> str:
        """A first simulation of the patient (no edit), on disk and closed: its slug."""
        ctl = self.controller()
        auto = self.records.start_simulation(self.pid, ctl, delay=60.0,
                                             reconstruction_sha256=self.saved.sha256)
        auto.close()
        ctl.close()
        return auto.slug


