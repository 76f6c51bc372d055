"""CityGML reader: the real files of tests/data/real end to end, the same buildings through the CityGML and
CityJSON readers, appearances and atlases, CRS forms, LoD choice and bad input (incl. a fuzz)."""

from __future__ import annotations

import gzip
import io
import json
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image
from pyproj import Transformer

from exporter.cli import main
from exporter.config import ConfigError, ReaderOptions, config_from_dict, default_config_yaml
from exporter.errors import InputError, ReadError
from exporter.readers import (
    check_crs_option,
    detect_format,
    input_paths,
    load_entry,
    scan_folder,
)
from exporter.readers import citygml as reader
from exporter.readers.atlas import shelf_pack
from tests.citygml_writer import (
    appearance_member,
    box,
    building_xml,
    citygml,
    texture_member,
    with_window,
    write,
    write_cityjson,
)
from tests.conftest import missing_tool, run_gltf_validator

X0, Y0 = 458870.0, 5438350.0  # EPSG:25832 metres, Karlsruhe (where the SIG 3D example stands)


def buildings() -> list[dict]:
    """A house with a windowed wall and a garage part, and a second detached box."""
    garage = {"id": "G1", "surfaces": box(X0 + 10, Y0, 112.0, 4, 5, 2.5)}
    return [
        {
            "id": "B1",
            "name": "House",
            "function": "1000",
            "height": 6.0,
            "surfaces": with_window(box(X0, Y0, 112.0, 10, 6, 6)),
            "parts": [garage],
        },
        {"id": "B2", "surfaces": box(X0 + 30, Y0 + 20, 113.5, 8, 8, 9)},
    ]


def load_all(path: Path, **options) -> list:
    opts = ReaderOptions(**options)
    scan = scan_folder(path, opts)
    return [load_entry(entry, opts) for entry in scan.entries]


def triangle_set(building, digits: int = 6) -> list:
    """Triangles as rounded local-position triples, each rotated to start at its smallest corner
    (orientation kept), sorted: equal for equal meshes whatever the vertex order."""
    out = []
    for part in building.parts:
        for tri in part.positions[part.triangles]:
            corners = [tuple(np.round(p, digits)) for p in tri]
            k = corners.index(min(corners))
            out.append(tuple(corners[k:] + corners[:k]))
    return sorted(out)


def outward_ok(building) -> bool:
    """Every triangle's normal points away from the building's centroid (boxes are convex)."""
    for part in building.parts:
        points = part.positions[part.triangles]
        normals = np.cross(points[:, 1] - points[:, 0], points[:, 2] - points[:, 0])
        centre = part.positions.mean(axis=0)
        if not np.all(np.einsum("ij,ij->i", normals, points.mean(axis=1) - centre) > 0):
            return False
    return True


# --------------------------------------------------------------------------- real files


