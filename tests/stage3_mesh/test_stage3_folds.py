"""No folded skin on a real face (issue 27 item 1): the generic face warped onto james-a
turned the alar skin over itself, a brown flap 5-7 mm out of the left nostril and dark
slits along both alar grooves; lps-a had 250 triangles turned over.

A triangle is folded when its normal in the reconstruction points against its normal in
the fitted face model (the model's own shape, which has no such flap). End to end on the
photo cases of ../shared/data/scan-cases (james-a: a face scan, lps-a: Lee Perry-Smith's
head, CC BY 3.0), both face models."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from naseview.case import read_case
from naseview.geometry.unfold import folded_faces, unfold
from naseview.pipeline import reconstruct

CASES = Path(__file__).resolve().parents[3] / "shared" / "data" / "scan-cases"

MAX_FOLDED = {"generic": 8, "ict": 2}
"""Nose triangles still turned over after stage 3 (before issue 27: james-a generic 51,
lps-a generic 240); the few left are single triangles ARAP tips over at the alar crease,
too small to see."""


def test_unfold_smooths_a_pulled_vertex_and_keeps_the_fixed_ones() -> None:
    xs, ys = np.meshgrid(np.arange(6.0), np.arange(6.0))
    V = np.c_[xs.ravel(), ys.ravel(), np.zeros(36)]
    F = np.array([[r * 6 + c, r * 6 + c + 1, (r + 1) * 6 + c] for r in range(5)
                  for c in range(5)] + [[r * 6 + c + 1, (r + 1) * 6 + c + 1,
                                         (r + 1) * 6 + c] for r in range(5) for c in range(5)])
    W = V.copy()
    W[14] += [-1.6, -1.4, 0.0]                       # dragged across its neighbours
    assert len(folded_faces(W, F, V)) > 0
    fixed = np.zeros(36, bool)
    fixed[[0, 35]] = True
    U, left = unfold(W, F, V, fixed=fixed)
    assert left == 0 and len(folded_faces(U, F, V)) == 0
    assert np.array_equal(U[fixed], W[fixed])
    assert np.allclose(unfold(V, F, V)[0], V)        # nothing folded: nothing moves


@pytest.mark.parametrize("case", ["james-a", "lps-a"])
@pytest.mark.parametrize("model", ["generic", "ict"])
def test_no_flap_or_fold_in_the_nose(case: str, model: str) -> None:
    path = CASES / case
    assert (path / "case.json").is_file(), f"{path} not found: ../shared is needed"
    res = reconstruct(read_case(path), model)
    R = res.refined
    assert R is not None
    nose = np.zeros(len(R.V), bool)
    nose[R.nose_vertex_ids] = True
    in_nose = np.flatnonzero(nose[R.F].all(1))
    # folds the model fit itself has (its own creases) are not stage 3's
    own = set(folded_faces(R.fit.vertices, R.F, R.model.mean, in_nose).tolist())
    folded = [f for f in folded_faces(R.V, R.F, R.fit.vertices, in_nose) if f not in own]
    assert len(folded) <= MAX_FOLDED[model], (
        f"{case} on {model}: {len(folded)} nose triangles folded over, at "
        f"{np.round(R.V[R.F[folded[:5]]].mean(1), 1).tolist()}")
