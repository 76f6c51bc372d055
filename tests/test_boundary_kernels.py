"""The compiled open boundary (:mod:`exporter.mesh.boundary_kernels`) gives the former numpy
form's border sides, border edges and loop count (kept here as the reference: one sorted key per side, the keys
used once, a Python union-find): on generated buildings, their slit-closed meshes and random
face soups (repeated, degenerate and non-manifold faces); bad vertex ids are errors."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.geometry import sorted_edge_keys
from exporter.mesh.slits import border_sides, close_slits
from exporter.mesh.topology import boundary_loops


def reference_count_components(edges: list) -> int:
    """Connected components of the graph of ``edges`` (only vertices on an edge count)."""
    parent: dict[int, int] = {}

    def find(x: int) -> int:
        while parent[x] != x:
            x = parent[x]
        return x

    count = 0
    for a, b in edges:
        for v in (a, b):
            if v not in parent:
                parent[v] = v
                count += 1
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
            count -= 1
    return count


def reference_boundary_loops(faces, vertex_count):
    """The former numpy body of ``topology.boundary_loops``."""
    first, second = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    keys = np.sort(np.minimum(first, second) * (vertex_count + 1) + np.maximum(first, second))
    once = np.ones(len(keys), dtype=bool)
    if len(keys) > 1:
        repeated = keys[1:] == keys[:-1]
        once[1:] &= ~repeated
        once[:-1] &= ~repeated
    border = np.column_stack(np.divmod(keys[once], vertex_count + 1))
    return border, reference_count_components(border.tolist())


def reference_border_sides(faces, vertex_count):
    """The former numpy body of ``slits.border_sides``."""
    ordered, order = sorted_edge_keys(faces, vertex_count)
    once = np.ones(len(ordered), dtype=bool)
    if len(ordered) > 1:
        repeated = ordered[1:] == ordered[:-1]
        once[1:] &= ~repeated
        once[:-1] &= ~repeated
    return np.sort(order[once])


def _same(faces, vertex_count):
    if len(faces) == 0 or faces.max() < vertex_count:
        sides = border_sides(faces, vertex_count)
        assert sides.dtype == np.int64
        assert np.array_equal(sides, reference_border_sides(faces, vertex_count))
    border, loops = boundary_loops(faces, vertex_count)
    expected, expected_loops = reference_boundary_loops(faces, vertex_count)
    assert border.dtype == np.int64 and border.shape == expected.shape
    assert np.array_equal(border, expected) and loops == expected_loops
    return loops


def test_generated_buildings_and_their_closed_slits():
    from exporter import samplegen
    from exporter.quality import joined

    loops = []
    for building in samplegen.generate_buildings(20, seed=6):
        positions, faces = joined(building.parts)
        loops.append(_same(faces, len(positions)))
        _same(close_slits(positions, faces, None)[0], len(positions))
    assert max(loops) > 0  # open buildings were met


def test_random_face_soups():
    rng = np.random.default_rng(13)
    loops = []
    for _ in range(100):
        vertices = int(rng.integers(3, 60))
        faces = rng.integers(0, vertices, size=(int(rng.integers(1, 80)), 3))
        loops.append(_same(faces, vertices + int(rng.integers(0, 3))))
    assert max(loops) > 1
    assert _same(np.zeros((0, 3), np.int64), 4) == 0


def test_bad_vertex_ids_are_errors():
    with pytest.raises(ValueError, match="boundary_loops"):
        boundary_loops(np.array([[0, 1, -1]]), 3)
    with pytest.raises(ValueError, match="boundary_loops"):
        boundary_loops(np.array([[0, 1, 9]]), 3)
    with pytest.raises(ValueError, match="border_sides"):
        border_sides(np.array([[0, 1, 3]]), 3)