def _export(tmp_path: Path, source: Path) -> tuple[list[dict], list[Path]]:
    out = tmp_path / "out"
    assert main(["export", str(source), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    records = [
        b
        for m in sorted(out.glob("*/lod_manifest.json"))
        for b in json.loads(m.read_text())["buildings"]
    ]
    # The buildings' level files (the tileset's proxies under tileset_proxies/ are not theirs).
    return records, sorted(out.glob("*/*/lod*.glb"))


def _independent_centres(path: Path, epsg: str) -> dict:
    """Per building, the lon/lat box centre and lowest height of all its coordinates by pyproj
    directly (ElementTree parse, no exporter code)."""
    transformer = Transformer.from_crs(epsg, "EPSG:4326", always_xy=True)
    centres = {}
    for element in ET.parse(path).getroot().iter():
        if element.tag.endswith("}Building"):  # the real files nest no Building in another
            gid = element.get("{http://www.opengis.net/gml}id")
            values = [
                float(v)
                for pl in element.iter("{http://www.opengis.net/gml}posList")
                for v in pl.text.split()
            ]
            xyz = np.array(values).reshape(-1, 3)
            lon, lat = transformer.transform(xyz[:, 0], xyz[:, 1])
            centres[gid] = (
                (min(lon) + max(lon)) / 2,
                (min(lat) + max(lat)) / 2,
                xyz[:, 2].min(),
            )
    return centres


@pytest.mark.parametrize(
    "name, epsg, count",
    [("berlin_3880_5819.gml", "EPSG:25833", 3), ("house_and_garage_lod2.gml", "EPSG:25832", 1)],
)
def test_shared_file_exports_valid_glb_placed_where_pyproj_says(
    tmp_path, shared_real, gltf_validator, name, epsg, count
):
    path = shared_real / "citygml" / name
    records, glbs = _export(tmp_path, path)
    assert len(records) == count and len(glbs) == 3 * count
    for report in gltf_validator(glbs):
        assert report["errors"] == 0, report
    expected = _independent_centres(path, epsg)
    for building in load_all(path):
        # Floorless and wound outward, the summed area vectors point up by the footprint area.
        up = sum(
            np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]).sum(axis=0) / 2
            for t in (p.positions[p.triangles] for p in building.parts)
        )
        assert up[1] > 10.0 and abs(up[0]) < 1e-6 * up[1] + 1e-6, up  # m^2 (local E, U, N)
    for record in records:
        lon, lat, low = expected[record["id"]]
        centre = record["center"]
        # Ground polygons are dropped, but walls reach the ground, so the box is the same.
        assert abs(centre["lon"] - lon) < 1e-9 and abs(centre["lat"] - lat) < 1e-9
        assert abs(centre["elev"] - low) < 1e-6
        assert record["attributes"]["gml_id"] == record["id"]
    if name.startswith("berlin"):  # its appearance images are not distributed with it
        assert all(any("texture" in p and "missing" in p for p in r["problems"]) for r in records)
        # With stand-in images beside a link to it, each building's 6 to 8 CityModel-level
        # textures become one atlas holding every image.
        (tmp_path / "linked").mkdir()
        (tmp_path / "linked" / name).symlink_to(path)
        uris = sorted(set(re.findall(r"<app:imageURI>([^<]+)</app:imageURI>", path.read_text())))
        for i, uri in enumerate(uris):
            _image(tmp_path / "linked" / uri, (10 * i, 100, 200), "JPEG", (32 + 4 * i, 16))
        for building in load_all(tmp_path / "linked" / name):
            textured = [p for p in building.parts if p.texture is not None]
            assert len(textured) == 1 and textured[0].texture.mime == "image/jpeg"
            assert not any("texture" in p for p in building.problems)
    else:
        assert records[0]["attributes"] == {
            "gml_id": "GML_7b1a5a6f-ddad-4c3d-a507-3eb9ee0a8e68",
            "name": "Example Building LOD2",
            "function": "1000",
            "year_of_construction": 1985,
            "roof_type": "1030",
            "measured_height": 6.0,
            "storeys_above_ground": 1,
        }


# --------------------------------------------------------------------------- same as CityJSON


@pytest.mark.parametrize(
    "version, mode", [("2.0", "boundedBy"), ("1.0", "boundedBy"), ("2.0", "solid")]
)
def test_same_meshes_and_placement_as_cityjson(tmp_path, version, mode):
    gml = write(tmp_path / "gml" / "city.gml", citygml(buildings(), version=version, mode=mode))
    cj = write_cityjson(tmp_path / "cj" / "city.city.json", buildings())
    from_gml, from_json = load_all(gml), load_all(cj)
    assert [b.id for b in from_gml] == [b.id for b in from_json] == ["B1", "B2"]
    for a, b in zip(from_gml, from_json):
        assert a.reference == b.reference and a.lonlat_bounds == b.lonlat_bounds
        assert triangle_set(a) == triangle_set(b)
        assert a.vertex_count == b.vertex_count and a.triangle_count == b.triangle_count
        assert outward_ok(a) or a.id == "B1"  # B1 holds a garage beside the house
    assert from_gml[0].attributes == {
        "gml_id": "B1",
        "name": "House",
        "function": "1000",
        "measured_height": 6.0,
    }


