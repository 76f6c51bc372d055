"""The compiled equal-row kernels (exporter/mesh/c/weld.c) against the numpy forms they replace,
bit for bit: ``weld_positions`` with ``distance <= 0`` (exact duplicates, clusters numbered by
their lowest member), with ``distance > 0`` (the tree over distinct positions only) and
``unique_float_rows`` (np.unique(axis=0) order, first occurrences,
inverse), on random rows full of duplicates, -0.0 / 0.0, NaN and ties, on empty and one-row
input, and on the rows the mesh stage hands them for generated buildings."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import exporter.mesh.geometry as geometry
import exporter.mesh.hausdorff as hausdorff
import exporter.mesh.weld as weld
import exporter.simplify as simplify
import exporter.simplify.meshopt as meshopt
from exporter.mesh import _weld
from exporter.mesh.component_kernels import lowest_member
from exporter.mesh.geometry import unique_float_rows
from exporter.mesh.weld import join_meshes, weld_positions


def reference_exact_weld(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The former ``weld_positions(positions, 0.0)``: np.unique rows, renumbered by lowest member."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    n = len(positions)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    _, first, inverse = np.unique(positions, axis=0, return_index=True, return_inverse=True)
    labels = inverse.reshape(-1)
    first = np.full(labels.max() + 1, n, dtype=np.int64)
    np.minimum.at(first, labels, np.arange(n))
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    welded = rank[labels].astype(np.int64)
    return welded, positions[first[order]]


def reference_near_weld(positions: np.ndarray, distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The former ``weld_positions(positions, distance > 0)``: the tree over every position."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    pairs = cKDTree(positions).query_pairs(r=float(distance), output_type="ndarray")
    lowest = lowest_member(len(positions), pairs[:, 0], pairs[:, 1])
    root = lowest == np.arange(len(positions))
    return (np.cumsum(root) - 1)[lowest], positions[root]


def reference_unique_float_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The former ``unique_float_rows``: one stable lexsort, groups of rows equal by ``!=``."""
    order = np.lexsort(keys.T[::-1])
    ordered = keys[order]
    start = np.ones(len(order), dtype=bool)
    start[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    inverse = np.empty(len(order), dtype=np.int64)
    inverse[order] = np.cumsum(start) - 1
    return order[start], inverse


def assert_same(got: tuple, expected: tuple) -> None:
    for a, b in zip(got, expected, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes()  # bit for bit: -0.0 and NaN payloads included


def duplicated_rows(rng: np.random.Generator, n: int, w: int, nan: bool) -> np.ndarray:
    """(n, w) float64 from a few values, so rows repeat and columns tie: signed zeros, a
    subnormal, infinities and (if ``nan``) NaN among them."""
    values = np.array([0.0, -0.0, 1.0, -1.0, 0.5, 5e-324, 1e300, np.inf, -np.inf, 2.0])
    if nan:
        values = np.append(values, np.nan)
    few = rng.choice(values, size=(max(1, n // 4), w))
    return few[rng.integers(0, len(few), n)]


@pytest.mark.parametrize("nan", [False, True])
def test_exact_weld_equals_numpy_unique(nan):
    rng = np.random.default_rng(24)
    for n in [0, 1, 2, 3, 7, 40, 300, 2000]:
        for _ in range(5):
            positions = duplicated_rows(rng, n, 3, nan)
            got = weld_positions(positions, 0.0)
            assert_same(got, reference_exact_weld(positions))
            assert_same(weld_positions(positions, -1.0), got)


@pytest.mark.parametrize("distance", [1e-6, 0.05, 0.7])
def test_near_weld_of_duplicated_positions_equals_the_tree_over_all(distance):
    # The tree now sees each distinct position once: the clusters and their numbering must not
    # change, with exact duplicates, near ones (noise below and above the distance) and chains.
    rng = np.random.default_rng(int(distance * 1e6))
    for n in [1, 2, 5, 40, 300]:
        for _ in range(6):
            positions = duplicated_rows(rng, n, 3, False)
            positions = np.where(np.isfinite(positions) & (np.abs(positions) < 1e3), positions, 3.0)
            noise = rng.normal(size=(n, 3)) * distance * rng.choice([0.0, 0.3, 2.0], size=(n, 1))
            positions = np.vstack([positions, positions + noise])[rng.permutation(2 * n)]
            got = weld_positions(positions, distance)
            assert_same(got, reference_near_weld(positions, distance))


@pytest.mark.parametrize("scale", [1.0, 100.0, 3e4])
@pytest.mark.parametrize("distance", [1e-6, 0.01, 0.5])
def test_near_weld_at_the_distance_equals_the_tree(scale, distance):
    # Pairs at the distance to within a few ulps either way (axis-aligned ones exact): the
    # compiled pair search must join exactly the pairs the tree joins.
    rng = np.random.default_rng(int(scale + distance * 1e6))
    base = rng.uniform(-scale, scale, size=(60, 3))
    direction = rng.normal(size=(60, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    direction[:20] = np.eye(3)[rng.integers(0, 3, 20)] * rng.choice([-1.0, 1.0], size=(20, 1))
    tweak = 1.0 + rng.integers(-4, 5, size=(60, 1)) * np.finfo(float).eps
    positions = np.vstack([base, base + direction * (distance * tweak)])[rng.permutation(120)]
    got = weld_positions(positions, distance)
    assert_same(got, reference_near_weld(positions, distance))
    assert len(got[1]) < 120  # some pairs do join


def test_near_weld_of_non_finite_input_asks_the_tree():
    positions = np.array([[0.0, 0, 0], [1e-7, 0, 0], [5.0, 5, 5], [2e-7, 0, 0], [5.0, 5, 5]])
    assert_same(weld_positions(positions, np.inf), reference_near_weld(positions, np.inf))
    positions[2, 1] = np.inf  # refused by the tree, as before
    with pytest.raises(ValueError, match="finite"):
        reference_near_weld(positions, 1e-6)
    with pytest.raises(ValueError, match="finite"):
        weld_positions(positions, 1e-6)
    with pytest.raises(ValueError, match="rows has 2 along axis 1"):
        _weld.near(np.zeros((3, 2)), 1.0)


def test_exact_weld_of_signed_zeros_keeps_the_lowest_members_bits():
    positions = np.array([[-0.0, 1, 2], [0.0, 1, 2], [0.0, -0.0, 0], [-0.0, 0.0, -0.0]])
    welded, points = weld_positions(positions)
    assert welded.tolist() == [0, 0, 1, 1]
    assert np.signbit(points).tolist() == [[True, False, False], [False, True, False]]
    nan = np.array([[np.nan, 0, 0], [np.nan, 0, 0], [1, 2, 3]])
    # A NaN equals nothing (numpy's comparison): each NaN row is a cluster of its own.
    assert weld_positions(nan)[0].tolist() == [0, 1, 2]


def test_exact_weld_of_a_strided_float32_view():
    rng = np.random.default_rng(5)
    rows = duplicated_rows(rng, 600, 6, False)
    positions = np.where(np.abs(rows) == 1e300, 3.0, rows).astype(np.float32)[::2, 1:4]
    assert not positions.flags.c_contiguous
    assert_same(weld_positions(positions), reference_exact_weld(positions))


@pytest.mark.parametrize("w", [1, 2, 3, 4, 5, 7])
@pytest.mark.parametrize("nan", [False, True])
def test_unique_float_rows_equals_the_lexsort(w, nan):
    rng = np.random.default_rng(w)
    for n in [0, 1, 2, 3, 9, 64, 333, 3000]:
        for _ in range(4):
            keys = duplicated_rows(rng, n, w, nan)
            assert_same(unique_float_rows(keys), reference_unique_float_rows(keys))


def test_unique_float_rows_of_distinct_and_of_equal_rows():
    rng = np.random.default_rng(2)
    keys = rng.normal(size=(500, 3))  # no ties: a plain lexicographic sort
    assert_same(unique_float_rows(keys), reference_unique_float_rows(keys))
    same = np.tile([[-0.0, 3.0]], (50, 1))
    same[::3, 0] = 0.0
    first, inverse = unique_float_rows(same)
    assert first.tolist() == [0] and inverse.tolist() == [0] * 50


def test_unique_float_rows_refuses_rows_it_cannot_sort():
    for bad in [np.zeros(3), np.zeros((3, 0)), np.zeros((2, 2, 2))]:
        with pytest.raises(ValueError, match="unique_float_rows"):
            unique_float_rows(bad)
    for kernel in (_weld.exact, _weld.unique):
        with pytest.raises(ValueError, match="rows must have 2 dimensions"):
            kernel(np.zeros(3))
        with pytest.raises(ValueError, match="castable to float64"):
            kernel(np.array([["a", "b"]], dtype=object))


def test_kernels_on_generated_buildings(monkeypatch):
    # The rows the mesh stage passes (simplify, meshopt wedges, Hausdorff, joined meshes), recorded
    # on generated buildings, then compared with the numpy forms; and the buildings' triangle
    # soups (float32 positions, every corner repeated) welded exactly.
    from exporter import samplegen
    from exporter.config import Config
    from exporter.quality import measure_lod
    from exporter.simplify import build_mesh_chain

    recorded: list[np.ndarray] = []

    def recording(keys):
        recorded.append(np.array(keys, copy=True))
        return unique_float_rows(keys)

    for module in (simplify, meshopt, hausdorff, weld):
        monkeypatch.setattr(module, "unique_float_rows", recording)
    config = Config()
    buildings = samplegen.generate_buildings(4, seed=11, atlas_size=16, two_part_share=0.5)
    for building in buildings:
        chain = build_mesh_chain(building.parts, config.lods, config.simplify)
        for level in chain[1:]:
            measure_lod(chain[0].parts, level.parts)
        for part in building.parts:
            soup = part.positions[part.triangles].reshape(-1, 3)
            assert_same(weld_positions(soup), reference_exact_weld(soup))
            assert_same(weld_positions(soup, 1e-6), reference_near_weld(soup, 1e-6))
            assert_same(weld_positions(soup, 0.3), reference_near_weld(soup, 0.3))
            assert_same(weld_positions(np.round(soup, 1)), reference_exact_weld(np.round(soup, 1)))
        joined = join_meshes([(p.positions, p.triangles) for p in building.parts])
        assert len(joined.positions) < sum(len(p.positions) for p in building.parts)
    widths = {keys.shape[1] for keys in recorded}
    assert len(recorded) > 20 and 3 in widths, widths
    for keys in recorded:
        assert_same(geometry.unique_float_rows(keys), reference_unique_float_rows(keys))
