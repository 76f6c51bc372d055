"""exporter.quality.measure_lod and its helpers behave: identical meshes score perfectly, damage is
seen by the metric meant to see it, distances are exact.

Positions are in the building-local East/Up/North frame (metres, y = Up).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_simplify_shapes import box_building, crafted_building

from exporter.mesh.distance import distance_to_surface, point_triangle_distance
from exporter.mesh.raster import rasterise
from exporter.mesh.topology import boundary_loops
from exporter.model import Part
from exporter.quality import boundary_quality, exact_quality, joined, measure_lod

KEYS = {
    "triangle_ratio",
    "hausdorff_rel",
    "silhouette_iou",
    "wall_coverage",
    "boundary_length_change",
    "new_holes",
}


@pytest.fixture(scope="module")
def box():
    """Floorless 10 x 6 x 20 m box (x, z, height), walls cut 2 x 4, roof 2 x 2: 36 triangles."""
    return box_building(5, 3, 20.0, (2, 4), 2)


def without(parts, mask):
    part = parts[0]
    return [dataclasses.replace(part, triangles=part.triangles[~mask])]


def test_identical_mesh_scores_perfectly(box):
    for parts in (box, crafted_building(2)):
        metrics = measure_lod(parts, parts)
        assert set(metrics.to_manifest()) == KEYS
        assert metrics.triangle_ratio == 1.0
        assert metrics.hausdorff_rel < 1e-12
        assert metrics.silhouette_iou == 1.0 and metrics.wall_coverage == 1.0
        assert metrics.boundary_length_change == 0.0 and metrics.new_holes == 0


def test_removed_wall_drops_coverage_and_opens_the_boundary(box):
    part = box[0]
    centres = part.positions[part.triangles].mean(axis=1)
    wall = centres[:, 0] > 4.99  # the whole east wall (x = +5 m)
    metrics = measure_lod(box, without(box, wall))
    # The east wall is 6 x 20 of 2 x (10 + 6) x 20 = 19 % of the wall area.
    assert 0.7 < metrics.wall_coverage < 0.9
    assert metrics.boundary_length_change > 1.0  # 40 m of sides and top added to 32 m of footprint
    assert (
        metrics.silhouette_iou == 1.0 or metrics.silhouette_iou > 0.9
    )  # seen edge-on from the side views
    assert metrics.triangle_ratio == pytest.approx(1 - wall.sum() / len(wall))


def test_hole_in_the_roof_is_a_new_hole(box):
    # The roof is cut 2 x 2: a triangle at its centre touches no border, so dropping it opens
    # one new boundary loop.
    part = box[0]
    centres = part.positions[part.triangles].mean(axis=1)
    roof = np.flatnonzero(centres[:, 1] > 19.99)
    mask = np.zeros(len(part.triangles), dtype=bool)
    mask[roof[np.argmin(centres[roof, 0] ** 2 + centres[roof, 2] ** 2)]] = True
    metrics = measure_lod(box, without(box, mask))
    assert metrics.new_holes == 1
    assert metrics.silhouette_iou < 1.0


def test_shifted_mesh_has_the_shift_as_hausdorff(box):
    diagonal = float(np.linalg.norm([10.0, 20.0, 6.0]))
    moved = [dataclasses.replace(box[0], positions=box[0].positions + [0.5, 0.0, 0.0])]
    metrics = measure_lod(box, moved)
    # Seen from the sampled points: the east wall's points are 0.5 m from the moved surface.
    assert metrics.hausdorff_rel == pytest.approx(0.5 / diagonal, rel=1e-6)
    assert metrics.silhouette_iou < 1.0


def test_point_triangle_distance_against_a_dense_barycentric_grid():
    rng = np.random.default_rng(1)
    points = rng.normal(size=(15, 3)) * 3.0
    tri = rng.normal(size=(15, 3, 3)) * 2.0
    s, t = np.meshgrid(np.linspace(0, 1, 151), np.linspace(0, 1, 151))
    inside = s + t <= 1.0
    s, t = s[inside], t[inside]
    samples = (
        tri[:, None, 0]
        + s[None, :, None] * (tri[:, None, 1] - tri[:, None, 0])
        + t[None, :, None] * (tri[:, None, 2] - tri[:, None, 0])
    )
    reference = np.linalg.norm(points[:, None, None, :] - samples[None], axis=-1).min(
        axis=-1
    )  # (15, 15)
    ours = point_triangle_distance(points[:, None, :], tri[None])
    assert (ours <= reference + 1e-9).all()  # exact is never above a sampled point
    np.testing.assert_allclose(ours, reference, atol=0.04)


def test_distance_to_surface_is_the_brute_force_minimum():
    part = crafted_building(6)[0]
    rng = np.random.default_rng(2)
    low, high = part.positions.min(0), part.positions.max(0)
    points = low + rng.random((300, 3)) * (high - low)
    brute = point_triangle_distance(points[:, None, :], part.positions[part.triangles][None]).min(
        axis=1
    )
    np.testing.assert_allclose(
        distance_to_surface(points, part.positions, part.triangles), brute, atol=1e-12
    )


def test_rasterise_covers_the_triangle_conservatively():
    # A right triangle with legs of 50 pixels covers about 1250 pixels (conservative: a bit more).
    xy = np.array([[10.0, 10.0], [60.0, 10.0], [10.0, 60.0]])
    image = rasterise(xy, np.array([[0, 1, 2]]), 128)
    assert 1250 <= image.sum() <= 1250 + 2 * 51 + 51
    assert image[20, 20] and not image[70, 70] and not image[55, 55]
    # An edge-on face still draws a line.
    line = rasterise(np.array([[5.0, 5.0], [100.0, 5.0], [50.0, 5.0]]), np.array([[0, 1, 2]]), 128)
    assert line[5, 5:101].all() and line.sum() == 96


def test_empty_level_scores_zero(box):
    empty = [Part(np.zeros((0, 3)), np.zeros((0, 3), np.int64))]
    metrics = measure_lod(box, empty)
    assert (
        metrics.triangle_ratio == 0.0
        and metrics.wall_coverage == 0.0
        and metrics.silhouette_iou == 0.0
    )


# --------------------------------------------------------------------------- exact_quality


def lossless_level(parts):
    """LOD0 and a level that is only its planar re-triangulation: every face protected from the
    quadric collapse, so only the lossless planar pass changes the mesh."""
    from exporter.config import Config, SimplifyOptions
    from exporter.simplify import build_mesh_lods, simplify_parts

    lod0 = build_mesh_lods(parts, Config().lods[:1], Config().simplify)[0]
    return lod0, simplify_parts(lod0, 1, SimplifyOptions(protect_largest=1.0))


def samplegen_buildings(folder, count):
    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder
    from exporter.samplegen import generate_tile

    generate_tile(folder, count=count, seed=7, atlas_size=32)
    options = Config().readers
    return [load_entry(entry, options).parts for entry in scan_folder(folder, options).entries]


def test_exact_quality_agrees_with_measure_lod_on_lossless_levels(box, tmp_path):
    """Tolerances of measure_lod on a re-triangulated surface: distances are float rounding (the
    samplegen walls are float32 .xdo vertices, flat only to ~1e-7 m), certified within 1e-5 x
    diagonal; the conservative raster and the outline length are the same up to rounding."""
    buildings = [box, crafted_building(2), crafted_building(4)] + samplegen_buildings(
        tmp_path / "tile", 3
    )
    for parts in buildings:
        lod0, level = lossless_level(parts)
        assert sum(p.triangle_count for p in level) < sum(
            p.triangle_count for p in lod0
        )  # it did change
        measured, exact = measure_lod(lod0, level), exact_quality(lod0, level)
        assert set(exact.to_manifest()) == KEYS
        assert exact.triangle_ratio == measured.triangle_ratio
        # Both certified upper bounds (flatness of the polygons): the same function, same value.
        assert exact.hausdorff_rel == measured.hausdorff_rel <= 5e-4
        assert exact.silhouette_iou == 1.0 and measured.silhouette_iou >= 0.999
        assert exact.wall_coverage == measured.wall_coverage == 1.0
        assert exact.boundary_length_change == 0.0 and abs(measured.boundary_length_change) < 1e-9
        assert exact.new_holes == measured.new_holes == 0
        assert type(exact.new_holes) is int and all(
            type(getattr(exact, k)) is float for k in KEYS - {"new_holes"}
        )


def test_exact_quality_differs_from_measure_lod_on_a_changed_level():
    import dataclasses

    from exporter.config import Config
    from exporter.simplify import build_mesh_lods

    # A budget large enough (8 px at 1080) that the dome of building 2 is collapsed.
    options = dataclasses.replace(Config().simplify, max_screen_error_px=8.0)
    chain = build_mesh_lods(crafted_building(2), Config().lods, options)
    measured, exact = measure_lod(chain[0], chain[2]), exact_quality(chain[0], chain[2])
    assert exact.triangle_ratio == measured.triangle_ratio < 1.0
    # The dome was collapsed: exact_quality's certificate fails and it reports the true bound.
    assert measured.hausdorff_rel == exact.hausdorff_rel > 1e-3
    assert measured.silhouette_iou < 1.0 == exact.silhouette_iou


def test_exact_quality_of_an_empty_source_is_measure_lods(box):
    empty = [Part(np.zeros((0, 3)), np.zeros((0, 3), np.int64))]
    assert exact_quality(empty, empty) == measure_lod(empty, empty)
    with pytest.raises(ValueError, match="empty level"):
        exact_quality(box, empty)  # nothing left cannot be the same surface


def test_exact_quality_agrees_with_measure_lod_on_real_exact_levels(tmp_path):
    """Levels the simplifier reports exact on real Zürich LoD2 buildings: their roof polygons
    are flat only to ~1e-5 x diagonal, so measure_lod sees up to that; the rest is identity."""
    from pathlib import Path

    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder
    from exporter.simplify import build_mesh_chain

    real = Path(__file__).resolve().parents[1] / "tests" / "data" / "real"
    config = Config()
    (tmp_path / "zurich_lod2.city.json").symlink_to(
        (real / "zurich_lod2.city.json").resolve()
    )  # read in place
    entries = scan_folder(tmp_path, config.readers).entries[:12]
    exact_levels = 0
    for entry in entries:
        chain = build_mesh_chain(
            load_entry(entry, config.readers).parts, config.lods, config.simplify
        )
        for level in chain[1:]:
            if not level.exact:
                continue
            exact_levels += 1
            measured, exact = (
                measure_lod(chain[0].parts, level.parts),
                exact_quality(chain[0].parts, level.parts),
            )
            assert exact.triangle_ratio == measured.triangle_ratio
            assert measured.hausdorff_rel < 1e-4 and measured.silhouette_iou >= 0.999
            assert measured.wall_coverage == 1.0 and abs(measured.boundary_length_change) < 1e-9
            assert measured.new_holes == 0
    assert exact_levels > 0


# --------------------------------------------------------------------------- boundary_quality

SURFACE_KEYS = ("hausdorff_rel", "silhouette_iou", "wall_coverage")
BOUNDARY_KEYS = ("triangle_ratio", "boundary_length_change", "new_holes")


def t_junction_roof():
    """A flat 2 x 2 m roof at 5 m (local East/Up/North): the left half two triangles, the right
    half a fan around (1, 1) on the shared line, so the line is a T-junction (open boundary of
    4 m inside the 8 m outline); and the same surface as two triangles (the junction closed)."""
    positions = np.array(
        [[x, 5.0, z] for x, z in [(0, 0), (1, 0), (1, 2), (0, 2), (2, 0), (2, 2), (1, 1)]], float
    )
    source = [Part(positions, np.array([[0, 2, 1], [0, 3, 2], [1, 6, 4], [6, 5, 4], [6, 2, 5]]))]
    closed = [Part(positions[[0, 3, 4, 5]], np.array([[0, 1, 3], [0, 3, 2]]))]
    return source, closed


def assert_boundary_quality_is_measure_lods(source, level):
    """Boundary keys bit for bit, surface keys within measure_lod's rounding on a same surface."""
    measured, bounded = measure_lod(source, level), boundary_quality(source, level)
    assert set(bounded.to_manifest()) == KEYS
    ours, theirs = bounded.to_manifest(), measured.to_manifest()
    for key in BOUNDARY_KEYS:
        assert ours[key] == theirs[key] and type(ours[key]) is type(theirs[key])
    assert bounded.hausdorff_rel == measured.hausdorff_rel <= 5e-4  # certified, both
    assert bounded.silhouette_iou == 1.0 and measured.silhouette_iou >= 0.999
    assert bounded.wall_coverage == measured.wall_coverage == 1.0
    return bounded


