"""``naseview model import-ict DIR`` on a folder that holds an already-converted
``ict_face_light.npz`` (e.g. ``../shared/data/ict-face-model``): validated and copied.

Installs go to a temporary NASEVIEW_DATA_DIR; the shared model is never modified.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.facemodel import store
from naseview.facemodel.ict import ICT_CREDIT


def test_import_folder_with_converted_npz_copies_it(ict_dir: Path, data_dir: Path) -> None:
    path = store.import_ict(ict_dir)
    assert path == data_dir / "models" / "ict_face_light.npz"
    assert path.read_bytes() == (ict_dir / "ict_face_light.npz").read_bytes()
    assert store.find_ict_npz() == path


def test_cli_import_folder_with_converted_npz(ict_dir: Path, data_dir: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["model", "import-ict", str(ict_dir)]) == 0
    out = capsys.readouterr().out
    assert str(data_dir / "models" / "ict_face_light.npz") in out and ICT_CREDIT in out
    assert "100 identity modes" in out


def test_import_folder_with_invalid_npz_names_it(tmp_path: Path, data_dir: Path) -> None:
    folder = tmp_path / "converted"
    folder.mkdir()
    np.savez(folder / "ict_face_light.npz", mean=np.zeros((10, 3)))
    with pytest.raises(NaseviewError, match=r"ict_face_light\.npz: key 'faces' missing"):
        store.import_ict(folder)
    assert not (data_dir / "models").exists()
