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
from test_simplify_shapes import box_building, crafted_building

from exporter import quality
from exporter.config import Config
from exporter.mesh import slits
from exporter.mesh.distance import SurfaceIndex, face_normals, point_triangle_distance, row_lengths
from exporter.mesh.hausdorff import hausdorff_bounds
from exporter.mesh.raster import rasterise, silhouettes
from exporter.mesh.slits import close_slits
from exporter.mesh.topology import boundary_loops
from exporter.quality import boundary_quality, joined, measure_lod
from exporter.simplify import build_mesh_lods

# --------------------------------------------------------------------------- reference formulations


def reference_rasterise(xy, faces, size):
    """Conservative raster over (triangle, row) pairs, every edge gathered per pair (af57811)."""
    tri = xy[faces]
    y_low, y_high = tri[:, :, 1].min(axis=1), tri[:, :, 1].max(axis=1)
    if len(tri) == 0:
        return np.zeros((size, size), dtype=bool)
    r0 = np.clip(np.ceil(y_low - 0.5), 0, size - 1).astype(np.int64)
    r1 = np.clip(np.floor(y_high + 0.5), 0, size - 1).astype(np.int64)
    counts = np.maximum(r1 - r0 + 1, 0)
    owner = np.repeat(np.arange(len(tri)), counts)
    rows = r0[owner] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    strip_low, strip_high = rows - 0.5, rows + 0.5
    lo = np.full(len(rows), np.inf)
    hi = np.full(len(rows), -np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        p, q = tri[:, i], tri[:, j]
        down = p[:, 1] > q[:, 1]
        p, q = np.where(down[:, None], q, p), np.where(down[:, None], p, q)
        dy = q[:, 1] - p[:, 1]
        slope = np.divide(q[:, 0] - p[:, 0], dy, out=np.zeros_like(dy), where=dy > 0)
        px, py, qx, qy, slope, rising = (
            p[owner, 0],
            p[owner, 1],
            q[owner, 0],
            q[owner, 1],
            slope[owner],
            (dy > 0)[owner],
        )
        a = np.maximum(py, strip_low)
        b = np.minimum(qy, strip_high)
        xa = np.where(rising, px + (a - py) * slope, px)
        xb = np.where(rising, px + (b - py) * slope, qx)
        valid = a <= b
        lo = np.where(valid, np.minimum(lo, np.minimum(xa, xb)), lo)
        hi = np.where(valid, np.maximum(hi, np.maximum(xa, xb)), hi)
    keep = lo <= hi
    rows = rows[keep]
    c0 = np.clip(np.ceil(lo[keep] - 0.5), 0, size - 1).astype(np.int64)
    c1 = np.clip(np.floor(hi[keep] + 0.5), 0, size - 1).astype(np.int64)
    width = size + 1
    spans = np.bincount(rows * width + c0, minlength=size * width) - np.bincount(
        rows * width + c1 + 1, minlength=size * width
    )
    return np.cumsum(spans[: size * width].reshape(size, width)[:, :size], axis=1) > 0


def reference_boundary_loops(faces, vertex_count):
    """Open-boundary edges and loop count through a COO matrix (af57811)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    keys, counts = np.unique(edges[:, 0] * (vertex_count + 1) + edges[:, 1], return_counts=True)
    border = np.column_stack(np.divmod(keys[counts == 1], vertex_count + 1))
    if len(border) == 0:
        return border, 0
    graph = coo_matrix(
        (np.ones(len(border)), (border[:, 0], border[:, 1])), shape=(vertex_count, vertex_count)
    )
    count, labels = connected_components(graph, directed=False)
    return border, int(len(np.unique(labels[np.unique(border)])))


def reference_refine(index, points, upper):
    """Exact distances with a (p, m, 3) gap temporary and np.minimum.at (af57811)."""
    exact = upper.copy()
    open_points = np.flatnonzero(upper > 1e-9)
    if len(open_points) == 0 or index.tree is None:
        return exact
    gap = (
        np.sqrt(((points[open_points, None, :] - index.centres[None]) ** 2).sum(-1))
        - index.radii[None]
    )
    rows, cols = np.nonzero(gap < upper[open_points, None] - 1e-12)
    if len(rows):
        np.minimum.at(
            exact,
            open_points[rows],
            point_triangle_distance(points[open_points[rows]], index.tri[cols]),
        )
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
        take = order[start : start + chunk]
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
    return np.vstack(
        [
            rng.normal(size=(count, 3)) * 12.0,
            positions[:25],
            on,
            on + rng.normal(size=on.shape) * 1e-7,
        ]
    )


# --------------------------------------------------------------------------- tests


def test_boundary_loops_csr_equals_the_coo_reference():
    rng = np.random.default_rng(11)
    cases = [joined(box_building(5, 3, 20.0, (2, 4), 2)), joined(crafted_building(3))]
    for _ in range(40):
        vertices = int(rng.integers(3, 120))
        cases.append((None, rng.integers(0, vertices, size=(int(rng.integers(1, 200)), 3))))
    for positions, faces in cases:
        count = (
            len(positions)
            if positions is not None
            else int(faces.max()) + 1 + int(rng.integers(0, 5))
        )
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
            assert np.array_equal(
                index.within(points, tolerance), reference_within(index, points, tolerance)
            )
        plain = reference_max_distance(index, points)
        assert index.max_distance(points) == plain
        # A floor only stops the search sooner: the result is max(floor, the exact maximum).
        for floor in (
            0.0,
            plain * 0.5,
            plain * 0.9,
            plain * 0.999,
            float(np.median(exact)),
            plain,
            plain * 1.5,
        ):
            assert index.max_distance(points, floor=floor) == max(floor, plain)


def test_empty_and_degenerate_surfaces_equal_the_references():
    rng = np.random.default_rng(13)
    points = rng.normal(size=(20, 3))
    empty = SurfaceIndex(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    assert np.array_equal(empty.within(points, 1.0), reference_within(empty, points, 1.0))
    assert empty.max_distance(points) == reference_max_distance(empty, points) == np.inf
    flat = SurfaceIndex(
        np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]])
    )  # a segment
    assert np.array_equal(flat.within(points, 0.5), reference_within(flat, points, 0.5))
    assert flat.max_distance(points) == reference_max_distance(flat, points)
    assert flat.within(np.zeros((0, 3)), 1.0).shape == (0,)


@pytest.mark.parametrize("seed", [2, 5])
def test_measure_lod_hausdorff_bounds_the_sampled_two_way_maximum(seed):
    # hausdorff_rel is the certified upper bound (issue 13): never below the old sampled value
    # (exact distances of vertices + samples, a lower bound), within HAUSDORFF_RTOL of the
    # certified lower bound.
    config = Config()
    chain = build_mesh_lods(crafted_building(seed), config.lods, config.simplify)
    source_pos, source_faces = joined(chain[0])
    for level in chain[1:]:
        lod_pos, lod_faces = joined(level)
        source_points = measure_points(source_pos, source_faces, seed=0)
        lod_points = measure_points(lod_pos, lod_faces, seed=1)
        expected = max(
            reference_max_distance(SurfaceIndex(lod_pos, lod_faces), source_points),
            reference_max_distance(SurfaceIndex(source_pos, source_faces), lod_points),
        )
        diagonal = float(np.linalg.norm(source_pos.max(0) - source_pos.min(0)))
        lower, upper = hausdorff_bounds(
            (source_pos, source_faces), (lod_pos, lod_faces), rtol=0.02, atol=1e-5 * diagonal
        )
        reported = measure_lod(chain[0], level).hausdorff_rel * diagonal
        # Both are certified upper bounds (measure_lod's own refinement order may end at another
        # one): each above every lower bound and within the requested gap of the lower bound.
        for bound in (upper, reported):
            assert lower <= bound <= lower * 1.02 + 1e-5 * diagonal
            assert expected <= bound * (1 + 1e-12)


def measure_points(positions, faces, seed):
    """The points measure_lod measures from: vertices + SAMPLES samples, seeded as it does."""
    from exporter.mesh.distance import SEED, sample_surface
    from exporter.quality import SAMPLES

    return np.vstack(
        [positions, sample_surface(positions, faces, SAMPLES, np.random.default_rng(SEED + seed))]
    )


def test_moved_level_keeps_its_values_through_the_floor():
    """A level shifted by 0.5 m: the larger direction is the second one measured, so the floor
    (the first direction) must not hide it."""
    box = box_building(5, 3, 20.0, (2, 4), 2)
    moved = [dataclasses.replace(box[0], positions=box[0].positions * [1.0, 1.3, 1.0])]  # taller
    source_pos, source_faces = joined(box)
    lod_pos, lod_faces = joined(moved)
    forward = reference_max_distance(
        SurfaceIndex(lod_pos, lod_faces), measure_points(source_pos, source_faces, 0)
    )
    backward = reference_max_distance(
        SurfaceIndex(source_pos, source_faces), measure_points(lod_pos, lod_faces, 1)
    )
    assert backward > forward  # the level's raised roof is far from the source, not the reverse
    diagonal = float(np.linalg.norm(source_pos.max(0) - source_pos.min(0)))
    # The certified bound (issue 13): the sampled value (the roof's top, exact) from below.
    assert backward / diagonal <= measure_lod(box, moved).hausdorff_rel
    assert measure_lod(box, moved).hausdorff_rel <= backward / diagonal * 1.02 + 1e-5


def tricky_pixels(rng, count, size):
    """Pixel coordinates that hit the rasteriser's edge cases: on strip lines (k - 0.5) and
    pixel centres, flat and vertical edges, outside the raster, near-flat slopes."""
    xy = rng.random((count, 2)) * (size + 8) - 4
    xy[::3, 1] = np.round(xy[::3, 1]) - 0.5  # on a strip line
    xy[1::5] = np.round(xy[1::5])  # on pixel centres
    xy[2::4, 1] = xy[0::4, 1][: len(xy[2::4])]  # flat edges
    xy[3::4, 0] = xy[1::4, 0][: len(xy[3::4])]  # vertical edges
    xy[1::6, 1] = xy[0::6, 1][: len(xy[1::6])] + 1e-13  # nearly flat: huge slopes
    return xy


@pytest.mark.parametrize("size", [1, 7, 128])
def test_rasterise_equals_the_reference_bit_for_bit(size):
    rng = np.random.default_rng(size)
    for _ in range(30):
        xy = tricky_pixels(rng, int(rng.integers(3, 60)), size)
        faces = rng.integers(0, len(xy), size=(int(rng.integers(1, 80)), 3))
        assert np.array_equal(rasterise(xy, faces, size), reference_rasterise(xy, faces, size))
    # Large triangles, slivers and single lines.
    xy = np.array(
        [[-50.0, -50.0], [300.0, 20.5], [10.0, 400.0], [3.5, 3.5], [90.25, 3.5], [3.5, 3.5 + 1e-12]]
    )
    faces = np.array([[0, 1, 2], [3, 4, 5], [3, 4, 4], [5, 5, 5], [2, 1, 0]])
    assert np.array_equal(rasterise(xy, faces, size), reference_rasterise(xy, faces, size))
    assert not rasterise(xy, faces[:0], size).any()


def test_silhouettes_of_buildings_equal_the_reference():
    config = Config()
    for seed in (1, 2, 6):
        for level in build_mesh_lods(crafted_building(seed), config.lods, config.simplify):
            positions, faces = joined(level)
            low, high = positions.min(0) + 0.3, positions.max(0) - 0.2  # some corners outside
            span = np.maximum(high - low, 1e-9)
            pixels = (positions - low) / span * 127
            expected = [
                reference_rasterise(pixels[:, [u, v]], faces, 128)
                for u, v in ((0, 2), (0, 1), (2, 1))
            ]
            assert all(
                np.array_equal(a, b)
                for a, b in zip(silhouettes(positions, faces, low, high), expected)
            )


def test_silhouettes_are_reused_for_the_same_triangles_only():
    """The guard and measure_lod rasterise the same triangles on vertex arrays numbered
    differently: the second call is the first's result; another box, dtype or triangle is not."""
    positions, faces = joined(crafted_building(2))
    low, high = positions.min(0), positions.max(0)
    first = silhouettes(positions, faces, low, high)
    order = np.random.default_rng(0).permutation(len(positions))  # vertices renumbered
    renumbered = np.empty_like(order)
    renumbered[order] = np.arange(len(order))
    again = silhouettes(positions[order], renumbered[faces], low, high)
    assert again is first and not first.flags.writeable
    moved = positions.copy()
    moved[faces[0, 0]] += 0.25 * (high - low)  # one corner moved
    for other in (
        silhouettes(positions, faces, low - 1.0, high),
        silhouettes(positions, faces[::-1], low, high),
        silhouettes(positions.astype(np.float32), faces, low, high),
        silhouettes(moved, faces, low, high),
    ):
        assert other is not first
    span = np.maximum(high - low, 1e-9)
    pixels = (moved - low) / span * 127
    expected = [
        reference_rasterise(pixels[:, [u, v]], faces, 128) for u, v in ((0, 2), (0, 1), (2, 1))
    ]
    assert all(np.array_equal(a, b) for a, b in zip(silhouettes(moved, faces, low, high), expected))


def test_flat_top_edge_ends_are_exact_where_the_slanted_edges_round():
    """A flat edge contributes both its end x; the slanted edge reaching the same corner gives it
    only up to rounding, which moves a span's end when the corner sits on a pixel border."""
    rng = np.random.default_rng(21)
    top, left, right = 60.3, 5.5, 40.5  # the flat edge's corners on pixel borders
    checked = 0
    for rx, ry in rng.random((3000, 2)) * [30.0, 20.0]:
        lossy = [rx + (top - ry) * ((x - rx) / (top - ry)) != x for x in (left, right)]
        if not any(lossy):
            continue  # exact here: nothing to tell apart
        xy = np.array([[rx, ry], [left, top], [right, top]])
        for faces in ([[0, 1, 2]], [[0, 2, 1]]):  # each corner once as the flat edge's end
            faces = np.array(faces)
            assert np.array_equal(rasterise(xy, faces, 128), reference_rasterise(xy, faces, 128))
        checked += 1
    assert checked >= 10


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_face_normals_and_lengths_are_numpys(scale):
    rng = np.random.default_rng(int(scale * 1000) + 3)
    positions = rng.normal(size=(300, 3)) * scale
    faces = rng.integers(0, 300, size=(2000, 3))
    faces[::7, 2] = faces[::7, 1]  # degenerate: zero normals
    a, b, c = (positions[faces[:, i]] for i in range(3))
    expected = np.cross(b - a, c - a)
    assert np.array_equal(face_normals(positions, faces), expected)
    assert np.array_equal(row_lengths(expected), np.linalg.norm(expected, axis=1))


def test_a_point_as_far_as_its_nearest_probe_still_counts_above_a_close_floor():
    """The floor skips points whose nearest probe is closer than it; a point whose distance is
    its probe distance (nearest to a corner) and just above the floor must still be measured."""
    index = SurfaceIndex(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    point = np.array([[-0.3, -0.4, 0.0]])  # 0.5 m from corner (0, 0, 0)
    assert reference_max_distance(index, point) == 0.5
    for floor in (0.5 * (1 - 1e-12), 0.5 * (1 - 1e-6), 0.5, 0.25):
        assert index.max_distance(point, floor=floor) == 0.5
    assert index.max_distance(point, floor=0.75) == 0.75


def reference_boundary_keys(source_parts, lod_parts):
    """triangle_ratio, boundary_length_change and new_holes as measure_lod computed them inline
    (f369deb): reference boundary loops, the outline's length as norm(diff).sum(); both sides
    with their slits closed first (a zero-width crack is no outline since issue 13, round 6)."""
    source_pos, source_faces = joined(source_parts)
    lod_pos, lod_faces = joined(lod_parts)
    source_faces = close_slits(source_pos, source_faces, None)[0]
    lod_faces = close_slits(lod_pos, lod_faces, None)[0]
    border, loops = reference_boundary_loops(source_faces, len(source_pos))
    length = float(np.linalg.norm(np.diff(source_pos[border], axis=1), axis=-1).sum())
    lod_border, lod_loops = reference_boundary_loops(lod_faces, len(lod_pos))
    lod_length = (
        float(np.linalg.norm(np.diff(lod_pos[lod_border], axis=1), axis=-1).sum())
        if len(lod_border)
        else 0.0
    )
    diagonal = max(float(np.linalg.norm(source_pos.max(0) - source_pos.min(0))), 1e-9)
    source_tris = sum(p.triangle_count for p in source_parts)
    return {
        "triangle_ratio": float(sum(p.triangle_count for p in lod_parts) / source_tris),
        "boundary_length_change": float(
            (lod_length - length) / length if length > 0 else lod_length / diagonal
        ),
        "new_holes": int(max(0, lod_loops - loops)),
    }


@pytest.mark.parametrize("boundary_first", [True, False])
def test_boundary_quality_keys_are_measure_lods_bit_for_bit(boundary_first):
    """On random face subsets of buildings (open boundaries that grow, split and close),
    whichever of the two runs first (both read the one cached source side, each piece made by
    whichever needs it first)."""
    rng = np.random.default_rng(31)
    sources = [box_building(5, 3, 20.0, (2, 4), 2), crafted_building(3), crafted_building(6)]
    checked = 0
    for source in sources:
        quality._CACHE.clear()
        for keep in (1.0, 0.9, 0.6, 0.3):
            part = source[0]
            mask = rng.random(part.triangle_count) < keep
            level = [dataclasses.replace(part, triangles=part.triangles[mask])] + source[1:]
            if boundary_first:
                bounded, measured = boundary_quality(source, level), measure_lod(source, level)
            else:
                measured, bounded = measure_lod(source, level), boundary_quality(source, level)
            expected = reference_boundary_keys(source, level)
            for key, value in expected.items():
                ours = getattr(bounded, key)
                assert ours == getattr(measured, key) == value and type(ours) is type(value)
            checked += keep < 1.0 and expected["boundary_length_change"] != 0.0
    assert checked >= 6  # the subsets did change the boundary


def reference_wall_points(parts):
    """The source's wall samples as af57811 drew them: after SAMPLES samples of the whole
    surface (for the sampled Hausdorff distance) from the same stream."""
    from exporter.mesh.distance import SEED, sample_surface
    from exporter.quality import SAMPLES, WALL_MAX_UP, WALL_SAMPLES

    positions, faces = joined(parts)
    rng = np.random.default_rng(SEED)
    normals = face_normals(positions, faces)
    lengths = row_lengths(normals)
    walls = (np.abs(normals[:, 1]) < WALL_MAX_UP * lengths) & (lengths > 0)
    sample_surface(positions, faces, SAMPLES, rng)
    return sample_surface(positions, faces[walls], WALL_SAMPLES, rng)


def test_wall_coverage_is_the_exact_share_whichever_path_gives_it():
    """Wall samples are af57811's; wall_coverage is the share of them within the tolerance by
    exact distances, also where the certified Hausdorff bound (below the tolerance) stands in."""
    config = Config()
    shortcut = 0
    for seed in (1, 3, 6):
        source = crafted_building(seed)
        quality._CACHE.clear()
        side = quality.prepare_source(source)
        assert np.array_equal(side.wall_points, reference_wall_points(source))
        tolerance = quality.COVER_TOLERANCE * side.diagonal
        box = box_building(5, 3, 20.0, (2, 4), 2)
        levels = build_mesh_lods(source, config.lods, config.simplify)[1:]
        levels.append([dataclasses.replace(source[0], triangles=source[0].triangles[::2])])
        levels.append([dataclasses.replace(box[0], positions=box[0].positions * 0.9)])
        for level in levels:
            lod_pos, lod_faces = joined(level)
            inside = reference_within(SurfaceIndex(lod_pos, lod_faces), side.wall_points, tolerance)
            measured = measure_lod(source, level)
            assert measured.wall_coverage == float(inside.mean())
            shortcut += measured.hausdorff_rel < quality.COVER_TOLERANCE
    assert 0 < shortcut < 12  # both paths were taken


def former_quality(source, level, kind, deviation, monkeypatch):
    """The value the former code gave (before the quality speed pass 2): every source side
    prepared afresh (no weld shared between the caches), the level welded again for the
    certification and the loops counted by scipy's connected_components."""
    with monkeypatch.context() as patch:
        patch.setattr(slits, "boundary_loops", reference_boundary_loops)
        patch.setattr(
            quality,
            "certified_hausdorff_rel",
            lambda s, lod, mesh=None, inner=quality.certified_hausdorff_rel: inner(s, lod),
        )
        quality._CACHE.clear()
        if kind == "exact":
            return quality.exact_quality(source, level)
        if kind == "boundary":
            return boundary_quality(source, level)
        return measure_lod(source, level, deviation)


def test_export_quality_equals_the_former_code_bit_for_bit(tmp_path, monkeypatch):
    """Every level k >= 1 of generated buildings, measured as the pipeline does (caches shared
    between a building's levels, in level order), against the former code's values."""
    from exporter.readers import load_entry, scan_folder
    from exporter.samplegen import generate_tile
    from exporter.simplify import build_mesh_chain

    generate_tile(str(tmp_path / "tile"), count=24, seed=3, atlas_size=64)
    config = Config()
    kinds = set()
    for entry in scan_folder(str(tmp_path / "tile"), config.readers).entries:
        parts = load_entry(entry, config.readers).parts
        chain = build_mesh_chain(parts, config.lods, config.simplify)
        quality._CACHE.clear()
        levels = []
        for level in chain[1:]:
            kind = "exact" if level.exact else "boundary" if level.surface_exact else "measured"
            if kind == "exact":
                value = quality.exact_quality(chain[0].parts, level.parts)
            elif kind == "boundary":
                value = boundary_quality(chain[0].parts, level.parts)
            else:
                value = measure_lod(chain[0].parts, level.parts, level.deviation)
            levels.append((kind, level, value))
        for kind, level, value in levels:
            former = former_quality(chain[0].parts, level.parts, kind, level.deviation, monkeypatch)
            assert repr(value) == repr(former), (entry.id, kind)
            kinds.add(kind)
        # With the level's own certification too (no guard bound given).
        for kind, level, _value in levels:
            if kind == "measured":
                assert repr(measure_lod(chain[0].parts, level.parts)) == repr(
                    former_quality(chain[0].parts, level.parts, kind, None, monkeypatch)
                )
    assert {"exact", "measured"} <= kinds


def test_chain_qualities_equal_the_per_level_calls_bit_for_bit(tmp_path, monkeypatch):
    """The pipeline's quality loop (:func:`exporter.job.chain_qualities`: one prepared source
    per building, its pieces made on demand) gives every level's values exactly as the former
    code measuring each level from the parts with every cache emptied; wall samples are drawn
    only for a level whose certified bound leaves the wall tolerance open."""
    import exporter.job
    from exporter.job import chain_qualities, same_geometry
    from exporter.readers import load_entry, scan_folder
    from exporter.samplegen import generate_tile
    from exporter.simplify import build_mesh_chain

    generate_tile(str(tmp_path / "tile"), count=24, seed=5, atlas_size=64)
    config = Config()
    kinds: dict[str, int] = {}
    for entry in scan_folder(str(tmp_path / "tile"), config.readers).entries:
        parts = load_entry(entry, config.readers).parts
        chain = build_mesh_chain(parts, config.lods, config.simplify)
        made: list[quality.Source] = []

        def recorded(parts, made=made):
            made.append(quality.Source(parts))
            return made[-1]

        with monkeypatch.context() as patch:
            patch.setattr(exporter.job, "Source", recorded)
            got = chain_qualities(chain, [level.parts for level in chain])
        assert got[0] is None and len(got) == len(chain)
        for k in range(1, len(chain)):
            if k > 1 and same_geometry(chain[k].parts, chain[k - 1].parts):
                assert got[k] is got[k - 1]
                continue
            level = chain[k]
            kind = "exact" if level.exact else "boundary" if level.surface_exact else "measured"
            former = former_quality(chain[0].parts, level.parts, kind, level.deviation, monkeypatch)
            assert repr(got[k]) == repr(former), (entry.id, k, kind)
            assert got[k].to_manifest() == dataclasses.asdict(former)
            assert list(got[k].to_manifest()) == list(dataclasses.asdict(former))
            kinds[kind] = kinds.get(kind, 0) + 1
        # Wall samples are drawn only when a level's bound leaves the coverage open.
        (source,) = made
        needed = any(
            q is not None and q.hausdorff_rel > 0.9 * quality.COVER_TOLERANCE for q in got[1:]
        )
        assert ("wall_points" in source.__dict__) <= needed
    assert kinds.get("exact", 0) and kinds.get("measured", 0)


@pytest.mark.parametrize("strict", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sphere_pairs_from_the_centre_tree_equal_all_pairs(seed, strict, monkeypatch):
    """The k-d tree path of ``SurfaceIndex.sphere_pairs`` (large problems) returns the very
    pairs, in the same order, that testing every point against every triangle does, limits
    at exactly a pair's gap included."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(-20, 20, (300, 3))
    faces = rng.integers(0, 300, (400, 3))
    index = SurfaceIndex(positions, faces)
    points = rng.uniform(-25, 25, (500, 3))
    limit = rng.uniform(0, 8, 500)
    # Some limits exactly at a triangle's gap, where < and <= differ.
    gap = np.sqrt(((points[:50, None] - index.centres[None, :50]) ** 2).sum(-1)) - index.radii[:50]
    limit[:50] = np.diagonal(gap)
    monkeypatch.setattr(SurfaceIndex, "DENSE_PAIRS", 10**12)
    dense = index.sphere_pairs(points, limit, strict)
    monkeypatch.setattr(SurfaceIndex, "DENSE_PAIRS", 0)
    monkeypatch.setattr(SurfaceIndex, "TREE_SHARE", 0)  # the lists however many pairs they hold
    tree = index.sphere_pairs(points, limit, strict)
    assert len(dense[0]) > 1000
    np.testing.assert_array_equal(dense[0], tree[0])
    np.testing.assert_array_equal(dense[1], tree[1])
