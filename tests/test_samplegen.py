"""The sample-building generator: determinism, floorless outward meshes, UVs, triangle statistics,
placement in the tile, and a round trip through the VWorld writer and reader.

Frames: building positions are local East/Up/North metres (x = East, y = Up, z = North); footprint
rings are ``(x, z)`` metres in the same frame; tile-local offsets are East/North metres from the
tile centre.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from shapely.geometry import Point, Polygon

from exporter.model import TileId
from exporter.samplegen import (
    KINDS,
    generate_buildings,
    generate_samples,
    generate_tile,
    make_building,
    triangle_budgets,
)
from exporter.samplegen.kinds import FACADE
from exporter.samplegen.mesh import triangle_normals
from exporter.tiles import tile_of

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "samples" / "15_279418_116113"


# --------------------------------------------------------------------------- helpers


def merged(building):
    """All parts as one ``(positions (n, 3), triangles (m, 3))`` mesh, local metres."""
    positions, triangles, offset = [], [], 0
    for part in building.parts:
        positions.append(part.positions)
        triangles.append(part.triangles + offset)
        offset += part.vertex_count
    return np.vstack(positions), np.vstack(triangles)


def welded_border_edges(positions, triangles):
    """Edges used by exactly one triangle after welding equal positions (1e-6 m): (welded positions, (e, 2))."""
    _, first, inverse = np.unique(
        np.round(positions, 6), axis=0, return_index=True, return_inverse=True
    )
    welded = inverse.ravel()[triangles]
    edges = np.sort(
        np.concatenate([welded[:, [0, 1]], welded[:, [1, 2]], welded[:, [2, 0]]]), axis=1
    )
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return positions[first], unique[counts == 1]


def base_border(sample):
    """Border edges lying at y = 0 (the open bottom of the floorless building)."""
    points, border = welded_border_edges(*merged(sample.building))
    at_base = np.all(np.abs(points[border][:, :, 1]) < 1e-6, axis=1)
    return points, border[at_base]


SHAPES = [
    (kind, budget, two_part)
    for kind in KINDS
    for budget in (40, 326, 1500)
    for two_part in (False, True)
]


@pytest.fixture(scope="module")
def shapes():
    """One sample per (kind, budget, two_part), small atlases."""
    return {
        key: make_building(
            np.random.default_rng(i),
            key[0],
            key[1],
            atlas_size=16,
            building_id=f"S{i}",
            yaw=0.3 * i,
            two_part=key[2],
        )
        for i, key in enumerate(SHAPES)
    }


# --------------------------------------------------------------------------- determinism


def test_same_seed_gives_identical_buildings_and_bytes():
    a = generate_buildings(6, seed=3, atlas_size=32)
    b = generate_buildings(6, seed=3, atlas_size=32)
    c = generate_buildings(6, seed=4, atlas_size=32)
    for x, y in zip(a, b):
        assert x.id == y.id and x.reference == y.reference and x.lonlat_bounds == y.lonlat_bounds
        assert len(x.parts) == len(y.parts)
        for p, q in zip(x.parts, y.parts):
            assert p.positions.tobytes() == q.positions.tobytes()
            assert p.triangles.tobytes() == q.triangles.tobytes()
            assert p.uvs.tobytes() == q.uvs.tobytes()
            assert p.texture.data == q.texture.data
    assert any(
        x.parts[0].positions.shape != z.parts[0].positions.shape or x.reference != z.reference
        for x, z in zip(a, c)
    )


def test_worker_processes_give_the_same_buildings():
    one = generate_buildings(5, seed=21, atlas_size=16)
    two = generate_buildings(5, seed=21, atlas_size=16, jobs=2)
    for x, y in zip(one, two):
        assert x.reference == y.reference and len(x.parts) == len(y.parts)
        for p, q in zip(x.parts, y.parts):
            assert (
                p.positions.tobytes() == q.positions.tobytes() and p.texture.data == q.texture.data
            )


def test_building_geometry_does_not_depend_on_count():
    few, more = (
        generate_buildings(3, seed=9, atlas_size=16),
        generate_buildings(7, seed=9, atlas_size=16),
    )
    for x, y in zip(few, more):
        assert x.parts[0].positions.tobytes() == y.parts[0].positions.tobytes()
        assert x.parts[0].texture.data == y.parts[0].texture.data


# --------------------------------------------------------------------------- mesh shape


@pytest.mark.parametrize(
    "key", SHAPES, ids=[f"{k}-{b}-{'2parts' if t else '1part'}" for k, b, t in SHAPES]
)
def test_floorless_outward_and_textured(shapes, key):
    sample = shapes[key]
    building = sample.building
    positions, triangles = merged(building)
    normals = triangle_normals(positions, triangles)
    area = np.linalg.norm(normals, axis=1)
    assert np.all(area > 1e-9), "degenerate triangles"
    unit = normals / area[:, None]
    # Floorless: nothing faces down, the base is at y = 0 and is open.
    assert unit[:, 1].min() > -1e-6, "a face points downward (floor or overhang)"
    assert abs(positions[:, 1].min()) < 1e-9
    # Winding: closing the mesh with its (y = 0) footprint adds no volume about an origin on the
    # base plane, so the signed volume of the open mesh must be that of the closed building: > 0.
    a, b, c = (positions[triangles[:, i]] for i in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    footprint_area = sum(Polygon(r).area for r in sample.footprints)
    assert volume > footprint_area * 2.0  # every building is taller than 2 m
    # Walls standing on a footprint outline (and away from the other footprints of the building,
    # which may touch it) face away from that footprint.
    polygons = [Polygon(r) for r in sample.footprints]
    centroids = positions[triangles].mean(axis=1)
    checked = 0
    for centroid, n in zip(centroids, unit):
        if abs(n[1]) > 1e-6:
            continue
        point = Point(centroid[0], centroid[2])
        near = [p for p in polygons if p.distance(point) < 1e-6]
        if len(near) != 1 or near[0].exterior.distance(point) > 1e-6:
            continue
        checked += 1
        assert not near[0].contains(Point(centroid[0] + 0.05 * n[0], centroid[2] + 0.05 * n[2]))
        assert near[0].contains(Point(centroid[0] - 0.05 * n[0], centroid[2] - 0.05 * n[2]))
    assert checked >= 4
    # Stored vertex normals agree with the winding (readers vote on this).
    for part in building.parts:
        face = triangle_normals(part.positions, part.triangles)
        for i in range(3):
            assert np.all(np.einsum("ij,ij->i", face, part.normals[part.triangles[:, i]]) > 0)
        assert part.uvs.min() >= 0.0 and part.uvs.max() <= 1.0
        assert part.texture is not None and part.texture.mime == "image/jpeg"
    assert len(building.parts) == (2 if key[2] else 1)


@pytest.mark.parametrize(
    "key", [k for k in SHAPES if not k[2]], ids=[f"{k}-{b}" for k, b, t in SHAPES if not t]
)
def test_open_base_outlines_the_footprint(shapes, key):
    sample = shapes[key]
    points, border = base_border(sample)
    assert len(border) >= 3
    degree = np.bincount(border.ravel(), minlength=len(points))
    assert np.all(degree % 2 == 0), "the base border does not form closed loops"
    length = np.linalg.norm(points[border[:, 0]] - points[border[:, 1]], axis=1).sum()
    perimeter = sum(Polygon(r).length for r in sample.footprints)
    assert length == pytest.approx(perimeter, rel=1e-6)
    rings = [Polygon(r).exterior for r in sample.footprints]
    for i, j in border:
        middle = (points[i] + points[j]) / 2
        assert min(r.distance(Point(middle[0], middle[2])) for r in rings) < 1e-6


@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(KINDS),
    budget=st.floats(30.0, 3000.0),
    yaw=st.floats(0.0, 2 * math.pi),
    two_part=st.booleans(),
)
def test_any_seed_budget_and_turn_gives_a_floorless_outward_building(
    seed, kind, budget, yaw, two_part
):
    sample = make_building(
        np.random.default_rng(seed), kind, budget, atlas_size=8, yaw=yaw, two_part=two_part
    )
    positions, triangles = merged(sample.building)
    normals = triangle_normals(positions, triangles)
    area = np.linalg.norm(normals, axis=1)
    assert np.all(area > 1e-9)
    assert (normals[:, 1] / area).min() > -1e-6
    a, b, c = (positions[triangles[:, i]] for i in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() > 0
    points, border = base_border(sample)
    assert np.all(np.bincount(border.ravel(), minlength=len(points)) % 2 == 0)
    length = np.linalg.norm(points[border[:, 0]] - points[border[:, 1]], axis=1).sum()
    assert length == pytest.approx(sum(Polygon(r).length for r in sample.footprints), rel=1e-6)
    assert all(p.uvs.min() >= 0 and p.uvs.max() <= 1 for p in sample.building.parts)
    low, high = positions[:, [0, 2]].min(axis=0), positions[:, [0, 2]].max(axis=0)
    np.testing.assert_allclose(
        (low + high) / 2, 0.0, atol=1e-9
    )  # reference = centre of the East/North box


def test_walls_are_gridded_by_floors_and_use_the_facade_region(shapes):
    sample = shapes[("box_flat", 326, False)]
    part = sample.building.parts[0]
    face = triangle_normals(part.positions, part.triangles)
    vertical = np.abs(face[:, 1]) < 1e-9 * np.linalg.norm(face, axis=1)
    on_outline = np.array(
        [
            Polygon(sample.footprints[0]).exterior.distance(Point(c[0], c[2])) < 1e-6
            for c in part.positions[part.triangles].mean(axis=1)
        ]
    )
    walls = part.triangles[vertical & on_outline]
    assert len(walls) >= 100  # most of a 326-triangle box is facade grid
    uv = part.uvs[walls.ravel()]
    assert uv[:, 0].min() >= FACADE[0] - 1e-6 and uv[:, 0].max() <= FACADE[2] + 1e-6
    assert uv[:, 1].min() >= FACADE[1] - 1e-6 and uv[:, 1].max() <= FACADE[3] + 1e-6
    heights = np.unique(np.round(part.positions[walls.ravel(), 1], 6))
    assert len(heights) >= 3  # several rows of cells, not one quad per wall


def test_unknown_kind_and_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="unknown building kind 'castle'"):
        make_building(np.random.default_rng(0), "castle")
    with pytest.raises(ValueError, match="count"):
        generate_buildings(-1)
    with pytest.raises(ValueError, match="atlas_size"):
        generate_buildings(1, atlas_size=2)


# --------------------------------------------------------------------------- statistics


@pytest.fixture(scope="module")
def town():
    """300 buildings with the defaults (mean 326 triangles, 5 % two-part), 8-pixel atlases."""
    return generate_samples(300, seed=11, atlas_size=8)


def test_triangle_counts_have_the_requested_mean_and_a_long_tail(town):
    counts = np.array([s.building.triangle_count for s in town])
    assert counts.mean() == pytest.approx(326.0, rel=0.10)
    assert np.median(counts) < counts.mean()  # right-skewed
    assert (counts < 100).sum() >= 3 and (counts > 1000).sum() >= 3
    small = np.array(
        [
            b.triangle_count
            for b in generate_buildings(80, seed=12, atlas_size=8, mean_triangles=150.0)
        ]
    )
    assert small.mean() == pytest.approx(150.0, rel=0.15)


def test_budgets_follow_a_log_normal_with_the_requested_mean():
    budgets = triangle_budgets(3000, seed=1, mean_triangles=326.0)
    assert budgets.mean() == pytest.approx(326.0, rel=0.05)
    assert 0.01 < (budgets > 1000).mean() < 0.06 and 0.005 < (budgets < 60).mean() < 0.05
    assert np.std(np.log(budgets)) == pytest.approx(0.75, rel=0.1)


def test_kinds_are_mixed_and_two_part_buildings_appear(town):
    assert {s.kind for s in town} == set(KINDS)
    two = [s for s in town if len(s.building.parts) == 2]
    assert 5 <= len(two) <= 30
    for s in two:
        first, second = s.building.parts
        assert first.texture.name != second.texture.name


# --------------------------------------------------------------------------- placement


def test_buildings_are_placed_inside_the_tile_without_overlap():
    tile = TileId(15, 279418, 116113)
    samples = generate_samples(8, seed=2, tile=tile, atlas_size=8)
    lat0 = samples[0].building.reference.lat
    metres_per_degree = math.radians(1.0) * 6378137.0
    outlines = []
    for s in samples:
        ref = s.building.reference
        assert s.building.tile == tile
        assert tile_of(ref.lon, ref.lat, 15) == tile
        assert 20.0 <= ref.elev <= 60.0 and np.float32(ref.elev) == ref.elev
        west, south, east, north = s.building.lonlat_bounds
        assert tile_of((west + east) / 2, (south + north) / 2, 15) == tile
        assert (west + east) / 2 == pytest.approx(ref.lon, abs=1e-9) and (
            south + north
        ) / 2 == pytest.approx(ref.lat, abs=1e-9)
        shift = np.array([(ref.lon) * math.cos(math.radians(lat0)), ref.lat]) * metres_per_degree
        for ring in s.footprints:
            outlines.append((s.building.id, Polygon(ring + shift)))
    for i, (a, pa) in enumerate(outlines):
        for b, pb in outlines[i + 1 :]:
            if a != b:
                assert pa.intersection(pb).area < 1e-6, f"{a} overlaps {b}"


def test_crowded_tiles_still_keep_centres_in_the_tile(town):
    tile = TileId(15, 279418, 116113)
    for s in town:
        assert tile_of(s.building.reference.lon, s.building.reference.lat, 15) == tile


# --------------------------------------------------------------------------- textures


def test_atlas_is_a_decodable_jpeg_of_the_requested_size():
    building = generate_buildings(1, seed=0, atlas_size=64)[0]
    texture = building.parts[0].texture
    with Image.open(io.BytesIO(texture.data)) as image:
        assert image.format == "JPEG" and image.size == (64, 64) and image.mode == "RGB"
        pixels = np.asarray(image, dtype=np.float64)
    assert (texture.width, texture.height) == (64, 64)
    assert pixels.std() > 5.0  # windows, roof courses and grain, not a flat colour


# --------------------------------------------------------------------------- VWorld round trip


def test_written_tile_reads_back_to_the_same_buildings(tmp_path):
    from exporter.readers import load_entry, scan_folder

    kwargs = dict(seed=6, atlas_size=32, two_part_share=0.3)
    folder = generate_tile(tmp_path / "tile", 8, **kwargs)
    expected = {b.id: b for b in generate_buildings(8, **kwargs)}
    assert any(len(b.parts) == 2 for b in expected.values())
    scan = scan_folder(folder)
    assert scan.format == "vworld" and not scan.skipped and len(scan.entries) == 8
    for entry in scan.entries:
        got = load_entry(entry)
        want = expected[got.id]
        assert got.tile == want.tile
        assert (got.reference.lon, got.reference.lat, got.reference.elev) == pytest.approx(
            (want.reference.lon, want.reference.lat, want.reference.elev), abs=1e-9
        )
        assert len(got.parts) == len(want.parts)
        for p, q in zip(got.parts, want.parts):
            np.testing.assert_allclose(
                p.positions, q.positions, atol=1e-3
            )  # float32 offsets in the .xdo
            np.testing.assert_array_equal(p.triangles, q.triangles)
            np.testing.assert_allclose(p.uvs, q.uvs, atol=1e-6)
            assert p.texture.data == q.texture.data
        assert not [m for m in got.problems if "wound" in m]


def same_model_files(a: Path, b: Path) -> None:
    """Assert two .dat or two .xdo files hold the same content up to float rounding."""
    from exporter.formats.vworld_binary import parse_dat, parse_xdo

    if a.suffix == ".dat":
        x, y = parse_dat(a.read_bytes(), str(a)), parse_dat(b.read_bytes(), str(b))
        assert (x.level, x.idx, x.idy, len(x.objects)) == (y.level, y.idx, y.idy, len(y.objects))
        for p, q in zip(x.objects, y.objects):
            assert (p.version, p.key, p.data_file, p.img_file_name) == (
                q.version,
                q.key,
                q.data_file,
                q.img_file_name,
            )
            np.testing.assert_allclose(
                [p.center_lon, p.center_lat, p.altitude],
                [q.center_lon, q.center_lat, q.altitude],
                rtol=0,
                atol=1e-6,
            )
            np.testing.assert_allclose(p.bbox, q.bbox, rtol=0, atol=1e-4)
        return
    x, y = parse_xdo(a.read_bytes(), str(a)), parse_xdo(b.read_bytes(), str(b))
    assert (x.version, x.key, len(x.meshes)) == (y.version, y.key, len(y.meshes))
    np.testing.assert_allclose(x.bbox, y.bbox, rtol=0, atol=1e-4)
    for p, q in zip(x.meshes, y.meshes):
        np.testing.assert_array_equal(p.indices, q.indices)
        np.testing.assert_allclose(p.vertices, q.vertices, rtol=0, atol=1e-4)
        assert (p.color, p.image_name) == (q.color, q.image_name)


def test_demo_tile_is_small_complete_and_regenerates(tmp_path):
    from exporter.readers import load_entry, scan_folder

    total = sum(p.stat().st_size for p in DEMO.iterdir())
    assert total < 2_000_000
    scan = scan_folder(DEMO)
    buildings = [load_entry(e) for e in scan.entries]
    assert len(buildings) == 12 and any(len(b.parts) == 2 for b in buildings)
    import runpy

    script = runpy.run_path(
        str(REPO / "samples" / "generate.py")
    )  # not as __main__: call its main()
    assert script["main"](["--out", str(tmp_path / DEMO.name), "--demo"]) == 0
    for committed in sorted(DEMO.iterdir()):
        fresh = tmp_path / DEMO.name / committed.name
        assert fresh.is_file(), f"{committed.name} is not regenerated"
        if committed.suffix in (".dat", ".xdo") and fresh.read_bytes() != committed.read_bytes():
            same_model_files(
                committed, fresh
            )  # another libm may move a float32 by an ulp; nothing more
        elif (
            committed.suffix == ".jpg"
        ):  # JPEG bytes may differ between libjpeg builds; pixels may not
            with Image.open(committed) as a, Image.open(fresh) as b:
                assert np.abs(np.asarray(a, float) - np.asarray(b, float)).mean() < 2.0


def test_generate_script_refuses_to_mix_into_an_existing_tile(tmp_path, capsys):
    import runpy

    main = runpy.run_path(str(REPO / "samples" / "generate.py"))["main"]
    out = tmp_path / "t"
    assert main(["--out", str(out), "--count", "2", "--atlas", "16"]) == 0
    first = sorted(p.name for p in out.iterdir())
    assert first == ["15_279418_116113.dat", "B0000.jpg", "B0000.xdo", "B0001.jpg", "B0001.xdo"]
    with pytest.raises(SystemExit):
        main(["--out", str(out), "--count", "1", "--atlas", "16"])
    assert "already holds 5 tile files" in capsys.readouterr().err
    assert main(["--out", str(out), "--count", "1", "--atlas", "16", "--overwrite"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "15_279418_116113.dat",
        "B0000.jpg",
        "B0000.xdo",
    ]
    with pytest.raises(SystemExit):
        main(["--out", str(out), "--count", "0"])
