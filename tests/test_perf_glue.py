"""The mesh LoD stage's glue (joining, welding, locks, the meshopt wrapper, splitting, the
silhouette floor) gives exactly what it gave before it was made faster: :func:`build_mesh_chain`
on generated buildings against the frozen copy in ``tests/legacy_glue`` (several seeds, both
engines, with and without ``preserve_uv_seam_edges``), bit for bit on every level's parts
(positions, triangles, UVs, normals), its flags, tolerance and ``deviation``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from legacy_glue import simplify as legacy

from exporter.config import Config
from exporter.readers import load_entry, scan_folder
from exporter.samplegen import generate_buildings, generate_tile
from exporter.simplify import build_mesh_chain


def same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def assert_same_chain(new, old) -> None:
    assert len(new) == len(old)
    for k, (a, b) in enumerate(zip(new, old)):
        where = f"level {k}"
        assert (a.exact, a.surface_exact) == (b.exact, b.surface_exact), where
        assert same(a.tolerance, b.tolerance), where
        assert same(a.deviation, b.deviation), where
        assert len(a.parts) == len(b.parts), where
        for p, q in zip(a.parts, b.parts):
            for name in ("positions", "triangles", "uvs", "normals"):
                assert same(getattr(p, name), getattr(q, name)), f"{where} {name}"
            assert (p.name, p.texture is q.texture, p.color) == (q.name, True, q.color), where


OPTIONS = {
    "meshoptimizer": {},
    "meshoptimizer-no-seams": {"preserve_uv_seam_edges": False},
    "pymeshlab": {"engine": "pymeshlab"},
    "pymeshlab-no-seams": {"engine": "pymeshlab", "preserve_uv_seam_edges": False},
    "link-distance": {"vertex_link_distance": 0.05},
}


@pytest.fixture(scope="module")
def buildings(tmp_path_factory):
    # In memory (exact coordinates) and read back from a tile (reprojection noise to weld).
    made = [
        b
        for seed in (3, 11, 29)
        for b in generate_buildings(6, seed, atlas_size=64, two_part_share=0.5)
    ]
    folder = tmp_path_factory.mktemp("tile")
    generate_tile(str(folder), count=8, seed=7, atlas_size=64)
    readers = Config().readers
    read = [load_entry(e, readers) for e in scan_folder(str(folder), readers).entries]
    # Split vertices 0.3 um apart: LOD0's noise welding moves them (a nonzero weld offset).
    rng = np.random.default_rng(2)
    noisy = [
        dataclasses.replace(
            b,
            parts=[
                dataclasses.replace(
                    p, positions=p.positions + rng.uniform(-3e-7, 3e-7, (len(p.positions), 3))
                )
                for p in b.parts
            ],
        )
        for b in made[:6]
    ]
    return made + read + noisy


@pytest.mark.parametrize("case", sorted(OPTIONS))
def test_build_mesh_chain_equals_the_former_glue(buildings, case):
    config = Config()
    options = dataclasses.replace(config.simplify, **OPTIONS[case])
    for building in buildings:
        parts = building.parts
        new = build_mesh_chain(parts, config.lods, options)
        old = legacy.build_mesh_chain(parts, config.lods, options)
        assert_same_chain(new, old)


def test_build_mesh_chain_equals_the_former_glue_with_normals(buildings):
    # Normals on the parts: _split picks every output vertex's normal from the source.
    config = Config()
    rng = np.random.default_rng(5)
    for building in buildings[:8]:
        parts = [
            dataclasses.replace(p, normals=rng.normal(size=(p.vertex_count, 3)))
            for p in building.parts
        ]
        new = build_mesh_chain(parts, config.lods, config.simplify)
        old = legacy.build_mesh_chain(parts, config.lods, config.simplify)
        assert_same_chain(new, old)
