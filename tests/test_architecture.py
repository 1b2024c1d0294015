"""The package's layers run one way (README, "Architecture").

Every ``import`` of a naseview module, at module top or inside a function, is read with
:mod:`ast`; a module may import only its own package or a unit of a strictly lower layer.
A unit is a top-level module (``naseview/case.py``) or package (``naseview/stage2_curves/``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "naseview"

# Lower number = lower layer. Core types first (file I/O, then photo files on it), then
# geometry and face models, the three stages (peers: none imports another), the photo
# texture (it uses stage 2's background mask), the pipeline (it bakes the texture of its
# textured exports), editing/intake/testbed, report, app and the command line.
LAYERS: dict[str, int] = {
    "errors": 0, "landmarks": 0, "stages": 0, "image_data": 0,
    "fileio": 1, "camera": 1, "params": 1,
    "imagefile": 2,
    "case": 3, "reconstruction": 3, "meshio": 3,
    "geometry": 4,
    "facemodel": 5, "render": 5, "measurements": 5,
    "stage1_landmarks": 6, "stage2_curves": 6, "stage3_mesh": 6,
    "texture": 7,
    "pipeline": 8,
    "editing": 9, "intake": 9, "testbed": 9,
    "report": 10, "records": 10,
    "app": 11,
    "cli": 12, "__main__": 13,
}


def _unit(module: str) -> str:
    """``naseview.stage2_curves.mask`` -> ``stage2_curves``; ``naseview`` -> ``""``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _submodule(mod: str, name: str) -> str:
    """``from mod import name``: ``mod.name`` when that is a module, else ``mod``."""
    where = PACKAGE.parent.joinpath(*mod.split("."), name)
    return f"{mod}.{name}" if where.with_suffix(".py").is_file() or where.is_dir() else mod


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every naseview import in ``path``."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("naseview")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod == "naseview" or mod.startswith("naseview."):
                out += [(node.lineno, _submodule(mod, a.name)) for a in node.names]
    return out


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_every_unit_has_a_layer():
    units = {_unit(_module_name(p)) for p in _sources()} - {""}
    assert units <= set(LAYERS), f"add {sorted(units - set(LAYERS))} to LAYERS"


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path: Path):
    me = _unit(_module_name(path))
    bad = []
    for line, mod in _imports(path):
        other = _unit(mod)
        if other in ("", "__init__") or other == me:
            continue
        if me and LAYERS[other] >= LAYERS[me]:
            bad.append(f"{path.relative_to(PACKAGE)}:{line} imports {mod} "
                       f"(layer {LAYERS[other]} >= {LAYERS[me]})")
    assert not bad, "\n".join(bad)


def test_no_import_cycles_between_modules():
    """Imports form no cycle (a reader and a tool see one direction): every import counts,
    at module top, type-only under ``if TYPE_CHECKING:`` and inside a function alike (a
    circle that only type hints or a lazy import close is still a circle of concepts)."""
    graph = {_module_name(path): {m for _, m in _imports(path)} for path in _sources()}
    state: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt not in graph:
                continue
            if state.get(nxt) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack + [node, nxt]))
            if nxt not in state:
                visit(nxt, stack + [node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


def test_only_the_command_line_imports_the_app_entry_point():
    """``naseview.app.serve`` is the entry point: the pieces of the app see one another
    through narrow protocols (``app/host.py``), never the module that builds them all."""
    bad = [f"{path.relative_to(PACKAGE)}:{line}" for path in _sources()
           for line, mod in _imports(path)
           if mod == "naseview.app.serve" and _module_name(path) not in ("naseview.cli",
                                                                         "naseview.app.serve")]
    assert not bad, "imports naseview.app.serve: " + ", ".join(bad)


MAX_MODULE_LINES = 700
"""No module of naseview/ is longer (issue 25): a longer one does more than one job."""


def test_no_module_is_over_700_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in _sources()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not long, f"split by job: {long}"
