"""Re-runs into a full OUT (issue 37, "Incremental"): each tile's summary (``.tile_records.json``,
exporter/records.py) lets an unchanged tile be recognised without reading its buildings' record
files, with every check the reuse had: inputs' stat/sha256 and the config, output files' size and
CRC-32, the record file itself; anything else falls back to the record files."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pytest

import exporter.pipeline as pipeline
from exporter.config import Config
from exporter.model import TileId
from exporter.records import SUMMARY_NAME

TILES = (TileId(15, 279418, 116112), TileId(15, 279418, 116113))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> list[Path]:
    from exporter.samplegen import generate_tile

    root = tmp_path_factory.mktemp("in")
    folders = []
    for n, tile in enumerate(TILES):
        folder = generate_tile(
            root / tile.name, count=4, seed=n, tile=tile, atlas_size=64, mean_triangles=120
        )
        old = time.time() - 3600  # out of the racy window: their stat is trusted on re-runs
        for path in folder.iterdir():
            os.utime(path, (old, old))
        folders.append(folder)
    return folders


def export(folders, out: Path, config: Config | None = None, **options) -> pipeline.RunStats:
    return pipeline.export_tiles(folders, out, config or Config(), jobs=1, **options)


def tree(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file()}


@pytest.fixture
def reads(monkeypatch) -> list[str]:
    """Paths of the building record files the pipeline parses (all three readers)."""
    seen: list[str] = []
    for name in ("read_record", "manifest_record"):
        real = getattr(pipeline, name)
        monkeypatch.setattr(
            pipeline, name, lambda path, real=real: seen.append(str(path)) or real(path)
        )
    return seen


def test_an_unchanged_rerun_reads_no_record_and_rewrites_nothing(inputs, tmp_path, reads):
    out = tmp_path / "out"
    export(inputs, out)
    assert all((out / tile.name / SUMMARY_NAME).is_file() for tile in TILES)
    before = {p: p.stat().st_mtime_ns for p in out.glob("*/*") if p.is_file()}
    reads.clear()
    again = export(inputs, out)
    assert again.reused == again.buildings == 8
    assert reads == []
    # The manifests and summaries are left as they were (no rewrite, no fsync).
    assert {p: p.stat().st_mtime_ns for p in out.glob("*/*") if p.is_file()} == before
    fresh = tmp_path / "fresh"
    export(inputs, fresh)
    assert tree(out) == tree(fresh)  # summaries included: no time in their bytes


def test_one_changed_tile_reads_only_its_own_records(inputs, tmp_path, reads):
    from exporter.samplegen import generate_tile

    out = tmp_path / "out"
    export(inputs, out)
    changed = generate_tile(
        tmp_path / "changed" / TILES[1].name, 4, seed=9, tile=TILES[1], atlas_size=64
    )
    reads.clear()
    run = export([inputs[0], changed], out)
    assert run.reused == 4 and run.buildings == 8
    assert reads and all(f"/{TILES[1].name}/" in path for path in reads)
    fresh = tmp_path / "fresh"
    export([inputs[0], changed], fresh)
    assert tree(out) == tree(fresh)


def test_what_changed_goes_to_the_workers_before_unchanged_files_are_read_back(
    inputs, tmp_path, monkeypatch
):
    """The changed tile comes last in entry order; its buildings are handed out first, so the
    workers make them while this process checks the unchanged buildings (their inputs, their
    files read back). The first task goes out after one check per tile (its first building),
    not after every unchanged building's check."""
    from exporter.samplegen import generate_tile

    out = tmp_path / "out"
    export(inputs, out)
    changed = generate_tile(
        tmp_path / "changed" / TILES[1].name, 4, seed=9, tile=TILES[1], atlas_size=64
    )
    order: list[str] = []
    results, intact = pipeline._results, pipeline.files_intact

    def recorded(work, jobs, total=0, idle=(), after_work=None):
        def seen(items):
            for item in items:
                order.append("reused" if isinstance(item, pipeline.EntryResult) else "task")
                yield item

        return results(seen(work), jobs, total, seen(idle), after_work)

    def checked(folder, files, unchanged_before=None):
        order.append("read back")
        return intact(folder, files, unchanged_before)

    def fingerprinted(names, known):
        order.append("check")
        return fingerprints(names, known)

    fingerprints = pipeline.input_fingerprints
    monkeypatch.setattr(pipeline, "_results", recorded)
    monkeypatch.setattr(pipeline, "files_intact", checked)
    monkeypatch.setattr(pipeline, "input_fingerprints", fingerprinted)
    run = export([inputs[0], changed], out)
    assert run.reused == 4 and run.buildings == 8
    # a look at the unchanged tile's first building (the changed tile's, from another folder,
    # has no earlier output to compare), then the changed tile's buildings (before any file is
    # read back), then the unchanged tile's
    expected = ["check"] + ["check", "task"] * 4 + ["check", "read back", "reused"] * 4
    assert order == expected, order


