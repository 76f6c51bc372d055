"""Each building tile's own tileset (``OUT/<tile>/tileset.json``, a 3D Tiles external tileset) and
the export's ``tileset.json`` made of tiles only (docs/tileset.md, "Files and tree").

Checked: the top-level tileset references each tile's tileset and holds no building (its size
depends on the tiles, not on the buildings); a re-run with one changed tile rewrites that tile's
tileset alone and reads no building of the others; metadata types that differ between tiles give
the union at the top level and the tile typed otherwise is written again with it."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pytest

from exporter.config import Config, TilesetOptions
from exporter.model import TileId
from exporter.pipeline import export_tiles
from exporter.samplegen import generate_tile
from exporter.tileset import write_tileset
from tests.tileset_check import external_problems, load, structural_problems, tiles_of, walk

TILES = [TileId(15, 279418, 116113), TileId(15, 279419, 116113)]


def make_inputs(root: Path, count: int, seeds=(1, 2)) -> list[Path]:
    """Generated tiles, their files dated an hour back (a re-run trusts their stat: the racy
    rule of exporter.pipeline.input_fingerprints)."""
    folders = [
        generate_tile(root / tile.name, count, seed=seed, tile=tile, atlas_size=64)
        for tile, seed in zip(TILES, seeds)
    ]
    old = time.time() - 3600
    for path in root.rglob("*"):
        os.utime(path, (old, old))
    return folders


@pytest.fixture(scope="module")
def city(tmp_path_factory) -> tuple[Path, list[Path]]:
    root = tmp_path_factory.mktemp("tile_tilesets")
    folders = make_inputs(root / "in", 3)
    export_tiles(folders, root / "out", Config(), jobs=1)
    return root / "out", folders


def top_level_nodes(out: Path) -> list[dict]:
    """Every tile of ``OUT/tileset.json`` itself (external tilesets not followed)."""
    return tiles_of(json.loads((out / "tileset.json").read_text()))


def test_the_top_level_tileset_holds_tiles_and_each_tile_its_buildings(city, tmp_path):
    out, _ = city
    top = json.loads((out / "tileset.json").read_text())
    assert top["schema"]["classes"]["building"]["properties"]
    uris = [t["content"]["uri"] for t in top_level_nodes(out) if "content" in t]
    assert sorted(u for u in uris if u.endswith(".json")) == [
        f"{tile.name}/tileset.json" for tile in TILES
    ]
    assert not any("/lod" in u for u in uris)  # no building level at the top
    for tile in TILES:
        own = json.loads((out / tile.name / "tileset.json").read_text())
        manifest = json.loads((out / tile.name / "lod_manifest.json").read_text())
        ids = {
            t["content"]["metadata"]["properties"]["id"] for t in tiles_of(own) if "content" in t
        }
        assert len(ids) == len(manifest["buildings"]) == 3
        assert "transform" not in own["root"]  # in the tile's frame, the referencing tile's
    tileset = load(out)
    assert structural_problems(out, tileset) == [] and external_problems(out, tileset) == []
    # Three times the buildings per tile: the same top-level tree (tiles and proxies only).
    more = tmp_path / "more"
    export_tiles(make_inputs(tmp_path / "in", 9), more, Config(), jobs=1)
    assert len(top_level_nodes(more)) == len(top_level_nodes(out))
    assert len(walk(load(more))) > len(walk(load(out)))


def test_one_changed_tile_rewrites_its_own_tileset_and_reads_no_other_building(
    city, tmp_path, monkeypatch
):
    from exporter.tileset import tree

    out, folders = city
    again = tmp_path / "out"
    shutil.copytree(out, again)
    changed = make_inputs(tmp_path / "in", 3, seeds=(7, 2))  # the first tile's buildings differ
    assert (changed[1] / "..").resolve() != (folders[1] / "..").resolve()
    shutil.rmtree(changed[1])
    shutil.copytree(folders[1], changed[1])  # the second tile's input as before, same bytes
    inputs = [changed[0], folders[1]]
    unchanged = again / TILES[1].name / "tileset.json"
    before = unchanged.stat().st_mtime_ns
    read: list[str] = []
    real = tree.read_chain  # every building record is read through it (tree.tile_chains)

    def counted(out_dir, tile, record, left_out):
        read.append(tile.name)
        return real(out_dir, tile, record, left_out)

    monkeypatch.setattr(tree, "read_chain", counted)
    export_tiles(inputs, again, Config(), jobs=1)
    assert read and set(read) == {TILES[0].name}
    assert unchanged.stat().st_mtime_ns == before
    assert unchanged.read_bytes() == (out / TILES[1].name / "tileset.json").read_bytes()
    assert (again / TILES[0].name / "tileset.json").read_bytes() != (
        out / TILES[0].name / "tileset.json"
    ).read_bytes()
    fresh = tmp_path / "fresh"
    export_tiles(inputs, fresh, Config(), jobs=1)
    for name in ["tileset.json", "tiles.json"] + [f"{t.name}/tileset.json" for t in TILES]:
        assert (again / name).read_bytes() == (fresh / name).read_bytes(), name


def test_a_changed_tile_s_buildings_are_read_once_for_its_tileset_and_its_leaf_proxy(
    city, tmp_path, monkeypatch
):
    """With a pool the changed tile's leaf proxy starts as soon as its tileset is written, with
    the task made for its summary's key: each of its building records is read once, not again
    for the proxy."""
    from exporter.tileset import tree

    out, folders = city
    again = tmp_path / "out"
    shutil.copytree(out, again)
    changed = make_inputs(tmp_path / "in", 3, seeds=(7, 2))
    shutil.rmtree(changed[1])
    shutil.copytree(folders[1], changed[1])
    read: list[str] = []
    real = tree.read_chain

    def counted(out_dir, tile, record, left_out):
        read.append(f"{tile.name}/{record['folder']}")
        return real(out_dir, tile, record, left_out)

    monkeypatch.setattr(tree, "read_chain", counted)
    run = export_tiles([changed[0], folders[1]], again, Config(), jobs=2)
    assert run.tileset is not None and run.tileset.proxies_built >= 2
    assert read and all(name.startswith(TILES[0].name) for name in read)
    assert sorted(read) == sorted(set(read)), read  # each once


def set_attribute(out: Path, tile: TileId, value) -> None:
    """Give every building of ``tile``'s manifest the attribute ``floors`` = ``value`` (removed
    when None)."""
    path = out / tile.name / "lod_manifest.json"
    manifest = json.loads(path.read_text())
    for record in manifest["buildings"]:
        attributes = record.setdefault("attributes", {})
        attributes.pop("floors", None)
        if value is not None:
            attributes["floors"] = value
    path.write_text(json.dumps(manifest))


def floors(tileset: dict) -> tuple[str | None, list]:
    """The ``floors`` property's type in ``tileset``'s class and its buildings' values (their
    coarsest level's content metadata)."""
    item = tileset["schema"]["classes"]["building"]["properties"].get("floors")
    kind = None if item is None else item.get("componentType") or item["type"]
    tops = [t.get("content", {}).get("metadata") for t in tileset["root"].get("children", [])]
    return kind, [entity["properties"].get("floors") for entity in tops if entity]


