"""Install, find and load the ICT Face Model (the ``naseview model ...`` commands).

The ICT Face Model is the preferred base face of stage 3 — mesh (paper §3.4, the 3D
morphable model). Its Light version lives in one ``.npz`` (format: ``mean`` (9409, 3)
float32 mm, ``faces`` (18460, 3) int32, ``basis`` (K, 9409, 3) float32 mm with
``basis[k] = identityK - neutral``, ``units`` = ``"mm"``, ``source``), found in this order:

1. the file named by the environment variable ``NASEVIEW_ICT_MODEL``;
2. ``<user data dir>/models/ict_face_light.npz``, where the user data dir is
   ``$NASEVIEW_DATA_DIR``, else ``$XDG_DATA_HOME/naseview``, else
   ``~/.local/share/naseview``.

It is installed by :func:`import_ict` (an ICT-FaceKit checkout, its ``FaceXModel/``
folder, a ready ``.npz`` or a folder holding ``ict_face_light.npz``; OBJ files are read by
:func:`naseview.meshio.read_obj`) or :func:`fetch_ict` (downloads the OBJ files from
GitHub: the only network access naseview makes). The model is ICT-FaceKit by the USC
Institute for Creative Technologies, MIT licence; :data:`ICT_CREDIT` is printed wherever it
is installed or shown.

Example
-------
>>> from naseview.facemodel.store import find_ict_npz, load_ict_npz
>>> path = find_ict_npz()                             # doctest: +SKIP
>>> fm = load_ict_npz(path)                           # doctest: +SKIP
>>> fm.mean.shape, fm.basis.shape                     # doctest: +SKIP
((9409, 3), (100, 9409, 3))
"""

from __future__ import annotations

import argparse
import functools
import io
import os
import re
import shutil
import sys
import tempfile
import urllib.error
import urllib.request
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from naseview.errors import NaseviewError
from naseview.facemodel.ict import (
    ICT_CREDIT,
    ICT_LANDMARK_VERTICES,
    ICT_N_VERTICES,
    ict_face_model,
)
from naseview.facemodel.model import FaceModel
from naseview.fileio import atomic_write_bytes, one_line
from naseview.meshio import read_obj, triangulate_polygons

ICT_BASE_URL = "https://raw.githubusercontent.com/ICT-VGL/ICT-FaceKit/master/FaceXModel/"
"""Default download location of the ICT-FaceKit OBJ files."""

ICT_NPZ_NAME = "ict_face_light.npz"
ICT_ENV = "NASEVIEW_ICT_MODEL"
DATA_DIR_ENV = "NASEVIEW_DATA_DIR"

ICT_FULL_VERTICES = 26719
"""Vertices of ICT-FaceKit's ``generic_neutral_mesh.obj`` (head, eyes, mouth, ...)."""
ICT_FACE_POLYGONS = 9230
"""The face area is polygons 0..9229 (quads) over vertices 0..9408 of that mesh."""
ICT_N_IDENTITIES = 100
CM_TO_MM = 10.0

_FIX = "re-run `naseview model fetch` or `naseview model import-ict DIR`"


def user_data_dir() -> Path:
    """naseview's user data folder: ``$NASEVIEW_DATA_DIR``, ``$XDG_DATA_HOME/naseview`` or
    ``~/.local/share/naseview`` (empty variables count as unset)."""
    env = os.environ.get(DATA_DIR_ENV)
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_DATA_HOME")
    if xdg:
        return Path(xdg).expanduser() / "naseview"
    return Path.home() / ".local" / "share" / "naseview"


def ict_install_path() -> Path:
    """Where :func:`import_ict` / :func:`fetch_ict` write the model."""
    return user_data_dir() / "models" / ICT_NPZ_NAME