def test_a_changed_tile_s_ancestors_are_built_while_the_unchanged_tiles_are_confirmed(
    inputs, tmp_path, monkeypatch
):
    """With a pool: the changed tile's buildings first, alone (no check of the unchanged tile
    beside them), then its ancestors' proxies are built ahead while the unchanged tile is
    confirmed; the tileset takes them (counted as built) and the output is a fresh export's."""
    import exporter.tileset as tileset
    from exporter.samplegen import generate_tile

    out = tmp_path / "out"
    pipeline.export_tiles(inputs, out, Config(), jobs=2)
    changed = generate_tile(
        tmp_path / "changed" / TILES[1].name, 4, seed=9, tile=TILES[1], atlas_size=64
    )
    order: list[str] = []
    results, prebuild = pipeline._results, tileset.prebuild_proxies

    def recorded(work, jobs, total=0, idle=(), after_work=None):
        def seen(items, kind):
            for item in items:
                order.append(kind)
                yield item

        def started():
            order.append("ahead")
            assert after_work is not None
            after_work()

        then = started if after_work is not None else None
        return results(seen(work, "work"), jobs, total, seen(idle, "idle"), then)

    ahead: list[dict] = []

    def built(*args):
        ahead.append(prebuild(*args))
        return ahead[-1]

    monkeypatch.setattr(pipeline, "_results", recorded)
    monkeypatch.setattr(tileset, "prebuild_proxies", built)
    run = pipeline.export_tiles([inputs[0], changed], out, Config(), jobs=2)
    assert run.reused == 4 and run.buildings == 8
    assert order == ["work"] * 4 + ["ahead"] + ["idle"] * 4, order
    # the two tiles' parent (the root) was built ahead, from the changed tile's new leaf
    assert len(ahead) == 1 and len(ahead[0]) == 1, ahead
    assert run.tileset is not None and run.tileset.proxies_built == 2  # leaf and parent
    fresh = tmp_path / "fresh"
    order.clear()
    pipeline.export_tiles([inputs[0], changed], fresh, Config(), jobs=2)
    assert "ahead" not in order  # a first export: nothing to build ahead
    assert tree(out) == tree(fresh)


def test_files_unchanged_since_their_summary_are_not_read_back(inputs, tmp_path, monkeypatch):
    """Their inode's ctime is older than the summary's: only their size is checked. A file
    changed since (any write or utime sets its ctime) is read back (next test)."""
    import exporter.records as records

    out = tmp_path / "out"
    export(inputs, out)
    # Files written in the summary's clock tick (a few ms) are read back, to be safe; here the
    # summaries' ctimes are moved a tick on, as a later run writing only them would.
    time.sleep(0.05)
    for tile in TILES:
        path = out / tile.name / SUMMARY_NAME
        stat = path.stat()
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    sums: list[int] = []
    real = records.crc32
    monkeypatch.setattr(records, "crc32", lambda data: sums.append(len(data)) or real(data))
    run = export(inputs, out)
    assert run.reused == 8 and sums == []


