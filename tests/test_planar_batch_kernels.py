"""The compiled planar-stage bookkeeping (``exporter/mesh/c/planar_batch.c``) gives bit for bit
what the numpy and Python forms it replaced in :mod:`exporter.simplify.planar` gave (kept here as
the references): the regions' normal sums and UV check (``region_setup``), the loops with the
droppable vertices removed and the earcut outline check (``_retriangulate_many``) and
:func:`straight_vertices`. Positions are building-local East/Up/North metres (random meshes:
frame-free metres)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from test_perf_simplify import planar_cases, same, welded_mesh

from exporter.mesh import _planar_batch
from exporter.mesh.geometry import cross_rows, row_norms, sorted_edge_keys
from exporter.mesh.topology import edge_use, planar_regions
from exporter.samplegen import generate_buildings
from exporter.simplify.planar import (
    _plane_basis,
    _region_loops,
    _row_dots,
    region_setup,
    straight_vertices,
)


def reference_region_sums(rows, sizes, row_region, bounds):
    """The former ``planar._region_sums``: rows added one after the other onto 0.0 per region."""
    count, longest = len(sizes), int(sizes.max())
    if count * longest > 4 * len(rows) + 256:
        return np.stack([rows[bounds[r] : bounds[r + 1]].sum(axis=0) for r in range(count)])
    padded = np.full((count, longest + 1, 3), -0.0)
    padded[:, 0] = 0.0
    padded[row_region, np.arange(1, len(rows) + 1) - np.repeat(bounds[:-1], sizes)] = rows
    return np.add.accumulate(padded, axis=1)[:, -1]


def reference_uvs(region_faces, face_uvs, sizes, k):
    """The former UV check of ``region_setup``: (keys, values, conflict per region)."""
    face_region = np.repeat(np.arange(len(sizes)), sizes)
    corner_key = np.repeat(face_region, 3) * k + region_faces.reshape(-1)
    order = np.argsort(corner_key, kind="stable")
    ordered = corner_key[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = ordered[1:] != ordered[:-1]
    corner_uv = face_uvs.reshape(-1, 2)[order]
    differs = ~first[1:] & (corner_uv[1:] != corner_uv[:-1]).any(axis=1)
    conflict = np.zeros(len(sizes), dtype=bool)
    conflict[ordered[1:][differs] // k] = True
    return ordered[first], corner_uv[first], conflict


def reference_spans(faces, regions, k):
    """The former numpy form: (one region, used, by region, region start)."""
    corner_region = np.repeat(regions, 3)
    low = np.full(k, np.iinfo(np.int64).max)
    high = np.full(k, -1)
    np.minimum.at(low, faces.reshape(-1), corner_region)
    np.maximum.at(high, faces.reshape(-1), corner_region)
    used = np.zeros(k, dtype=bool)
    used[faces.reshape(-1)] = True
    by_region = np.argsort(regions, kind="stable")
    region_start = np.searchsorted(regions[by_region], np.arange(regions.max() + 2))
    return low == high, used, by_region, region_start


def reference_straight(
    positions, faces, regions, locked, tolerance=1e-6, on_border=True, distances=None
):
    """The former numpy body of :func:`straight_vertices` (on the sorted edge keys);
    ``distances``: a list that gets the off-line distances (metres) of the degree-2 vertices."""
    k = len(positions)
    keys, order = sorted_edge_keys(faces, k)
    start = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]]))
    counts = np.concatenate([start[1:], [len(keys)]]) - start
    owner = regions[order // 3]
    existing = keys[start]
    low, high = np.divmod(existing, k)
    outline = (counts == 1) | (
        np.minimum.reduceat(owner, start) != np.maximum.reduceat(owner, start)
    )
    ends = np.concatenate([low[outline], high[outline]])
    degree = np.bincount(ends, minlength=k)
    half = np.argsort(ends, kind="stable")
    source = ends[half]
    target = np.concatenate([high[outline], low[outline]])[half]
    straight = np.zeros(k, dtype=bool)
    two = np.flatnonzero(degree == 2)
    if not on_border:
        border = np.zeros(k, dtype=bool)
        border[low[counts == 1]] = True
        border[high[counts == 1]] = True
        two = two[~border[two]]
    if len(two):
        first = np.searchsorted(source, two)
        left, right = target[first], target[first + 1]
        a, b = positions[left], positions[right]
        p = positions[two]
        direction = b - a
        length = row_norms(direction)
        off_line = row_norms(cross_rows(direction, p - a)) / np.maximum(length, 1e-30)
        between = ((p - a) * direction).sum(1) / np.maximum(length**2, 1e-30)
        if distances is not None:
            distances.extend(off_line[(between > 0) & (between < 1)].tolist())
        pair = np.minimum(left, right) * k + np.maximum(left, right)
        closes = existing[np.minimum(np.searchsorted(existing, pair), len(existing) - 1)] == pair
        straight[two] = (off_line < tolerance) & (between > 0) & (between < 1) & ~closes
    return straight & ~locked


def reference_rings(loops, setup_ok, ids, droppable):
    """The former loop filtering of ``_retriangulate_many``: ok, ring vertices, predecessors,
    ring ends, each todo region's first ring, todo."""
    drop = droppable.tolist()
    kept: list = []
    for i in ids:
        rings = loops[i]
        if rings is not None:
            rings = [[v for v in ring if not drop[v]] for ring in rings]
            if any(len(ring) < 3 for ring in rings):
                rings = None
        kept.append(rings)
    ok = setup_ok[ids] & np.array([rings is not None for rings in kept])
    todo = np.flatnonzero(ok)
    rings_of = [kept[r] for r in todo]
    ring_sizes = [len(ring) for rings in rings_of for ring in rings]
    ring_vertices = np.array(
        [v for rings in rings_of for ring in rings for v in ring], dtype=np.int64
    )
    ring_ends = np.array(list(itertools.accumulate(ring_sizes)), dtype=np.int64)
    previous = np.arange(-1, len(ring_vertices) - 1)
    previous[ring_ends - np.array(ring_sizes, dtype=np.int64)] = ring_ends - 1
    region_rings = np.array([0, *itertools.accumulate(len(r) for r in rings_of)], dtype=np.int64)
    return (
        ok,
        ring_vertices,
        previous,
        ring_ends,
        region_rings,
        todo,
        np.array(ring_sizes, dtype=np.uint32),
    )


