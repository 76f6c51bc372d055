"""build_mesh_lods: the pipeline's contract, the paper's targets on crafted floorless buildings,
robustness on bad and degenerate input, and the comparison with plain quadric collapse.

Positions are in the building-local East/Up/North frame (metres, y = Up).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pymeshlab
import pytest
from test_simplify_shapes import Atlas, Builder, add_cylinder, add_dome, crafted_building

from exporter.config import SimplifyOptions, default_lods
from exporter.errors import ProcessError
from exporter.model import Part
from exporter.quality import joined, measure_lod
from exporter.simplify import build_mesh_lods
from exporter.simplify.protect import face_areas

OPTIONS = SimplifyOptions()


def count(parts):
    return sum(p.triangle_count for p in parts)


def nonzero(parts):
    """Triangles of non-zero area (what level 0 keeps)."""
    return sum(int((face_areas(p.positions, p.triangles) >= 1e-12).sum()) for p in parts)


@pytest.fixture(scope="module")
def buildings():
    return [crafted_building(seed) for seed in range(12)]


@pytest.fixture(scope="module")
def chains(buildings):
    return [build_mesh_lods(parts, default_lods(), OPTIONS) for parts in buildings]


def test_contract_levels_parts_and_attributes(buildings, chains):
    for parts, levels in zip(buildings, chains):
        assert len(levels) == len(default_lods())
        assert count(levels[0]) == nonzero(parts)  # only zero-area faces (dome poles) go
        for level in levels:
            assert [p.name for p in level] == [p.name for p in parts]
            for part, source in zip(level, parts):
                assert part.texture is source.texture and part.color == source.color
                assert part.uvs is not None and part.uvs.shape == (len(part.positions), 2)
                assert part.triangles.min(initial=0) >= 0 and part.triangles.max(initial=-1) < len(
                    part.positions
                )


def test_never_larger_than_the_level_above_and_targets_respected(buildings, chains):
    for _parts, levels in zip(buildings, chains):
        counts = [count(level) for level in levels]
        assert all(b <= a for a, b in zip(counts, counts[1:])), counts


def test_quality_on_crafted_buildings(buildings, chains):
    for parts, levels in zip(buildings, chains):
        for level in levels[1:]:
            metrics = measure_lod(parts, level)
            assert metrics.silhouette_iou >= 0.97, metrics
            assert metrics.wall_coverage >= 0.98, metrics
            assert metrics.boundary_length_change == pytest.approx(0.0, abs=1e-9), metrics
            assert metrics.new_holes == 0, metrics


def test_paper_targets_on_sample_generator_buildings():
    # Issue 5's done-when on VWorld-like buildings: Table III ratios (mean triangles per level over
    # mean LOD0 triangles) at most 67.46 % and 48.07 %, quality thresholds on every building.
    from exporter import samplegen

    buildings = samplegen.generate_buildings(24, seed=3, atlas_size=16)
    totals = []
    for building in buildings:
        levels = build_mesh_lods(building.parts, default_lods(), OPTIONS)
        for level in levels[1:]:
            metrics = measure_lod(building.parts, level)
            assert metrics.silhouette_iou >= 0.97 and metrics.wall_coverage >= 0.98, (
                building.id,
                metrics,
            )
            assert (
                metrics.boundary_length_change == pytest.approx(0.0, abs=1e-9)
                and metrics.new_holes == 0
            )
        totals.append([count(level) for level in levels])
    mean = np.mean(totals, axis=0)
    assert mean[1] / mean[0] <= 0.6746 and mean[2] / mean[0] <= 0.4807, mean


def test_uvs_stay_inside_their_source_islands(buildings, chains):
    from exporter.mesh.distance import point_triangle_distance

    # Every output UV lies in the UV box of the source part (no UV from another part or nowhere),
    # and the winding stays outward: each face's normal agrees with its nearest source face's.
    for parts, levels in zip(buildings, chains):
        for level in levels[1:]:
            for part, source in zip(level, parts):
                if part.triangle_count == 0:
                    continue
                assert (part.uvs >= source.uvs.min(axis=0) - 1e-6).all() and (
                    part.uvs <= source.uvs.max(axis=0) + 1e-6
                ).all()
                c = part.positions[part.triangles]
                normal = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
                s = source.positions[source.triangles]
                source_normal = np.cross(s[:, 1] - s[:, 0], s[:, 2] - s[:, 0])
                # The source face nearest to the face's centroid (point-to-triangle distance).
                nearest = np.argmin(point_triangle_distance(c.mean(1)[:, None], s[None]), axis=1)
                assert ((normal * source_normal[nearest]).sum(1) > 0).mean() > 0.95


def test_no_cracks_between_parts():
    # A tower (part 0) with a dome (part 1, another texture) sharing the ring at 12 m.
    walls, dome = Builder(), Builder()
    atlas = Atlas()
    add_cylinder(walls, atlas, 0.0, 0.0, 0.0, 12.0, 6.0, 24, rings=6)
    add_dome(dome, atlas, 0.0, 0.0, 12.0, 6.0, 6, 24)
    parts = [walls.part(name="tower"), dome.part(name="dome")]
    ring = {tuple(p) for p in np.round(parts[0].positions[parts[0].positions[:, 1] == 12.0], 9)}
    for level in build_mesh_lods(parts, default_lods(), OPTIONS)[1:]:
        for part in level:
            assert ring <= {tuple(p) for p in np.round(part.positions, 9)}
        assert measure_lod(parts, level).new_holes == 0


def plain_qec(parts, ratio):
    """pymeshlab's quadric collapse with its defaults on the welded building (the peer)."""
    positions, faces = joined(parts)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(positions, faces.astype(np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(round(ratio * len(faces))))
    mesh = ms.current_mesh()
    return [Part(mesh.vertex_matrix(), mesh.face_matrix())]


def test_plain_quadric_collapse_loses_walls_where_this_method_keeps_them():
    # Crafted building 6 with an 8 px budget (a lossy LOD2): at the same triangle count
    # pymeshlab's plain collapse moves the footprint; this method keeps it and the walls. (At
    # the default 2 px its LOD2 and building 3's, used before issue 13's round 6, are lossless
    # re-triangulations, and a plain collapse to that count is lossless too.)
    parts = crafted_building(6)
    options = dataclasses.replace(OPTIONS, max_screen_error_px=8.0)
    ours = build_mesh_lods(parts, default_lods(), options)[2]
    # pymeshlab may stop short of its face target: raised until it keeps as many as ours.
    target = count(ours)
    theirs = plain_qec(parts, target / len(joined(parts)[1]))
    while count(theirs) < count(ours):
        target += 2
        theirs = plain_qec(parts, target / len(joined(parts)[1]))
    assert count(theirs) - count(ours) <= 4
    ours_m, theirs_m = measure_lod(parts, ours), measure_lod(parts, theirs)
    assert ours_m.wall_coverage >= 0.98 and ours_m.silhouette_iou >= 0.97
    assert ours_m.boundary_length_change == pytest.approx(0.0, abs=1e-9)
    assert abs(theirs_m.boundary_length_change) > 0.01


def test_bad_input_raises_process_error_naming_the_part():
    good = crafted_building(0)
    with pytest.raises(ProcessError, match="main.*NaN"):
        bad = dataclasses.replace(
            good[0],
            positions=np.where(
                np.arange(len(good[0].positions))[:, None] == 3, np.nan, good[0].positions
            ),
        )
        build_mesh_lods([bad, good[1]], default_lods(), OPTIONS)
    with pytest.raises(ProcessError, match="index outside"):
        build_mesh_lods(
            [dataclasses.replace(good[0], triangles=good[0].triangles + 10_000)],
            default_lods(),
            OPTIONS,
        )
    with pytest.raises(ProcessError, match="UVs for"):
        build_mesh_lods(
            [dataclasses.replace(good[0], uvs=good[0].uvs[:-1])], default_lods(), OPTIONS
        )


def test_degenerate_and_non_manifold_input_does_not_crash():
    parts = crafted_building(5)
    part = parts[0]
    n = len(part.positions)
    extra_positions = np.vstack([part.positions, part.positions[:3] + [0.0, 0.0, 5.0]])
    triangles = np.vstack(
        [
            part.triangles,
            [[0, 0, 1]],  # repeated index
            [[0, 1, 1]],
            part.triangles[:1],  # duplicate face
            [
                [part.triangles[0, 0], part.triangles[0, 1], n]
            ],  # third face on an edge: non-manifold
            [[n, n + 1, n + 2]],
        ]
    )
    uvs = np.vstack([part.uvs, part.uvs[:3]])
    messy = dataclasses.replace(part, positions=extra_positions, triangles=triangles, uvs=uvs)
    levels = build_mesh_lods([messy, parts[1]], default_lods(), OPTIONS)
    assert (
        count(levels[0]) == nonzero([messy, parts[1]]) <= count([messy, parts[1]]) - 2
    )  # zero-area faces go
    counts = [count(level) for level in levels]
    assert all(b <= a for a, b in zip(counts, counts[1:]))
    # Fully degenerate parts and empty parts come through too.
    empty = Part(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    flat = Part(np.zeros((3, 3)), np.array([[0, 1, 2]]))
    levels = build_mesh_lods([empty, flat], default_lods(), OPTIONS)
    assert [count(level) for level in levels] == [0, 0, 0]


REAL = Path(__file__).resolve().parents[1] / "tests" / "data" / "real"


@pytest.mark.parametrize(
    "folder, crs, limit", [(REAL, "EPSG:7415", 12), (REAL / "rotterdam_textured", None, 2)]
)
def test_real_cityjson_buildings(folder, crs, limit):
    # Real LoD2 buildings (Zurich, 3D BAG; Rotterdam with aerial-photo atlases), ground dropped:
    # never larger than the level above, quality thresholds on every building, UVs kept.
    from exporter.config import ReaderOptions
    from exporter.readers import load_entry, scan_folder

    options = ReaderOptions(crs=crs)
    scan = scan_folder(str(folder), options)
    assert scan.entries
    for entry in scan.entries[:limit]:
        building = load_entry(entry, options)
        levels = build_mesh_lods(building.parts, default_lods(), OPTIONS)
        counts = [count(level) for level in levels]
        assert all(b <= a for a, b in zip(counts, counts[1:])), (building.id, counts)
        for level in levels[1:]:
            metrics = measure_lod(building.parts, level)
            assert metrics.silhouette_iou >= 0.97 and metrics.wall_coverage >= 0.98, (
                building.id,
                metrics,
            )
            assert metrics.new_holes == 0 and abs(metrics.boundary_length_change) < 1e-9, (
                building.id,
                metrics,
            )
            for part, source in zip(level, building.parts):
                assert (part.uvs is None) == (source.uvs is None)


@pytest.mark.parametrize("engine", ["pymeshlab", "meshoptimizer"])
def test_untextured_parts_collapse_to_the_quadric_optimum(engine):
    # Without UVs a vertex may move to the quadric's optimum (no texture to keep exact); the
    # open border still never moves and the guard still bounds the deviation. meshoptimizer (this
    # version) always collapses onto an input vertex.
    builder, atlas = Builder(), Atlas()
    add_dome(builder, atlas, 0.0, 0.0, 0.0, 10.0, 8, 24)
    textured = builder.part()
    parts = [dataclasses.replace(textured, uvs=None, texture=None)]
    options = dataclasses.replace(
        OPTIONS, planar_retriangulation=False, protect_largest=0.0, engine=engine
    )
    level = build_mesh_lods(parts, default_lods(), options)[1]
    assert count(level) < count(parts)
    source = {tuple(p) for p in np.round(parts[0].positions, 9)}
    output = [tuple(p) for p in np.round(level[0].positions, 9)]
    assert any(p not in source for p in output) == (engine == "pymeshlab")
    metrics = measure_lod(parts, level)
    assert metrics.boundary_length_change == pytest.approx(0.0, abs=1e-9) and metrics.new_holes == 0
    assert metrics.hausdorff_rel <= 0.0055


def _bad_inputs():
    """Named bad buildings: (name, parts). Local East/Up/North metres."""
    box = crafted_building(0)
    part = box[0]
    # Self-overlapping: the building twice, the copy shifted 0.3 m into the first.
    shifted = dataclasses.replace(
        part,
        positions=np.vstack([part.positions, part.positions + [0.3, 0.0, 0.2]]),
        triangles=np.vstack([part.triangles, part.triangles + len(part.positions)]),
        uvs=np.vstack([part.uvs, part.uvs]),
    )
    # Zero-area: every face of a second part squashed onto a line.
    squashed = dataclasses.replace(
        box[1], positions=box[1].positions * [1.0, 0.0, 0.0] + [0.0, 1.0, 0.0]
    )
    single = Part(np.array([[0.0, 0, 0], [4, 0, 0], [0, 3, 0]]), np.array([[0, 1, 2]]))
    # One flat polygon: a 10 x 6 m roof cut 10 x 6, its outline the open border.
    g = np.stack(np.meshgrid(np.arange(11.0), np.arange(7.0)), -1).reshape(-1, 2)
    i = (np.arange(6)[:, None] * 11 + np.arange(10)[None, :]).ravel()
    flat = Part(
        np.column_stack([g[:, 0], np.full(len(g), 5.0), g[:, 1]]),
        np.concatenate(
            [np.column_stack([i, i + 11, i + 1]), np.column_stack([i + 1, i + 11, i + 12])]
        ),
    )
    # Non-manifold: three walls on one edge (a fin), pinned vertices.
    fin = Part(
        np.array([[0.0, 0, 0], [0, 5, 0], [4, 0, 0], [-4, 0, 0], [0, 0, 4]]),
        np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]),
    )
    return [
        ("self-overlapping", [shifted, box[1]]),
        ("zero-area part", [part, squashed]),
        ("single triangle", [single]),
        ("one flat polygon", [flat]),
        ("non-manifold fin", [fin]),
    ]