def raw_border_length(parts) -> float:
    """Metres of edges used by one face, slits included (what the metric no longer counts)."""
    positions, faces = joined(parts)
    border, _ = boundary_loops(faces, len(positions))
    return float(np.linalg.norm(positions[border[:, 0]] - positions[border[:, 1]], axis=1).sum())


def test_a_closed_t_junction_is_no_boundary_change():
    """The T-junction's 4 m of open edges are a crack of zero width inside the roof: the surface
    goes on across it, so its open boundary is the 8 m outline on both sides."""
    source, closed = t_junction_roof()
    assert raw_border_length(source) == pytest.approx(12.0) and raw_border_length(
        closed
    ) == pytest.approx(8.0)
    bounded = assert_boundary_quality_is_measure_lods(source, closed)
    assert (
        bounded.boundary_length_change
        == 0.0
        == exact_quality(source, closed).boundary_length_change
    )
    assert bounded.triangle_ratio == 2 / 5 and bounded.new_holes == 0


def square_roof():
    """A 3 x 3 m flat roof at 5 m (local East/Up/North), two triangles, and its corners."""
    corners = [(0, 0), (3, 0), (3, 3), (0, 3)]
    positions = np.array([[x, 5.0, z] for x, z in corners], float)
    return [Part(positions, np.array([[0, 2, 1], [0, 3, 2]]))], corners


