"""The mesh LoD stage's fast paths (issue 8) give exactly what the per-region / scipy formulations
they replaced give, and :func:`build_mesh_chain`'s ``exact`` flag is True only for levels whose
surface is LOD0's.

Fast-vs-reference tests assert equality bit for bit (``np.array_equal`` on the same dtype), so a
later "speed-up" that changes a result fails here. Positions are building-local East/Up/North
metres (y = Up); random meshes are frame-free metres.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from test_simplify_shapes import Atlas, Builder, add_dome, box_building, crafted_building

from exporter.config import LodSpec, SimplifyOptions, default_lods
from exporter.mesh.geometry import cross_rows, unique_float_rows
from exporter.mesh.topology import (
    COPLANAR_COS,
    PLANE_M,
    border_vertices,
    boundary_loops,
    planar_regions,
)
from exporter.mesh.weld import lowest_member, weld_positions
from exporter.quality import joined, measure_lod
from exporter.simplify import NOISE_M, MeshLevel, build_mesh_chain, build_mesh_lods, uv_charts
from exporter.simplify.planar import (
    _loops,
    _plane_basis,
    _region_loops,
    _retriangulate,
    _retriangulate_many,
    _row_dots,
)
from exporter.simplify.quadric import assign_uvs, closest_barycentric


def same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


# --------------------------------------------------------------------------- graph components


def scipy_lowest(n, left, right):
    """The partition of scipy's connected_components as each node's lowest member."""
    graph = coo_matrix((np.ones(len(left)), (left, right)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    lowest = np.full(labels.max() + 1, n)
    np.minimum.at(lowest, labels, np.arange(n))
    return lowest[labels]


def test_lowest_member_is_the_connected_components_partition():
    rng = np.random.default_rng(1)
    for _ in range(60):
        n = int(rng.integers(1, 300))
        e = int(rng.integers(0, 2 * n))
        left, right = rng.integers(0, n, e), rng.integers(0, n, e)
        assert np.array_equal(lowest_member(n, left, right), scipy_lowest(n, left, right))
    # A long chain numbered backwards: many rounds, still the exact partition.
    chain = np.arange(499, 0, -1)
    assert np.array_equal(lowest_member(500, chain, chain - 1), np.zeros(500, np.int64))


def reference_weld(positions, distance):
    """The former weld_positions (scipy components, clusters renumbered by lowest member)."""
    n = len(positions)
    pairs = cKDTree(positions).query_pairs(r=float(distance), output_type="ndarray")
    _, labels = connected_components(
        coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)), directed=False
    )
    first = np.full(labels.max() + 1, n, dtype=np.int64)
    np.minimum.at(first, labels, np.arange(n))
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels].astype(np.int64), positions[first[order]]


@pytest.mark.parametrize("distance", [NOISE_M, 0.05, 0.5])
def test_weld_positions_equals_the_scipy_components(distance):
    rng = np.random.default_rng(int(distance * 1e6))
    for _ in range(20):
        positions = rng.normal(size=(int(rng.integers(1, 200)), 3)) * 3.0
        noisy = positions[rng.integers(0, len(positions), 40)] + rng.normal(size=(40, 3)) * 1e-7
        positions = np.vstack([positions, noisy, positions[:5]])
        fast, reference = weld_positions(positions, distance), reference_weld(positions, distance)
        assert same(fast[0], reference[0]) and same(fast[1], reference[1])


def test_uv_charts_equal_scipy_components_of_the_face_vertex_graph():
    rng = np.random.default_rng(4)
    for _ in range(40):
        vertices = int(rng.integers(3, 300))
        faces = rng.integers(0, vertices, size=(int(rng.integers(1, 200)), 3))
        m = len(faces)
        graph = coo_matrix(
            (np.ones(3 * m), (np.repeat(np.arange(m), 3), m + faces.reshape(-1))),
            shape=(m + vertices, m + vertices),
        )
        expected = connected_components(graph, directed=False)[1][:m].astype(np.int64)
        assert same(uv_charts(faces, vertices), expected)


def reference_planar_regions(positions, faces, groups):
    """The former planar_regions ending (scipy components of the coplanar face graph)."""
    m = len(faces)
    a, b, c = (positions[faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(m), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    shared = (edges[1:] == edges[:-1]).all(axis=1)
    f, g = owner[:-1][shared], owner[1:][shared]
    keep = groups[f] == groups[g]
    f, g = f[keep], g[keep]
    coplanar = ((normal[f] * normal[g]).sum(1) > COPLANAR_COS) & (
        np.abs(((positions[faces[g]].mean(axis=1) - a[f]) * normal[f]).sum(1)) < PLANE_M
    )
    graph = coo_matrix((np.ones(coplanar.sum()), (f[coplanar], g[coplanar])), shape=(m, m))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def welded_mesh(parts):
    """(positions, faces, corner_uvs, charts) of parts joined and welded as the simplifier does."""
    from exporter.simplify import _join

    positions, faces, _, corner_uvs, charts, _ = _join(parts, 0.0)
    return positions, faces, corner_uvs, charts


def test_planar_regions_equal_the_scipy_components():
    for seed in range(8):
        positions, faces, _, charts = welded_mesh(crafted_building(seed))
        assert same(
            planar_regions(positions, faces, charts),
            reference_planar_regions(positions, faces, charts),
        )


# --------------------------------------------------------------------------- small numerics


def test_unique_float_rows_equals_numpy_unique_axis0():
    rng = np.random.default_rng(7)
    for _ in range(100):
        c = int(rng.integers(1, 120))
        keys = np.column_stack(
            [rng.integers(0, 12, c).astype(float), rng.choice([0.0, -0.0, 0.25, 1e-9, 0.5], (c, 2))]
        )
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        fast_first, fast_inverse = unique_float_rows(keys)
        assert same(fast_first, first) and same(fast_inverse, inverse.reshape(-1).astype(np.int64))


def test_batched_norms_and_plane_bases_equal_the_per_region_calls():
    # The batch replaces np.linalg.norm of one 3-vector (its dot) by sqrt of a stacked matmul and
    # _plane_basis by the same IEEE operations on arrays; both must agree bit for bit.
    rng = np.random.default_rng(9)
    normals = rng.normal(size=(3000, 3)) * rng.choice([1e-4, 1.0, 300.0], (3000, 1))
    normals[::7, 0] = 0.95  # the other helper axis
    batched = np.sqrt(_row_dots(normals))
    assert same(batched, np.array([np.linalg.norm(n) for n in normals]))
    unit = normals / batched[:, None]
    x, y, z = unit[:, 0], unit[:, 1], unit[:, 2]
    hx = np.where(np.abs(x) < 0.9, 1.0, 0.0)
    hy = 1.0 - hx
    u = np.stack([y * 0.0 - z * hy, z * hx - x * 0.0, x * hy - y * hx], axis=1)
    u = u / np.sqrt(_row_dots(u))[:, None]
    v = np.stack(
        [y * u[:, 2] - z * u[:, 1], z * u[:, 0] - x * u[:, 2], x * u[:, 1] - y * u[:, 0]], axis=1
    )
    reference = [_plane_basis(n) for n in unit]
    assert same(u, np.array([r[0] for r in reference])) and same(
        v, np.array([r[1] for r in reference])
    )


# --------------------------------------------------------------------------- planar batch


def random_region_faces(rng):
    """Face sets that exercise _loops: grids (one loop), grids with a hole, pinched and open sets."""
    cols, rows = int(rng.integers(1, 6)), int(rng.integers(1, 6))
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (r * (cols + 1) + c).ravel()
    cells = np.column_stack([a, a + 1, a + cols + 2, a + cols + 1])
    keep = rng.random(len(cells)) > rng.choice([0.0, 0.2, 0.5])
    cells = cells[keep] if keep.any() else cells[:1]
    faces = np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]])
    if rng.random() < 0.2:
        faces = np.vstack([faces, faces[:1]])  # a repeated face
    return faces[rng.permutation(len(faces))]


def test_region_loops_equal_loops_with_droppable_vertices_removed():
    rng = np.random.default_rng(11)
    for _ in range(30):
        regions = [random_region_faces(rng) for _ in range(int(rng.integers(1, 6)))]
        k = 1 + max(int(f.max()) for f in regions)
        droppable = rng.random(k) < 0.3
        half = np.concatenate([f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2) for f in regions])
        owner = np.repeat(np.arange(len(regions)), [3 * len(f) for f in regions])
        fast = _region_loops(half, owner, len(regions), k, droppable.tolist())
        for faces, loops in zip(regions, fast):
            expected = _loops(faces)
            if expected is not None:
                expected = [[v for v in loop if not droppable[v]] for loop in expected]
                if not expected or any(len(loop) < 3 for loop in expected):
                    expected = None
            assert loops == expected


def planar_cases():
    """Welded meshes with planar regions: crafted buildings, a grid box, a wall with a window."""
    meshes = [welded_mesh(crafted_building(seed)) for seed in range(6)] + [
        welded_mesh(box_building(6, 4.5, 8.0, (4, 3), 4))
    ]
    builder, atlas = Builder(), Atlas()
    builder.grid((0, 0, 0), (9, 0, 0), (0, 6, 0), 9, 6, atlas.rect())
    window = builder.triangles[0]
    builder.triangles[0] = window[~np.isin(np.arange(len(window)) // 2, [3 * 9 + 4, 3 * 9 + 5])]
    meshes.append(welded_mesh([builder.part()]))
    return meshes


def test_retriangulate_many_equals_one_region_at_a_time():
    rng = np.random.default_rng(13)
    checked = 0
    for positions, faces, corner_uvs, charts in planar_cases():
        regions = planar_regions(positions, faces, charts)
        members = [np.flatnonzero(regions == r) for r in range(regions.max() + 1)]
        # Droppable as the pass chooses them (vertices inside one region, off the open border),
        # plus a few random ones that make some regions fail.
        k = len(positions)
        low, high = np.full(k, k), np.full(k, -1)
        np.minimum.at(low, faces.reshape(-1), np.repeat(regions, 3))
        np.maximum.at(high, faces.reshape(-1), np.repeat(regions, 3))
        inside = (low == high) & ~border_vertices(faces, k)
        for uvs in (corner_uvs, None):
            for share in (0.0, 0.05):
                droppable = inside | (rng.random(k) < share)
                fast = _retriangulate_many(positions, faces, uvs, members, droppable)
                for m, result in zip(members, fast):
                    expected = _retriangulate(
                        positions, faces[m], None if uvs is None else uvs[m], droppable
                    )
                    assert (result is None) == (expected is None)
                    if result is not None:
                        checked += 1
                        assert same(result[0], expected[0]) and same(result[1], expected[1])
    assert checked > 50  # the comparison covered many re-triangulated regions


# --------------------------------------------------------------------------- the exact flag


def chain(parts, ratio, **changes):
    options = dataclasses.replace(SimplifyOptions(), **changes)
    return build_mesh_chain(parts, [LodSpec(0.5), LodSpec(0.1, mesh=ratio)], options)


def count(parts):
    return sum(p.triangle_count for p in parts)


def test_chain_is_build_mesh_lods_with_flags():
    parts = crafted_building(2)
    levels = build_mesh_chain(parts, default_lods(), SimplifyOptions())
    assert all(isinstance(level, MeshLevel) for level in levels) and levels[0].exact
    plain = build_mesh_lods(parts, default_lods(), SimplifyOptions())
    for level, other in zip(levels, plain):
        assert all(
            same(a.positions, b.positions) and same(a.triangles, b.triangles) and same(a.uvs, b.uvs)
            for a, b in zip(level.parts, other)
        )


def test_exact_when_the_planar_pass_alone_meets_the_target():
    box = box_building(6, 4.5, 8.0, (4, 3), 4)  # every wall and the roof one flat polygon
    lod0, lod1 = chain(box, 0.5)
    assert count(lod1.parts) <= round(0.5 * count(box)) and lod1.exact and lod1.surface_exact
    assert lod0.exact and lod0.surface_exact
    metrics = measure_lod(lod0.parts, lod1.parts)
    assert metrics.hausdorff_rel <= 5e-4 and metrics.silhouette_iou == 1.0


def test_not_exact_when_the_collapse_removed_faces():
    builder, atlas = Builder(), Atlas()
    add_dome(builder, atlas, 0.0, 0.0, 0.0, 10.0, 8, 24)  # curved: the planar pass cannot help
    dome = [builder.part()]
    lod0, lod1 = chain(
        dome, 0.5, max_screen_error_px=0.0, protect_largest=0.0, preserve_uv_foldover_edges=False
    )
    assert count(lod1.parts) < count(lod0.parts)
    assert not lod1.exact and not lod1.surface_exact
    assert measure_lod(lod0.parts, lod1.parts).hausdorff_rel > 0
    # The flag is passed down: a level built from an inexact one is inexact even when unchanged.
    levels = build_mesh_chain(
        dome,
        [LodSpec(0.5), LodSpec(0.2, mesh=0.5), LodSpec(0.1, mesh=0.5)],
        dataclasses.replace(
            SimplifyOptions(),
            max_screen_error_px=0.0,
            protect_largest=0.0,
            preserve_uv_foldover_edges=False,
        ),
    )
    assert [level.exact for level in levels] == [True, False, False]
    assert [level.surface_exact for level in levels] == [True, False, False]


def gable_under_a_roof():
    """A 4 m gable wall (z = 0, outline from (4, 0) m, fanned around one interior vertex) and a
    flat 4 x 5 m roof at y = 3 m whose open edge runs along the gable's chord (0, 3)-(4, 3): a
    T-junction the source leaves open. Earcut's triangulation of the gable cuts the chord, so the
    edge becomes shared: same surface, shorter open boundary."""
    outline = [(4, 0), (4, 3), (2, 4), (0, 3), (0, 0)]
    builder = Builder()
    wall = [(x, y, 0.0) for x, y in outline] + [(2.0, 1.5, 0.0)]
    builder.add(
        wall,
        [(5, i, (i + 1) % 5) for i in range(5)],
        [(0.1 + x / 40, 0.1 + y / 40) for x, y, _ in wall],
    )
    roof = [(0, 3, 0), (4, 3, 0), (4, 3, 5), (0, 3, 5)]
    builder.add(roof, [(0, 2, 1), (0, 3, 2)], [(0.6 + x / 40, 0.6 + z / 40) for x, _, z in roof])
    return [builder.part()]


def test_slit_closed_by_the_planar_pass_is_surface_exact_not_exact():
    gable = gable_under_a_roof()
    levels = build_mesh_chain(
        gable, [LodSpec(0.5), LodSpec(0.2, mesh=0.8), LodSpec(0.1, mesh=0.5)], SimplifyOptions()
    )
    assert count(levels[1].parts) == 5 < count(gable)  # the fan's 5 faces became earcut's 3
    metrics = measure_lod(levels[0].parts, levels[1].parts)
    assert metrics.hausdorff_rel <= 5e-4 and metrics.boundary_length_change < -0.1, metrics
    assert [(level.exact, level.surface_exact) for level in levels] == [
        (True, True),
        (False, True),
        (False, True),
    ]
    # The same gable without the roof: nothing to close, exact.
    alone = dataclasses.replace(gable[0], triangles=gable[0].triangles[:5])
    assert [(level.exact, level.surface_exact) for level in chain([alone], 0.5)] == [
        (True, True),
        (True, True),
    ]


def two_panels(gap):
    """Two coplanar 5 x 10 m wall panels ``gap`` metres apart along x, each cut 4 x 8."""
    builder = Builder()
    builder.grid((0, 0, 0), (5, 0, 0), (0, 10, 0), 4, 8, (0.0, 0.0, 0.2, 0.2))
    builder.grid((5 + gap, 0, 0), (5, 0, 0), (0, 10, 0), 4, 8, (0.2, 0.0, 0.4, 0.2))
    return [builder.part()]


def test_link_distance_welding_distinct_vertices_is_not_exact():
    panels = two_panels(0.001)
    welded = chain(panels, 0.9, vertex_link_distance=0.01, preserve_uv_seam_edges=False)[1]
    assert count(welded.parts) < count(panels) and not welded.exact and not welded.surface_exact
    # The same distance merging nothing (panels 1 m apart) leaves the planar-only level exact,
    # as does the default noise-only welding.
    apart = chain(two_panels(1.0), 0.9, vertex_link_distance=0.01)[1]
    assert count(apart.parts) < count(panels) and apart.exact and apart.surface_exact
    assert chain(panels, 0.9)[1].exact


# --------------------------------------------------------------------------- collapse UVs


def reference_assign_uvs(
    positions, faces, corner_uvs, face_chart, out_faces, face_ids, project=True
):
    """The former assign_uvs: every changed corner looked up one at a time."""
    in_faces, in_uvs = faces[face_ids], corner_uvs[face_ids]
    out_uvs = in_uvs.copy()
    match = out_faces[:, :, None] == in_faces[:, None, :]
    found = match.any(axis=2)
    source_corner = match.argmax(axis=2)
    rows = np.arange(len(out_faces))[:, None]
    out_uvs[found] = in_uvs[np.broadcast_to(rows, found.shape)[found], source_corner[found]]
    crossings = []
    if (~found).any():
        keys = face_chart[:, None] * (len(positions) + 1) + faces
        order = np.argsort(keys.reshape(-1), kind="stable")
        sorted_keys = keys.reshape(-1)[order]
        flat_uvs = corner_uvs.reshape(-1, 2)[order]
        for o, j in zip(*np.nonzero(~found)):
            chart = face_chart[face_ids[o]]
            vertex = out_faces[o, j]
            key = chart * (len(positions) + 1) + vertex
            lo, hi = (
                np.searchsorted(sorted_keys, key, "left"),
                np.searchsorted(sorted_keys, key, "right"),
            )
            if hi > lo:
                block = flat_uvs[lo:hi]
                if (block == block[0]).all():
                    out_uvs[o, j] = block[0]
                    continue
                candidates = np.unique(block, axis=0)
                others = out_uvs[o, found[o]] if found[o].any() else in_uvs[o]
                out_uvs[o, j] = candidates[
                    np.argmin(np.linalg.norm(candidates - others.mean(axis=0), axis=1))
                ]
            else:
                crossings.append(vertex)
                if not project:
                    continue
                in_chart = np.flatnonzero(face_chart == chart)
                index, weights = closest_barycentric(positions[vertex], positions[faces[in_chart]])
                out_uvs[o, j] = weights @ corner_uvs[in_chart[index]]
    return out_uvs.astype(np.float32), np.unique(np.asarray(crossings, dtype=np.int64))


def test_assign_uvs_equals_the_corner_by_corner_lookup():
    rng = np.random.default_rng(17)
    for seed in range(6):
        positions, faces, corner_uvs, charts = welded_mesh(crafted_building(seed))
        if seed % 2:  # a chart where one vertex has two UVs (a wrapped seam)
            corner_uvs = corner_uvs.copy()
            corner_uvs[0, 0] += np.float32(0.125)
            charts = charts.copy()
            charts[faces[:, 0] == faces[0, 0]] = charts[0]
        face_ids = np.sort(rng.choice(len(faces), size=len(faces) // 2, replace=False))
        out_faces = faces[face_ids].copy()
        # Move corners to another vertex: mostly within the face's chart, some across a seam.
        moved = rng.random(out_faces.shape) < 0.3
        same_chart = [np.unique(faces[charts == charts[f]]) for f in face_ids]
        for o, j in zip(*np.nonzero(moved)):
            pool = same_chart[o] if rng.random() < 0.85 else np.arange(len(positions))
            out_faces[o, j] = rng.choice(pool)
        for project in (True, False):
            fast = assign_uvs(
                positions, faces, corner_uvs, charts, out_faces, face_ids, project=project
            )
            expected = reference_assign_uvs(
                positions, faces, corner_uvs, charts, out_faces, face_ids, project=project
            )
            assert same(fast[0], expected[0]) and same(fast[1], expected[1])


def open_edges(parts) -> int:
    """Edges used by one face of the welded parts, slits included."""
    positions, faces = joined(parts)
    return len(boundary_loops(faces, len(positions))[0])


def test_exact_levels_measure_as_identity_slits_closed_or_not(tmp_path):
    # VWorld-like buildings read back from generated .xdo files (float32 positions, as the
    # issue 8 tile): every level flagged exact must measure as LOD0 itself (what the pipeline
    # reports for it without measuring), also where the planar stage closed slits of the source
    # (same surface; a zero-width crack is no part of the open boundary).
    from exporter import samplegen
    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder

    samplegen.generate_tile(tmp_path, count=12, seed=3, atlas_size=16)
    readers = Config().readers
    exact, slit_closed = 0, 0
    for building in [
        load_entry(entry, readers) for entry in scan_folder(tmp_path, readers).entries
    ]:
        levels = build_mesh_chain(building.parts, default_lods(), SimplifyOptions())
        for above, level in zip(levels, levels[1:]):
            metrics = measure_lod(levels[0].parts, level.parts)
            assert level.surface_exact or not level.exact
            assert above.surface_exact or not level.surface_exact
            if level.surface_exact:
                assert metrics.hausdorff_rel <= 5e-4, metrics
            if level.exact:
                exact += 1
                assert metrics.hausdorff_rel <= 5e-4 and metrics.new_holes == 0, metrics
                assert abs(metrics.boundary_length_change) < 1e-9, metrics
                assert metrics.silhouette_iou == 1.0 and metrics.wall_coverage == 1.0, metrics
                # Fewer open edges than LOD0, yet no boundary change: slits closed.
                slit_closed += open_edges(level.parts) < open_edges(levels[0].parts)
    # Levels go as far as their error budget allows, so only some stay exact.
    assert exact > 5 and slit_closed > 0, (exact, slit_closed)


# --------------------------------------------------------------------------- error guard


def test_guard_exceeds_agrees_with_the_certified_bounds():
    # The guard's decision (early exits) against the bounds of the symmetric distance: it
    # refuses every tolerance below the lower bound, accepts every one from the upper bound up,
    # and the true distance (a dense sampling's maximum stands in, from below) lies between.
    from exporter.simplify import simplify_parts
    from exporter.simplify.guard import Reference, deviation, deviation_bounds, exceeds
    from tests.hausdorff_check import dense_hausdorff

    builder, atlas = Builder(), Atlas()
    add_dome(builder, atlas, 0.0, 0.0, 0.0, 10.0, 8, 24)
    shapes = [[builder.part()]] + [crafted_building(seed) for seed in range(3)]
    rng = np.random.default_rng(3)
    checked = 0
    for parts in shapes:
        positions, faces, _, _ = welded_mesh(parts)
        reference = Reference(positions, faces)
        options = SimplifyOptions(
            max_screen_error_px=0.0,
            protect_largest=0.0,
            preserve_uv_foldover_edges=False,
            preserve_uv_seam_edges=False,
        )
        levels = [
            simplify_parts(parts, int(count(parts) * ratio), options) for ratio in (0.8, 0.5, 0.2)
        ]
        jitter = positions + rng.normal(size=positions.shape) * 0.01  # no corner shared with LOD0
        for level_positions, level_faces in [welded_mesh(level)[:2] for level in levels] + [
            (jitter, faces),
            (positions, faces),
        ]:
            lower, upper = deviation_bounds(reference, level_positions, level_faces)
            assert deviation(reference, level_positions, level_faces) == upper
            dense = dense_hausdorff((positions, faces), (level_positions, level_faces), 6)
            assert lower <= upper and dense <= upper * (1 + 1e-9) + 1e-12
            for tolerance in (0.5 * lower, np.nextafter(lower, 0.0)):
                if lower > 0:
                    assert exceeds(reference, level_positions, level_faces, tolerance)
                    checked += 1
            for tolerance in (upper, 2.0 * upper + 1e-3):
                assert not exceeds(reference, level_positions, level_faces, tolerance)
                checked += 1
        assert exceeds(reference, positions, faces[:0], 1.0)  # nothing left: infinitely far
    assert checked >= 4 * 4 * 4