def reference_outline(tris, offsets, sizes, ring_vertices, previous, k):
    """The former outline check of ``_retriangulate_many``: (new faces, broken per region)."""
    face_counts = [len(t) // 3 for t in tris]
    done = np.arange(len(tris))
    new_faces = ring_vertices[
        np.concatenate(tris).astype(np.int64) + np.repeat(offsets, 3 * np.array(face_counts))
    ].reshape(-1, 3)
    new_region = np.repeat(done, face_counts)
    ahead = new_faces[:, [1, 2, 0]]
    edge_key = np.sort(
        (
            (new_region[:, None] * k + np.minimum(new_faces, ahead)) * k
            + np.maximum(new_faces, ahead)
        ).reshape(-1)
    )
    differs = np.concatenate([[True], edge_key[1:] != edge_key[:-1], [True]])
    single = edge_key[differs[:-1] & differs[1:]]
    overused = edge_key[2:][edge_key[2:] == edge_key[:-2]]
    index = np.concatenate([np.arange(o, o + s) for o, s in zip(offsets, sizes)]).astype(int)
    vertex_region = np.repeat(done, sizes)
    ends_a, ends_b = ring_vertices[index], ring_vertices[previous[index]]
    loop_key = (vertex_region * k + np.minimum(ends_a, ends_b)) * k + np.maximum(ends_a, ends_b)
    loop_key.sort()
    broken = np.zeros(len(tris), dtype=bool)
    broken[np.setxor1d(single, loop_key) // (k * k)] = True
    broken[overused // (k * k)] = True
    return new_faces, broken


def reference_finish(positions, new_faces, face_counts, normal, total):
    """The former numpy tail of ``_retriangulate_many`` before the matmul recheck: (n, flip,
    bad, recheck) per face / region (regions are 0..d-1, all done)."""
    face_bounds = [0, *itertools.accumulate(face_counts)]
    new_region = np.repeat(np.arange(len(face_counts)), face_counts)
    corners = positions[new_faces]
    n = cross_rows(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = 0.5 * row_norms(n)
    starts = face_bounds[:-1]
    smallest = np.minimum.reduceat(areas, starts)
    scale = np.maximum(total, 1.0)
    off = np.abs(np.add.reduceat(areas, starts) - total) - 1e-6 * scale
    for i in np.flatnonzero(np.abs(off) <= 1e-9 * scale).tolist():
        lo, hi = face_bounds[i], face_bounds[i + 1]
        off[i] = abs(areas[lo:hi].sum() - total[i]) - 1e-6 * scale[i]
    bad = (off > 0) | (smallest < 1e-9 * scale)
    dots = (n * normal[new_region]).sum(axis=1)
    edge_on = np.abs(dots) <= 1e-12 * areas
    recheck = np.zeros(len(face_counts), dtype=bool)
    recheck[new_region[edge_on]] = True
    return n, dots < 0, bad, recheck


def meshes():
    buildings = generate_buildings(8, seed=7, atlas_size=32, two_part_share=0.3)
    return [welded_mesh(b.parts) for b in buildings] + planar_cases()


def regions_of(positions, faces, charts):
    regions = planar_regions(positions, faces, charts)
    return regions, [np.flatnonzero(regions == r) for r in range(regions.max() + 1)]


def test_sums_equal_the_region_sums_of_the_cross_products():
    rng = np.random.default_rng(41)
    for _ in range(200):
        sizes = rng.integers(1, 30, int(rng.integers(1, 15)))
        k = int(rng.integers(3, 40))
        positions = rng.normal(size=(k, 3)) * rng.choice([1e-300, 1e-3, 1.0, 1e150], (k, 1))
        positions[rng.random(positions.shape) < 0.2] = -0.0
        faces = rng.integers(0, k, (int(sizes.sum()), 3))
        rows = cross_rows(
            positions[faces[:, 1]] - positions[faces[:, 0]],
            positions[faces[:, 2]] - positions[faces[:, 0]],
        )
        bounds = np.concatenate([[0], np.cumsum(sizes)]).tolist()
        expected = np.stack(
            [rows[bounds[r] : bounds[r + 1]].sum(axis=0) for r in range(len(sizes))]
        )
        got = _planar_batch.sums(positions, faces, sizes)
        assert same(got, expected)
        region = np.repeat(np.arange(len(sizes)), sizes)
        assert same(got, reference_region_sums(rows, sizes, region, bounds))


def test_uvs_equal_the_numpy_uv_check():
    rng = np.random.default_rng(43)
    conflicts = 0
    for _ in range(200):
        sizes = rng.integers(1, 20, int(rng.integers(1, 10)))
        k = int(rng.integers(3, 25))
        faces = rng.integers(0, k, (int(sizes.sum()), 3))
        per_vertex = rng.choice([0.0, -0.0, 0.25, 1.0], (k, 2)).astype(np.float32)
        uvs = per_vertex[faces]
        # Some corners with another UV, a NaN, or -0.0 for 0.0 (equal).
        uvs[rng.random(uvs.shape[:2]) < 0.03] = 0.5
        uvs[rng.random(uvs.shape[:2]) < 0.01] = np.nan
        keys, values, conflict, n = _planar_batch.uvs(faces, uvs, sizes, k)
        expected = reference_uvs(faces, uvs, sizes, k)
        assert same(keys[:n], expected[0]) and same(values[:n], expected[1])
        assert same(conflict, expected[2])
        conflicts += int(conflict.sum())
    assert conflicts > 50


def test_rings_equal_the_filtered_loops():
    rng = np.random.default_rng(47)
    checked = 0
    for positions, faces, _, charts in meshes():
        k = len(positions)
        _, members = regions_of(positions, faces, charts)
        setup = region_setup(positions, faces, None, members)
        assert setup is not None
        sizes = np.array([len(m) for m in members])
        half = faces[np.concatenate(members)][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        owner = np.repeat(np.arange(len(members)), 3 * sizes)
        loops = _region_loops(half, owner, len(members), k, np.zeros(k, dtype=bool))
        # The setup's flat loops are the list form's.
        for r, rings in enumerate(loops):
            if rings is not None:
                lo, hi = setup.region_loops[r], setup.region_loops[r + 1]
                flat = [
                    setup.loop_vertices[setup.loop_bounds[i] : setup.loop_bounds[i + 1]].tolist()
                    for i in range(lo, hi)
                ]
                assert flat == rings
        setup_ok = setup.ok & (rng.random(len(members)) < 0.9)
        for share in (0.0, 0.2, 0.6):
            droppable = rng.random(k) < share
            ids = rng.permutation(len(members))[: int(rng.integers(1, len(members) + 1))]
            got = _planar_batch.rings(
                setup.loop_vertices, setup.loop_bounds, setup.region_loops, setup_ok, ids, droppable
            )
            expected = reference_rings(loops, setup_ok, ids, droppable)
            assert all(np.array_equal(a, b) for a, b in zip(got, expected))
            assert got[0].dtype == bool and all(a.dtype == np.int64 for a in got[1:6])
            assert got[6].dtype == np.uint32
            checked += len(expected[5])
    assert checked > 100


def test_outline_equals_the_numpy_outline_check():
    rng = np.random.default_rng(53)
    broken = 0
    for _ in range(200):
        count = int(rng.integers(1, 8))
        sizes = rng.integers(3, 12, count)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        k = int(sizes.sum()) + 5
        ring_vertices = rng.permutation(k)[: int(sizes.sum())].astype(np.int64)
        previous = np.arange(-1, len(ring_vertices) - 1)
        previous[offsets] = offsets + sizes - 1
        tris = []
        for s in sizes.tolist():
            fan = np.array([[0, i, i + 1] for i in range(1, s - 1)], dtype=np.uint32)
            choice = rng.random()
            if choice < 0.2:
                fan[rng.integers(len(fan))] = rng.integers(0, s, 3)  # a wrong triangle
            elif choice < 0.3:
                fan = np.vstack([fan, fan[:1], fan[:1]])  # an edge used three times and more
            tris.append(fan.reshape(-1))
        new_faces, bad = _planar_batch.outline(
            np.concatenate(tris), offsets, sizes, [len(t) // 3 for t in tris],
            ring_vertices, previous, k,
        )  # fmt: skip
        expected = reference_outline(tris, offsets, sizes, ring_vertices, previous, k)
        assert same(new_faces, expected[0]) and same(bad, expected[1])
        broken += int(bad.sum())
    assert broken > 50


@pytest.mark.parametrize("on_border", [True, False])
def test_straight_equals_the_numpy_straight_vertices(on_border):
    rng = np.random.default_rng(59)
    found = edges = 0
    for positions, faces, _, charts in meshes():
        regions, _ = regions_of(positions, faces, charts)
        locked = rng.random(len(positions)) < 0.1
        for noise in (0.0, 1e-7, 1e-6, 1e-3):
            # Jitter around the tolerance: the comparisons must agree at their edges too.
            moved = positions + noise * rng.normal(size=positions.shape)
            got = straight_vertices(moved, faces, regions, locked, on_border=on_border)
            expected = reference_straight(moved, faces, regions, locked, on_border=on_border)
            assert same(got, expected)
            found += int(got.sum())
        # Tolerances equal to distances found: the strict comparison decides on the last bit.
        distances: list = []
        moved = positions + 1e-4 * rng.normal(size=positions.shape)
        reference_straight(moved, faces, regions, locked, 1.0, on_border, distances)
        for tolerance in rng.choice(distances, min(len(distances), 8), replace=False).tolist():
            for nudge in (np.nextafter(tolerance, 0), tolerance, np.nextafter(tolerance, 1)):
                args = (moved, faces, regions, locked, float(nudge), on_border)
                assert same(straight_vertices(*args), reference_straight(*args))
                edges += 1
    assert found > 50 and edges > 100


def test_plane_and_basis_equal_the_one_region_plane_bases():
    # The one-region reference _retriangulate's arithmetic: np.linalg.norm, _plane_basis.
    rng = np.random.default_rng(61)
    sums = rng.normal(size=(3000, 3)) * rng.choice([1e-150, 1e-3, 1.0, 1e100], (3000, 1))
    sums[rng.random(sums.shape) < 0.2] = -0.0
    sums[rng.random(sums.shape) < 0.1] = 0.0
    sums[:20] = 0.0  # zero area: refused by the caller
    sums[20:40, 0] = rng.choice([0.9, -0.9], 20) * np.sqrt((sums[20:40, 1:] ** 2).sum(1) / 0.19)
    area, normal, u = _planar_batch.plane(sums, _row_dots(sums))
    basis = _planar_batch.basis(normal, u, _row_dots(u))
    assert (area[:20] == 0).all() and np.isnan(basis[:20]).all()
    for r in range(20, len(sums)):
        expected_area = 0.5 * np.linalg.norm(sums[r])
        assert area[r] == expected_area
        if expected_area > 0:
            expected_normal = sums[r] / (2 * expected_area)
            assert same(normal[r], expected_normal)
            assert same(basis[r], np.stack(_plane_basis(expected_normal), axis=1))


def test_spans_and_held_equal_the_numpy_forms():
    rng = np.random.default_rng(67)
    for _ in range(300):
        m, k = int(rng.integers(1, 60)), int(rng.integers(3, 50))
        faces = rng.integers(0, k, (m, 3))
        count = int(rng.integers(1, m + 1))
        regions = np.concatenate([np.arange(count), rng.integers(0, count, m - count)])
        regions = regions[rng.permutation(m)]
        got = _planar_batch.spans(faces, regions, count, k)
        expected = reference_spans(faces, regions, k)
        assert all(same(a, b) for a, b in zip(got, expected))
        droppable = rng.random(k) < rng.choice([0.02, 0.2])
        region_faces = faces[expected[2]]
        held = np.logical_or.reduceat(droppable[region_faces].any(axis=1), expected[3][:-1])
        assert same(_planar_batch.held(droppable, region_faces, expected[3]), held)


def test_pairwise_is_numpy_sum():
    rng = np.random.default_rng(71)
    for n in [*range(300), 511, 512, 513, 1023, 1025, 8191, 8193, 20000]:
        values = rng.normal(size=n) * rng.choice([1e-8, 1.0, 1e8], n)
        values[rng.random(n) < 0.1] = -0.0
        assert same(np.float64(_planar_batch.pairwise(values)), np.float64(np.sum(values)))


def test_border_length_is_the_numpy_boundary_length():
    rng = np.random.default_rng(73)
    for positions, faces, _, _ in meshes():
        for drop in (0.0, 0.3):
            kept = faces[rng.random(len(faces)) >= drop]
            edges, counts = edge_use(kept)
            border = edges[counts == 1]
            expected = np.linalg.norm(positions[border[:, 0]] - positions[border[:, 1]], axis=1)
            got = _planar_batch.border_length(positions, edges, counts)
            assert same(np.float64(got), np.float64(expected.sum()))


def test_finish_and_uv_lookup_equal_the_numpy_forms():
    rng = np.random.default_rng(79)
    bad = rechecked = 0
    for _ in range(300):
        d, k = int(rng.integers(1, 8)), int(rng.integers(4, 30))
        positions = rng.normal(size=(k, 3)) * rng.choice([1e-6, 1.0, 1e3])
        positions[rng.random(k) < 0.2, 1] = 0.0  # some faces in the plane y = 0
        face_counts = rng.integers(1, 12, d)
        new_faces = rng.integers(0, k, (int(face_counts.sum()), 3))
        normal = rng.normal(size=(d, 3))
        normal[rng.random(d) < 0.4] = [0.0, 1.0, 0.0]  # edge-on faces for the recheck
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        bounds = np.concatenate([[0], np.cumsum(face_counts)])
        areas = 0.5 * row_norms(
            cross_rows(
                positions[new_faces[:, 1]] - positions[new_faces[:, 0]],
                positions[new_faces[:, 2]] - positions[new_faces[:, 0]],
            )
        )
        # Totals at the tolerance's edges and off them.
        total = np.array([areas[bounds[i] : bounds[i + 1]].sum() for i in range(d)])
        total *= rng.choice([1.0, 1 + 1e-6, 1 - 1e-6, 1 + 2e-6, 1.5], d)
        got = _planar_batch.finish(positions, new_faces, face_counts, normal, total)
        expected = reference_finish(positions, new_faces, face_counts, normal, total)
        assert all(same(a, b) for a, b in zip(got, expected))
        bad += int(got[2].sum())
        rechecked += int(got[3].sum())
        region = rng.permutation(d) + 3
        keys = np.unique(np.concatenate([region * k + v for v in range(k)]))
        values = rng.normal(size=(len(keys), 2)).astype(np.float32)
        uvs = _planar_batch.uv_lookup(keys, values, region, face_counts, new_faces, k)
        face_region = np.repeat(region, face_counts)
        expected_uvs = values[np.searchsorted(keys, face_region[:, None] * k + new_faces)]
        assert same(uvs, expected_uvs.astype(np.float32))
    assert bad > 50 and rechecked > 50


def test_bad_inputs_are_value_errors():
    faces = np.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="sums"):
        _planar_batch.sums(np.eye(3), faces + 1, np.array([1]))
    with pytest.raises(ValueError, match="sums"):
        _planar_batch.sums(np.eye(3), faces, np.array([2]))
    with pytest.raises(ValueError, match="uvs"):
        _planar_batch.uvs(faces, np.zeros((1, 3, 2), np.float32), np.array([1]), 2)
    with pytest.raises(ValueError, match="rings"):
        _planar_batch.rings(
            np.array([0, 1, 5]), np.array([0, 3]), np.array([0, 1]), np.ones(1, bool),
            np.array([0]), np.zeros(3, bool),
        )  # fmt: skip
    with pytest.raises(ValueError, match="rings"):
        _planar_batch.rings(
            np.array([0, 1, 2]), np.array([0, 3]), np.array([0, 1]), np.ones(1, bool),
            np.array([1]), np.zeros(3, bool),
        )  # fmt: skip
    ring = np.array([0, 1, 2])
    previous = np.array([2, 0, 1])
    with pytest.raises(ValueError, match="outline"):
        _planar_batch.outline(np.array([0, 1, 3]), [0], [3], [1], ring, previous, 3)
    with pytest.raises(ValueError, match="outline"):
        _planar_batch.outline(np.array([0, 1, 2]), [1], [3], [1], ring, previous, 3)
    with pytest.raises(ValueError, match="outline"):
        _planar_batch.outline(np.array([0, 1, 2]), [0], [3], [2], ring, previous, 3)
    with pytest.raises(ValueError, match="plane"):
        _planar_batch.plane(np.zeros((2, 3)), np.zeros(3))
    with pytest.raises(ValueError, match="basis"):
        _planar_batch.basis(np.zeros((2, 3)), np.zeros((3, 3)), np.zeros(2))
    with pytest.raises(ValueError, match="spans"):
        _planar_batch.spans(faces, np.array([1]), 1, 3)
    with pytest.raises(ValueError, match="spans"):
        _planar_batch.spans(faces, np.array([0]), 1, 2)
    with pytest.raises(ValueError, match="held"):
        _planar_batch.held(np.zeros(2, bool), faces, np.array([0, 1]))
    with pytest.raises(ValueError, match="held"):
        _planar_batch.held(np.zeros(3, bool), faces, np.array([1, 0, 1]))
    with pytest.raises(ValueError, match="border_length"):
        _planar_batch.border_length(np.eye(3), np.array([[0, 3]]), np.array([1]))
    with pytest.raises(ValueError, match="finish"):
        _planar_batch.finish(np.eye(3), faces, [2], np.eye(3)[:1], np.ones(1))
    with pytest.raises(ValueError, match="uv_lookup"):
        _planar_batch.uv_lookup(
            np.arange(3), np.zeros((3, 2), np.float32), np.array([5]), [1], faces, 3
        )
    keys, order = sorted_edge_keys(faces, 3)
    with pytest.raises(ValueError, match="straight"):
        _planar_batch.straight(
            np.eye(3), keys, order + 1, np.zeros(1, np.int64), np.zeros(3, bool), 1e-6, True
        )
    with pytest.raises(ValueError, match="straight"):
        _planar_batch.straight(
            np.eye(3),
            keys[::-1].copy(),
            order,
            np.zeros(1, np.int64),
            np.zeros(3, bool),
            1e-6,
            True,
        )
    with pytest.raises(ValueError, match="straight"):
        _planar_batch.straight(
            np.eye(2, 3), keys, order, np.zeros(1, np.int64), np.zeros(2, bool), 1e-6, True
        )