@pytest.mark.parametrize("engine", ["meshoptimizer", "pymeshlab"])
def test_bad_buildings_go_through_within_their_budget(engine):
    from exporter.quality import joined
    from exporter.simplify import build_mesh_chain
    from exporter.simplify.guard import deviation

    options = dataclasses.replace(OPTIONS, engine=engine, max_screen_error_px=4.0)
    for name, parts in _bad_inputs():
        chain = build_mesh_chain(parts, default_lods(), options)
        counts = [count(level.parts) for level in chain]
        assert all(b <= a for a, b in zip(counts, counts[1:])), (name, counts)
        source = joined(chain[0].parts)
        for level in chain[1:]:
            if count(level.parts) == 0:
                assert counts[0] == 0, name
                continue
            # Honest: the level stays within its budget (a dense check, not the simplifier's word).
            assert deviation(source, *joined(level.parts)) <= level.tolerance * (1 + 1e-9), name
    # The flat polygon is lossless down to two triangles whatever the engine.
    flat = build_mesh_chain(_bad_inputs()[3][1], default_lods(), options)
    assert count(flat[1].parts) == 2 and flat[1].exact


def test_planar_stage_not_rerun_below_a_surface_exact_level_changes_nothing():
    # A level whose level above kept LOD0's surface skips the planar stage (the level above is its
    # output): the same level as rerunning it, bit for bit.
    from exporter.samplegen import generate_buildings
    from exporter.simplify import _join, _simplify_level, build_mesh_chain, screen_tolerance
    from exporter.simplify.guard import Reference

    lods, options = default_lods(), SimplifyOptions()
    checked = 0
    for building in generate_buildings(12, seed=23, atlas_size=16):
        chain = build_mesh_chain(building.parts, lods, options)
        if not chain[1].surface_exact:
            continue
        reference = Reference(*_join(chain[0].parts, 0.0)[:2])
        size = float(np.ptp(reference.positions, axis=0).max())
        rerun, _, _, _ = _simplify_level(
            chain[1].parts,
            round(sum(p.triangle_count for p in building.parts) * lods[2].mesh),
            options,
            reference,
            tolerance=screen_tolerance(size, lods[1].transition, options),
        )
        for mine, theirs in zip(chain[2].parts, rerun):
            assert np.array_equal(mine.triangles, theirs.triangles)
            assert np.array_equal(mine.positions, theirs.positions)
            assert np.array_equal(mine.uvs, theirs.uvs)
        checked += 1
    assert checked >= 5
