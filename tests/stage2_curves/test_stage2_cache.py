"""The step cache of parameter re-runs: stage2_curves.cache."""

from __future__ import annotations

from naseview.stage2_curves import StepCache


def test_step_cache_reuses_by_key() -> None:
    c = StepCache(max_entries=2)
    calls = []
    for k in (1, 2, 1, 3, 1):
        c.get("s", str(k), lambda k=k: calls.append(k) or k)
    assert calls == [1, 2, 3] and c.hits["s"] == 2
