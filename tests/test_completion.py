"""A tile's manifest and leaf proxy made as soon as its buildings are done (issue 37, overlap):
when a tile completes (exporter/completion.py), what its manifest lists as skipped, the early
proxies' records taken by the tileset, and an export whose first tile's proxy starts before the
last building is done, with the same bytes as a run without overlap."""

from __future__ import annotations

import json
import random
import shutil
from pathlib import Path

import pytest

from exporter import pipeline
from exporter.completion import TileCompletion, known_tile, tile_skips
from exporter.config import Config, TilesetOptions
from exporter.model import Skipped, TileId
from exporter.samplegen import generate_tile
from exporter.tileset import schedule
from exporter.tileset.tree import quadtree, read_buildings

A, B, C = TileId(15, 1, 1), TileId(15, 2, 1), TileId(15, 3, 1)


def test_a_tile_completes_when_its_last_result_comes_back_in_any_order():
    entries = [(f"a{i}", A) for i in range(3)] + [(f"b{i}", B) for i in range(2)] + [("c0", C)]
    for seed in range(20):
        order = list(entries)
        random.Random(seed).shuffle(order)
        tracker = TileCompletion(entries)
        seen: list[TileId] = []
        for index, (entry_id, tile) in enumerate(order):
            completed = tracker.done(entry_id, tile)
            last = max(i for i, (_, t) in enumerate(order) if t == tile)
            assert completed == ([tile] if index == last else []), (seed, index)
            seen += completed
        assert sorted(seen, key=lambda t: t.idx) == [A, B, C]


def test_a_failed_building_counts_for_its_tile():
    tracker = TileCompletion([("a0", A), ("a1", A)])
    assert tracker.done("a0", A) == []  # a skipped building's result carries its entry's tile
    assert tracker.done("a1", A) == [A]


def test_no_tile_completes_before_every_entry_of_unknown_tile_is_done():
    # Entries of CityJSON, CityGML or OBJ/glTF land where their geometry is, known once read.
    tracker = TileCompletion([("a0", A), ("x", None), ("y", None), ("b0", B)])
    assert tracker.done("a0", A) == []
    assert tracker.done("x", C) == []  # landed in C: no entry known to go there
    assert tracker.done("b0", B) == []
    # The last unknown entry (a skip without a tile) completes every tile with nothing pending.
    assert tracker.done("y", None) == [A, B, C]


def test_tiles_with_known_entries_left_wait_for_them_after_the_unknown_ones():
    tracker = TileCompletion([("x", None), ("a0", A), ("a1", A)])
    assert tracker.done("a0", A) == []
    assert tracker.done("x", A) == []  # an unknown entry landed in A too; a1 still pending
    assert tracker.done("a1", A) == [A]


def test_a_contradicting_result_stops_early_completion():
    tracker = TileCompletion([("a0", A), ("b0", B), ("c0", C)])
    assert tracker.done("a0", B) == []  # known to go to A, came back in B
    assert tracker.done("b0", B) == [] and tracker.done("c0", C) == []
    tracker = TileCompletion([("a0", A), ("c0", C)])
    assert tracker.done("never listed", A) == []
    assert tracker.done("a0", A) == [] and tracker.done("c0", C) == []


def test_only_vworld_entries_have_a_known_tile():
    assert known_tile("vworld", A) == A
    for name in ("cityjson", "citygml", "folder"):
        assert known_tile(name, A) is None


def test_a_tiles_skips_in_the_order_the_end_of_the_run_writes_them():
    scanned = {A: [Skipped("s.dat", "unreadable", None, A)], None: [Skipped("x", "no tile")]}
    failed = [
        Skipped("b", "bad", "e3", A),
        Skipped("z", "bad", "e4", None),
        Skipped("other", "bad", "e1", B),
        Skipped("a", "bad", "e0", A),
        Skipped("y", "bad", "e2", None),
    ]
    order = {f"e{i}": i for i in range(5)}
    sources = [item.source for item in tile_skips(A, scanned, failed, order)]
    assert sources == ["s.dat", "a", "b", "x", "y", "z"]
    assert [item.source for item in tile_skips(B, scanned, failed, order)] == [
        "other",
        "x",
        "y",
        "z",
    ]


# --------------------------------------------------------------------------- exports

TILES = [TileId(15, 279416, 116112), TileId(15, 279417, 116112), TileId(15, 279418, 116112)]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> list[Path]:
    root = tmp_path_factory.mktemp("overlap")
    return [
        generate_tile(root / t.name, 6, seed=i, tile=t, atlas_size=64, mean_triangles=80)
        for i, t in enumerate(TILES)
    ]


