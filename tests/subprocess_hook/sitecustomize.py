"""Loaded at start-up by the Python subprocesses the tests start with
``setup_cache.subprocess_env()`` (this folder on PYTHONPATH; ``naseview serve`` in
``helpers.naseview_serve``): when ``naseview.texture.bake`` is imported, its
``skin_texture`` is replaced by the cached bake of ``tests/setup_cache.py``, so the
server's texture of a reconstruction the tests baked before comes from the cache.

Nothing of naseview is imported here: at start-up the subprocess's working folder (the
checkout under test) is not yet on ``sys.path``.
"""

from __future__ import annotations

import os
import sys


def _install() -> None:
    import functools
    import importlib.abc
    import importlib.util
    from pathlib import Path

    folder = Path(os.environ["NASEVIEW_TEST_BAKE_CACHE"])
    spec = importlib.util.spec_from_file_location(
        "_naseview_setup_cache", Path(__file__).resolve().parents[1] / "setup_cache.py")
    assert spec is not None and spec.loader is not None
    setup_cache = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(setup_cache)

    class BakeHook(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):  # type: ignore[no-untyped-def]
            if name != "naseview.texture.bake":
                return None
            sys.meta_path.remove(self)            # once: find the module as usual
            found = importlib.util.find_spec(name)
            if found is None or found.loader is None:
                return found
            exec_module = found.loader.exec_module

            def exec_and_patch(module):  # type: ignore[no-untyped-def]
                exec_module(module)
                module.skin_texture = functools.partial(
                    setup_cache.cached_bake, module.skin_texture, folder)

            found.loader.exec_module = exec_and_patch  # type: ignore[method-assign]
            return found

    sys.meta_path.insert(0, BakeHook())


if os.environ.get("NASEVIEW_TEST_BAKE_CACHE"):
    _install()
