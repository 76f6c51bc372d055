"""The export's tile index (``OUT/tiles.json``): complete across runs, schema-valid, atomic."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from exporter.config import GlobeOptions
from exporter.model import TileId
from exporter.tile_index import INDEX_NAME, build_index, validate_index, write_tile_index
from exporter.tiles import tile_bounds, tile_center


def fake_manifest(out: Path, tile: TileId, buildings: int) -> Path:
    """Just enough of a manifest for the index: the file exists and has ``summary.buildings``."""
    path = out / tile.name / "lod_manifest.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    globe = {"earth_radius_m": 6378137.0, "unity_radius": 1000.0}
    path.write_text(
        json.dumps({"summary": {"buildings": buildings}, "globe": globe}), encoding="utf-8"
    )
    return path


class Result:  # the two fields of exporter.pipeline.TileResult the index reads
    def __init__(self, tile: TileId, buildings: int):
        self.tile, self.buildings = tile, buildings


A, B, C = TileId(15, 279418, 116113), TileId(15, 279419, 116113), TileId(14, 139709, 58056)


def test_index_lists_every_tile_with_a_manifest_in_order_with_bounds_and_centre(tmp_path):
    fake_manifest(tmp_path, B, 3)
    fake_manifest(tmp_path, A, 5)
    fake_manifest(tmp_path, C, 1)
    (tmp_path / "15_1_1").mkdir()  # a tile folder whose manifest is not written (yet)
    (tmp_path / "notes").mkdir()  # not a tile
    path = write_tile_index(tmp_path, [Result(A, 5)], GlobeOptions(unity_radius=500.0))
    index = json.loads(path.read_text(encoding="utf-8"))
    validate_index(index)
    assert [t["name"] for t in index["tiles"]] == [C.name, A.name, B.name]  # (level, idx, idy)
    by_name = {t["name"]: t for t in index["tiles"]}
    assert by_name[B.name]["buildings"] == 3 and by_name[A.name]["buildings"] == 5
    west, south, east, north = tile_bounds(A)
    assert by_name[A.name]["bounds"] == {"west": west, "south": south, "east": east, "north": north}
    lon, lat = tile_center(A)
    assert by_name[A.name]["center"] == {"lon": lon, "lat": lat, "elev": 0.0}
    assert by_name[A.name]["manifest"] == f"{A.name}/lod_manifest.json"
    # The run's radii for its tiles; the others' from their manifests.
    assert by_name[A.name]["globe"] == {"earth_radius_m": 6378137.0, "unity_radius": 500.0}
    assert by_name[B.name]["globe"] == {"earth_radius_m": 6378137.0, "unity_radius": 1000.0}
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def test_a_second_run_keeps_the_tiles_of_the_first_and_rereads_newer_manifests(tmp_path):
    fake_manifest(tmp_path, A, 5)
    write_tile_index(tmp_path, [Result(A, 5)])
    fake_manifest(tmp_path, B, 2)  # another run, into the same OUT
    index = json.loads(write_tile_index(tmp_path, [Result(B, 2)]).read_text())
    assert {t["name"]: t["buildings"] for t in index["tiles"]} == {A.name: 5, B.name: 2}

    # A manifest rewritten after the index (e.g. by an older exporter) is read again.
    manifest = fake_manifest(tmp_path, A, 9)
    later = (tmp_path / INDEX_NAME).stat().st_mtime_ns + 10**9
    os.utime(manifest, ns=(later, later))
    assert {t["name"]: t["buildings"] for t in build_index(tmp_path)["tiles"]}[A.name] == 9

    # A tile whose manifest is gone leaves the index; a broken manifest is not listed.
    (tmp_path / A.name / "lod_manifest.json").unlink()
    (tmp_path / B.name / "lod_manifest.json").write_text("{broken", encoding="utf-8")
    assert build_index(tmp_path)["tiles"] == []


def test_the_pipeline_writes_the_index_after_the_manifests(tmp_path):
    from exporter.config import Config
    from exporter.pipeline import export_tiles
    from exporter.samplegen import generate_tile

    source = tmp_path / "src" / A.name
    generate_tile(source, count=2, seed=5, tile=A, atlas_size=32, mean_triangles=40)
    out = tmp_path / "out"
    fake_manifest(out, B, 4)  # a tile from an earlier run stays listed
    stats = export_tiles([source], out, Config(), jobs=1)
    index = json.loads((out / INDEX_NAME).read_text(encoding="utf-8"))
    validate_index(index)
    manifest = json.loads((out / A.name / "lod_manifest.json").read_text(encoding="utf-8"))
    listed = {t["name"]: t for t in index["tiles"]}
    assert set(listed) == {A.name, B.name}
    assert listed[A.name]["buildings"] == manifest["summary"]["buildings"] == stats.buildings
    assert listed[A.name]["center"]["lon"] == pytest.approx(manifest["tile"]["center"]["lon"])
    assert listed[A.name]["globe"] == {
        k: manifest["globe"][k] for k in ("earth_radius_m", "unity_radius")
    }
