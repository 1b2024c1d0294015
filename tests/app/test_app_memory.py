"""The server's malloc settings (naseview.app.memory, issue 26 item 13): on glibc the
arena limit is taken (a wrong parameter number or binding makes mallopt return 0);
benchmarks/bench_memory.py measures the effect (RSS over 100 tab open/close cycles)."""

from __future__ import annotations

import platform

import pytest

from naseview.app.memory import limit_malloc_arenas, release_freed_memory


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                    reason="mallopt and malloc_trim are glibc's")
def test_glibc_takes_the_arena_limit() -> None:
    assert limit_malloc_arenas() is True
    release_freed_memory()