def test_citygml_3_building_geometry(tmp_path):
    """CityGML 3.0's names (core:boundary, con:WallSurface, core:lod2MultiSurface, GML 3.2 ids)
    read as 2.0's."""
    v2 = citygml(buildings())
    v3 = re.sub(r"bldg:(Wall|Roof|Ground)Surface", r"con:\1Surface", v2)
    v3 = re.sub(
        r"bldg:(boundedBy|lod2MultiSurface)\b",
        lambda m: "boundary" if m[1] == "boundedBy" else m[1],
        v3,
    )
    v3 = (
        v3.replace("citygml/2.0", "citygml/3.0")
        .replace("building/2.0", "building/3.0")
        .replace(
            '"http://www.opengis.net/gml"',
            '"http://www.opengis.net/gml/3.2" xmlns:con="http://www.opengis.net/citygml/construction/3.0"',
        )
    )
    assert "bldg:boundedBy" not in v3 and "<con:WallSurface>" in v3 and "<lod2MultiSurface>" in v3
    a = load_all(write(tmp_path / "v2" / "a.gml", v2))
    b = load_all(write(tmp_path / "v3" / "a.gml", v3))
    assert [x.id for x in b] == ["B1", "B2"]
    assert [triangle_set(x) for x in a] == [triangle_set(x) for x in b]


def test_latitude_first_crs_gives_the_same_placement(tmp_path):
    """The same boxes in EPSG:4326 written latitude, longitude, height (the CRS's axis order, as
    PLATEAU's EPSG:6697 is) land where the projected file puts them."""
    to_geo = Transformer.from_crs("EPSG:25832", "EPSG:4326", always_xy=True)

    def geographic(surfaces):
        out = []
        for kind, rings in surfaces:
            new = []
            for ring in rings:
                lon, lat = to_geo.transform([p[0] for p in ring], [p[1] for p in ring])
                new.append([(la, lo, p[2]) for lo, la, p in zip(lon, lat, ring)])
            out.append((kind, new))
        return out

    data = [{"id": "B2", "surfaces": box(X0, Y0, 100.0, 8, 8, 9)}]
    projected = load_all(write(tmp_path / "a.gml", citygml(data)))[0]
    geo = [{"id": "B2", "surfaces": geographic(data[0]["surfaces"])}]
    geo_text = citygml(geo, srs="urn:ogc:def:crs:EPSG::4326")
    flipped = load_all(write(tmp_path / "b.gml", geo_text))[0]
    assert abs(flipped.reference.lon - projected.reference.lon) < 1e-9
    assert abs(flipped.reference.lat - projected.reference.lat) < 1e-9
    a, b = triangle_set(projected, 3), triangle_set(flipped, 3)
    assert len(a) == len(b) and np.allclose(np.array(a), np.array(b), atol=2e-3)


# --------------------------------------------------------------------------- CRS, LoD, formats


@pytest.mark.parametrize(
    "srs, expected",
    [
        ("EPSG:25833", "EPSG:25833"),
        ("urn:ogc:def:crs:EPSG::25832", "EPSG:25832"),
        ("urn:ogc:def:crs:EPSG:6.12:25833", "EPSG:25833"),
        ("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783", "EPSG:25832+5783"),
        ("http://www.opengis.net/def/crs/EPSG/0/6697", "EPSG:6697"),
        ("http://www.opengis.net/gml/srs/epsg.xml#25833", "EPSG:25833"),
        ("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", "EPSG:25832"),
    ],
)
def test_srs_name_forms(srs, expected):
    assert reader.crs_of_srs_name(srs) == expected


def test_axis_order_and_unknown_srs():
    assert reader.latitude_first("EPSG:6697") and reader.latitude_first("EPSG:4326")
    assert not reader.latitude_first("EPSG:25832+5783")
    with pytest.raises(ValueError, match="EPSG:999999"):
        reader.crs_of_srs_name("EPSG:999999")