def test_boundary_quality_counts_a_new_hole():
    """The roof with a triangular hole (1, 1), (2, 1), (1.5, 2) m: a loop of its own, 1 + 2 x
    sqrt(1.25) m more open boundary."""
    source, corners = square_roof()
    a, b, c, d, p, q, r = range(7)
    positions = np.array([[x, 5.0, z] for x, z in corners + [(1, 1), (2, 1), (1.5, 2)]], float)
    faces = np.array([[a, q, b], [a, p, q], [b, r, c], [b, q, r], [c, r, d], [d, r, p], [d, p, a]])
    holed = [Part(positions, faces)]
    # The faces cover the roof but the hole: 9 - 0.5 m^2, all facing the same way.
    cross = np.cross(
        positions[faces[:, 1]] - positions[faces[:, 0]],
        positions[faces[:, 2]] - positions[faces[:, 0]],
    )
    assert (
        0.5 * np.abs(cross[:, 1]).sum() == pytest.approx(8.5)
        and (np.sign(cross[:, 1]) == np.sign(cross[0, 1])).all()
    )
    bounded = boundary_quality(source, holed)
    assert bounded.new_holes == measure_lod(source, holed).new_holes == 1
    hole = 1.0 + 2.0 * np.sqrt(1.25)
    assert bounded.boundary_length_change == pytest.approx(hole / 12.0, abs=1e-12)
    assert bounded.boundary_length_change == measure_lod(source, holed).boundary_length_change


