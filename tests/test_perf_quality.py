"""The quality stage's fast paths (issue 8) give exactly what their plain formulations give.

Each test runs a fast path of ``exporter.quality`` and the formulation it replaced (copied here
from commit af57811 as ``reference_*``) on random or crafted input and asserts equality bit for
bit, so a later "speed-up" that changes a metric value fails here. Coordinates are arbitrary
metres (frame-free) unless a building is used (local East/Up/North metres).
"""
import dataclasses

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exporter.config import Config
from exporter.quality import SurfaceIndex, boundary_loops, joined, measure_lod, point_triangle_distance
from exporter.simplify import build_mesh_lods
from test_simplify_shapes import box_building, crafted_building


# --------------------------------------------------------------------------- reference formulations

def reference_boundary_loops(faces, vertex_count):
    """Open-boundary edges and loop count through a COO matrix (af57811)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys, counts = np.unique(edges[:, 0] * (vertex_count + 1) + edges[:, 1], return_counts=True)
    border = np.column_stack(np.divmod(keys[counts == 1], vertex_count + 1))
    if len(border) == 0:
        return border, 0
    graph = coo_matrix((np.ones(len(border)), (border[:, 0], border[:, 1])), shape=(vertex_count, vertex_count))
    count, labels = connected_components(graph, directed=False)
    return border, int(len(np.unique(labels[np.unique(border)])))


def reference_refine(index, points, upper):
    """Exact distances with a (p, m, 3) gap temporary and np.minimum.at (af57811)."""
    exact = upper.copy()
    open_points = np.flatnonzero(upper > 1e-9)
    if len(open_points) == 0 or index.tree is None:
        return exact
    gap = np.sqrt(((points[open_points, None, :] - index.centres[None]) ** 2).sum(-1)) - index.radii[None]
    rows, cols = np.nonzero(gap < upper[open_points, None] - 1e-12)
    if len(rows):
        np.minimum.at(exact, open_points[rows], point_triangle_distance(points[open_points[rows]], index.tri[cols]))
    return exact


def reference_within(index, points, tolerance):
    """Coverage with a nearest-probe query, then a second 6-probe query for the rest (af57811)."""
    if index.tree is None:
        return np.zeros(len(points), dtype=bool)
    inside = index.tree.query(points)[0] <= tolerance
    if (~inside).any():
        rest = points[~inside]
        upper = index.upper(rest)
        near = upper <= tolerance
        if (~near).any():
            near[~near] = reference_refine(index, rest[~near], upper[~near]) <= tolerance
        inside[~inside] = near
    return inside


def reference_max_distance(index, points, chunk=32):
    """Exact maximum from 0, refining the largest upper bounds first (af57811)."""
    if len(points) == 0:
        return 0.0
    upper = index.upper(points)
    order = np.argsort(-upper)
    best = 0.0
    for start in range(0, len(order), chunk):
        if upper[order[start]] <= best:
            break
        take = order[start:start + chunk]
        best = max(best, float(reference_refine(index, points[take], upper[take]).max()))
    return best


# --------------------------------------------------------------------------- inputs

def random_mesh(rng, vertices=80, faces=150):
    """Random triangles (some degenerate: repeated corners), metres."""
    positions = rng.normal(size=(vertices, 3)) * 10.0
    triangles = rng.integers(0, vertices, size=(faces, 3))
    triangles[::17, 2] = triangles[::17, 1]
    return positions, triangles


def query_points(rng, positions, faces, count=300):
    """Points off the surface, on its corners and (within rounding) on its triangles."""
    r = rng.random((count, 2))
    r[r.sum(1) > 1] = 1 - r[r.sum(1) > 1]
    tri = positions[faces[rng.integers(0, len(faces), count)]]
    on = tri[:, 0] + r[:, :1] * (tri[:, 1] - tri[:, 0]) + r[:, 1:] * (tri[:, 2] - tri[:, 0])
    return np.vstack([rng.normal(size=(count, 3)) * 12.0, positions[:25], on, on + rng.normal(size=on.shape) * 1e-7])


# --------------------------------------------------------------------------- tests

def test_boundary_loops_csr_equals_the_coo_reference():
    rng = np.random.default_rng(11)
    cases = [joined(box_building(5, 3, 20.0, (2, 4), 2)), joined(crafted_building(3))]
    for _ in range(40):
        vertices = int(rng.integers(3, 120))
        cases.append((None, rng.integers(0, vertices, size=(int(rng.integers(1, 200)), 3))))
    for positions, faces in cases:
        count = len(positions) if positions is not None else int(faces.max()) + 1 + int(rng.integers(0, 5))
        border, loops = boundary_loops(faces, count)
        ref_border, ref_loops = reference_boundary_loops(faces, count)
        assert np.array_equal(border, ref_border) and loops == ref_loops


def test_refine_within_and_max_distance_equal_the_references():
    rng = np.random.default_rng(12)
    for _ in range(4):
        positions, faces = random_mesh(rng, 40, 60)
        index = SurfaceIndex(positions, faces)
        points = query_points(rng, positions, faces, 100)
        upper = index.upper(points)
        exact = reference_refine(index, points, upper)
        assert np.array_equal(index.refine(points, upper), exact)
        for tolerance in (0.0, 1e-7, float(np.median(exact)), float(exact.max()) * 2):
            assert np.array_equal(index.within(points, tolerance), reference_within(index, points, tolerance))
        plain = reference_max_distance(index, points)
        assert index.max_distance(points) == plain
        # A floor only stops the search sooner: the result is max(floor, the exact maximum).
        for floor in (0.0, plain * 0.5, float(np.median(exact)), plain, plain * 1.5):
            assert index.max_distance(points, floor=floor) == max(floor, plain)


def test_empty_and_degenerate_surfaces_equal_the_references():
    rng = np.random.default_rng(13)
    points = rng.normal(size=(20, 3))
    empty = SurfaceIndex(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    assert np.array_equal(empty.within(points, 1.0), reference_within(empty, points, 1.0))
    assert empty.max_distance(points) == reference_max_distance(empty, points) == np.inf
    flat = SurfaceIndex(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]))  # a segment
    assert np.array_equal(flat.within(points, 0.5), reference_within(flat, points, 0.5))
    assert flat.max_distance(points) == reference_max_distance(flat, points)
    assert flat.within(np.zeros((0, 3)), 1.0).shape == (0,)


@pytest.mark.parametrize("seed", [2, 5])
def test_measure_lod_hausdorff_is_the_reference_two_way_maximum(seed):
    config = Config()
    chain = build_mesh_lods(crafted_building(seed), config.lods, config.simplify)
    source_pos, source_faces = joined(chain[0])
    for level in chain[1:]:
        lod_pos, lod_faces = joined(level)
        source_points = measure_points(source_pos, source_faces, seed=0)
        lod_points = measure_points(lod_pos, lod_faces, seed=1)
        expected = max(reference_max_distance(SurfaceIndex(lod_pos, lod_faces), source_points),
                       reference_max_distance(SurfaceIndex(source_pos, source_faces), lod_points))
        diagonal = float(np.linalg.norm(source_pos.max(0) - source_pos.min(0)))
        assert measure_lod(chain[0], level)["hausdorff_rel"] == expected / diagonal


def measure_points(positions, faces, seed):
    """The points measure_lod measures from: vertices + SAMPLES samples, seeded as it does."""
    from exporter.quality import SAMPLES, SEED, sample_surface
    return np.vstack([positions, sample_surface(positions, faces, SAMPLES, np.random.default_rng(SEED + seed))])


def test_moved_level_keeps_its_values_through_the_floor():
    """A level shifted by 0.5 m: the larger direction is the second one measured, so the floor
    (the first direction) must not hide it."""
    box = box_building(5, 3, 20.0, (2, 4), 2)
    moved = [dataclasses.replace(box[0], positions=box[0].positions * [1.0, 1.3, 1.0])]  # taller
    source_pos, source_faces = joined(box)
    lod_pos, lod_faces = joined(moved)
    forward = reference_max_distance(SurfaceIndex(lod_pos, lod_faces), measure_points(source_pos, source_faces, 0))
    backward = reference_max_distance(SurfaceIndex(source_pos, source_faces), measure_points(lod_pos, lod_faces, 1))
    assert backward > forward  # the level's raised roof is far from the source, not the reverse
    diagonal = float(np.linalg.norm(source_pos.max(0) - source_pos.min(0)))
    assert measure_lod(box, moved)["hausdorff_rel"] == backward / diagonal