def test_crs_inherited_declared_wins_and_missing_needs_crs(tmp_path):
    data = [{"id": "B2", "surfaces": box(X0, Y0, 100.0, 8, 8, 9)}]
    reference = load_all(write(tmp_path / "a" / "a.gml", citygml(data)))[0].reference
    # No envelope: the srsName on the MultiSurface (an ancestor of the polygons) is used.
    text = citygml(data, srs=None).replace(
        "<gml:MultiSurface>", '<gml:MultiSurface srsName="EPSG:25832">'
    )
    assert load_all(write(tmp_path / "b" / "b.gml", text))[0].reference == reference
    # --crs does not override a declared CRS.
    assert load_all(tmp_path / "a" / "a.gml", crs="EPSG:25833")[0].reference == reference
    bare = write(tmp_path / "c" / "c.gml", citygml(data, srs=None))
    with pytest.raises(InputError, match=r"c\.gml.*no coordinate reference system"):
        scan_folder(bare)
    assert load_all(bare, crs="EPSG:25832")[0].reference == reference


def test_crs_options_follow_the_cityjson_rules(tmp_path):
    """--override-crs replaces a declared CRS (noted); a --crs other than the declared one is a
    conflict that check_crs_option refuses unless another input lacks a CRS (issue 26's rules)."""
    data = [{"id": "B2", "surfaces": box(X0, Y0, 100.0, 8, 8, 9)}]
    declared = write(tmp_path / "a" / "a.gml", citygml(data))  # EPSG:25832
    kept = load_all(declared)[0]
    moved = load_all(declared, override_crs="EPSG:25833")[0]
    assert abs(moved.reference.lon - kept.reference.lon) > 1.0  # 6 degrees: the next UTM zone
    assert any("in place of the declared" in p for p in moved.problems)
    options = ReaderOptions(crs="EPSG:25833")
    scan = scan_folder(declared, options)
    assert scan.crs_conflicts and not scan.crs_option_used
    with pytest.raises(InputError, match=r"a\.gml: declares .*25832.*no input lacks a CRS"):
        check_crs_option([scan], options)
    bare = write(tmp_path / "c" / "c.gml", citygml(data, srs=None))
    bare_scan = scan_folder(bare, options)
    assert bare_scan.crs_option_used and not bare_scan.crs_conflicts
    check_crs_option([scan, bare_scan], options)  # --crs is for c.gml; a.gml keeps its own


def test_lod_choice_follows_the_config(tmp_path):
    lod1 = building_xml({"id": "x", "surfaces": box(X0, Y0, 0.0, 8, 8, 4)}, "multisurface", lod=1)
    lod3 = building_xml(
        {"id": "y", "surfaces": with_window(box(X0, Y0, 0.0, 8, 8, 9))}, "boundedBy", lod=3
    )
    inner = lambda xml: xml.split(">", 1)[1].rsplit("<", 1)[0]
    data = {"id": "B", "surfaces": box(X0, Y0, 0.0, 8, 8, 6), "extra": inner(lod1) + inner(lod3)}
    path = write(tmp_path / "l.gml", citygml([data]))
    heights = {}
    for cap in (0, 1, 2, 3):
        building = load_all(path, citygml_lod=cap)[0]
        heights[cap] = max(p.positions[:, 1].max() for p in building.parts)
    assert np.allclose([heights[0], heights[1], heights[2], heights[3]], [4, 4, 6, 9], atol=1e-6)
    assert any("read LoD 1" in p for p in load_all(path, citygml_lod=0)[0].problems)
    assert "  citygml_lod: 2  # CityGML" in default_config_yaml()
    with pytest.raises(ConfigError, match="citygml_lod"):
        config_from_dict({"readers": {"citygml_lod": 7}})


