"""The simplifier's glue moved off per-call numpy work: compiled face areas (exporter/mesh/c/area.c)
and the exact-match shortcut of the split's normal lookup, each against the numpy form it
replaces, bit for bit, on generated buildings and on random and degenerate input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from exporter.mesh.geometry import cross_rows, row_norms
from exporter.samplegen import generate_buildings
from exporter.simplify import nearest_rows
from exporter.simplify.protect import face_areas


def reference_face_areas(positions, faces):
    """The former numpy face_areas (protect.py before area.c)."""
    a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    return 0.5 * row_norms(cross_rows(b - a, c - a))


def same_bits(x, y) -> bool:
    return x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


@pytest.fixture(scope="module")
def buildings():
    return generate_buildings(6, seed=11, atlas_size=16, two_part_share=0.5)


def test_face_areas_equal_numpy_on_generated_buildings(buildings):
    for building in buildings:
        for part in building.parts:
            got = face_areas(part.positions, part.triangles)
            assert same_bits(got, reference_face_areas(part.positions, part.triangles))


def test_face_areas_equal_numpy_on_random_and_degenerate_faces():
    rng = np.random.default_rng(5)
    for scale in (1e-9, 1e-3, 1.0, 1e3, 1e7):
        positions = rng.normal(size=(60, 3)) * scale
        positions[:5] = positions[5]  # repeated positions: zero-area faces
        positions[10:15] = positions[20] + np.outer(np.arange(5), [1.0, 2.0, 3.0]) * scale
        faces = rng.integers(0, 60, size=(400, 3))
        faces[:20, 1] = faces[:20, 0]  # repeated indices
        faces[20:40] = rng.integers(10, 15, size=(20, 3))  # collinear
        assert same_bits(face_areas(positions, faces), reference_face_areas(positions, faces))
        faces32 = faces.astype(np.int32)
        assert same_bits(face_areas(positions, faces32), reference_face_areas(positions, faces32))
    # float32 positions keep numpy's float32 arithmetic
    p32 = rng.normal(size=(30, 3)).astype(np.float32)
    f = rng.integers(0, 30, size=(50, 3))
    assert same_bits(face_areas(p32, f), reference_face_areas(p32, f))
    assert face_areas(np.zeros((0, 3)), np.zeros((0, 3), np.int64)).shape == (0,)


def test_face_areas_refuse_out_of_range_faces():
    with pytest.raises(ValueError, match="outside"):
        face_areas(np.zeros((3, 3)), np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="outside"):
        face_areas(np.zeros((3, 3)), np.array([[0, -1, 2]]))


def test_nearest_rows_give_the_tree_s_values():
    rng = np.random.default_rng(8)
    for _ in range(60):
        n = int(rng.integers(1, 80))
        src = np.round(rng.normal(size=(n, 5)), 1)
        src[rng.integers(0, n, n // 3)] = src[rng.integers(0, n, n // 3)]  # duplicates
        src[: n // 4, 0] = -0.0 * src[: n // 4, 0]  # signed zeros
        values = rng.integers(0, 3, size=(n, 3)).astype(np.float32)
        # Duplicate rows with equal values (the shortcut) and with different ones (the tree).
        query = np.concatenate(
            [
                src[rng.integers(0, n, 30)],
                src[rng.integers(0, n, 10)] + rng.normal(size=(10, 5)) * 1e-7,
            ]
        )
        query[:3, 0] = np.abs(query[:3, 0])
        nearest = nearest_rows(src, query, values)
        expected = cKDTree(src).query(query)[1]
        assert same_bits(values[nearest], values[expected])
