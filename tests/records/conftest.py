"""Fixtures of the records tests (helpers: records_fixtures.py)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from records_fixtures import Patient, grid_result, write_case_json

from naseview.editing.baseline import baseline_from_pipeline
from naseview.records import PatientRecords


@pytest.fixture()
def patient(tmp_path: Path) -> Iterator[Patient]:
    records = PatientRecords(tmp_path / "work")
    case = write_case_json(records.folders.case_dir("P001"), "P001")
    result = grid_result(case)
    saved = records.save_reconstruction("P001", result)
    yield Patient(records, "P001", saved, baseline_from_pipeline(result))
    records.close()