def test_gz_xml_folder_and_glob_inputs(tmp_path):
    text = citygml(buildings())
    folder = tmp_path / "tiles"
    write(folder / "a.gml", text)
    (folder / "b.gml.gz").write_bytes(gzip.compress(text.replace('"B', '"C').encode()))
    write(folder / "c.xml", text.replace('"B', '"D'))
    write(folder / "notes.xml", "<notes/>")
    assert detect_format(folder) == "citygml" and detect_format(folder / "b.gml.gz") == "citygml"
    ids = [b.id for b in load_all(folder)]
    assert ids == ["B1", "B2", "C1", "C2", "D1", "D2"]
    files = input_paths(sorted(folder.glob("*.gml*")))
    assert [p.name for p in files] == ["a.gml", "b.gml.gz"]
    _image(folder / "a_appearance" / "t.jpg", (1, 2, 3), "JPEG")  # CityGML's image folder
    files = input_paths(sorted(folder.glob("*")))  # tiles/*
    assert [p.name for p in files] == ["a.gml", "b.gml.gz", "c.xml", "notes.xml"]
    with pytest.raises(InputError, match="notes.xml"):
        detect_format(folder / "notes.xml")


def _refs(*ids: str) -> str:
    members = "".join(f'<gml:surfaceMember xlink:href="#{i}"/>' for i in ids)
    return f"<bldg:lod2MultiSurface><gml:MultiSurface>{members}</gml:MultiSurface></bldg:lod2MultiSurface>"


def test_xlinks_to_polygons_of_other_buildings(tmp_path):
    """References forward and backward to another building's polygons are followed (the
    polygon keeps the CRS it inherits where it is defined); a dangling one costs only itself."""
    b1 = {"id": "B1", "surfaces": box(X0, Y0, 0.0, 8, 6, 5), "extra": _refs("B2_p1")}
    b2 = {
        "id": "B2",
        "surfaces": box(X0 + 20, Y0, 0.0, 8, 6, 5),
        "extra": _refs("B1_p2", "nowhere"),
    }
    b3 = {"id": "B3", "surfaces": [], "extra": _refs("B1_p1")}
    text = citygml([b1, b2, b3], srs=None).replace(
        "<gml:MultiSurface>", '<gml:MultiSurface srsName="urn:ogc:def:crs:EPSG::25832">'
    )
    one, two, three = load_all(write(tmp_path / "x.gml", text))
    assert (one.triangle_count, two.triangle_count, three.triangle_count) == (12, 12, 2)
    assert not any("dangling" in p for p in one.problems + three.problems)
    assert any("dangling xlink:href (first: #nowhere" in p for p in two.problems)
    roof_of_b1 = max(p.positions[:, 1].max() for p in three.parts)  # B1's roof, 5 m up
    assert abs(three.reference.elev - 5.0) < 1e-9 and abs(roof_of_b1) < 1e-5  # sphere: 2 um
    assert (
        one.lonlat_bounds[2]
        > load_all(write(tmp_path / "y.gml", citygml([b1])))[0].lonlat_bounds[2]
    )


def test_loads_in_file_order_parse_the_file_once(tmp_path, monkeypatch):
    path = write(
        tmp_path / "a.gml",
        citygml(buildings() * 1 + [{"id": "B3", "surfaces": box(X0, Y0 + 40, 0, 5, 5, 5)}]),
    )
    opts = ReaderOptions()
    entries = scan_folder(path, opts).entries
    calls = []
    original = reader.stream
    monkeypatch.setattr(reader, "stream", lambda *a, **k: calls.append(1) or original(*a, **k))
    reader._cursors.clear()
    assert [load_entry(e, opts).id for e in entries] == ["B1", "B2", "B3"]
    assert len(calls) == 1
    assert load_entry(entries[0], opts).id == "B1" and len(calls) == 2  # backwards: restarts


