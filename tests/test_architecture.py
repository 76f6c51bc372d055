"""The import contract of ``exporter/`` (docs/ARCHITECTURE.md, "Layers"): no import cycle between
modules, and no import from a lower layer to a higher one.

An ``ast`` walk over every module's ``import`` statements, those inside functions and under
``TYPE_CHECKING`` included (an import hidden in a function is still a dependency). Importing
``a.b.c`` also runs ``a.b``'s ``__init__``: that edge counts too.
"""

from __future__ import annotations

import ast
import functools
import graphlib
from pathlib import Path

import pytest

EXPORTER = Path(__file__).resolve().parents[1] / "exporter"

# Bottom to top. A module may import its own layer and the layers below it, never one above;
# "mesh" and "base" share the bottom rank but are separate: neither imports the other (the mesh
# layer works on plain arrays, knows no building, configuration or error type).
LAYERS: list[tuple[str, int, tuple[str, ...]]] = [
    ("mesh", 0, ("exporter.mesh",)),
    (
        "base",
        0,
        (
            "exporter",  # the package itself: __version__
            "exporter.errors",
            "exporter.model",
            "exporter.config",
            "exporter.atomic",
            "exporter.json_members",
            "exporter.geodesy",
            "exporter.tiles",
            "exporter.names",
            "exporter.plausible",
            "exporter.scheduler_probe",
        ),
    ),
    (
        "stages",
        1,
        (
            "exporter.formats",
            "exporter.readers",
            "exporter.simplify",
            "exporter.crop",
            "exporter.quality",
            "exporter.textures",
            "exporter.ktx2",
            "exporter.placement",
            "exporter.gltf_writer",
            "exporter.manifest",
            "exporter.tile_index",
            "exporter.tileset",
            "exporter.report",
            "exporter.samplegen",
        ),
    ),
    (
        "run",
        2,
        (
            "exporter.job",
            "exporter.completion",
            "exporter.distributed",
            "exporter.pipeline",
            "exporter.records",
            "exporter.workers",
        ),
    ),
    ("cli", 3, ("exporter.cli", "exporter.__main__")),
]


def module_names(root: Path) -> dict[str, Path]:
    """Every module of the package at ``root``: dotted name -> file (a package is its
    ``__init__.py``)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = [root.name, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def import_graph(root: Path, replaced: dict[str, str] | None = None) -> dict[str, set[str]]:
    """module -> the package's modules it imports (resolved: relative imports, ``from pkg import
    submodule``, the packages run on the way). ``replaced``: file (relative to ``root``) -> the
    text to read instead of the file's."""
    modules = module_names(root)
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        text = (replaced or {}).get(path.relative_to(root).as_posix())
        if text is None:
            text = path.read_text(encoding="utf-8")
        for target in imported_names(text, name, path.name == "__init__.py"):
            if target not in modules:
                continue
            # The packages between the root and the target run their __init__ first, except
            # those the importer is itself inside (already being imported).
            pieces = target.split(".")
            for depth in range(1, len(pieces) + 1):
                step = ".".join(pieces[:depth])
                if step in modules and not (name == step or name.startswith(step + ".")):
                    graph[name].add(step)
    return graph


@functools.cache
def imported_names(text: str, name: str, is_package: bool) -> tuple[str, ...]:
    """Every dotted name the module ``name`` of source ``text`` imports, relative ones resolved
    (``from pkg import x`` gives ``pkg`` and ``pkg.x``: x may be a module)."""
    package = name if is_package else name.rpartition(".")[0]
    targets: list[str] = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            targets += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            targets.append(module)
            targets += [f"{module}.{alias.name}" for alias in node.names]
    return tuple(targets)


def layer_of(module: str) -> tuple[str, int]:
    """(layer name, rank) of a module: the layer listing its longest prefix."""
    best = ("", -1, 0)
    for layer, rank, prefixes in LAYERS:
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best[2]:
                best = (layer, rank, len(prefix))
    if best[1] < 0:
        raise KeyError(f"{module} is in no layer: add it to LAYERS (and docs/ARCHITECTURE.md)")
    return best[0], best[1]


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Every import from a layer to a higher one, or between the two bottom layers."""
    found = []
    for module, targets in sorted(graph.items()):
        layer, rank = layer_of(module)
        for target in sorted(targets):
            their_layer, their_rank = layer_of(target)
            if their_rank > rank or (their_rank == rank and their_layer != layer and rank == 0):
                found.append(f"{module} ({layer}) imports {target} ({their_layer})")
    return found


def import_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle (its modules, the first repeated last), or None."""
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as error:
        return list(error.args[1])
    return None


def test_every_module_has_a_layer():
    for module in import_graph(EXPORTER):
        layer_of(module)  # raises for a module no layer lists


def test_no_import_cycle():
    assert import_cycle(import_graph(EXPORTER)) is None


def test_no_import_from_a_lower_layer_to_a_higher_one():
    assert upward_imports(import_graph(EXPORTER)) == []


def test_the_mesh_layer_imports_nothing_outside_it():
    graph = import_graph(EXPORTER)
    outside = {
        f"{module} -> {target}"
        for module, targets in graph.items()
        if module.startswith("exporter.mesh")
        for target in targets
        if not target.startswith("exporter.mesh")
    }
    assert not outside


@pytest.mark.parametrize(
    ("file", "line", "expected"),
    [
        ("mesh/coverage.py", "from ..simplify import guard", "upward"),  # a stage, from the mesh
        ("mesh/weld.py", "from ..model import Part", "upward"),  # the bottom layers are apart
        ("quality.py", "from .pipeline import export_tiles", "upward"),  # a stage reaching up
        (
            "job.py",
            "    from .pipeline import export_tiles",
            "cycle",
        ),  # in a function, still a cycle
        ("mesh/topology.py", "from . import slits", "cycle"),  # slits imports topology
    ],
)
def test_a_bad_import_is_caught(file, line, expected):
    """The checks above, on the package with one bad import added to one file."""
    text = (EXPORTER / file).read_text(encoding="utf-8")
    text += f"\n\ndef _added():\n{line}\n" if line.startswith(" ") else f"\n{line}\n"
    graph = import_graph(EXPORTER, {file: text})
    assert graph != import_graph(EXPORTER)
    if expected == "upward":
        assert upward_imports(graph)
    else:
        assert import_cycle(graph) is not None
