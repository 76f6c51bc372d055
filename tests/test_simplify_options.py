"""Each SimplifyOptions key really changes the result, on a crafted mesh where it matters.

Meshes are in the building-local East/Up/North frame (metres, y = Up); see test_simplify_shapes.
Most tests switch the lossless planar stage and the error guard off (``BASE``) so the quadric
stage and the option under test act alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from test_simplify_shapes import Atlas, Builder, add_dome, box_building

from exporter.config import LodSpec, SimplifyOptions
from exporter.mesh.topology import boundary_loops
from exporter.model import Part
from exporter.quality import joined, measure_lod
from exporter.simplify import build_mesh_chain, build_mesh_lods, clean_part
from exporter.simplify.protect import face_areas, largest_faces

BASE = SimplifyOptions(planar_retriangulation=False, max_screen_error_px=0.0, protect_largest=0.0)


def lod(parts, ratio, **changes):
    options = dataclasses.replace(BASE, **changes)
    return build_mesh_lods(parts, [LodSpec(0.5), LodSpec(0.1, mesh=ratio)], options)[1]


def count(parts):
    return sum(p.triangle_count for p in parts)


@pytest.fixture(scope="module")
def dome():
    builder, atlas = Builder(), Atlas()
    add_dome(builder, atlas, 0.0, 0.0, 0.0, 10.0, 8, 24)
    return [builder.part()]


@pytest.fixture(scope="module")
def two_chart_plane():
    """A 10 x 10 m wall in the x-y plane cut 12 x 12, left and right halves in separate UV islands."""
    builder = Builder()
    builder.grid((0, 0, 0), (5, 0, 0), (0, 10, 0), 6, 12, (0.0, 0.0, 0.2, 0.2))
    builder.grid((5, 0, 0), (5, 0, 0), (0, 10, 0), 6, 12, (0.5, 0.5, 0.7, 0.7))
    return [builder.part()]


@pytest.fixture(scope="module")
def grid_box():
    """Floorless 12 x 9 x 8 m box, walls cut 4 x 3, flat roof cut 4 x 4 (edges match: no T-junctions)."""
    return box_building(6, 4.5, 8.0, (4, 3), 4)


def uv_stretch(parts):
    """(min, max) over faces of UV area / 3-D area (constant on an affine chart)."""
    p = parts[0]
    c, u = p.positions[p.triangles], p.uvs[p.triangles].astype(float)
    area3 = 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)
    d1, d2 = u[:, 1] - u[:, 0], u[:, 2] - u[:, 0]
    ratio = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / area3
    return ratio.min(), ratio.max()


def test_protect_largest_keeps_exactly_the_largest_faces(dome):
    part = clean_part(dome[0])  # the simplifier ranks the faces it gets (zero-area ones dropped)
    areas = face_areas(part.positions, part.triangles)
    protected = largest_faces(areas, 0.3)
    assert protected.sum() == round(0.3 * len(areas))
    assert areas[protected].min() >= areas[~protected].max()
    with_filter, without = lod(dome, 0.3, protect_largest=0.3), lod(dome, 0.3)
    assert count(with_filter) != count(without)
    # Every protected triangle is still there, corner for corner.
    out = with_filter[0]
    kept = {tuple(sorted(map(tuple, np.round(out.positions[t], 9)))) for t in out.triangles}
    for t in part.triangles[protected]:
        assert tuple(sorted(map(tuple, np.round(part.positions[t], 9)))) in kept
    # Without the filter some of them are gone.
    out = without[0]
    kept = {tuple(sorted(map(tuple, np.round(out.positions[t], 9)))) for t in out.triangles}
    assert any(
        tuple(sorted(map(tuple, np.round(part.positions[t], 9)))) not in kept
        for t in part.triangles[protected]
    )


def test_preserve_border_edges_keeps_the_open_bottom(grid_box):
    source_pos, source_faces = joined(grid_box)
    bottom = {tuple(p) for p in np.round(source_pos[source_pos[:, 1] == 0.0], 9)}
    kept = lod(grid_box, 0.2)
    free = lod(grid_box, 0.2, preserve_border_edges=False)
    kept_bottom = {tuple(p) for p in np.round(joined(kept)[0], 9) if p[1] == 0.0}
    free_bottom = {tuple(p) for p in np.round(joined(free)[0], 9) if p[1] == 0.0}
    assert kept_bottom == bottom
    assert free_bottom != bottom
    assert measure_lod(grid_box, kept).boundary_length_change == pytest.approx(0.0, abs=1e-12)


def test_preserve_uv_seam_edges_keeps_the_texture_unstretched(two_chart_plane):
    low, high = uv_stretch(two_chart_plane)
    assert high / low == pytest.approx(1.0, abs=1e-4)
    kept = lod(two_chart_plane, 0.2)
    free = lod(two_chart_plane, 0.2, preserve_uv_seam_edges=False)
    low_kept, high_kept = uv_stretch(kept)
    low_free, high_free = uv_stretch(free)
    assert high_kept / low_kept == pytest.approx(1.0, abs=1e-4)
    assert high_free > 1.05 * low_free  # stretched (low_free may be 0: a chart squashed flat)

    # The seam is the line x = 5 m: kept, no face reaches across it.
    def straddling(parts):
        x = parts[0].positions[parts[0].triangles][:, :, 0]
        return int(((x.min(axis=1) < 5 - 1e-9) & (x.max(axis=1) > 5 + 1e-9)).sum())

    assert straddling(kept) == 0 and straddling(lod(two_chart_plane, 0.1)) == 0
    assert straddling(lod(two_chart_plane, 0.1, preserve_uv_seam_edges=False)) > 0


def flipped(parts):
    """Faces whose UV triangle is oriented against the source's (all counter-clockwise)."""
    p = parts[0]
    u = p.uvs[p.triangles].astype(float)
    d1, d2 = u[:, 1] - u[:, 0], u[:, 2] - u[:, 0]
    return int(((d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) < -1e-12).sum())