def test_a_damaged_output_file_still_makes_its_building_redone(inputs, tmp_path):
    out = tmp_path / "out"
    export(inputs, out)
    good = tree(out)
    lod1 = sorted((out / TILES[0].name).glob("*/lod1.glb"))[0]
    stat = lod1.stat()
    data = bytearray(lod1.read_bytes())
    data[len(data) // 2] ^= 0xFF
    lod1.write_bytes(bytes(data))  # same size, its old times put back: only the CRC-32 sees it
    os.utime(lod1, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    run = export(inputs, out)
    assert run.reused == 7 and run.buildings == 8
    assert tree(out) == good


@pytest.mark.parametrize("damage", ["truncated", "removed"])
def test_a_damaged_record_file_makes_its_building_redone(inputs, tmp_path, damage):
    out = tmp_path / "out"
    export(inputs, out)
    good = tree(out)
    record = sorted((out / TILES[0].name).glob("*/building.json"))[0]
    if damage == "removed":
        record.unlink()
    else:
        record.write_bytes(record.read_bytes()[:-10])
    run = export(inputs, out)
    assert run.reused == 7 and run.buildings == 8
    assert tree(out) == good


def test_a_touched_input_with_the_same_bytes_is_reused_and_its_new_stat_kept(
    inputs, tmp_path, reads, monkeypatch
):
    folders = [tmp_path / "in" / f.name for f in inputs]
    for source, copy in zip(inputs, folders):
        shutil.copytree(source, copy)  # copystat: the inputs' old times are kept
    out = tmp_path / "out"
    export(folders, out)
    hashed: list[str] = []
    real_sha = pipeline._sha256_file
    monkeypatch.setattr(pipeline, "_sha256_file", lambda n: hashed.append(n) or real_sha(n))
    jpg = sorted(folders[0].glob("*.jpg"))[0]
    os.utime(jpg, (time.time() - 1800, time.time() - 1800))
    reads.clear()
    run = export(folders, out)
    assert run.reused == 8 and hashed == [str(jpg)]
    # Its buildings' records got the new stat (read for it), no other tile's was read.
    assert reads and all(f"/{TILES[0].name}/" in path for path in reads)
    summary = json.loads((out / TILES[0].name / SUMMARY_NAME).read_text())
    stats = [i for b in summary["buildings"] for i in b["inputs"] if i["path"] == str(jpg)]
    assert stats and all(i["mtime_ns"] == jpg.stat().st_mtime_ns for i in stats)
    hashed.clear()
    reads.clear()
    assert export(folders, out).reused == 8 and hashed == [] and reads == []


def test_an_edited_input_is_redone_and_an_added_or_deleted_one_too(inputs, tmp_path):
    folders = [tmp_path / "in" / f.name for f in inputs]
    for source, copy in zip(inputs, folders):
        shutil.copytree(source, copy)
    out = tmp_path / "out"
    export(folders, out)
    xdo = sorted(folders[0].glob("*.xdo"))[0]
    data = bytearray(xdo.read_bytes())
    data[-5] ^= 0x01  # a vertex coordinate's low bit: same size
    xdo.write_bytes(bytes(data))
    run = export(folders, out)
    assert run.reused == 7 and run.buildings == 8
    fresh = tmp_path / "fresh"
    export(folders, fresh)
    assert tree(out) == tree(fresh)
    # A building's input deleted: its building is no longer reused (the load reports it).
    xdo.unlink()
    run = export(folders, out)
    assert run.reused == 7 and run.buildings == 7 and run.skipped == 1


def test_a_stale_summary_falls_back_to_the_record_files(inputs, tmp_path, reads):
    """An interrupted later run leaves records newer than the summary; an edited manifest no
    longer matches its summary: the record files decide, and the output is a fresh export's."""
    out = tmp_path / "out"
    export(inputs, out)
    other = Config()
    other.textures.jpeg_quality -= 20
    done = tmp_path / "done"
    export(inputs, done, other)
    # As if a run with ``other`` stopped after writing two buildings of the first tile.
    written = sorted(p.name for p in (done / TILES[0].name).iterdir() if p.is_dir())[:2]
    for name in written:
        shutil.rmtree(out / TILES[0].name / name)
        shutil.copytree(done / TILES[0].name / name, out / TILES[0].name / name)
    reads.clear()
    run = export(inputs, out, other)
    assert run.reused == 2 and run.buildings == 8
    assert tree(out) == tree(done)
    # A manifest edited by hand is made again from the records.
    manifest = out / TILES[0].name / "lod_manifest.json"
    manifest.write_text(manifest.read_text().replace('"buildings": 4', '"buildings": 5'))
    reads.clear()
    assert export(inputs, out, other).reused == 8
    assert any(f"/{TILES[0].name}/" in path for path in reads)
    assert tree(out) == tree(done)


def test_force_redoes_every_building_and_a_tile_left_out_of_a_run_stays(inputs, tmp_path):
    """--force redoes every building of a tile with a summary; a run over one folder leaves the
    other folder's tile (manifest and summary) as it was, and the next full run reuses it."""
    out = tmp_path / "out"
    export(inputs, out)
    assert export(inputs, out, force=True).reused == 0
    other = out / TILES[1].name
    before = {p.name: p.read_bytes() for p in (other / "lod_manifest.json", other / SUMMARY_NAME)}
    assert export([inputs[0]], out).reused == 4
    assert {
        p.name: p.read_bytes() for p in (other / "lod_manifest.json", other / SUMMARY_NAME)
    } == before
    assert export(inputs, out).reused == 8
    fresh = tmp_path / "fresh"
    export(inputs, fresh)
    assert tree(out) == tree(fresh)


def test_a_config_change_outside_the_buildings_remakes_the_manifests_only(inputs, tmp_path, reads):
    """The tileset's options are not in a building's input hash but are in its tile's manifest
    (``config``): every building is reused from the summaries, and the manifests are made again
    (a new head), as a fresh export with that config writes them."""
    out = tmp_path / "out"
    export(inputs, out)
    other = Config()
    other.tileset.proxy_max_triangles += 1
    reads.clear()
    run = export(inputs, out, other)
    assert run.reused == 8 and reads == []
    for tile in TILES:
        manifest = json.loads((out / tile.name / "lod_manifest.json").read_text())
        assert (
            manifest["config"]["tileset"]["proxy_max_triangles"]
            == other.tileset.proxy_max_triangles
        )
    fresh = tmp_path / "fresh"
    export(inputs, fresh, other)
    assert tree(out) == tree(fresh)