def files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def test_a_tiles_leaf_proxy_starts_before_the_last_building_and_the_bytes_stay(
    inputs, tmp_path, monkeypatch
):
    plain = tmp_path / "plain"
    stats = pipeline.export_tiles(inputs, plain, Config(), jobs=1)  # no overlap with one job
    assert stats.tileset is not None and stats.tileset.proxies_built == 5  # 3 leaves, 2 parents

    events: list[tuple] = []
    start = schedule.LeafProxies.start

    def recorded_start(self, tile, known_key=None, task=None):
        started = start(self, tile, known_key, task)
        events.append(("proxy", tile, started))
        return started

    monkeypatch.setattr(schedule.LeafProxies, "start", recorded_start)

    def progress(done, total):
        if done == total:
            events.append(("last building",))

    out = tmp_path / "overlap"
    stats = pipeline.export_tiles(inputs, out, Config(), jobs=2, progress=progress)
    last = events.index(("last building",))
    assert ("proxy", TILES[0], True) in events[:last]  # started while buildings were being made
    assert {e[1] for e in events if e[0] == "proxy"} == set(TILES)
    assert stats.tileset is not None and stats.tileset.proxies_built == 5  # none built twice
    assert files(out) == files(plain)

    # A re-run finds every proxy as it was (none started), from the tiles' summaries: no tile's
    # buildings are read again to find its proxy's key; --force builds each once.
    events.clear()
    read: list[TileId] = []
    leaf_task = schedule.leaf_task

    def counted_leaf_task(out_dir, tile, options, quality):
        read.append(tile)
        return leaf_task(out_dir, tile, options, quality)

    monkeypatch.setattr(schedule, "leaf_task", counted_leaf_task)
    stats = pipeline.export_tiles(inputs, out, Config(), jobs=2)
    assert stats.tileset is not None and stats.tileset.proxies_built == 0
    assert [e[2] for e in events] == [False] * 3
    assert read == []
    stats = pipeline.export_tiles(inputs, out, Config(), jobs=2, force=True)
    assert stats.tileset is not None and stats.tileset.proxies_built == 5
    assert files(out) == files(plain)


def test_the_leaf_task_of_a_manifest_is_the_tilesets_own(inputs, tmp_path):
    out = tmp_path / "out"
    pipeline.export_tiles(inputs[:1], out, Config(), jobs=1)
    options = TilesetOptions()
    task = schedule.leaf_task(out, TILES[0], options, 85)
    by_tile, _ = read_buildings(out)
    tree_task = schedule._task(out, quadtree(by_tile)[0], options, 85)
    assert task is not None and tree_task is not None and task.key == tree_task.key
    # One unusable record leaves out that building only, as the tile's own tileset does.
    path = out / TILES[0].name / "lod_manifest.json"
    manifest = json.loads(path.read_text(encoding="utf-8"))
    manifest["buildings"][0] = "not a record"
    path.write_text(json.dumps(manifest), encoding="utf-8")
    chains = schedule.manifest_chains(out, TILES[0])
    assert chains is not None and len(chains) == len(manifest["buildings"]) - 1
    path.write_text("{", encoding="utf-8")
    assert schedule.leaf_task(out, TILES[0], options, 85) is None  # left to the tileset


def test_an_early_proxy_that_failed_is_reported_and_its_tile_shown_without(inputs, tmp_path):
    out = tmp_path / "out"
    pipeline.export_tiles(inputs[:2], out, Config(), jobs=1)
    shutil.rmtree(out / "tileset_proxies")
    options = TilesetOptions()
    key = schedule.leaf_task(out, TILES[0], options, 85).key  # type: ignore[union-attr]
    problem = "tileset_proxies/15_279416_116112.glb: not built (OSError()); tile shown without"
    by_tile, problems = read_buildings(out)
    tops = quadtree(by_tile)
    placed, built = schedule.add_proxies(
        out, tops, options, 85, problems, early={key: {"problem": problem}}
    )
    assert problems == [problem]
    assert (placed, built) == (1, 2)  # the other leaf; no parent above a tile without proxy
    assert not (out / "tileset_proxies" / f"{TILES[0].name}.glb").exists()  # not built again


def test_a_tile_with_a_finer_tile_below_it_waits_for_the_tileset(inputs, tmp_path):
    out = tmp_path / "out"
    pipeline.export_tiles(inputs[:1], out, Config(), jobs=1)
    shutil.rmtree(out / "tileset_proxies")

    class Here:
        def submit(self, function, item, out_dir):
            raise AssertionError("no proxy to start")

    below = TileId(16, 2 * TILES[0].idx + 1, 2 * TILES[0].idy)
    leaves = schedule.LeafProxies(out, TilesetOptions(), 85, False, Here(), {TILES[0], below})
    assert leaves.start(TILES[0]) is False  # in the tree it has the level-16 tile as a child
    assert leaves.records() == {}


def test_broken_buildings_are_listed_as_without_overlap(inputs, tmp_path):
    root = tmp_path / "in"
    folders = []
    for folder in inputs:
        shutil.copytree(folder, root / folder.name)
        folders.append(root / folder.name)
    for folder in (folders[0], folders[2]):  # two unreadable buildings in two tiles
        for model in sorted(folder.glob("*.xdo"))[1:3]:
            model.write_bytes(b"\x00" * 7)
    plain = pipeline.export_tiles(folders, tmp_path / "plain", Config(), jobs=1)
    overlap = pipeline.export_tiles(folders, tmp_path / "overlap", Config(), jobs=2)
    assert plain.skipped == overlap.skipped == 4
    manifest = json.loads((tmp_path / "overlap" / TILES[0].name / "lod_manifest.json").read_text())
    assert len(manifest["skipped"]) == 2
    assert files(tmp_path / "overlap") == files(tmp_path / "plain")