def find_ict_npz() -> Path | None:
    """The installed ICT model file, or ``None``.

    ``$NASEVIEW_ICT_MODEL`` first, then :func:`ict_install_path`.

    Raises:
        NaseviewError: ``NASEVIEW_ICT_MODEL`` is set but names no file.
    """
    env = os.environ.get(ICT_ENV)
    if env:
        p = Path(env).expanduser()
        if not p.is_file():
            raise NaseviewError(
                f"{p}: file not found (named by {ICT_ENV}); fix or unset the variable")
        return p
    p = ict_install_path()
    return p if p.is_file() else None


def read_ict_arrays(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read and validate an ICT-format ``.npz``; arrays as stored (plus ``units``).

    Checks: readable zip, keys ``mean``/``faces``/``basis``, shapes (9409, 3),
    (F, 3) with ids in range, (K, 9409, 3) with K >= 1, finite values, ``units`` "mm",
    millimetre-sized face with the nose tip at vertex 4841.

    Raises:
        NaseviewError: one line naming the file, the key and the fix.
    """
    path = Path(path)
    if not path.is_file():
        raise NaseviewError(f"{path}: face model file not found; {_FIX}")
    try:
        npz = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        raise NaseviewError(f"{path}: not a readable .npz file ({one_line(e)}); {_FIX}") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise NaseviewError(f"{path}: a single .npy array, not an .npz archive; {_FIX}")
    out: dict[str, np.ndarray] = {}
    with npz:
        for key in ("mean", "faces", "basis"):
            if key not in npz.files:
                raise NaseviewError(
                    f"{path}: key '{key}' missing; expected an ICT Face Model .npz with "
                    f"mean, faces, basis; {_FIX}")
        for key in ("mean", "faces", "basis", "units", "source"):
            if key not in npz.files:
                continue
            try:
                out[key] = npz[key]
            except (OSError, ValueError, zipfile.BadZipFile, zlib.error, EOFError) as e:
                raise NaseviewError(
                    f"{path}: key '{key}' unreadable ({one_line(e)}); {_FIX}") from None
    _validate_arrays(path, out)
    return out


def _validate_arrays(path: Path, a: dict[str, np.ndarray]) -> None:
    """The checks of :func:`read_ict_arrays` on the arrays read from ``path``."""
    nv = ICT_N_VERTICES
    mean, faces, basis = a["mean"], a["faces"], a["basis"]
    if mean.dtype.kind != "f" or mean.shape != (nv, 3):
        raise NaseviewError(
            f"{path}: key 'mean' is {mean.dtype}{mean.shape}, expected float ({nv}, 3) "
            f"(the ICT face area); {_FIX}")
    if faces.dtype.kind not in "iu" or faces.ndim != 2 or faces.shape[1] != 3 or not len(faces):
        raise NaseviewError(
            f"{path}: key 'faces' is {faces.dtype}{faces.shape}, expected integer (F, 3); {_FIX}")
    if faces.min() < 0 or faces.max() >= nv:
        raise NaseviewError(
            f"{path}: key 'faces' has vertex ids outside 0..{nv - 1}; {_FIX}")
    if basis.dtype.kind != "f" or basis.ndim != 3 or basis.shape[1:] != (nv, 3) or not len(basis):
        raise NaseviewError(
            f"{path}: key 'basis' is {basis.dtype}{basis.shape}, expected float (K, {nv}, 3) "
            f"with K >= 1; {_FIX}")
    for key in ("mean", "basis"):
        if not np.isfinite(a[key]).all():
            raise NaseviewError(f"{path}: key '{key}' has NaN or infinite values; {_FIX}")
    if "units" in a and str(a["units"]) != "mm":
        raise NaseviewError(f"{path}: key 'units' is {str(a['units'])!r}, expected 'mm'; {_FIX}")
    width = float(np.ptp(mean[:, 0]))
    if not 80.0 < width < 400.0:
        raise NaseviewError(
            f"{path}: key 'mean' is {width:.1f} units wide, expected a face in millimetres "
            f"(80..400); {_FIX}")
    tip = ICT_LANDMARK_VERTICES["prn"]
    if mean[tip, 2] < mean[:, 2].max() - 5.0:
        raise NaseviewError(
            f"{path}: key 'mean' is not the ICT face (vertex {tip}, the nose tip, is not the "
            f"most anterior point); {_FIX}")


def load_ict_npz(path: str | os.PathLike[str]) -> FaceModel:
    """Load an ICT-format ``.npz`` as a :class:`FaceModel` (see :func:`ict_face_model`).

    Cached per resolved path (and file modification time/size), so repeated calls are
    free; the returned arrays are read-only because they are shared.

    Raises:
        NaseviewError: missing, unreadable or invalid file (names the file and the key).
    """
    p = Path(path).expanduser()
    if not p.is_file():
        raise NaseviewError(f"{p}: face model file not found; {_FIX}")
    p = p.resolve()
    st = p.stat()
    return _load_cached(str(p), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=4)
def _load_cached(path: str, mtime_ns: int, size: int) -> FaceModel:
    """The model of ``path``; ``mtime_ns`` and ``size`` only key the cache."""
    fm = ict_face_model(read_ict_arrays(path))
    for arr in (fm.mean, fm.faces, fm.basis, fm.nose_vertices, fm.nostril_vertices,
                *fm.curve_vertices.values()):
        arr.flags.writeable = False
    return fm


def _npz_bytes(mean_mm: np.ndarray, faces: np.ndarray, basis_mm: np.ndarray,
               source: str) -> bytes:
    """The ``.npz`` file of the module docstring's format (float32 mm, int32 faces)."""
    buf = io.BytesIO()
    np.savez_compressed(buf, mean=mean_mm.astype(np.float32), faces=faces.astype(np.int32),
                        basis=basis_mm.astype(np.float32), units=np.array("mm"),
                        source=np.array(source))
    return buf.getvalue()


def _facexmodel_dir(source: Path) -> Path:
    """The folder holding ``generic_neutral_mesh.obj``: ``source/FaceXModel`` or ``source``."""
    for d in (source / "FaceXModel", source):
        if (d / "generic_neutral_mesh.obj").is_file():
            return d
    raise NaseviewError(
        f"{source}: no generic_neutral_mesh.obj here or in FaceXModel/, and no {ICT_NPZ_NAME}; "
        f"give an ICT-FaceKit checkout, its FaceXModel folder, or a converted .npz")


def _identity_files(folder: Path) -> list[Path]:
    """``identityNNN.obj`` files of ``folder``, by number."""
    found = []
    for p in folder.iterdir():
        m = re.fullmatch(r"identity(\d{3})\.obj", p.name)
        if m and p.is_file():
            found.append((int(m.group(1)), p))
    return [p for _, p in sorted(found)]


def convert_facekit(folder: str | os.PathLike[str],
                    progress: Callable[[int, int], None] | None = None
                    ) -> dict[str, np.ndarray | str]:
    """ICT-FaceKit OBJ files -> the arrays of the ``.npz`` format (mm).

    Args:
        folder: a ``FaceXModel`` folder (or a checkout containing one) with
            ``generic_neutral_mesh.obj`` and ``identity000.obj`` ... (any number >= 1).
        progress: optional callback ``(done, total)`` per identity file read.
    Returns:
        ``mean`` (9409, 3) mm, ``faces`` (18460, 3), ``basis`` (K, 9409, 3) mm with
        ``basis[k] = identityK - neutral``, ``source`` text; float64 / int64.
    Raises:
        NaseviewError: missing files or files that are not ICT-FaceKit's (names the file).
    """
    d = _facexmodel_dir(Path(folder))
    neutral_path = d / "generic_neutral_mesh.obj"
    ids = _identity_files(d)
    if not ids:
        raise NaseviewError(f"{d}: no identity000.obj ... identity099.obj beside "
                            f"generic_neutral_mesh.obj; the identity shapes are needed")
    neutral = read_obj(neutral_path)
    nv = len(neutral.vertices)
    if nv != ICT_FULL_VERTICES or len(neutral.sizes) < ICT_FACE_POLYGONS:
        raise NaseviewError(
            f"{neutral_path}: {nv} vertices and {len(neutral.sizes)} faces, expected "
            f"{ICT_FULL_VERTICES} vertices (ICT-FaceKit's generic neutral mesh)")
    sizes = neutral.sizes[:ICT_FACE_POLYGONS]
    idx = neutral.indices[: int(sizes.sum())]
    if idx.max() >= ICT_N_VERTICES:
        raise NaseviewError(
            f"{neutral_path}: the first {ICT_FACE_POLYGONS} faces use vertices beyond "
            f"{ICT_N_VERTICES - 1}; not ICT-FaceKit's face-area layout")
    faces = triangulate_polygons(idx, sizes)
    v0 = neutral.vertices[:ICT_N_VERTICES]
    basis = np.empty((len(ids), ICT_N_VERTICES, 3))
    for k, p in enumerate(ids):
        vk = read_obj(p, faces=False).vertices
        if len(vk) != nv:
            raise NaseviewError(
                f"{p}: {len(vk)} vertices, expected {nv} like generic_neutral_mesh.obj")
        basis[k] = (vk[:ICT_N_VERTICES] - v0) * CM_TO_MM
        if progress is not None:
            progress(k + 1, len(ids))
    source = (f"ICT-FaceKit (MIT, USC Institute for Creative Technologies), converted by "
              f"naseview from {d.name}/: face area vertices 0..{ICT_N_VERTICES - 1}, polygons "
              f"0..{ICT_FACE_POLYGONS - 1} (quads split (a,b,c),(a,c,d)), {len(ids)} identity "
              f"modes identityK - neutral, cm -> mm")
    return {"mean": v0 * CM_TO_MM, "faces": faces, "basis": basis, "source": source}


def import_ict(source: str | os.PathLike[str],
               progress: Callable[[int, int], None] | None = None) -> Path:
    """Install the ICT model from an ICT-FaceKit checkout, its ``FaceXModel/``, a converted
    ``.npz``, or a folder holding a converted ``ict_face_light.npz``.

    OBJ files are converted (:func:`convert_facekit`); a ``.npz`` is validated and copied
    (a folder's ``ict_face_light.npz`` is used before any OBJ files beside it). The result
    is written atomically to :func:`ict_install_path`.

    Returns:
        The installed file.
    Raises:
        NaseviewError: unusable source (names the file and what was expected).
    """
    src = Path(source).expanduser()
    if src.is_file():
        if src.suffix.lower() != ".npz":
            raise NaseviewError(
                f"{src}: expected an ICT-FaceKit folder or a converted .npz file")
        return _install_npz(src)
    if not src.is_dir():
        raise NaseviewError(f"{src}: not found; give an ICT-FaceKit checkout, its "
                            f"FaceXModel folder or a converted .npz")
    if (src / ICT_NPZ_NAME).is_file():
        return _install_npz(src / ICT_NPZ_NAME)
    return _install_converted(convert_facekit(src, progress))


def _install_npz(src: Path) -> Path:
    """Validate a converted ``.npz`` (:func:`read_ict_arrays`) and copy it into place."""
    dest = ict_install_path()
    read_ict_arrays(src)
    if dest.exists() and dest.resolve() == src.resolve():
        return dest
    atomic_write_bytes(dest, src.read_bytes())
    return dest


def _install_converted(arrays: dict[str, np.ndarray | str]) -> Path:
    """Write :func:`convert_facekit` arrays as the installed ``.npz``, validated before it
    replaces a working model."""
    dest = ict_install_path()
    mean, faces, basis = (np.asarray(arrays[k]) for k in ("mean", "faces", "basis"))
    data = _npz_bytes(mean, faces, basis, str(arrays["source"]))
    tmp = dest.with_name(dest.name + ".check.npz")
    try:
        atomic_write_bytes(tmp, data)
        read_ict_arrays(tmp)
        os.replace(tmp, dest)
    finally:
        tmp.unlink(missing_ok=True)
    return dest


def _progress_bar(label: str) -> Callable[[int, int], None]:
    """A ``(done, total)`` callback drawing ``label [####....] done/total`` on stderr."""
    def show(done: int, total: int) -> None:
        width = 30
        fill = int(round(width * done / max(total, 1)))
        sys.stderr.write(f"\r{label} [{'#' * fill}{'.' * (width - fill)}] {done}/{total}")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()
    return show


def _download(url: str, dest: Path, timeout: float) -> int:
    """Download ``url`` to ``dest``; returns its size in bytes."""
    try:
        with urllib.request.urlopen(url, timeout=timeout) as resp, open(dest, "wb") as f:
            shutil.copyfileobj(resp, f, length=1 << 20)
    except urllib.error.HTTPError as e:
        raise NaseviewError(
            f"could not download {url}: HTTP {e.code} {e.reason}; check the network or use "
            f"`naseview model import-ict DIR`") from None
    except (urllib.error.URLError, OSError, ValueError) as e:
        reason = e.reason if isinstance(e, urllib.error.URLError) else e
        raise NaseviewError(
            f"could not download {url}: {one_line(reason)}; check the network or use "
            f"`naseview model import-ict DIR`") from None
    return dest.stat().st_size


def fetch_ict(base_url: str | None = None, timeout: float = 60.0) -> Path:
    """Download ICT-FaceKit's ``generic_neutral_mesh.obj`` and ``identity000..099.obj``
    (about 260 MB) into a temporary folder, then :func:`import_ict` it.

    Args:
        base_url: folder URL holding the OBJ files (default :data:`ICT_BASE_URL`).
        timeout: seconds per connection attempt.
    Returns:
        The installed ``.npz``.
    Raises:
        NaseviewError: ``could not download <url>: <reason>; check the network or use
            `naseview model import-ict DIR```.
    """
    base = (base_url or ICT_BASE_URL).rstrip("/") + "/"
    names = ["generic_neutral_mesh.obj"] + [f"identity{k:03d}.obj"
                                            for k in range(ICT_N_IDENTITIES)]
    show = _progress_bar("downloading ICT Face Model")
    with tempfile.TemporaryDirectory(prefix="naseview-ict-") as tmp:
        folder = Path(tmp)
        show(0, len(names))
        for i, name in enumerate(names):
            try:
                _download(base + name, folder / name, timeout)
            except NaseviewError:
                sys.stderr.write("\n")
                raise
            show(i + 1, len(names))
        return import_ict(folder, progress=_progress_bar("converting"))


def model_command(args: argparse.Namespace) -> int:
    """``naseview model import-ict SOURCE | fetch [--url URL] | info``."""
    action = args.model_command
    if action == "import-ict":
        path = import_ict(args.source, progress=_progress_bar("converting"))
        _print_installed(path)
        return 0
    if action == "fetch":
        path = fetch_ict(getattr(args, "url", None))
        _print_installed(path)
        return 0
    if action == "info":
        return _print_info()
    raise NaseviewError(f"unknown model action {action!r}; use import-ict, fetch or info")


def _print_installed(path: Path) -> None:
    """Print what was installed and the ICT credit."""
    fm = load_ict_npz(path)
    print(f"installed face model 'ict': {path} ({fm.n_vertices} vertices, "
          f"{fm.n_modes} identity modes)")
    print(f"credit: {ICT_CREDIT}")


def _print_info() -> int:
    """``naseview model info``: the data folder and every face model naseview can use."""
    print(f"user data dir: {user_data_dir()}")
    path = find_ict_npz()
    if path is None:
        print("ict: not installed; run `naseview model fetch` (download) or "
              "`naseview model import-ict DIR` (an ICT-FaceKit checkout or a folder with "
              f"{ICT_NPZ_NAME})")
    else:
        where = f"from {ICT_ENV}" if os.environ.get(ICT_ENV) else "installed"
        fm = load_ict_npz(path)
        print(f"ict: {path} ({where}; {fm.n_vertices} vertices, {len(fm.faces)} triangles, "
              f"{fm.n_modes} identity modes)")
        print(f"  credit: {ICT_CREDIT}")
    print("generic: built in (naseview's own face; used when 'ict' is not installed)")
    return 0
