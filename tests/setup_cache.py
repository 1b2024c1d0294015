"""Set-up made once per version of the code, shared by every test process (xdist's
workers, the servers a test starts) through a cache on disk.

A cached item is keyed by everything that makes it: the sources and data of naseview,
the demo case, the face model file, naseview's environment variables, the numeric
libraries' versions, this file and ``helpers.py`` (the commands that make the items) and
this checkout's path (an output folder names its case relative to itself), so a test
still sees what the code makes today. The cache lives in the system's temporary folder
(``<tmp>/naseview-test-cache/<key>``), never in the repository.

Only the standard library and numpy are imported here: ``subprocess_hook/sitecustomize.py``
loads this file in a ``naseview serve`` subprocess before naseview is imported.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CACHE_ROOT = Path(tempfile.gettempdir()) / "naseview-test-cache"
HOOK_DIR = Path(__file__).resolve().parent / "subprocess_hook"
"""On a subprocess's PYTHONPATH (with ``BAKE_CACHE_ENV``): its texture bakes use the cache."""
BAKE_CACHE_ENV = "NASEVIEW_TEST_BAKE_CACHE"
"""Environment variable naming the cache folder for the subprocess hook."""


@functools.cache
def code_key() -> str:
    """SHA-256 (hex) of what the cached set-ups are made from (see the module doc)."""
    from importlib.metadata import PackageNotFoundError, version

    h = hashlib.sha256()
    h.update(f"{REPO}\n{sys.version}\n".encode())
    for dist in ("numpy", "scipy", "opencv-python-headless", "libigl", "trimesh", "viser"):
        try:
            h.update(f"{dist} {version(dist)}\n".encode())
        except PackageNotFoundError:            # not installed under that name
            h.update(f"{dist} ?\n".encode())
    for k in sorted(os.environ):
        if k.startswith("NASEVIEW_") and k not in ("NASEVIEW_WORK_DIR", BAKE_CACHE_ENV):
            h.update(f"{k}={os.environ[k]}\n".encode())
    files = [f for d in (REPO / "naseview", REPO / "assets") for f in sorted(d.rglob("*"))
             if f.is_file() and "__pycache__" not in f.parts]
    files += [Path(__file__).resolve(), Path(__file__).resolve().parent / "helpers.py"]
    model = os.environ.get("NASEVIEW_ICT_MODEL")
    if model and Path(model).is_file():
        files.append(Path(model))
    for f in files:
        h.update(f"{f}\n".encode())
        h.update(hashlib.sha256(f.read_bytes()).digest())
    return h.hexdigest()


@functools.cache
def cache_dir() -> Path:
    """``<tmp>/naseview-test-cache/<code key>`` (created; the caches of other versions
    not used for a week are removed)."""
    d = CACHE_ROOT / code_key()[:20]
    d.mkdir(parents=True, exist_ok=True)
    os.utime(d)
    for old in CACHE_ROOT.iterdir():
        try:
            if old != d and time.time() - old.stat().st_mtime > 7 * 86400:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            pass
    return d


@contextmanager
def file_lock(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` between processes (and threads)."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def bake_key(V: Any, F: Any, cameras: Mapping[str, Any], photos: Mapping[str, Any],
             params: Any) -> str:
    """SHA-256 (hex) of a bake's inputs: the mesh, the cameras, the photos, the
    parameters."""
    h = hashlib.sha256()

    def arr(a: Any) -> None:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())

    arr(V)
    arr(F)
    for v in sorted(cameras):
        c = cameras[v]
        h.update(f"cam {v} {c.width} {c.height}".encode())
        for a in (c.K, c.R, c.t):
            arr(np.asarray(a, dtype=np.float64))
    for v in sorted(photos):
        h.update(f"photo {v}".encode())
        arr(photos[v])
    h.update(repr(params).encode())
    return h.hexdigest()


_BAKES: dict[str, Any] = {}


def _copy_texture(tex: Any) -> Any:
    """A copy of a FaceTexture (a test may change the arrays it was given)."""
    return type(tex)(tex.uv.copy(), tex.image.copy(), tex.coverage.copy(),
                     tex.vertex_colors.copy(), {k: g.copy() for k, g in tex.gains.items()},
                     dict(tex.view_share))


def cached_bake(skin_texture: Callable[..., Any], folder: Path, V: Any, F: Any,
                cameras: Mapping[str, Any], photos: Mapping[str, Any],
                params: Any = None) -> Any:
    """``skin_texture(V, F, cameras, photos, params)`` (naseview.texture.bake's), made
    once per set of inputs: kept in memory and in ``folder`` (a :func:`cache_dir`). A
    bake that gives None (no photo, a refused photo: logged) is never cached."""
    from naseview.texture.bake import FaceTexture

    key = bake_key(V, F, cameras, photos, params)
    hit = _BAKES.get(key)
    if hit is not None:
        return _copy_texture(hit)
    path = folder / f"bake-{key[:32]}.npz"
    with file_lock(folder / f"bake-{key[:32]}.lock"):
        if path.is_file():
            with np.load(path) as z:
                tex = FaceTexture(z["uv"], z["image"], z["coverage"], z["vertex_colors"],
                                  {k[5:]: z[k] for k in z.files if k.startswith("gain:")},
                                  {k[6:]: float(z[k]) for k in z.files
                                   if k.startswith("share:")})
        else:
            tex = skin_texture(V, F, cameras, photos, params)
            if tex is None:
                return None
            part = folder / f"{path.name}.{os.getpid()}.part.npz"
            np.savez(part, uv=tex.uv, image=tex.image, coverage=tex.coverage,
                     vertex_colors=tex.vertex_colors,
                     **{f"gain:{k}": g for k, g in tex.gains.items()},
                     **{f"share:{k}": np.float64(s) for k, s in tex.view_share.items()})
            os.replace(part, path)
    _BAKES[key] = tex
    return _copy_texture(tex)


def cached_skin_texture(V: Any, F: Any, cameras: Mapping[str, Any],
                        photos: Mapping[str, Any], params: Any = None) -> Any:
    """:func:`naseview.texture.bake.skin_texture`, baked once per version of the code
    and set of inputs (:func:`cached_bake` in :func:`cache_dir`)."""
    from naseview.texture import bake

    return cached_bake(bake.skin_texture, cache_dir(), V, F, cameras, photos, params)


def subprocess_env() -> dict[str, str]:
    """Environment variables that make a Python subprocess (``naseview serve``) bake its
    textures through the cache too (``subprocess_hook/sitecustomize.py``)."""
    path = os.environ.get("PYTHONPATH")
    return {"PYTHONPATH": str(HOOK_DIR) + (os.pathsep + path if path else ""),
            BAKE_CACHE_ENV: str(cache_dir())}