def test_a_crack_of_zero_width_is_no_new_hole():
    """The roof with an interior T-junction from (1, 1) to (2, 1) m (one side has the edge, the
    other goes through (1.5, 1)): 2 m more open edges, but the surface goes on across them."""
    source, corners = square_roof()
    a, b, c, d, p, q, m = range(7)
    positions = np.array([[x, 5.0, z] for x, z in corners + [(1, 1), (2, 1), (1.5, 1)]], float)
    slit = [
        Part(
            positions,
            np.array([[a, q, b], [a, p, q], [a, d, p], [p, d, m], [m, d, c], [m, c, q], [q, c, b]]),
        )
    ]
    assert raw_border_length(slit) == pytest.approx(12.0 + 2.0)
    bounded = assert_boundary_quality_is_measure_lods(source, slit)
    assert bounded.new_holes == 0 and bounded.boundary_length_change == 0.0


def test_levels_that_closed_the_source_s_slits_are_exact_and_measure_so(tmp_path):
    """Generated buildings (slits along eaves and hip ends) whose level 1 is the planar stage's
    output alone (no error budget, a 99 % cap): the slits are closed (fewer open edges than
    LOD0), the level is reported exact, and measure_lod agrees: no boundary change, no hole."""
    import dataclasses

    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder
    from exporter.samplegen import generate_tile
    from exporter.simplify import build_mesh_chain

    generate_tile(tmp_path / "tile", count=40, seed=7, atlas_size=32)
    config = Config()
    options = dataclasses.replace(config.simplify, max_screen_error_px=0.0)
    lods = [config.lods[0], dataclasses.replace(config.lods[1], mesh=0.99)]
    closed = 0
    for entry in scan_folder(tmp_path / "tile", config.readers).entries:
        chain = build_mesh_chain(load_entry(entry, config.readers).parts, lods, options)
        lod0, level = chain[0].parts, chain[1]
        if raw_border_length(level.parts) >= raw_border_length(lod0) - 1e-6:
            continue
        closed += 1
        measured = measure_lod(lod0, level.parts)
        assert level.exact and measured.new_holes == 0, measured
        assert abs(measured.boundary_length_change) < 1e-9, measured
        assert measured.silhouette_iou == 1.0 and measured.wall_coverage == 1.0, measured
    assert closed >= 3


def test_boundary_quality_of_empty_sides():
    source, _ = t_junction_roof()
    empty = [Part(np.zeros((0, 3)), np.zeros((0, 3), np.int64))]
    assert boundary_quality(empty, empty) == measure_lod(empty, empty)
    with pytest.raises(ValueError, match="empty level"):
        boundary_quality(source, empty)
