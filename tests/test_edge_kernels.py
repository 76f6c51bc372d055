"""The compiled edge keys (:mod:`exporter.mesh.edge_kernels`, behind
``geometry.sorted_edge_keys``) give the former numpy form's keys and stable order (kept here as
the reference): on generated buildings, random face soups (repeated, degenerate, non-manifold
faces) and a fan of 500 triangles around one vertex; bad vertex ids are errors."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.geometry import sorted_edge_keys


def reference_sorted_edge_keys(faces, vertex_count):
    """The former numpy body of ``geometry.sorted_edge_keys``."""
    sides = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    low, high = sides.min(axis=1), sides.max(axis=1)
    keys = low * vertex_count + high
    order = np.argsort(keys, kind="stable")
    return keys[order], order


def _same(faces, vertex_count):
    keys, order = sorted_edge_keys(faces, vertex_count)
    expected_keys, expected_order = reference_sorted_edge_keys(faces, vertex_count)
    assert keys.dtype == order.dtype == np.int64
    assert np.array_equal(keys, expected_keys) and np.array_equal(order, expected_order)


def test_generated_buildings():
    samplegen = pytest.importorskip("exporter.samplegen")
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
