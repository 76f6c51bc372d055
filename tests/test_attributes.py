"""Building attributes: one model for every reader (exporter/attributes.py, docs/input.md
'Attributes'), from the source files to the manifest."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from exporter.attributes import MAX_ATTRIBUTES, MAX_TEXT, clean_attributes
from exporter.config import ReaderOptions
from exporter.readers import load_entry, scan_folder

REAL = Path(__file__).resolve().parent / "data" / "real"
SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "15_279418_116113"


def load_all(path: Path, options: ReaderOptions | None = None) -> list:
    options = options or ReaderOptions()
    return [load_entry(e, options) for e in scan_folder(path, options).entries]


def test_odd_values_follow_the_documented_rules():
    attributes, notes = clean_attributes(
        [
            ("address", {"street": "Main", "geo": {"zip": 8001}}),
            ("tags", [1, "a", None]),
            ("nan", math.nan),
            ("inf", -math.inf),
            ("null", None),
            ("long", "x" * 1_000_000),
            ("bytes", b"caf\xe9 ok"),
            ("surrogate", "a\ud800b"),
            ("address.street", "again"),
            ("huge", 2**70),
            ("flag", True),
            ("  ", 1),
            (7, 1.5),
        ]
    )
    assert attributes["address.street"] == "Main"  # the first value of a repeated key kept
    assert attributes["address.geo.zip"] == 8001
    assert attributes["tags"] == '[1,"a",null]'
    assert "nan" not in attributes and "inf" not in attributes and "null" not in attributes
    assert len(attributes["long"]) == MAX_TEXT + 9 and attributes["long"][MAX_TEXT] == "…"
    assert attributes["bytes"] == "caf\ufffd ok"
    assert attributes["surrogate"].startswith("a\ufffd") and attributes["surrogate"].endswith("b")
    assert attributes["huge"] == str(2**70)
    assert attributes["flag"] is True and attributes["7"] == 1.5
    json.dumps(attributes, allow_nan=False).encode("utf-8")  # always writable
    assert any("given again" in n for n in notes) and any("cut to" in n for n in notes)
    many, notes = clean_attributes((f"k{i}", i) for i in range(MAX_ATTRIBUTES + 5))
    assert len(many) == MAX_ATTRIBUTES and any("5 attribute(s)" in n for n in notes)


def test_cityjson_keeps_every_attribute_and_odd_values_never_stop_a_building(tmp_path):
    data = json.loads((REAL / "zurich_lod2.city.json").read_text())
    ids = [k for k, v in data["CityObjects"].items() if v["type"] == "Building"]
    expected = data["CityObjects"][ids[0]]["attributes"]
    odd = data["CityObjects"][ids[1]]
    odd["attributes"] = {"nested": {"a": {"b": 1}}, "bad": float("nan"), "big": "y" * 2_000_000}
    path = tmp_path / "z.city.json"
    path.write_text(json.dumps(data))  # NaN written as the NaN literal Python's parser accepts
    by_id = {b.id: b for b in load_all(path)}
    assert by_id[ids[0]].attributes == expected and expected
    assert by_id[ids[1]].attributes["nested.a.b"] == 1
    assert "bad" not in by_id[ids[1]].attributes
    assert len(by_id[ids[1]].attributes["big"]) == MAX_TEXT + 9
    assert any("nan left out" in p for p in by_id[ids[1]].problems)


def test_citygml_standard_and_generic_attributes_with_types(tmp_path):
    text = (REAL / "citygml" / "house_and_garage_lod2.gml").read_text(encoding="utf-8")
    generic = (
        '<gen:stringAttribute name="Strasse"><gen:value>Hauptstr. 1</gen:value></gen:stringAttribute>'
        '<gen:intAttribute name="Geschosse"><gen:value>3</gen:value></gen:intAttribute>'
        '<gen:doubleAttribute name="Flaeche"><gen:value>120.5</gen:value></gen:doubleAttribute>'
        '<gen:intAttribute name="Kaputt"><gen:value>drei</gen:value></gen:intAttribute>'
        '<gen:genericAttributeSet name="Set"><gen:stringAttribute name="a"><gen:value>x'
        "</gen:value></gen:stringAttribute></gen:genericAttributeSet>"
    )
    marker = "<bldg:function"
    text = text.replace(marker, generic + marker, 1)
    if 'xmlns:gen="' not in text:
        text = text.replace(
            "<CityModel", '<CityModel xmlns:gen="http://www.opengis.net/citygml/generics/2.0"', 1
        )
    path = tmp_path / "house.gml"
    path.write_text(text, encoding="utf-8")
    (building,) = load_all(path)
    attributes = building.attributes
    assert attributes["gml_id"] == building.id
    assert attributes["year_of_construction"] == 1985 and attributes["storeys_above_ground"] == 1
    assert attributes["measured_height"] == 6.0 and attributes["roof_type"] == "1030"
    assert attributes["Strasse"] == "Hauptstr. 1" and attributes["Geschosse"] == 3
    assert attributes["Flaeche"] == 120.5 and attributes["Kaputt"] == "drei"
    assert attributes["Set.a"] == "x"


def test_vworld_attributes_name_the_record_and_files():
    buildings = load_all(SAMPLE)
    first = buildings[0]
    assert first.attributes["key"] == first.id
    assert first.attributes["dat_file"] == f"{SAMPLE.name}.dat"
    assert first.attributes["xdo_file"].endswith(".xdo")
    assert first.attributes["altitude"] == pytest.approx(first.reference.elev, abs=1e-3)
    assert [b.attributes["dat_index"] for b in buildings] == list(range(len(buildings)))


def test_folder_index_extra_columns_become_attributes(tmp_path):
    import trimesh

    trimesh.creation.box(extents=(2, 3, 4)).export(tmp_path / "a.glb")
    (tmp_path / "buildings.csv").write_text(
        "file,lon,lat,elev,id,name,year,code,height,empty\n"
        "a.glb,126.978,37.5665,30,A,City Hall,1926,007,12.5,\n",
        encoding="utf-8",
    )
    (building,) = load_all(tmp_path)
    assert building.attributes == {"name": "City Hall", "year": 1926, "code": "007", "height": 12.5}


def test_manifest_carries_attributes_for_every_building(tmp_path):
    from exporter.config import Config
    from exporter.manifest import validate_manifest
    from exporter.pipeline import export_tiles

    out = tmp_path / "out"
    export_tiles([REAL / "zurich_lod2.city.json"], out, Config(), jobs=1)
    data = json.loads((REAL / "zurich_lod2.city.json").read_text())
    manifests = list(out.glob("*/lod_manifest.json"))
    records = [r for m in manifests for r in json.loads(m.read_text())["buildings"]]
    assert records
    for manifest in manifests:
        validate_manifest(json.loads(manifest.read_text()))
    for record in records:
        assert record["attributes"] == data["CityObjects"][record["id"]]["attributes"]