def test_types_differing_between_tiles_give_the_union_and_that_tile_is_typed_with_it(
    city, tmp_path
):
    out = tmp_path / "out"
    shutil.copytree(city[0], out)
    options = TilesetOptions(proxies=False)
    own = [out / tile.name / "tileset.json" for tile in TILES]

    set_attribute(out, TILES[0], 3)
    set_attribute(out, TILES[1], "three")
    write_tileset(out, options)
    tileset = load(out)
    assert external_problems(out, tileset) == [] and structural_problems(out, tileset) == []
    assert floors(json.loads((out / "tileset.json").read_text()))[0] == "STRING"
    # The integer tile, STRING on its own only in the union: written again with the union's class.
    assert floors(json.loads(own[0].read_text())) == ("STRING", ["3"] * 3)
    assert floors(json.loads(own[1].read_text())) == ("STRING", ["three"] * 3)
    stamps = [path.stat().st_mtime_ns for path in own]
    write_tileset(out, options)  # nothing changed: no tile's tileset written again
    assert [path.stat().st_mtime_ns for path in own] == stamps

    set_attribute(out, TILES[1], 4)  # the types agree again: the first tile takes its own back
    write_tileset(out, options)
    assert floors(json.loads(own[0].read_text())) == ("INT32", [3] * 3)
    assert floors(json.loads((out / "tileset.json").read_text()))[0] == "INT32"

    set_attribute(out, TILES[1], None)  # only in one tile: the other's class lacks it, as valid
    write_tileset(out, options)
    assert floors(json.loads(own[1].read_text())) == (None, [None] * 3)
    tileset = load(out)
    assert external_problems(out, tileset) == []
    assert floors(json.loads((out / "tileset.json").read_text()))[0] == "INT32"


