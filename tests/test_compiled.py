"""The compiled kernels (``exporter/mesh/c/*.c``, built by setup.py into ``exporter.mesh._<name>``):
every source has its module, built from the current source, and a type stub that lists exactly
the functions the module has; a kernel gives the same result from threads running at once (they
run without the GIL, as a Dask worker's threads do)."""

from __future__ import annotations

import ast
import importlib
import re
import threading
from pathlib import Path

import numpy as np
import pytest

MESH = Path(__file__).resolve().parents[1] / "exporter" / "mesh"
SOURCES = sorted((MESH / "c").glob("*.c"))


def _included_headers(source: Path) -> list[Path]:
    """The project headers ``source`` includes, followed through the headers themselves."""
    seen: list[Path] = []
    todo = [source]
    while todo:
        text = todo.pop().read_text()
        for name in re.findall(r'#include "([^"]+)"', text):
            header = MESH / "c" / name
            if header not in seen:
                seen.append(header)
                todo.append(header)
    return seen


def test_there_are_sources():
    assert len(SOURCES) >= 10


@pytest.mark.parametrize("source", SOURCES, ids=[s.stem for s in SOURCES])
def test_module_is_built_from_the_current_source(source):
    module = importlib.import_module(f"exporter.mesh._{source.stem}")
    built = Path(module.__file__).stat().st_mtime
    stale = [p.name for p in [source, *_included_headers(source)] if p.stat().st_mtime > built]
    assert not stale, (
        f"exporter.mesh._{source.stem} is older than {stale}: rebuild with `pip install -e .`"
    )


@pytest.mark.parametrize("source", SOURCES, ids=[s.stem for s in SOURCES])
def test_stub_lists_the_module_functions(source):
    module = importlib.import_module(f"exporter.mesh._{source.stem}")
    stub = MESH / f"_{source.stem}.pyi"
    assert stub.exists(), f"{stub.name} missing (mypy needs a stub per compiled module)"
    declared = {
        node.name for node in ast.parse(stub.read_text()).body if isinstance(node, ast.FunctionDef)
    }
    present = {name for name in dir(module) if not name.startswith("__")}
    assert declared == present


def test_kernel_gives_the_same_result_in_threads():
    from exporter.mesh.distance_kernels import point_triangle_distance

    rng = np.random.default_rng(0)
    points, tri = rng.normal(size=(20000, 3)), rng.normal(size=(20000, 3, 3))
    expected = point_triangle_distance(points, tri)
    results: list = [None] * 4

    def run(i: int) -> None:
        results[i] = point_triangle_distance(points, tri)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for result in results:
        assert np.array_equal(result, expected)
