"""The compiled edge keys (:mod:`exporter.mesh.edge_kernels`, behind
``geometry.sorted_edge_keys`` and ``topology.edge_use``) give the former numpy forms' keys,
stable order, edges and their uses (kept here as the reference): on generated buildings, random
face soups (repeated, degenerate, non-manifold faces) and a fan of 500 triangles around one
vertex; bad vertex ids are errors."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.geometry import sorted_edge_keys
from exporter.mesh.topology import edge_use


def reference_sorted_edge_keys(faces, vertex_count):
    """The former numpy body of ``geometry.sorted_edge_keys``."""
    sides = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    low, high = sides.min(axis=1), sides.max(axis=1)
    keys = low * vertex_count + high
    order = np.argsort(keys, kind="stable")
    return keys[order], order


def reference_edge_use(faces):
    """The former numpy body of ``topology.edge_use``."""
    if len(faces) == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    corners = np.asarray(faces, dtype=np.int64)
    ahead = corners[:, [1, 2, 0]]
    low, high = np.minimum(corners, ahead).reshape(-1), np.maximum(corners, ahead).reshape(-1)
    base = int(high.max()) + 1
    keys = np.sort(low * base + high)
    start = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]]))
    counts = np.concatenate([start[1:], [len(keys)]]) - start
    unique = np.empty((len(start), 2), np.int64)
    unique[:, 0], unique[:, 1] = np.divmod(keys[start], base)
    return unique, counts


def _same(faces, vertex_count):
    edges, uses = edge_use(faces.copy())  # a new array: edge_use keeps the last result
    expected_edges, expected_uses = reference_edge_use(faces)
    assert edges.dtype == uses.dtype == np.int64
    assert np.array_equal(edges, expected_edges) and np.array_equal(uses, expected_uses)
    keys, order = sorted_edge_keys(faces, vertex_count)
    expected_keys, expected_order = reference_sorted_edge_keys(faces, vertex_count)
    assert keys.dtype == order.dtype == np.int64
    assert np.array_equal(keys, expected_keys) and np.array_equal(order, expected_order)


def test_generated_buildings():
    from exporter import samplegen
    from exporter.quality import joined

    for building in samplegen.generate_buildings(20, seed=8):
        positions, faces = joined(building.parts)
        _same(faces, len(positions))


def test_random_face_soups_and_a_large_fan():
    rng = np.random.default_rng(14)
    for _ in range(100):
        vertices = int(rng.integers(3, 40))
        faces = rng.integers(0, vertices, size=(int(rng.integers(1, 120)), 3))
        _same(faces, vertices + int(rng.integers(0, 3)))
    ring = rng.permutation(np.arange(1, 501))
    fan = np.column_stack([np.zeros(500, np.int64), ring, np.roll(ring, -1)])
    _same(np.concatenate([fan, fan[:7]]), 501)
    _same(np.zeros((0, 3), np.int64), 3)


def test_bad_vertex_ids_are_errors():
    with pytest.raises(ValueError, match="sorted_edge_keys"):
        sorted_edge_keys(np.array([[0, 1, 3]]), 3)
    with pytest.raises(ValueError, match="edge_use"):
        edge_use(np.array([[0, 1, -1]]))