def test_a_proxy_built_on_a_worker_sends_back_no_per_building_list(city, tmp_path):
    """What comes back to the main process of a proxy is what the tree needs (hash, errors,
    bounds): a parent's record lists every building below it, which stays on disk."""
    from exporter.tileset.proxy import proxy_of
    from exporter.tileset.schedule import PER_BUILDING, build_proxy_record, leaf_task

    out = tmp_path / "out"
    shutil.copytree(city[0], out)
    task = leaf_task(out, TILES[0], TilesetOptions(), Config().textures.jpeg_quality)
    assert task is not None
    (out / "tileset_proxies" / f"{TILES[0].name}.json").unlink()  # built again, not cached
    record = build_proxy_record(task)
    on_disk = json.loads((out / "tileset_proxies" / f"{TILES[0].name}.json").read_text())
    assert len(on_disk["buildings"]) == 3 and on_disk["owners"] and on_disk["values"]
    assert not set(PER_BUILDING) & set(record)
    assert proxy_of(record) == proxy_of(on_disk)


def test_a_tile_holding_buildings_and_a_finer_tile_has_both_under_its_proxy(tmp_path):
    """Inputs of mixed levels: the level-15 tile's proxy node has its own tileset's reference and
    the level-16 tile's proxy as children; its proxy (its buildings read from its manifest, its
    child's proxy) is built once, then taken as it is."""
    coarse = TILES[0]
    fine = TileId(16, 2 * coarse.idx + 1, 2 * coarse.idy)
    folders = [
        generate_tile(tmp_path / "in" / coarse.name, 3, seed=1, tile=coarse, atlas_size=64),
        generate_tile(tmp_path / "in" / fine.name, 2, seed=2, tile=fine, atlas_size=64),
    ]
    out = tmp_path / "out"
    first = export_tiles(folders, out, Config(), jobs=1)
    assert first.tileset is not None and first.tileset.proxies_built == 2
    tileset = load(out)
    assert structural_problems(out, tileset) == [] and external_problems(out, tileset) == []
    root = json.loads((out / "tileset.json").read_text())["root"]
    assert root["content"]["uri"] == f"tileset_proxies/{coarse.name}.glb"
    assert [child["content"]["uri"] for child in root["children"]] == [
        f"{coarse.name}/tileset.json",
        f"tileset_proxies/{fine.name}.glb",
    ]
    proxy = json.loads((out / "tileset_proxies" / f"{coarse.name}.json").read_text())
    assert len(proxy["buildings"]) == 5  # its own three and the finer tile's two
    again = export_tiles(folders, out, Config(), jobs=1)
    assert again.tileset is not None and again.tileset.proxies_built == 0