def test_a_file_many_buildings_share_is_hashed_once_per_process(tmp_path, monkeypatch):
    """Export hashes every building's inputs; one 100 MB CityGML file of 30,000 buildings must not
    be read 30,000 times (the same trust rule as across runs: not modified in the last 2 s)."""
    from exporter import pipeline

    calls: list[str] = []
    monkeypatch.setattr(pipeline, "_sha256_file", lambda name: calls.append(name) or "digest")
    monkeypatch.setattr(pipeline, "_hashed", {})
    old = write(tmp_path / "old.gml", citygml(buildings()))
    an_hour_ago = os.stat(old).st_mtime_ns - 3600 * 10**9
    os.utime(old, ns=(an_hour_ago, an_hour_ago))
    for _ in range(5):
        assert pipeline.input_fingerprints([str(old)], {})[0]["sha256"] == "digest"
    assert len(calls) == 1
    fresh = write(tmp_path / "fresh.gml", citygml(buildings()))  # may still be changing
    for _ in range(3):
        pipeline.input_fingerprints([str(fresh)], {})
    assert len(calls) == 4


# --------------------------------------------------------------------------- appearance


def _image(path: Path, colour, fmt: str, size=(16, 8)) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", size, colour).save(path, format=fmt)


def test_per_surface_images_packed_into_one_atlas(tmp_path):
    data = [{"id": "B", "surfaces": box(X0, Y0, 0.0, 8, 6, 5)}]
    full = [(0, 0), (1, 0), (1, 1), (0, 1)]
    members = (
        texture_member("tex/red.png", "B_p2", [full])
        + texture_member("tex/blue.jpg", "B_p3", [full])
        + texture_member("tex/missing.jpg", "B_p4", [full])
        + texture_member("tex/red.png", "B_p5", [full[:2]])  # 3 coordinates for 5
        + texture_member("tex/red.png", "B_p1", [full])  # the same image again: packed once
    )
    _image(tmp_path / "tex" / "red.png", (255, 0, 0), "PNG")
    _image(tmp_path / "tex" / "blue.jpg", (0, 0, 255), "JPEG", (8, 8))
    path = write(tmp_path / "a.gml", citygml(data, appearance=appearance_member(members)))
    scan = scan_folder(path)
    assert sorted(Path(p).name for p in scan.entries[0].inputs) == ["a.gml", "blue.jpg", "red.png"]
    building = load_entry(scan.entries[0])
    textured = [p for p in building.parts if p.texture is not None]
    assert len(textured) == 1, "both images in one atlas"
    part = textured[0]
    atlas = Image.open(io.BytesIO(part.texture.data)).convert("RGB")
    assert part.texture.mime == "image/png" and atlas.size == (
        part.texture.width,
        part.texture.height,
    )
    assert atlas.size == shelf_pack([(16, 8), (8, 8)])[1:]  # red and blue once each
    # Every corner's UV samples its own image's colour; the red wall faces south (-North).
    centre = part.uvs.reshape(-1, 2)[part.triangles].mean(axis=1)
    colours = [atlas.getpixel((int(u * atlas.width), int(v * atlas.height))) for u, v in centre]
    assert {c[0] > 200 for c in colours} == {True, False} and all(
        (c[0] > 200) != (c[2] > 200) for c in colours
    )
    assert any("missing.jpg missing" in p for p in building.problems)
    assert any("do not match its rings" in p for p in building.problems)
    assert building.triangle_count == 10  # roof + 4 walls, ground dropped, none lost
    # Through the whole export: the atlas goes down the texture LoD chain, the files validate.
    records, glbs = _export(tmp_path, path)
    assert len(glbs) == 3 and records[0]["attributes"] == {"gml_id": "B"}
    if missing_tool("node", "gltf-validator") is None:
        assert all(r["errors"] == 0 for r in run_gltf_validator(glbs))


def test_material_colour(tmp_path):
    data = [{"id": "B", "surfaces": box(X0, Y0, 0.0, 8, 6, 5)}]
    material = (
        "<app:surfaceDataMember><app:X3DMaterial><app:diffuseColor>0.2 0.4 0.6</app:diffuseColor>"
        "<app:transparency>0.5</app:transparency><app:target>#B_p1</app:target></app:X3DMaterial>"
        "</app:surfaceDataMember>"
    )
    path = write(tmp_path / "a.gml", citygml(data, appearance=appearance_member(material)))
    parts = load_all(path)[0].parts
    assert sorted(p.color for p in parts) == [(0.2, 0.4, 0.6, 0.5), (1.0, 1.0, 1.0, 1.0)]


