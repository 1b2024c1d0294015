"""Linear face models (3D morphable models) with nasal landmarks and regions.

A :class:`FaceModel` (``model.py``) is ``mean + sum_k w_k basis[k]`` with ``w_k ~ N(0, 1)``,
in mm, in the SPEC axes (+x subject's left, +y up, +z anterior); its origin is the model's
own (not g). :func:`load_face_model` loads one by name.

Two models ship with naseview:

- ``ict``: ICT Face Model Light (USC Institute for Creative Technologies, MIT licence),
  installed by ``naseview model fetch`` or ``naseview model import-ict``
  (:mod:`naseview.facemodel.ict`, :mod:`naseview.facemodel.store`);
- ``generic``: a face built by naseview's own code, used when nothing is installed
  (:mod:`naseview.facemodel.generic`).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> fm = load_face_model("generic")                   # doctest: +SKIP
>>> V = fm.shape(np.zeros(fm.n_modes))                # doctest: +SKIP
"""

from __future__ import annotations

from naseview.errors import NaseviewError
from naseview.facemodel import generic, store
from naseview.facemodel.model import FaceModel

__all__ = ["FaceModel", "load_face_model"]


def load_face_model(name: str | None = None) -> FaceModel:
    """Load a face model by name or path.

    Args:
        name: ``"ict"`` (installed ICT model), ``"generic"`` (built-in), a path to an
            ICT-format ``.npz``, or ``None`` for ``ict`` when installed, else ``generic``.
    Raises:
        NaseviewError: ``ict`` requested but not installed (names the commands that
            install it), unreadable file.
    """
    if name is None:
        path = store.find_ict_npz()
        return store.load_ict_npz(path) if path is not None else generic.generic_face_model()
    if name == "generic":
        return generic.generic_face_model()
    if name == "ict":
        path = store.find_ict_npz()
        if path is None:
            raise NaseviewError(
                "face model 'ict' is not installed; run `naseview model fetch` (download) or "
                "`naseview model import-ict DIR` (an ICT-FaceKit checkout), or use "
                "--model generic")
        return store.load_ict_npz(path)
    return store.load_ict_npz(name)
