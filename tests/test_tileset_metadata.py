"""The buildings' metadata in 3D Tiles 1.1: the tilesets' schema and content metadata, the proxies'
EXT_mesh_features + EXT_structural_metadata (docs/tileset.md "Metadata").

The rules the CesiumGS 3d-tiles-validator applies to them are checked here independently of the
exporter's code: the JSON walked as the 3D Metadata specification says, the proxies' property
tables decoded from their bytes (values, UINT32 string offsets, 8-byte aligned views), every
vertex's feature id resolved to the building whose piece it is."""

from __future__ import annotations

import json
import os
import re
import shlex
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from exporter.config import Config
from exporter.model import TileId
from exporter.pipeline import export_tiles
from exporter.samplegen import generate_tile
from exporter.tileset.features import with_features
from exporter.tileset.metadata import building_values, property_id
from exporter.tileset.proxy import owners_of
from tests.tileset_check import external_problems, load

REAL = Path(__file__).resolve().parent / "data" / "real"
VALIDATOR_BIN = Path(__file__).resolve().parent / "tileset_client" / "node_modules" / ".bin"
TILES = [TileId(15, 279418, 116113), TileId(15, 279419, 116113)]
IDENTIFIER = re.compile(r"^[a-zA-Z_][a-zA-Z0-9_]*$")
TYPES = {"STRING": str, "BOOLEAN": bool}
RANGES = {"INT32": (-(2**31), 2**31 - 1), "INT64": (-(2**63), 2**63 - 1)}