# --------------------------------------------------------------------------- bad input


def _bad_surfaces() -> dict:
    """Surfaces each spoiled in one way (the ids name them), after a good box."""
    good = box(X0, Y0, 0.0, 8, 6, 5)
    return {
        "two_points": (
            "WallSurface",
            [[(X0, Y0, 0), (X0 + 1, Y0, 0), (X0, Y0, 0), (X0 + 1, Y0, 0)]],
        ),
        "bow_tie": (
            "WallSurface",
            [[(X0, Y0 - 1, 0), (X0 + 4, Y0 - 1, 4), (X0 + 4, Y0 - 1, 0), (X0, Y0 - 1, 4)]],
        ),
        "not_planar": (
            "WallSurface",
            [[(X0, Y0 - 2, 0), (X0 + 4, Y0 - 2, 0), (X0 + 4, Y0 + 2, 4), (X0, Y0 - 2, 4)]],
        ),
        "good": good,
    }


def test_bad_polygons_cost_only_themselves(tmp_path):
    bad = _bad_surfaces()
    surfaces = bad["good"] + [bad["two_points"], bad["bow_tie"], bad["not_planar"]]
    text = citygml([{"id": "B", "surfaces": surfaces}])
    # NaN and text in a posList, a dangling xlink:href.
    text = text.replace(
        "</bldg:Building>",
        '<bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember xlink:href="#nowhere"/>'
        '<gml:surfaceMember><gml:Polygon gml:id="nan"><gml:exterior><gml:LinearRing><gml:posList>'
        "1 2 NaN 4 5 6 7 8 9 1 2 NaN</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
        '</gml:surfaceMember><gml:surfaceMember><gml:Polygon gml:id="text"><gml:exterior><gml:LinearRing>'
        "<gml:posList>1 2 three 4 5 6 7 8 9</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
        '</gml:surfaceMember><gml:surfaceMember><gml:Polygon gml:id="odd"><gml:exterior><gml:LinearRing>'
        "<gml:posList>1 2 3 4 5 6 7 8</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
        "</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building>",
    )
    building = load_all(write(tmp_path / "a.gml", text))[0]
    assert building.triangle_count == 10  # the good box without its ground
    problems = " | ".join(building.problems)
    for expected in (
        "fewer than 3 distinct points (first: Polygon B_p6)",
        "self-intersecting ring (first: Polygon B_p7)",
        "non-planar ring (first: Polygon B_p8)",
        "dangling xlink:href (first: #nowhere",
        "2 polygon(s) left out: text, NaN or infinity",
        "do not split into srsDimension 3",
    ):
        assert expected in problems, problems


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(-3, 3), st.integers(-3, 3)), min_size=4, max_size=12))
def test_small_ring_crossing_check_matches_the_array_one(points):
    flat = np.array(points, dtype=np.float64)
    assert reader.ring_crossings(flat) == reader._crossings_array(flat)


