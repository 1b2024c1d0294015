"""A small content-keyed cache so stage 2 re-runs only the steps whose inputs changed.

Each step is keyed on a digest of exactly what it reads (the photo's pixels, the
anchors, the cameras and the :class:`~naseview.stage2_curves.params.CurveParams` fields it uses).
Changing, say, ``closing_px`` changes only the nostril steps' keys; masks, edge maps and
paths are served from the cache.

Example
-------
>>> c = StepCache()
>>> c.get("square", digest(3), lambda: 9), c.get("square", digest(3), lambda: -1)
(9, 9)
>>> c.hits, c.misses
({'square': 1}, {'square': 1})
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar, cast

import numpy as np

from naseview.camera import Camera

if TYPE_CHECKING:
    from hashlib import _Hash

T = TypeVar("T")


def _feed(h: _Hash, obj: object) -> None:
    """Feed one key part into the hash: arrays by dtype, shape and bytes, containers
    element by element, numbers and strings by type and value, cameras by K, R, t, size."""
    if isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        h.update(f"nd{a.dtype.str}{a.shape}".encode())
        h.update(a.view(np.uint8).reshape(-1).data if a.size else b"")
    elif isinstance(obj, dict):
        h.update(b"{")
        for k in sorted(obj, key=str):
            _feed(h, str(k))
            _feed(h, obj[k])
        h.update(b"}")
    elif isinstance(obj, (list, tuple)):
        h.update(b"(")
        for x in obj:
            _feed(h, x)
        h.update(b")")
    elif isinstance(obj, (float, np.floating)):
        h.update(repr(float(obj)).encode())
    elif obj is None or isinstance(obj, (str, int, bool, np.integer)):
        h.update(f"{type(obj).__name__}:{obj!r}".encode())
    elif isinstance(obj, Camera):
        _feed(h, (obj.K, obj.R, obj.t, int(obj.width), int(obj.height)))
    else:
        raise TypeError(f"cannot key the cache on {type(obj).__name__}")


def digest(*parts: object) -> str:
    """Hex digest of nested arrays / dicts / lists / numbers / strings / cameras."""
    h = hashlib.sha256()  # hardware-accelerated on most CPUs
    _feed(h, parts)
    return h.hexdigest()[:32]


@dataclass
class StepCache:
    """Least-recently-used store of step results keyed by ``(step, digest)``.

    Attributes:
        max_entries: entries kept per step (older ones are dropped).
        hits, misses: step name -> count, for diagnostics and tests.
    """

    max_entries: int = 16
    hits: dict[str, int] = field(default_factory=dict)
    misses: dict[str, int] = field(default_factory=dict)
    _store: dict[str, OrderedDict[str, object]] = field(default_factory=dict, repr=False)

    def get(self, step: str, key: str, compute: Callable[[], T]) -> T:
        """The cached value of ``step`` for ``key``, computing and storing it if absent."""
        bucket = self._store.setdefault(step, OrderedDict())
        if key in bucket:
            bucket.move_to_end(key)
            self.hits[step] = self.hits.get(step, 0) + 1
            return cast(T, bucket[key])
        value = compute()
        bucket[key] = value
        while len(bucket) > self.max_entries:
            bucket.popitem(last=False)
        self.misses[step] = self.misses.get(step, 0) + 1
        return value

    def reset_stats(self) -> None:
        """Zero the hit and miss counters (the stored values stay)."""
        self.hits.clear()
        self.misses.clear()
