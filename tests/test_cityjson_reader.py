"""CityJSON reader: real files from tests/data/real and small crafted files.

Expected values are computed independently from the JSON (polygon and triangle counts) and with
pyproj directly (lon/lat), not with the reader's own helpers.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from pyproj import Transformer

from exporter import geodesy
from exporter.config import ReaderOptions
from exporter.errors import InputError, ReadError
from exporter.readers import (
    Entry,
    check_crs_option,
    cityjson,
    detect_format,
    load_entry,
    scan_folder,
)

REAL = Path(__file__).resolve().parents[1] / "tests" / "data" / "real"
ZURICH = REAL / "zurich_lod2.city.json"
BAG = REAL / "bag_multi_lod.city.json"
ROTTERDAM = REAL / "rotterdam_textured" / "twobuildings.city.json"


def linked_folder(tmp_path: Path, *files: Path) -> Path:
    """A folder holding symlinks to real files (the real data is read in place, never copied)."""
    folder = tmp_path / "tile"
    folder.mkdir()
    for file in files:
        (folder / file.name).symlink_to(file.resolve())
    return folder


def triangle_normals(part) -> np.ndarray:
    p, t = part.positions, part.triangles
    return np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])


def expected_triangles(data: dict, geometries: list[dict], drop_ground: bool) -> int:
    """Triangles an exact polygon triangulation gives: k vertices and h holes -> k + 2h - 2."""
    count = 0
    depth = {
        "MultiSurface": 1,
        "CompositeSurface": 1,
        "Solid": 2,
        "MultiSolid": 3,
        "CompositeSolid": 3,
    }

    def walk(boundaries, semantics, level, surfaces):
        nonlocal count
        if level == 0:
            if (
                drop_ground
                and semantics is not None
                and surfaces[semantics]["type"] == "GroundSurface"
            ):
                return
            count += sum(len(r) for r in boundaries) + 2 * (len(boundaries) - 1) - 2
            return
        for i, child in enumerate(boundaries):
            walk(child, semantics[i] if semantics is not None else None, level - 1, surfaces)

    for g in geometries:
        sem = g.get("semantics") or {}
        walk(g["boundaries"], sem.get("values"), depth[g["type"]], sem.get("surfaces"))
    return count


# --------------------------------------------------------------------------- real data


def test_zurich_every_building_loads_without_ground(tmp_path):
    folder = linked_folder(tmp_path, ZURICH)
    assert detect_format(folder) == "cityjson"
    scan = scan_folder(folder)
    data = json.loads(ZURICH.read_text())
    assert len(scan.entries) == 49 and not scan.skipped
    assert {e.id for e in scan.entries} == {
        k for k, v in data["CityObjects"].items() if v["type"] == "Building"
    }

    part_geometries = [g for v in data["CityObjects"].values() for g in v.get("geometry", [])]
    total, total_with_ground = 0, 0
    for entry in scan.entries:
        building = load_entry(entry)
        assert building.id == entry.id and building.parts
        total += building.triangle_count
        west, south, east, north = building.lonlat_bounds
        assert west <= building.reference.lon <= east and south <= building.reference.lat <= north
        lowest = min(p.positions[:, 1].min() for p in building.parts)
        assert (
            abs(lowest) < 1e-3
        )  # metres: reference at the base (the sphere drops d²/2R below the tangent plane)
        assert entry.tile.level == 15
        with_ground = cityjson.load(entry, ReaderOptions(drop_ground_surfaces=False))
        total_with_ground += with_ground.triangle_count
    assert total == expected_triangles(data, part_geometries, drop_ground=True)
    assert total_with_ground == expected_triangles(data, part_geometries, drop_ground=False)
    assert total_with_ground > total


def test_zurich_faces_point_outward_and_roofs_up(tmp_path):
    scan = scan_folder(linked_folder(tmp_path, ZURICH))
    away, area_total, up, horizontal = 0.0, 0.0, 0.0, 0.0
    for entry in scan.entries:
        building = load_entry(entry)
        points = np.concatenate([p.positions for p in building.parts])
        centre = points.mean(axis=0)
        for part in building.parts:
            n = triangle_normals(part)
            area = np.linalg.norm(n, axis=1)
            mid = part.positions[part.triangles].mean(axis=1) - centre
            away += area[np.einsum("ij,ij->i", n, mid) > 0].sum()
            area_total += area.sum()
            flat = np.abs(n[:, 1]) > 0.95 * area
            horizontal += area[flat].sum()
            up += area[flat & (n[:, 1] > 0)].sum()
    # Outward faces: nearly all area faces away from the building's centre; ground dropped, so
    # horizontal faces are roofs and point up.
    assert away / area_total > 0.95
    assert up / horizontal > 0.99


def test_rotterdam_textures_are_real_atlases_with_unchanged_bytes(tmp_path):
    folder = tmp_path / "tile"
    folder.mkdir()
    (folder / ROTTERDAM.name).symlink_to(ROTTERDAM.resolve())
    # Copied, not linked: an image reached through a symlink leading out of the input is refused.
    shutil.copytree(ROTTERDAM.parent / "appearances", folder / "appearances")
    scan = scan_folder(folder)
    assert len(scan.entries) == 2
    data = json.loads(ROTTERDAM.read_text())
    source_uv = np.asarray(data["appearance"]["vertices-texture"])
    textured = 0
    for entry in scan.entries:
        assert any(name.endswith(".jpg") for name in entry.inputs)
        building = load_entry(entry)
        assert building.triangle_count == expected_triangles(
            data, data["CityObjects"][entry.id]["geometry"], True
        )
        for part in building.parts:
            if part.texture is None:
                assert part.uvs is None
                continue
            textured += 1
            image_file = ROTTERDAM.parent / "appearances" / part.texture.name
            assert part.texture.data == image_file.read_bytes()
            assert part.texture.mime == "image/jpeg" and (
                part.texture.width,
                part.texture.height,
            ) == (1024, 1024)
            assert part.uvs.min() >= -0.01 and part.uvs.max() <= 1.01
            # glTF convention: v flipped from CityJSON's bottom-left origin.
            index = [t["image"] for t in data["appearance"]["textures"]].index(part.texture.name)
            used = {
                uv
                for g in data["CityObjects"][entry.id]["geometry"]
                for s in g["texture"]["default"]["values"]
                for ring in s
                if ring[0] == index
                for uv in ring[1:]
            }
            expected = {(round(u, 4), round(1 - v, 4)) for u, v in source_uv[sorted(used)]}
            assert {(round(float(u), 4), round(float(v), 4)) for u, v in part.uvs} == expected
    assert textured >= 10


def test_bag_without_crs_is_refused_and_loads_with_it(tmp_path):
    folder = linked_folder(tmp_path, BAG)
    with pytest.raises(InputError, match="--crs"):
        scan_folder(folder)
    entry = Entry(
        format="cityjson",
        id="6751773",
        source=str(BAG),
        tile=None,
        inputs=[str(BAG)],
        key="6751773",
    )
    with pytest.raises(ReadError, match="--crs"):
        load_entry(entry, ReaderOptions())

    options = ReaderOptions(crs="EPSG:7415")
    scan = scan_folder(folder, options)
    assert len(scan.entries) == 10
    data = json.loads(BAG.read_text())
    scale, translate = (
        np.asarray(data["transform"]["scale"]),
        np.asarray(data["transform"]["translate"]),
    )
    rd_to_wgs84 = Transformer.from_crs("EPSG:28992", "EPSG:4326", always_xy=True)
    for entry in scan.entries:
        building = load_entry(entry, options)
        assert any("2.2" in p for p in building.problems)  # highest LoD used and said so
        lod22 = [g for g in data["CityObjects"][entry.id]["geometry"] if g["lod"] == "2.2"]
        assert building.triangle_count == expected_triangles(data, lod22, drop_ground=True)
        # The footprint at its known lon/lat: the source vertices' box centre through pyproj.
        ids = sorted(
            {i for g in lod22 for shell in g["boundaries"] for s in shell for r in s for i in r}
        )
        xyz = np.asarray(data["vertices"])[ids] * scale + translate
        lon, lat = rd_to_wgs84.transform(xyz[:, 0], xyz[:, 1])
        centre = ((min(lon) + max(lon)) / 2, (min(lat) + max(lat)) / 2)
        metres_east = (
            (building.reference.lon - centre[0]) * 111320 * math.cos(math.radians(centre[1]))
        )
        metres_north = (building.reference.lat - centre[1]) * 110574
        assert math.hypot(metres_east, metres_north) < 1.0
        assert building.reference.elev == pytest.approx(xyz[:, 2].min(), abs=1e-6)
        # Every source vertex's horizontal distance from the centre is kept (to 1 cm per 10 m).
        radius = np.hypot(
            (np.asarray(lon) - centre[0]) * 111320 * math.cos(math.radians(centre[1])),
            (np.asarray(lat) - centre[1]) * 110574,
        )
        positions = np.concatenate([p.positions for p in building.parts])
        local_radius = np.hypot(positions[:, 0], positions[:, 2])
        assert local_radius.max() == pytest.approx(radius.max(), rel=0.01)


# --------------------------------------------------------------------------- crafted files


def unit_box(lod="2", ground=True) -> dict:
    """A 1 m box as a Solid in EPSG:2056 at Bern, rings CCW from outside, ground/roof/wall semantics."""
    return {
        "type": "Solid",
        "lod": lod,
        "boundaries": [
            [
                [[0, 3, 2, 1]],
                [[4, 5, 6, 7]],
                [[0, 1, 5, 4]],
                [[1, 2, 6, 5]],
                [[2, 3, 7, 6]],
                [[3, 0, 4, 7]],
            ]
        ],
        "semantics": {
            "surfaces": [
                {"type": "GroundSurface"},
                {"type": "RoofSurface"},
                {"type": "WallSurface"},
            ],
            "values": [[0 if ground else 2, 1, 2, 2, 2, 2]],
        },
    }


BOX_VERTICES = [
    [0, 0, 0],
    [1000, 0, 0],
    [1000, 1000, 0],
    [0, 1000, 0],
    [0, 0, 1000],
    [1000, 0, 1000],
    [1000, 1000, 1000],
    [0, 1000, 1000],
]


def city(
    objects: dict,
    vertices: list,
    version="2.0",
    crs="https://www.opengis.net/def/crs/EPSG/0/2056",
    **extra,
) -> dict:
    data = {
        "type": "CityJSON",
        "version": version,
        "CityObjects": objects,
        "vertices": vertices,
        "transform": {"scale": [0.001, 0.001, 0.001], "translate": [2600000.0, 1200000.0, 500.0]},
    }
    if crs:
        data["metadata"] = {"referenceSystem": crs}
    data.update(extra)
    return data


def write(folder: Path, name: str, data: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(data))
    return path


def only_building(folder: Path, options=None):
    scan = scan_folder(folder, options)
    assert len(scan.entries) == 1, scan
    return scan, load_entry(scan.entries[0], options)


def test_unit_box_solid_faces_point_outward(tmp_path):
    write(
        tmp_path,
        "box.city.json",
        city({"B1": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES),
    )
    scan, building = only_building(tmp_path)
    assert building.triangle_count == 10  # 5 quads, ground dropped
    (part,) = building.parts
    size = part.positions.max(axis=0) - part.positions.min(axis=0)
    assert size == pytest.approx([1.0, 1.0, 1.0], abs=0.01)  # metres, East/Up/North
    assert part.positions[:, 1].min() == pytest.approx(0.0, abs=1e-6)  # base at the reference
    assert building.reference.elev == pytest.approx(500.0)
    centre = part.positions.mean(axis=0)
    n = triangle_normals(part)
    mid = part.positions[part.triangles].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", n, mid - centre) > 0)
    assert (n[:, 1] > 0.9 * np.linalg.norm(n, axis=1)).sum() == 2  # the roof points up
    # Same box, pyproj directly: Bern's LV95 point to lon/lat.
    lon, lat = Transformer.from_crs("EPSG:2056", "EPSG:4326", always_xy=True).transform(
        2600000.5, 1200000.5
    )
    assert building.reference.lon == pytest.approx(
        lon, abs=1e-6
    ) and building.reference.lat == pytest.approx(lat, abs=1e-6)
    assert scan.entries[0].tile.idx == math.floor((lon + 180) / (36 / 2**15))
    assert scan.entries[0].tile.idy == math.floor((lat + 90) / (36 / 2**15))
    # East really is East: the vertex with the larger LV95 easting has the larger local x.
    assert part.positions[:, 0].max() > 0.49 and part.positions[:, 2].max() > 0.49


def test_keep_ground_when_asked(tmp_path):
    write(
        tmp_path,
        "box.city.json",
        city({"B1": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES),
    )
    _, building = only_building(tmp_path, ReaderOptions(drop_ground_surfaces=False))
    assert building.triangle_count == 12
    (part,) = building.parts
    n = triangle_normals(part)
    assert (
        n[:, 1] < -0.9 * np.linalg.norm(n, axis=1)
    ).sum() == 2  # the floor points down (outward)


def test_v11_multisurface_polygon_with_hole(tmp_path):
    # A flat 10 m x 10 m roof with a 2 m x 2 m hole, and a vertical wall with a window hole.
    vertices = [
        [0, 0, 5000],
        [10000, 0, 5000],
        [10000, 10000, 5000],
        [0, 10000, 5000],
        [4000, 4000, 5000],
        [4000, 6000, 5000],
        [6000, 6000, 5000],
        [6000, 4000, 5000],
        [0, 0, 0],
        [10000, 0, 0],
        [4000, 0, 2000],
        [4000, 0, 3000],
        [6000, 0, 3000],
        [6000, 0, 2000],
    ]
    roof = [[0, 1, 2, 3], [4, 5, 6, 7]]  # outer CCW from above, hole clockwise
    wall = [[8, 9, 1, 0], [10, 11, 12, 13]]  # south wall, outward = -North
    geometry = {"type": "MultiSurface", "lod": "2", "boundaries": [roof, wall]}
    write(
        tmp_path,
        "holes.json",
        city(
            {"B": {"type": "Building", "geometry": [geometry]}},
            vertices,
            version="1.1",
            crs="urn:ogc:def:crs:EPSG::2056",
        ),
    )
    _, building = only_building(tmp_path)
    (part,) = building.parts
    n = triangle_normals(part)
    area = np.linalg.norm(n, axis=1) / 2
    assert len(n) == 16  # each: 8 vertices, 1 hole -> 8 triangles
    roof_faces = n[:, 1] > 0
    assert area[roof_faces].sum() == pytest.approx(96.0, rel=0.01)  # m², the hole is left open
    assert area[~roof_faces].sum() == pytest.approx(50.0 - 2.0, rel=0.01)
    assert np.all(n[~roof_faces][:, 2] < 0)  # the wall faces South
    hole_centre = part.positions[part.triangles].mean(axis=1)[roof_faces]
    assert not np.any(
        np.all(
            np.abs(hole_centre[:, [0, 2]] - part.positions[:, [0, 2]].mean(axis=0)) < 0.5, axis=1
        )
    )


def test_highest_lod_and_building_parts(tmp_path):
    lod1 = unit_box(lod="1")
    lod2 = dict(
        unit_box(lod="2.2"), boundaries=[unit_box()["boundaries"][0][:2]]
    )  # only ground + roof
    part_box = dict(unit_box(lod="2.2"))
    objects = {
        "B": {"type": "Building", "geometry": [lod1, lod2], "children": ["P"]},
        "P": {"type": "BuildingPart", "parents": ["B"], "geometry": [part_box]},
        "Other": {"type": "Building", "geometry": [unit_box(lod="1")]},
    }
    write(tmp_path, "parts.city.json", city(objects, BOX_VERTICES))
    scan = scan_folder(tmp_path)
    assert sorted(e.id for e in scan.entries) == ["B", "Other"]  # parts are not buildings
    building = load_entry(next(e for e in scan.entries if e.id == "B"))
    # LoD 2.2: roof of B (2 triangles) + part box without ground (10), merged in one part.
    assert building.triangle_count == 12 and len(building.parts) == 1
    assert any("used the highest, 2.2" in p for p in building.problems)


def test_crs_override_forms_and_missing_crs(tmp_path):
    data = city({"B": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES, crs=None)
    write(tmp_path, "nocrs.city.json", data)
    with pytest.raises(InputError) as error:
        scan_folder(tmp_path)
    assert (
        "--crs" in str(error.value)
        and "readers.crs" in str(error.value)
        and "nocrs.city.json" in str(error.value)
    )
    for form in (
        "EPSG:2056",
        "urn:ogc:def:crs:EPSG::2056",
        "https://www.opengis.net/def/crs/EPSG/0/2056",
    ):
        _, building = only_building(tmp_path, ReaderOptions(crs=form))
        assert building.reference.lon == pytest.approx(7.4386, abs=1e-3)  # Bern
    with pytest.raises(InputError, match="unknown coordinate reference system"):
        scan_folder(tmp_path, ReaderOptions(crs="EPSG:999999"))


def test_missing_texture_goes_untextured_with_a_problem(tmp_path):
    geometry = unit_box()
    geometry["texture"] = {
        "facade": {
            "values": [[[[None]], [[0, 0, 1, 2, 3]], [[None]], [[None]], [[None]], [[None]]]]
        }
    }
    appearance = {
        "textures": [{"image": "missing.jpg", "type": "JPG"}],
        "vertices-texture": [[0, 0], [1, 0], [1, 1], [0, 1]],
    }
    write(
        tmp_path,
        "tex.city.json",
        city(
            {"B": {"type": "Building", "geometry": [geometry]}}, BOX_VERTICES, appearance=appearance
        ),
    )
    _, building = only_building(tmp_path)
    assert building.triangle_count == 10 and all(p.texture is None for p in building.parts)
    assert any("missing.jpg missing" in p for p in building.problems)


def test_texture_found_and_uvs_split_at_seams(tmp_path):
    from PIL import Image

    Image.new("RGB", (8, 4), (200, 10, 10)).save(tmp_path / "atlas.png")
    geometry = unit_box()
    # Roof and south wall textured from the same atlas with different UVs: shared corners split.
    geometry["texture"] = {
        "t": {
            "values": [
                [[[None]], [[0, 0, 1, 2, 3]], [[0, 4, 5, 6, 7]], [[None]], [[None]], [[None]]]
            ]
        }
    }
    uv = [[0, 0], [0.5, 0], [0.5, 1], [0, 1], [0.5, 0], [1, 0], [1, 1], [0.5, 1]]
    write(
        tmp_path,
        "tex.city.json",
        city(
            {"B": {"type": "Building", "geometry": [geometry]}},
            BOX_VERTICES,
            appearance={
                "textures": [{"image": "atlas.png", "type": "PNG"}],
                "vertices-texture": uv,
            },
        ),
    )
    scan, building = only_building(tmp_path)
    assert str(tmp_path / "atlas.png") in scan.entries[0].inputs
    textured = [p for p in building.parts if p.texture is not None]
    untextured = [p for p in building.parts if p.texture is None]
    assert len(textured) == 1 and len(untextured) == 1
    part = textured[0]
    assert part.texture.mime == "image/png" and (part.texture.width, part.texture.height) == (8, 4)
    assert part.texture.data == (tmp_path / "atlas.png").read_bytes()
    assert part.triangle_count == 4 and part.vertex_count == 8  # the 2 shared corners are split
    assert untextured[0].triangle_count == 6


def test_city_json_seq(tmp_path):
    header = {
        "type": "CityJSON",
        "version": "2.0",
        "CityObjects": {},
        "vertices": [],
        "transform": {"scale": [0.001, 0.001, 0.001], "translate": [2600000.0, 1200000.0, 500.0]},
        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/2056"},
    }
    features = []
    for i in range(2):
        shifted = [[x + 50000 * i, y, z] for x, y, z in BOX_VERTICES]
        features.append(
            {
                "type": "CityJSONFeature",
                "id": f"F{i}",
                "CityObjects": {f"F{i}": {"type": "Building", "geometry": [unit_box()]}},
                "vertices": shifted,
            }
        )
    (tmp_path / "seq.city.jsonl").write_text(
        "\n".join(json.dumps(r) for r in [header] + features) + "\n"
    )
    scan = scan_folder(tmp_path)
    buildings = [load_entry(e) for e in scan.entries]
    assert [b.id for b in buildings] == ["F0", "F1"] and all(
        b.triangle_count == 10 for b in buildings
    )
    east = geodesy.lonlath_to_local(
        [[buildings[1].reference.lon, buildings[1].reference.lat, 500.0]], buildings[0].reference
    )[0, 0]
    assert east == pytest.approx(50.0, abs=0.2)  # metres: 50 m apart in LV95


def test_file_parsed_once_for_scan_and_loads(tmp_path, monkeypatch):
    objects = {f"B{i}": {"type": "Building", "geometry": [unit_box()]} for i in range(5)}
    write(tmp_path, "many.city.json", city(objects, BOX_VERTICES))
    calls = []
    original = cityjson._parse
    monkeypatch.setattr(cityjson, "_parse", lambda *a: calls.append(a) or original(*a))
    scan = scan_folder(tmp_path)
    for entry in scan.entries:
        load_entry(entry)
    assert len(scan.entries) == 5 and len(calls) == 1


def test_bad_files_are_reported_not_raised(tmp_path):
    write(
        tmp_path,
        "good.city.json",
        city({"B": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES),
    )
    (tmp_path / "broken.city.json").write_text('{"type": "CityJSON", "CityObjects": {')
    write(
        tmp_path,
        "range.city.json",
        city({"R": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES[:4]),
    )
    scan = scan_folder(tmp_path)
    assert [e.id for e in scan.entries] == ["B"]
    reasons = {Path(s.source).name: s.reason for s in scan.skipped}
    assert "not valid JSON" in reasons["broken.city.json"]
    assert "out of range" in reasons["range.city.json"]
    with pytest.raises(ReadError, match="broken.city.json"):
        load_entry(Entry("cityjson", "X", str(tmp_path / "broken.city.json"), None, [], "X"))
    with pytest.raises(ReadError, match="no Building with id 'nope'"):
        load_entry(Entry("cityjson", "nope", str(tmp_path / "good.city.json"), None, [], "nope"))


def test_crs_text_forms():
    for text in (
        "EPSG:7415",
        "urn:ogc:def:crs:EPSG::7415",
        "https://www.opengis.net/def/crs/EPSG/0/7415",
        "http://www.opengis.net/def/crs/EPSG/0/7415",
    ):
        assert geodesy.normalise_crs_text(text) == "EPSG:7415"
    assert geodesy.parse_crs("https://www.opengis.net/def/crs/EPSG/0/7415").is_compound


def test_local_frame_round_trip_and_axes():
    ref = geodesy.GeoPoint(126.978, 37.5665, 20.0)
    points = np.array([[10.0, 5.0, -30.0], [0.0, 0.0, 0.0], [-200.0, 40.0, 500.0]])
    back = geodesy.lonlath_to_local(geodesy.local_to_lonlath(points, ref), ref)
    assert back == pytest.approx(points, abs=1e-6)
    east, north = geodesy.local_to_lonlath([[100.0, 0, 0], [0, 0, 100.0]], ref)
    assert east[0] > ref.lon and east[1] == pytest.approx(ref.lat, abs=1e-7)
    assert north[1] > ref.lat and north[0] == pytest.approx(ref.lon, abs=1e-9)
    # 100 m along the sphere of radius 6378137 m, at the reference's height of 20 m.
    assert math.radians(north[1] - ref.lat) * (6378137.0 + 20.0) == pytest.approx(100.0, rel=1e-6)


def test_degenerate_polygon_left_out_and_declared_crs_override_noted(tmp_path):
    geometry = unit_box()
    geometry["boundaries"][0].append([[0, 1, 1, 0]])  # no area
    geometry["semantics"]["values"][0].append(2)
    write(
        tmp_path,
        "deg.city.json",
        city({"B": {"type": "Building", "geometry": [geometry]}}, BOX_VERTICES),
    )
    scan, building = only_building(tmp_path)
    assert building.triangle_count == 10
    assert any("1 degenerate polygon" in p for p in building.problems)
    assert not scan.notes
    scan = scan_folder(tmp_path, ReaderOptions(crs="EPSG:2056"))
    assert not scan.notes  # same CRS written another way
    # --crs is for files that declare none: the declared one is kept (noted), and a run where no
    # file lacks a CRS refuses the contradiction (issue 26) ...
    options = ReaderOptions(crs="EPSG:21781")
    scan = scan_folder(tmp_path, options)
    assert any("read in it" in note for note in scan.notes)
    assert load_entry(scan.entries[0], options).reference == building.reference
    with pytest.raises(InputError, match="declares .*2056, not EPSG:21781.*--override-crs"):
        check_crs_option([scan], options)
    # ... unless a file of the run lacks one: the option is for that file.
    write(
        tmp_path,
        "nocrs.city.json",
        city({"C": {"type": "Building", "geometry": [unit_box()]}}, BOX_VERTICES, crs=None),
    )
    check_crs_option([scan_folder(tmp_path, options)], options)
    # ... and replacing the declared one takes override_crs, noted in the scan and per building.
    options = ReaderOptions(override_crs="EPSG:21781")  # LV03
    scan = scan_folder(tmp_path, options)
    assert any("declares" in note and "EPSG:21781" in note for note in scan.notes)
    building = load_entry(scan.entries[0], options)
    assert any("in place of the declared" in p for p in building.problems)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_triangulate_concave_ring_follows_outward(sign):
    # An L-shaped wall in the East/Up plane (metres), slightly non-planar (5 mm out of plane).
    ring = np.array(
        [[0, 0, 0], [4, 0, 0], [4, 1, 0.005], [1, 1, 0], [1, 3, 0], [0, 3, 0.005]], dtype=float
    )
    outward = np.array([0.0, 0.0, sign])
    triangles = cityjson.triangulate_polygon([ring], outward)
    assert len(triangles) == 4
    n = np.cross(
        ring[triangles[:, 1]] - ring[triangles[:, 0]], ring[triangles[:, 2]] - ring[triangles[:, 0]]
    )
    assert np.all(n @ outward > 0)
    assert (np.linalg.norm(n, axis=1) / 2).sum() == pytest.approx(6.0, rel=1e-3)  # m², the L's area


def test_a_crs_that_puts_buildings_off_the_globe_skips_them_with_a_reason(tmp_path):
    """Coordinates read in the wrong CRS can land outside lon/lat range: each such building is
    listed as skipped with the reason, the scan goes on."""
    from exporter.config import ReaderOptions
    from exporter.readers import cityjson

    document = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [1.0, 1.0, 1.0], "translate": [0.0, 0.0, 0.0]},
        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/4979"},
        "CityObjects": {
            "far": {
                "type": "Building",
                "geometry": [{"type": "MultiSurface", "lod": "1", "boundaries": [[[0, 1, 2]]]}],
            }
        },
        "vertices": [[10.0, 95.0, 0.0], [10.001, 95.0, 0.0], [10.0, 95.001, 5.0]],
    }
    (tmp_path / "bad.city.json").write_text(__import__("json").dumps(document))
    scan = cityjson.scan(tmp_path, ReaderOptions())
    assert scan.entries == []
    assert (
        len(scan.skipped) == 1
        and "far" in scan.skipped[0].reason
        and "CRS" in scan.skipped[0].reason
    )