@pytest.fixture(scope="module")
def swirl():
    """A flat 10 x 10 m wall cut 16 x 16 whose UVs are a swirl (one-to-one, not affine): the
    geometry allows any collapse, the texture mapping folds under some."""
    g = np.linspace(0.0, 10.0, 17)
    x, y = np.meshgrid(g, g)
    positions = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    c = positions[:, :2] - 5.0
    turn = 0.9 * np.pi * (1.0 - np.linalg.norm(c, axis=1) / 7.1) ** 2
    cos, sin = np.cos(turn), np.sin(turn)
    uvs = np.column_stack([c[:, 0] * cos - c[:, 1] * sin, c[:, 0] * sin + c[:, 1] * cos]) / 14 + 0.5
    i = (np.arange(16)[:, None] * 17 + np.arange(16)[None, :]).ravel()
    triangles = np.concatenate(
        [np.column_stack([i, i + 1, i + 18]), np.column_stack([i, i + 18, i + 17])]
    )
    return [Part(positions, triangles, uvs=uvs.astype(np.float32))]


def test_preserve_uv_foldover_edges_refuses_flipped_uvs(swirl):
    assert flipped(swirl) == 0
    assert flipped(lod(swirl, 0.3)) == 0
    assert flipped(lod(swirl, 0.3, preserve_uv_foldover_edges=False)) > 0


def test_preserve_surface_curvature_changes_the_collapse(dome):
    # Vertex normals join the collapse cost: other collapses are chosen, the shape no worse.
    plain = lod(dome, 0.3)
    curved = lod(dome, 0.3, preserve_surface_curvature=True)
    faces = lambda ps: {
        tuple(sorted(map(tuple, np.round(ps[0].positions[t], 9)))) for t in ps[0].triangles
    }
    assert faces(curved) != faces(plain)
    assert measure_lod(dome, curved).hausdorff_rel <= measure_lod(dome, plain).hausdorff_rel


def test_vertex_link_distance_closes_a_crack():
    # Two wall panels 1 mm apart: a crack the source's float noise left behind.
    builder = Builder()
    builder.grid((0, 0, 0), (5, 0, 0), (0, 10, 0), 4, 8, (0.0, 0.0, 0.2, 0.2))
    builder.grid((5.001, 0, 0), (5, 0, 0), (0, 10, 0), 4, 8, (0.2, 0.0, 0.4, 0.2))
    parts = [builder.part()]
    welded = lod(parts, 0.5, vertex_link_distance=0.01, preserve_uv_seam_edges=False)
    apart = lod(parts, 0.5, vertex_link_distance=0.0, preserve_uv_seam_edges=False)
    loops = lambda ps: boundary_loops(joined(ps)[1], len(joined(ps)[0]))[1]
    assert loops(apart) == 2
    assert loops(welded) == 1


