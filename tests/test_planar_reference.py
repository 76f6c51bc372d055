"""The batched planar stage (:func:`retriangulate_planar_checked`) gives bit for bit what the
straightforward formulation it replaced gives: the reference below is the stage as it was before
issue 14's speed-up (planar regions, straight vertices, the border passes), with every region
re-triangulated one at a time by the one-region :func:`_retriangulate` and no caching, after
the source's slits are closed (:func:`exporter.mesh.slits.close_slits`).

Meshes are welded as the simplifier welds them; positions are building-local East/Up/North metres.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_perf_simplify import planar_cases, reference_planar_regions, same, welded_mesh
from test_simplify_shapes import crafted_building

from exporter.mesh.geometry import cross_rows, row_norms
from exporter.mesh.slits import close_slits, slit_vertices
from exporter.mesh.topology import border_vertices, edge_use, nonmanifold_vertices, unique_rows
from exporter.samplegen import generate_buildings
from exporter.simplify.planar import (
    _retriangulate,
    _retriangulate_keeping_boundary,
    retriangulate_planar_checked,
    straight_vertices,
)


def reference_straight_vertices(positions, faces, regions, locked, tolerance=1e-6, on_border=True):
    k = len(positions)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(regions, 3)
    order = np.lexsort((owner, edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    unique, start, counts = unique_rows(edges, return_index=True, return_counts=True)
    outline = (counts == 1) | (owner[start] != owner[start + counts - 1])
    ends = unique[outline]
    degree = np.bincount(ends.reshape(-1), minlength=k)
    half = np.concatenate([ends, ends[:, ::-1]])
    half = half[np.argsort(half[:, 0], kind="stable")]
    straight = np.zeros(k, dtype=bool)
    two = np.flatnonzero(degree == 2)
    if not on_border:
        border = np.zeros(k, dtype=bool)
        border[unique[counts == 1].reshape(-1)] = True
        two = two[~border[two]]
    if len(two):
        first = np.searchsorted(half[:, 0], two)
        a, b = positions[half[first, 1]], positions[half[first + 1, 1]]
        p = positions[two]
        direction = b - a
        length = np.linalg.norm(direction, axis=1)
        off_line = np.linalg.norm(cross_rows(direction, p - a), axis=1) / np.maximum(length, 1e-30)
        between = ((p - a) * direction).sum(1) / np.maximum(length**2, 1e-30)
        pair = np.sort(np.stack([half[first, 1], half[first + 1, 1]], axis=1), axis=1)
        closes = np.isin(pair[:, 0] * k + pair[:, 1], unique[:, 0] * k + unique[:, 1])
        straight[two] = (off_line < tolerance) & (between > 0) & (between < 1) & ~closes
    return straight & ~locked


def reference_boundary(positions, faces):
    edges, counts = edge_use(faces)
    border = edges[counts == 1]
    return float(np.linalg.norm(positions[border[:, 0]] - positions[border[:, 1]], axis=1).sum())


def reference_pass(positions, faces, corner_uvs, regions, droppable):
    """One pass: every region with a droppable vertex redone one at a time, in region order; a
    failure keeps its vertices (for every later region at once) and the pass starts over."""
    results: dict = {}
    for _ in range(8):
        candidates = np.unique(regions[droppable[faces].any(axis=1)]).tolist()
        results, failed = {}, False
        for region in candidates:
            members = np.flatnonzero(regions == region)
            uvs = None if corner_uvs is None else corner_uvs[members]
            result = _retriangulate(positions, faces[members], uvs, droppable)
            if result is None:
                droppable[faces[members].reshape(-1)] = False
                failed = True
            else:
                results[region] = (members, result)
        if not failed:
            break
    else:
        results = {}
    keep = np.ones(len(faces), dtype=bool)
    new_faces, new_uvs, new_source = [], [], []
    for members, (tri, uvs) in results.values():
        keep[members] = False
        new_faces.append(tri)
        new_uvs.append(uvs)
        new_source.append(np.full(len(tri), members[0]))
    if not new_faces:
        return faces, corner_uvs, np.arange(len(faces))
    out_uvs = None if corner_uvs is None else np.concatenate([corner_uvs[keep]] + new_uvs)
    return (
        np.concatenate([faces[keep]] + new_faces),
        out_uvs,
        np.concatenate([np.flatnonzero(keep)] + new_source),
    )


def reference_checked(positions, faces, corner_uvs, face_chart, locked):
    """The planar stage before the speed-up, and whether its first pass changed the boundary."""
    before = reference_boundary(positions, faces)
    regions = reference_planar_regions(positions, faces, face_chart)
    k = len(positions)
    low, high = np.full(k, np.iinfo(np.int64).max), np.full(k, -1)
    np.minimum.at(low, faces.reshape(-1), np.repeat(regions, 3))
    np.maximum.at(high, faces.reshape(-1), np.repeat(regions, 3))
    border = border_vertices(faces, k)
    interior = (low == high) & ~border & ~locked
    used = np.zeros(k, dtype=bool)
    used[faces.reshape(-1)] = True
    straight = reference_straight_vertices(positions, faces, regions, locked)
    tolerance = 1e-9 * max(before, 1.0)
    result = reference_pass(positions, faces, corner_uvs, regions, (interior | straight) & used)
    second = abs(reference_boundary(positions, result[0]) - before) > tolerance
    # Then keeping the straight border vertices inside a slit, then all of them.
    for keep in (slit_vertices(positions, faces), border):
        if abs(reference_boundary(positions, result[0]) - before) <= tolerance:
            break
        droppable = (interior | straight & ~keep) & used
        result = reference_pass(positions, faces, corner_uvs, regions, droppable)
    kept = abs(reference_boundary(positions, result[0]) - before) <= tolerance
    return (*result, kept), second


def reference_closed_then_checked(positions, faces, corner_uvs, face_chart, locked):
    """Slits closed first (kept only when the planar stage then gets below the input's face
    count), then :func:`reference_checked`."""
    closed, closed_uvs, source = close_slits(positions, faces, corner_uvs)
    (out, out_uvs, kept_source, kept), second = reference_checked(
        positions, closed, closed_uvs, face_chart[source], locked
    )
    if len(out) >= len(faces) and len(closed) > len(faces):
        return reference_checked(positions, faces, corner_uvs, face_chart, locked)
    return (out, out_uvs, source[kept_source], kept), second


def meshes():
    """Welded generated buildings (every sample kind), crafted buildings and the planar cases."""
    buildings = generate_buildings(12, seed=5, atlas_size=32, two_part_share=0.3)
    return (
        [welded_mesh(b.parts) for b in buildings]
        + [welded_mesh(crafted_building(seed)) for seed in range(4)]
        + planar_cases()
    )


@pytest.mark.parametrize("with_uvs", [True, False])
def test_retriangulate_planar_checked_equals_the_reference(with_uvs):
    rng = np.random.default_rng(17)
    second_passes = changed = 0
    for positions, faces, corner_uvs, charts in meshes():
        uvs = corner_uvs if with_uvs else None
        k = len(positions)
        # The pipeline's locks (non-manifold vertices), then random locks that make regions keep
        # vertices and outlines differ between the passes.
        for locked in (nonmanifold_vertices(faces, k), rng.random(k) < 0.1):
            fast = retriangulate_planar_checked(positions, faces, uvs, charts, locked.copy())
            expected, _ = reference_closed_then_checked(
                positions, faces, uvs, charts, locked.copy()
            )
            assert all(same(a, b) for a, b in zip(fast[:3], expected[:3]))
            assert fast[3] == expected[3]
            changed += len(fast[0]) < len(faces)
            # The passes alone, on the slits as they are: the border-keeping passes run.
            fast = _retriangulate_keeping_boundary(positions, faces, uvs, charts, locked.copy())
            expected, second = reference_checked(positions, faces, uvs, charts, locked.copy())
            assert all(same(a, b) for a, b in zip(fast[:3], expected[:3]))
            assert fast[3] == expected[3]
            second_passes += second
    # The comparison covered re-triangulated meshes and the border-keeping passes.
    assert changed > 20 and second_passes > 3


def test_row_norms_equal_numpy_norms():
    rng = np.random.default_rng(23)
    rows = rng.normal(size=(5000, 3)) * rng.choice([1e-200, 1e-3, 1.0, 1e150], (5000, 1))
    rows[rng.random(rows.shape) < 0.1] = -0.0
    assert same(row_norms(rows), np.linalg.norm(rows, axis=1))


@pytest.mark.parametrize("on_border", [True, False])
def test_straight_vertices_equal_the_reference(on_border):
    rng = np.random.default_rng(29)
    found = 0
    for positions, faces, _, charts in meshes():
        regions = reference_planar_regions(positions, faces, charts)
        locked = rng.random(len(positions)) < 0.1
        fast = straight_vertices(positions, faces, regions, locked, on_border=on_border)
        assert same(
            fast,
            reference_straight_vertices(positions, faces, regions, locked, on_border=on_border),
        )
        found += int(fast.sum())
    assert found > 50


def test_edge_use_equals_numpy_unique_of_sorted_pairs():
    rng = np.random.default_rng(31)
    for size in (0, 1, 5, 40, 300):
        for dtype in (np.int64, np.int32):
            faces = rng.integers(0, max(3, size // 2), (size, 3)).astype(dtype)
            unique, counts = edge_use(faces)
            pairs = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64), axis=1)
            expected, expected_counts = np.unique(pairs, axis=0, return_counts=True)
            assert same(unique, expected.reshape(-1, 2)) and same(counts, expected_counts)