def glb_parts(path: Path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    json_length = struct.unpack_from("<I", data, 12)[0]
    document = json.loads(data[20 : 20 + json_length])
    blob_length = struct.unpack_from("<I", data, 20 + json_length)[0]
    return document, data[28 + json_length : 28 + json_length + blob_length]


def view_bytes(document: dict, blob: bytes, index: int) -> bytes:
    view = document["bufferViews"][index]
    assert view["byteOffset"] % 8 == 0  # EXT_structural_metadata: 8-byte aligned
    return blob[view["byteOffset"] : view["byteOffset"] + view["byteLength"]]


def check_value(value, item: dict) -> None:
    """A metadata entity's JSON value against its class property (3D Metadata spec)."""
    kind = item.get("componentType") or item["type"]
    if kind in TYPES:
        assert isinstance(value, TYPES[kind]), (value, item)
    elif kind in RANGES:
        assert isinstance(value, int) and not isinstance(value, bool), (value, item)
        assert RANGES[kind][0] <= value <= RANGES[kind][1]
    else:
        assert kind == "FLOAT64" and isinstance(value, (int, float)) and not isinstance(value, bool)


def property_table(path: Path) -> tuple[np.ndarray, list[dict]]:
    """(per-vertex feature ids, one dict of decoded values per row) of a proxy .glb."""
    document, blob = glb_parts(path)
    assert {"EXT_mesh_features", "EXT_structural_metadata"} <= set(document["extensionsUsed"])
    (primitive,) = document["meshes"][0]["primitives"]
    (feature_ids,) = primitive["extensions"]["EXT_mesh_features"]["featureIds"]
    accessor = document["accessors"][primitive["attributes"]["_FEATURE_ID_0"]]
    assert accessor["type"] == "SCALAR" and accessor["componentType"] == 5126
    position = document["accessors"][primitive["attributes"]["POSITION"]]
    assert accessor["count"] == position["count"]
    view = document["bufferViews"][accessor["bufferView"]]
    ids = np.frombuffer(blob, "<f4", accessor["count"], view["byteOffset"])
    assert np.all(ids == np.round(ids))
    metadata = document["extensions"]["EXT_structural_metadata"]
    (table,) = metadata["propertyTables"]
    assert feature_ids["propertyTable"] == 0 and feature_ids["featureCount"] == table["count"]
    properties = metadata["schema"]["classes"][table["class"]]["properties"]
    rows: list[dict] = [{} for _ in range(table["count"])]
    for pid, column in table["properties"].items():
        assert IDENTIFIER.match(pid)
        item = properties[pid]
        kind = item.get("componentType") or item["type"]
        data = view_bytes(document, blob, column["values"])
        if kind == "STRING":
            assert column["stringOffsetType"] == "UINT32"
            offsets = np.frombuffer(view_bytes(document, blob, column["stringOffsets"]), "<u4")
            assert len(offsets) == table["count"] + 1 and np.all(np.diff(offsets.astype(int)) >= 0)
            values = [data[a:b].decode("utf-8") for a, b in zip(offsets[:-1], offsets[1:])]
        elif kind == "BOOLEAN":
            bits = np.unpackbits(np.frombuffer(data, np.uint8), bitorder="little")
            values = [bool(b) for b in bits[: table["count"]]]
        else:
            dtype = {"INT32": "<i4", "INT64": "<i8", "FLOAT64": "<f8"}[kind]
            values = np.frombuffer(data, dtype).tolist()
            assert len(values) == table["count"]
        for row, value in zip(rows, values):
            if "noData" not in item or value != item["noData"]:
                row[item.get("name", pid)] = value
    return ids.astype(np.int64), rows


def check_tileset(out: Path) -> tuple[dict, dict]:
    """tileset.json's schema and content metadata (its tiles' own tilesets resolved: tests/tileset_check.py)
    against the manifests; returns (the resolved tileset, records by '<tile>/<id>')."""
    tileset = load(out)
    assert external_problems(out, tileset) == []
    records = {
        f"{m.parent.name}/{r['id']}": r
        for m in out.glob("*/lod_manifest.json")
        for r in json.loads(m.read_text())["buildings"]
    }
    schema = tileset["schema"]
    properties = schema["classes"]["building"]["properties"]
    assert IDENTIFIER.match(schema["id"])
    assert {"id", "source_id", "source_file", "height"} <= set(properties)
    assert all(IDENTIFIER.match(pid) for pid in properties)
    assert "groups" not in tileset  # content metadata: CesiumJS reads it in external tilesets
    seen: dict[str, dict] = {}  # building key -> its entity

    def visit(tile: dict, entity: dict | None) -> None:
        content = tile.get("content")
        if content is not None:
            uri = content["uri"]
            if uri.startswith("tileset_proxies/"):
                assert "metadata" not in content
            else:
                found = content["metadata"]
                key = f"{uri.split('/')[0]}/{found['properties']['id']}"
                assert uri.startswith(f"{key.split('/')[0]}/{records[key]['folder']}/")
                assert entity is None or entity == found  # one building per chain
                entity = found
                seen[key] = found
        for child in tile.get("children", []):
            visit(child, entity if content is not None and "metadata" in content else None)

    visit(tileset["root"], None)
    assert set(seen) == set(records)
    for entity in seen.values():
        assert entity["class"] == "building"
        for pid, value in entity["properties"].items():
            check_value(value, properties[pid])
        for pid, item in properties.items():
            assert pid in entity["properties"] or not item.get("required")
    for key, record in records.items():
        values = seen[key]["properties"]
        for name, value in record.get("attributes", {}).items():
            pid = property_id(name)
            assert properties[pid]["name"] == name
            assert values[pid] == value or str(values[pid]) == json.dumps(value), (name, value)
    return tileset, records


def check_proxies(out: Path, records: dict) -> int:
    """Every proxy's feature ids resolve, vertex by vertex, to the building that vertex came from
    (the proxy record's ``owners``, run-length over its ``buildings``); returns the number of
    proxies checked."""
    proxies = sorted((out / "tileset_proxies").glob("*.glb"))
    for path in proxies:
        ids, rows = property_table(path)
        record = json.loads(path.with_suffix(".json").read_text())
        owners = owners_of(record["owners"], len(ids))
        assert np.array_equal(ids, owners)
        assert len(rows) == len(record["buildings"])
        for row, key in zip(rows, record["buildings"]):
            assert row["id"] == records[key]["id"]
            for name, value in records[key].get("attributes", {}).items():
                assert row[name] == value or row[name] == json.dumps(value)
    return len(proxies)


@pytest.fixture(scope="module")
def two_tiles(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("meta")
    folders = [
        generate_tile(root / "in" / t.name, 4, seed=i, tile=t, atlas_size=64)
        for i, t in enumerate(TILES)
    ]
    export_tiles(folders, root / "out", Config(), jobs=1)
    return root / "out"


def test_vworld_tiles_metadata_and_a_proxy_of_proxies_keeps_every_building(two_tiles):
    _, records = check_tileset(two_tiles)
    assert check_proxies(two_tiles, records) == 3  # two tile proxies and the one above them
    above = json.loads((two_tiles / "tileset_proxies" / "14_139709_58056.json").read_text())
    assert len(above["buildings"]) == 8


def test_cityjson_attributes_reach_the_tileset_and_the_proxies(tmp_path):
    out = tmp_path / "out"
    export_tiles([REAL / "zurich_lod2.city.json"], out, Config(), jobs=1)
    tileset, records = check_tileset(out)
    properties = tileset["schema"]["classes"]["building"]["properties"]
    assert properties["QualitaetStatus"].get("componentType") == "INT32"
    assert properties["Herkunft"]["type"] == "STRING"
    assert check_proxies(out, records) >= 1


@pytest.mark.parametrize(
    "source",
    [
        REAL / "citygml" / "house_and_garage_lod2.gml",
        Path(__file__).resolve().parents[1] / "samples" / "15_279418_116113",
    ],
    ids=["citygml", "sample_tile"],
)
def test_citygml_and_the_sample_tile_attributes_reach_the_tileset_and_the_proxies(source, tmp_path):
    out = tmp_path / "out"
    export_tiles([source], out, Config(), jobs=1)
    _, records = check_tileset(out)
    assert all(record["attributes"] for record in records.values())
    assert check_proxies(out, records) >= 1


def test_a_missing_value_is_no_data_and_a_partly_missing_boolean_is_text(tmp_path):
    from exporter.gltf_writer import glb_bytes
    from exporter.model import Part

    part = Part(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]))
    records = [
        building_values("a", "x/a.gml", 3.0, {"flag": True, "year": 1990, "name": "Ä"}),
        building_values("b", "x/b.gml", 4.0, {"address.city": "Zürich"}),
    ]
    path = tmp_path / "p.glb"
    path.write_bytes(with_features(glb_bytes([part], "p"), np.array([0, 1, 1]), records))
    ids, rows = property_table(path)
    assert ids.tolist() == [0, 1, 1]
    assert rows[0] == {
        "id": "a",
        "source_id": "a",
        "source_file": "a.gml",
        "height": 3.0,
        "flag": "true",
        "year": 1990,
        "name": "Ä",
    }
    assert rows[1] == {
        "id": "b",
        "source_id": "b",
        "source_file": "b.gml",
        "height": 4.0,
        "address.city": "Zürich",
    }
    with pytest.raises(ValueError, match="feature ids"):
        with_features(glb_bytes([part], "p"), np.array([0, 2, 1]), records)


