"""The server's memory over a long consultation: many tabs opened and closed (issue 26).

Every tab builds its own scene and GUI on viser's thread pool and encodes meshes and
textures there; glibc gives each of those threads its own malloc arena (up to 8 per core),
and memory freed in one arena is not reused by another, so the server's resident memory
crept up by about 0.8 MB a tab (``benchmarks/bench_memory.py``: 502 -> 576 MB over 100
tab open/close cycles, +15 % after the first 10; Python's own allocations grew by 0.3 MB).
With at most two arenas it stays flat (+1.5 %): no object leaks, the arenas fragment.

- :func:`limit_malloc_arenas` - at server start: at most :data:`MALLOC_ARENAS` arenas for
  the threads created after it (``mallopt(M_ARENA_MAX)``, as ``MALLOC_ARENA_MAX=2``);
- :func:`release_freed_memory` - when a tab closes: freed memory back to the system
  (``malloc_trim(0)``).

Both do nothing where the C library is not glibc (macOS, Windows, musl).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

MALLOC_ARENAS = 2
"""Largest number of glibc malloc arenas of the server process."""

_M_ARENA_MAX = -8
"""glibc's ``mallopt`` parameter number of ``M_ARENA_MAX`` (malloc.h)."""


@functools.lru_cache(maxsize=1)
def _glibc() -> ctypes.CDLL | None:
    """The process's C library when it is glibc (it has ``mallopt`` and
    ``malloc_trim``), else None."""
    name = ctypes.util.find_library("c")
    if not name:
        return None
    try:
        libc = ctypes.CDLL(name)
        libc.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
        libc.malloc_trim.argtypes = [ctypes.c_size_t]
    except (OSError, AttributeError):
        return None
    return libc


def limit_malloc_arenas(arenas: int = MALLOC_ARENAS) -> bool:
    """At most ``arenas`` malloc arenas from now on; True when glibc took it."""
    libc = _glibc()
    return bool(libc is not None and libc.mallopt(_M_ARENA_MAX, int(arenas)) == 1)


def release_freed_memory() -> None:
    """Return the memory malloc holds free to the system (glibc ``malloc_trim``)."""
    libc = _glibc()
    if libc is not None:
        libc.malloc_trim(0)