def test_max_iterations_bounds_the_retries(swirl):
    # The first pass folds the texture, so one pass is not enough: the level stays unchanged.
    assert count(lod(swirl, 0.3, max_iterations=1)) == count(swirl)
    assert count(lod(swirl, 0.3, max_iterations=100)) < count(swirl)


def test_max_screen_error_px_bounds_the_deviation(dome):
    free = lod(dome, 0.3)
    size = float(np.ptp(dome[0].positions, axis=0).max())
    # Level 1 is shown up to lods[0].transition = 50 % of a 1080-pixel screen.
    bounded = lod(dome, 0.3, max_screen_error_px=2.0)
    budget = 2.0 * size / (0.5 * 1080)
    diagonal = float(np.linalg.norm(np.ptp(dome[0].positions, axis=0)))
    assert measure_lod(dome, free).hausdorff_rel * diagonal > 2 * budget
    assert measure_lod(dome, bounded).hausdorff_rel * diagonal <= budget
    assert count(bounded) > count(free)
    # Error-driven: without the cap's help (mesh 1.0) the budget alone shrinks the level.
    uncapped = lod(dome, 1.0, max_screen_error_px=2.0)
    assert count(uncapped) < count([clean_part(dome[0])])


def test_nothing_locked_and_a_huge_budget_collapses_without_failing(grid_box):
    """Border, seams and the largest faces all free, a budget of 1000 px and seams free (UVs
    taken from the nearest chart): meshoptimizer may collapse a candidate to no face at all. That
    candidate is refused like any other (empty level), not a crash (it used to raise in the UV
    transfer), and the levels still shrink within their budgets."""
    options = dataclasses.replace(
        BASE,
        planar_retriangulation=True,
        max_screen_error_px=1000.0,
        min_silhouette_iou=0.0,
        preserve_border_edges=False,
        preserve_uv_seam_edges=False,
    )
    lods = [LodSpec(0.5), LodSpec(0.17, mesh=1.0), LodSpec(0.02, mesh=1.0)]
    levels = build_mesh_lods(grid_box, lods, options)
    counts = [count(level) for level in levels]
    assert counts[0] > counts[1] >= counts[2] > 0


def test_protect_walls_keeps_the_footprint_walls(grid_box):
    walls = lod(grid_box, 0.2, protect_walls=True, preserve_border_edges=False)
    free = lod(grid_box, 0.2, preserve_border_edges=False)
    source = joined(grid_box)[0]
    # The bottom row of wall cells stands on the open border: its corners stay.
    low_wall_points = {tuple(p) for p in np.round(source[source[:, 1] <= 8.0 / 3 + 1e-9], 9)}
    assert low_wall_points <= {tuple(p) for p in np.round(joined(walls)[0], 9)}
    assert not low_wall_points <= {tuple(p) for p in np.round(joined(free)[0], 9)}


def test_planar_retriangulation_is_lossless_and_reduces(grid_box):
    options = SimplifyOptions()
    flat = build_mesh_lods(grid_box, [LodSpec(0.5), LodSpec(0.1, mesh=0.99)], options)[1]
    off = build_mesh_lods(
        grid_box,
        [LodSpec(0.5), LodSpec(0.1, mesh=0.99)],
        dataclasses.replace(options, planar_retriangulation=False),
    )[1]
    assert count(flat) < count(off)
    metrics = measure_lod(grid_box, flat)
    assert metrics.hausdorff_rel <= 5e-4  # certified bound: flat up to rounding
    assert metrics.silhouette_iou == 1.0 and metrics.wall_coverage == 1.0
    assert (
        metrics.boundary_length_change == pytest.approx(0.0, abs=1e-12) and metrics.new_holes == 0
    )
    # Four walls and a roof, each one rectangle: 5 x 2 triangles.
    assert count(flat) == 10
    low, high = uv_stretch([Part(flat[0].positions, flat[0].triangles[:2], uvs=flat[0].uvs)])
    assert high / low == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("engine", ["meshoptimizer", "pymeshlab"])