def test_bad_building_and_bad_file(tmp_path, capsys):
    good = {"id": "B1", "surfaces": box(X0, Y0, 0.0, 8, 6, 5)}
    unknown = {"id": "B2", "surfaces": box(X0 + 20, Y0, 0.0, 8, 6, 5)}
    text = citygml([good, unknown]).replace(
        '<bldg:Building gml:id="B2">',
        '<bldg:Building gml:id="B2"><gml:boundedBy><gml:Envelope srsName="EPSG:999999"/></gml:boundedBy>',
    )
    scan = scan_folder(write(tmp_path / "a" / "a.gml", text))
    assert [e.id for e in scan.entries] == ["B1"]
    assert "EPSG:999999" in scan.skipped[0].reason and scan.skipped[0].id == "B2"
    # Truncated in the second building: the first is read, the file noted (exit 0).
    full = citygml([good, unknown])
    cut = write(tmp_path / "b" / "cut.gml", full[: full.index('gml:id="B2"') + 200])
    scan = scan_folder(cut)
    assert [e.id for e in scan.entries] == ["B1"] and "invalid XML" in scan.skipped[0].reason
    assert load_entry(scan.entries[0]).triangle_count == 10
    # Nothing readable: one line naming the file and where (exit 2).
    broken = write(tmp_path / "c" / "broken.gml", full.replace("</gml:posList>", "</gml:pos>", 1))
    assert main(["inspect", str(broken)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "broken.gml" in err[0] and "line" in err[0] and "posList" in err[0], (
        err
    )
    assert (
        main(
            [
                "inspect",
                str(write(tmp_path / "d" / "unknown.gml", citygml([good], srs="EPSG:999999"))),
            ]
        )
        == 2
    )
    assert "EPSG:999999" in capsys.readouterr().err


# --------------------------------------------------------------------------- fuzz

_TAGS = [
    "bldg:Building",
    "bldg:BuildingPart",
    "bldg:consistsOfBuildingPart",
    "bldg:boundedBy",
    "bldg:WallSurface",
    "bldg:GroundSurface",
    "bldg:lod2MultiSurface",
    "bldg:lod1Solid",
    "gml:Solid",
    "gml:exterior",
    "gml:interior",
    "gml:MultiSurface",
    "gml:CompositeSurface",
    "gml:OrientableSurface",
    "gml:baseSurface",
    "gml:surfaceMember",
    "gml:Polygon",
    "gml:LinearRing",
    "gml:posList",
    "gml:pos",
]
_TEXT = st.one_of(
    st.lists(st.floats(-5, 5, allow_nan=False).map(lambda v: f"{v:.3f}"), max_size=16).map(
        " ".join
    ),
    st.sampled_from(["", "NaN 1 2", "a b c", "1e999 0 0 1 1 1 2 2 2"]),
)


@st.composite
def _element(draw, depth=0):
    tag = draw(st.sampled_from(_TAGS))
    attrs = ""
    if draw(st.booleans()):
        attrs += f' gml:id="i{draw(st.integers(0, 5))}"'
    if draw(st.integers(0, 5)) == 0:
        attrs += f' xlink:href="#i{draw(st.integers(0, 6))}"'
    if draw(st.integers(0, 6)) == 0:
        attrs += f' srsDimension="{draw(st.sampled_from(["2", "3", "x", "0"]))}"'
    if tag == "gml:OrientableSurface":
        attrs += ' orientation="-"'
    children = ""
    if depth < 6 and tag not in ("gml:posList", "gml:pos"):
        children = "".join(draw(st.lists(_element(depth + 1), max_size=3)))
    text = draw(_TEXT) if tag in ("gml:posList", "gml:pos") else ""
    return f"<{tag}{attrs}>{text}{children}</{tag}>"


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(bodies=st.lists(_element(), min_size=1, max_size=3), cut=st.integers(0, 40))
def test_fuzz_xml_shape_never_crashes(tmp_path, bodies, cut):
    anchor = building_xml({"id": "A", "surfaces": box(X0, Y0, 0.0, 2, 2, 2)})
    inner = "".join(bodies)
    text = citygml([]).replace(
        "\n\n</CityModel>",
        f'<cityObjectMember>{anchor}</cityObjectMember><cityObjectMember><bldg:Building gml:id="F">'
        f"{inner}</bldg:Building></cityObjectMember></CityModel>",
    )
    if cut:
        text = text[: len(text) - cut]
    path = write(tmp_path / "fuzz.gml", text)
    try:
        scan = scan_folder(path)
    except InputError as error:
        assert "fuzz.gml" in str(error)
        return
    for entry in scan.entries:
        try:
            building = load_entry(entry)
        except ReadError as error:
            assert "fuzz.gml" in str(error) and "unexpected" not in str(error), error
            continue
        assert all(np.isfinite(p.positions).all() for p in building.parts)