def test_property_ids_are_identifiers_and_keep_the_name():
    assert property_id("year") == "year"
    for name in ("address.city", "id", "2nd", "Höhe", "gen:x"):
        pid = property_id(name)
        assert IDENTIFIER.match(pid) and pid != name
    assert property_id("a.b") != property_id("a_b")


def validator_command() -> list[str] | None:
    """The CesiumGS 3d-tiles-validator: ``$VWORLD_LOD_3DTILES_VALIDATOR`` (a command line, e.g.
    ``npx ts-node --transpile-only <checkout>/src/main.ts``) or an npm install beside the
    CesiumJS client."""
    if os.environ.get("VWORLD_LOD_3DTILES_VALIDATOR"):
        return shlex.split(os.environ["VWORLD_LOD_3DTILES_VALIDATOR"])
    found = VALIDATOR_BIN / "3d-tiles-validator"
    return [str(found)] if found.exists() else None


@pytest.mark.slow
@pytest.mark.skipif(
    validator_command() is None,
    reason="CesiumGS 3d-tiles-validator not installed (the npm registry reached here lacks it): "
    "`npm install 3d-tiles-validator` with overrides 3d-tiles-tools 0.5.3 and sharp ^0.33.5 in "
    "tests/tileset_client, or set VWORLD_LOD_3DTILES_VALIDATOR to a command running one",
)
def test_the_cesium_3d_tiles_validator_reports_no_error(two_tiles, tmp_path):
    tilesets = [two_tiles / "tileset.json"]
    for number, source in enumerate(
        [REAL / "citygml" / "berlin_3880_5819.gml", REAL / "zurich_lod2.city.json"]
    ):
        export_tiles([source], tmp_path / f"out{number}", Config(), jobs=1)
        tilesets.append(tmp_path / f"out{number}" / "tileset.json")
    command = validator_command()
    assert command is not None
    for tileset in tilesets:
        report_file = tmp_path / "report.json"
        subprocess.run(
            [*command, "--tilesetFile", str(tileset), "--reportFile", str(report_file)],
            capture_output=True,
            text=True,
            timeout=600,
            cwd=command[-1].rsplit("/src/", 1)[0] if "/src/" in command[-1] else None,
        )
        report = json.loads(report_file.read_text())
        assert report["numErrors"] == 0 and report["numWarnings"] == 0, json.dumps(report)[:4000]