def test_min_silhouette_iou_keeps_a_thin_tower_s_outline(engine):
    """A generated tower without the paper's filter: its LOD2 budget (2 px at 17 % of a 1080-line
    screen, ~1 % of the building's size) lets the collapse move the tower's crown by a large
    share of the tower's own width; the silhouette floor refuses that."""
    from exporter.config import Config
    from exporter.samplegen import make_building

    building = make_building(np.random.default_rng(10), "tower", 326.0, atlas_size=64).building
    lods = Config().lods
    options = dataclasses.replace(SimplifyOptions(), protect_largest=0.0, engine=engine)
    free = build_mesh_lods(building.parts, lods, dataclasses.replace(options, min_silhouette_iou=0))
    kept = build_mesh_lods(building.parts, lods, options)
    iou_free = min(measure_lod(free[0], level).silhouette_iou for level in free[1:])
    iou_kept = min(measure_lod(kept[0], level).silhouette_iou for level in kept[1:])
    assert iou_kept >= 0.97
    if engine == "meshoptimizer":  # the floor acted: without it the outline went
        assert iou_free < 0.97
        assert count(kept[2]) > count(free[2])


@pytest.fixture(scope="module")
def mixed_buildings():
    """A generated tower, dome and L-shaped building (small atlases), the crafted grid box."""
    from exporter.samplegen import generate_buildings

    kinds = ["tower", "dome", "l_shape"]
    generated = generate_buildings(3, seed=12, atlas_size=16, mean_triangles=200, kinds=kinds)
    return [b.parts for b in generated] + [box_building(6, 4.5, 8.0, (4, 3), 4)]


@settings(max_examples=12, deadline=None)
@given(
    engine=st.sampled_from(["meshoptimizer", "pymeshlab"]),
    flags=st.lists(st.booleans(), min_size=6, max_size=6),
    protect=st.sampled_from([0.0, 0.3, 0.9]),
    pixels=st.sampled_from([0.0, 0.5, 2.0, 1000.0]),
    link=st.sampled_from([0.0, 0.05]),
    caps=st.sampled_from([(0.65, 0.45), (0.1, 0.01), (1.0, 1.0)]),
)
# Found by a wider sweep: nothing locked and no real budget collapsed a candidate to no face.
@example(
    engine="meshoptimizer",
    flags=[False, False, True, False, True, False],
    protect=0.0,
    pixels=1000.0,
    link=0.0,
    caps=(1.0, 1.0),
)
def test_any_option_set_gives_a_chain_within_its_budgets(
    mixed_buildings, engine, flags, protect, pixels, link, caps
):
    """Whatever the user sets in ``simplify:`` (every Table II switch, the filter, the budget,
    the engine, the link distance, the caps), every building gets a chain: no level larger than
    the one above, every certified bound within its level's budget, UVs kept per corner."""
    border, seams, foldovers, curvature, planar, walls = flags
    options = SimplifyOptions(
        engine=engine,
        preserve_border_edges=border,
        preserve_uv_seam_edges=seams,
        preserve_uv_foldover_edges=foldovers,
        preserve_surface_curvature=curvature,
        planar_retriangulation=planar,
        protect_walls=walls,
        protect_largest=protect,
        max_screen_error_px=pixels,
        vertex_link_distance=link,
        min_silhouette_iou=0.97 if pixels < 100 else 0.0,
    )
    lods = [LodSpec(0.5), LodSpec(0.17, mesh=caps[0]), LodSpec(0.02, mesh=caps[1])]
    for parts in mixed_buildings:
        chain = build_mesh_chain(parts, lods, options)
        counts = [count(level.parts) for level in chain]
        assert all(b <= a for a, b in zip(counts, counts[1:])), counts
        for level in chain[1:]:
            if level.deviation is not None:
                assert level.deviation <= level.tolerance * (1 + 1e-9) + 1e-12
            for part in level.parts:
                if part.uvs is not None:
                    assert len(part.uvs) == len(part.positions)
