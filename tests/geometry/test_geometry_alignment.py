"""Umeyama's similarity between corresponding point sets (naseview.geometry.alignment)."""

from __future__ import annotations

import numpy as np
import pytest

from naseview.geometry.alignment import umeyama


def test_umeyama_recovers_a_similarity() -> None:
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 3)) * 20
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    a, b, c, d = q
    R = np.array([[a*a+b*b-c*c-d*d, 2*(b*c-a*d), 2*(b*d+a*c)],
                  [2*(b*c+a*d), a*a-b*b+c*c-d*d, 2*(c*d-a*b)],
                  [2*(b*d-a*c), 2*(c*d+a*b), a*a-b*b-c*c+d*d]])
    Y = 1.3 * X @ R.T + [1, -2, 3]
    s, R2, t = umeyama(X, Y)
    assert s == pytest.approx(1.3) and np.allclose(R2, R) and np.allclose(t, [1, -2, 3])
