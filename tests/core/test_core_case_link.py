"""An output folder beside its case (``reconstruct case -o out``) finds that case's photos,
and only that case's: the link is bound to the SHA-256 of the case.json it was made from."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from helpers import write_projected_case

from naseview.cli import main
from naseview.errors import NaseviewError
from naseview.reconstruction import Reconstruction, output_case_dir, read_reconstruction


def test_an_output_beside_its_case_follows_it_and_nothing_else(tmp_path: Path):
    case_dir = write_projected_case(tmp_path / "case", seed=81)
    out = tmp_path / "out"
    assert main(["reconstruct", str(case_dir), "-o", str(out), "--stages", "1"]) == 0
    rec = read_reconstruction(out / "reconstruction.json")
    assert output_case_dir(out, rec) == case_dir.resolve()
    # another patient's case copied over the path: same folder name, other case.json
    other = write_projected_case(tmp_path / "other", seed=82)
    shutil.rmtree(case_dir)
    shutil.copytree(other, case_dir)
    with pytest.raises(NaseviewError, match="not the case this output was reconstructed"):
        output_case_dir(out, rec)
    # a hand-edited link to the other folder is refused the same way
    obj = json.loads((out / "reconstruction.json").read_text())
    obj["case_dir"] = "../other"
    rec2 = Reconstruction.from_json(obj)
    with pytest.raises(NaseviewError, match="outside the output folder"):
        output_case_dir(out, rec2)
