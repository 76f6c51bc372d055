"""End to end: `vworld-lod export` on VWorld-format tiles written by the sample generator."""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from exporter.cli import main
from exporter.manifest import validate_manifest
from exporter.model import TileId
from exporter.simplify.guard import BUDGET_SHARE

REPO = Path(__file__).resolve().parents[1]
TILE = TileId(15, 279418, 116113)


@pytest.fixture(scope="module")
def small_tile(tmp_path_factory) -> Path:
    from exporter.samplegen import generate_tile

    folder = tmp_path_factory.mktemp("tile") / TILE.name
    generate_tile(folder, count=6, seed=7, tile=TILE, atlas_size=128, mean_triangles=200)
    return folder


def export(args: list[str]) -> int:
    return main(["export", *args, "--quiet", "--jobs", "1"])


def manifest_of(out: Path) -> dict:
    (path,) = list(out.glob("*/lod_manifest.json"))
    return json.loads(path.read_text())


def test_demo_tile_exports_a_valid_manifest_and_valid_gltf(tmp_path, gltf_validator):
    demo = sorted(p for p in (REPO / "samples").iterdir() if p.is_dir() and list(p.glob("*.dat")))
    assert demo, "samples/ must hold the committed demo tile"
    out = tmp_path / "out"
    assert main(["export", str(demo[0]), "--out", str(out), "--quiet"]) == 0
    manifest = manifest_of(out)
    validate_manifest(manifest)
    assert manifest["lod_group"]["screen_relative_heights"] == [0.5, 0.17, 0.02]
    assert manifest["buildings"] and not manifest["skipped"]
    tile_dir = out / manifest["tile"]["name"]
    files = [tile_dir / lod["file"] for b in manifest["buildings"] for lod in b["lods"]]
    assert all(f.is_file() for f in files) and len(files) == 3 * len(manifest["buildings"])
    reports = gltf_validator(files)
    assert all(r["errors"] == 0 for r in reports), [r for r in reports if r["errors"]][:3]
    levels = manifest["summary"]["levels"]
    assert levels[0]["ratio_to_lod0"] == 1.0
    assert levels[0]["mean_triangles"] > levels[1]["mean_triangles"] > levels[2]["mean_triangles"]
    for building in manifest["buildings"]:
        sizes = [lod["texture_size"] for lod in building["lods"]]
        assert sizes[1][0] * 2 == sizes[0][0] and sizes[2][0] * 4 == sizes[0][0]


def test_yaml_transitions_and_levels_reach_the_manifest(tmp_path, small_tile):
    config = tmp_path / "lod.yaml"
    config.write_text(
        "lods:\n  - {transition: 60%, mesh: 1.0, texture: 1.0}\n  - {transition: 0.05, mesh: 0.5, texture: 0.5}\nunity: {fade_mode: cross_fade}\n"
    )
    out = tmp_path / "out"
    assert export([str(small_tile), "--out", str(out), "--config", str(config)]) == 0
    manifest = manifest_of(out)
    validate_manifest(manifest)
    assert manifest["lod_group"]["screen_relative_heights"] == [0.6, 0.05]
    assert manifest["lod_group"]["fade_mode"] == "cross_fade"
    assert all(len(b["lods"]) == 2 for b in manifest["buildings"])
    assert manifest["tile"]["name"] == TILE.name


def test_a_corrupt_building_is_skipped_and_the_rest_of_the_tile_exported(tmp_path, small_tile):
    tile = tmp_path / "tile"
    shutil.copytree(small_tile, tile)
    victim = sorted(tile.glob("*.xdo"))[2]
    victim.write_bytes(victim.read_bytes()[:40])
    out = tmp_path / "out"
    assert export([str(tile), "--out", str(out)]) == 0
    manifest = manifest_of(out)
    validate_manifest(manifest)
    assert (
        len(manifest["skipped"]) == 1
        and victim.name in manifest["skipped"][0]["source"] + manifest["skipped"][0]["reason"]
    )
    assert len(manifest["buildings"]) == 5


def test_unusable_input_and_config_exit_non_zero_with_one_line(tmp_path, small_tile, capsys):
    assert main(["export", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")]) == 2
    assert "nowhere" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["export", str(empty), "--out", str(tmp_path / "o")]) == 2
    assert "empty" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("lods:\n  - {transition: 0.1}\n  - {transition: 0.2}\n")
    assert (
        main(["export", str(small_tile), "--out", str(tmp_path / "o"), "--config", str(bad)]) == 2
    )
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "bad.yaml" in err and "lods[1].transition" in err
    assert not (tmp_path / "o").exists(), "a bad config is refused before any work"


def test_rerun_skips_unchanged_buildings_force_redoes_and_removed_ones_disappear(
    tmp_path, small_tile
):
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    tile = tmp_path / "tile"
    shutil.copytree(small_tile, tile)
    out = tmp_path / "out"
    first = export_tiles([tile], out, Config(), jobs=1)
    assert first.buildings == 6 and first.reused == 0
    before = manifest_of(out)
    second = export_tiles([tile], out, Config(), jobs=1)
    assert second.reused == 6
    assert manifest_of(out) == before
    forced = export_tiles([tile], out, Config(), jobs=1, force=True)
    assert forced.reused == 0 and manifest_of(out) == before
    # Changing the config redoes everything; the output follows the new config.
    changed = Config()
    changed.lods = changed.lods[:2]
    third = export_tiles([tile], out, changed, jobs=1)
    assert third.reused == 0
    assert not list((out / TILE.name).glob("*/lod2.glb"))


def test_a_forced_re_export_leaves_levels_with_unchanged_bytes_untouched(tmp_path, small_tile):
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    out = tmp_path / "out"
    export_tiles([small_tile], out, Config(), jobs=1)
    old = 10**18  # ns: 2001, so any rewrite shows
    for path in out.glob("*/*/*"):
        os.utime(path, ns=(old, old))

    def times() -> dict:
        return {p.relative_to(out).as_posix(): p.stat().st_mtime_ns for p in out.glob("*/*/*")}

    export_tiles([small_tile], out, Config(), jobs=1, force=True)
    after = times()
    assert len(after) == 6 * 4
    assert all(t == old for name, t in after.items() if name.endswith(".glb"))
    assert all(t != old for name, t in after.items() if name.endswith("building.json"))
    # Another JPEG quality changes the reduced atlases only: LOD0 keeps the source's bytes.
    before = {name: (out / name).read_bytes() for name in after}
    coarser = Config()
    coarser.textures.jpeg_quality -= 20
    export_tiles([small_tile], out, coarser, jobs=1, force=True)
    for name, t in times().items():
        if name.endswith("lod0.glb"):
            assert t == old and (out / name).read_bytes() == before[name]
        elif name.endswith((".glb", ".json")):
            assert t != old and (out / name).read_bytes() != before[name], name


def test_stale_levels_are_looked_for_only_in_folders_an_earlier_export_made(
    tmp_path, small_tile, monkeypatch
):
    from exporter import job
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    looked = []
    real = job.remove_stale_levels
    monkeypatch.setattr(job, "remove_stale_levels", lambda *a: looked.append(a) or real(*a))
    out = tmp_path / "out"
    export_tiles([small_tile], out, Config(), jobs=1)
    assert looked == []  # every building folder was new: nothing of an earlier export in it
    folder = sorted((out / TILE.name).glob("*/lod2.glb"))[0].parent
    for name in ("lod7.glb", "lod.glb", "lod1.glb.bak", "notes.txt", "LOD3.glb"):
        (folder / name).write_bytes(b"old")
    fewer = Config()
    fewer.lods = fewer.lods[:2]
    export_tiles([small_tile], out, fewer, jobs=1, force=True)
    assert len(looked) == 6
    left = sorted(p.name for p in folder.iterdir())
    assert left == [
        "LOD3.glb",
        "building.json",
        "lod0.glb",
        "lod1.glb",
        "lod1.glb.bak",
        "notes.txt",
    ]


def test_inspect_lists_buildings_without_writing(tmp_path, small_tile, capsys):
    before = sorted(p.name for p in small_tile.iterdir())
    assert main(["inspect", str(small_tile)]) == 0
    text = capsys.readouterr().out
    assert "format vworld" in text and "6 buildings" in text and "triangles" in text
    assert sorted(p.name for p in small_tile.iterdir()) == before


def test_init_config_writes_a_loadable_commented_file(tmp_path, capsys):
    path = tmp_path / "lod.yaml"
    assert main(["init-config", str(path)]) == 0
    assert main(["init-config", str(path)]) == 2, "never overwrites what the user had"
    from exporter.config import Config, load_config

    assert load_config(path) == Config()


INTERRUPTIBLE = (
    "import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "  # as on a terminal
    "from exporter.cli import main; sys.exit(main(sys.argv[1:]))"
)


@pytest.fixture(scope="module")
def interrupted_tile(tmp_path_factory) -> Path:
    """Enough buildings that a signal sent once two are written lands while the rest are made:
    with six, the run could reach its tile manifest before the signal (a race, not a failure of
    the run)."""
    from exporter.samplegen import generate_tile

    folder = tmp_path_factory.mktemp("interrupted") / TILE.name
    generate_tile(folder, count=48, seed=7, tile=TILE, atlas_size=128, mean_triangles=200)
    return folder


@pytest.mark.slow
@pytest.mark.parametrize("how, jobs", [("kill", "1"), ("ctrl-c", "2")])
def test_interrupted_run_resumes_to_the_same_output_as_an_uninterrupted_one(
    tmp_path, interrupted_tile, how, jobs
):
    reference = tmp_path / "reference"
    assert export([str(interrupted_tile), "--out", str(reference)]) == 0
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        INTERRUPTIBLE,
        "export",
        str(interrupted_tile),
        "--out",
        str(out),
        "--jobs",
        jobs,
        "--quiet",
    ]
    process = subprocess.Popen(
        command,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while (
        time.monotonic() < deadline
        and len(list(out.glob("*/*/building.json"))) < 2
        and process.poll() is None
    ):
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL if how == "kill" else signal.SIGINT)
    _, err = process.communicate(timeout=60)
    if process.returncode != 0:  # it was stopped midway (not finished before the signal)
        assert not (out / TILE.name / "lod_manifest.json").exists()
        if how == "ctrl-c":
            assert process.returncode == 130 and "interrupted" in err
    leftovers = [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    if how == "ctrl-c":
        assert leftovers == [], "an interrupted write removes its temporary file"
    else:  # SIGKILL can land inside a write: its temporary may stay, hidden, never under a final name
        assert all(p.name.startswith(".") for p in leftovers), leftovers
    assert (
        export([str(interrupted_tile), "--out", str(out)]) == 0
    )  # removes stale temporaries first
    assert manifest_of(out) == manifest_of(reference)
    names = lambda root: sorted(str(p.relative_to(root)) for p in root.rglob("*"))
    assert names(out) == names(reference)


def test_a_tile_index_that_disagrees_with_the_centre_is_kept_and_reported(tmp_path):
    from exporter.readers.vworld import write_tile
    from exporter.samplegen import generate_buildings

    buildings = generate_buildings(2, seed=3, tile=TILE, atlas_size=32, mean_triangles=60)
    claimed = TileId(15, TILE.idx + 1, TILE.idy)  # the data says: the tile to the east
    folder = tmp_path / "tile"
    write_tile(folder, claimed, buildings)
    out = tmp_path / "out"
    assert export([str(folder), "--out", str(out)]) == 0
    manifest = manifest_of(out)
    assert manifest["tile"]["name"] == claimed.name, "the data's own tile index wins"
    for building in manifest["buildings"]:
        assert building["tile_from_center"] == {"level": 15, "idx": TILE.idx, "idy": TILE.idy}
        assert any(str(TILE.idx) in problem for problem in building["problems"])


def test_the_same_building_id_in_two_folders_of_one_tile_gets_two_outputs(tmp_path):
    from exporter.samplegen import generate_tile

    folders = [
        generate_tile(
            tmp_path / name, count=2, seed=seed, tile=TILE, atlas_size=32, mean_triangles=60
        )
        for name, seed in (("a", 1), ("b", 2))
    ]
    out = tmp_path / "out"
    assert export([str(f) for f in folders] + ["--out", str(out)]) == 0
    manifest = manifest_of(out)
    ids = [b["id"] for b in manifest["buildings"]]
    assert len(ids) == 4 and len(set(ids)) == 4, ids
    files = {lod["file"] for b in manifest["buildings"] for lod in b["lods"]}
    assert len(files) == 4 * 3 and all((out / TILE.name / f).is_file() for f in files)
    assert export([str(f) for f in folders] + ["--out", str(out)]) == 0
    assert manifest_of(out) == manifest, "a re-run finds every building's record again"


def test_the_same_cityjson_object_id_in_two_files_of_one_tile_gets_two_outputs(tmp_path):
    """CityJSON readers name buildings by their CityObject id; two files may repeat one."""
    lon, lat = 126.97833, 37.56610  # inside TILE
    d = 0.00005
    document = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [1.0, 1.0, 1.0], "translate": [0.0, 0.0, 0.0]},
        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/4979"},
        "CityObjects": {
            "hall": {
                "type": "Building",
                "geometry": [{"type": "MultiSurface", "lod": "1", "boundaries": [[[0, 1, 2, 3]]]}],
            }
        },
        "vertices": [[lon, lat, 0.0], [lon + d, lat, 0.0], [lon + d, lat, 10.0], [lon, lat, 10.0]],
    }
    folders = []
    for name in ("a", "b"):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "hall.city.json").write_text(json.dumps(document))
        folders.append(folder)
    out = tmp_path / "out"
    assert export([str(f) for f in folders] + ["--out", str(out)]) == 0
    manifest = manifest_of(out)
    assert [b["id"] for b in manifest["buildings"]] == ["hall", "hall~1"]
    folders_out = {b["lods"][0]["file"].split("/")[0] for b in manifest["buildings"]}
    assert len(folders_out) == 2


def test_exact_levels_carry_identity_metrics_and_changed_levels_are_measured(tmp_path):
    """A level the lossless planar pass settled is not measured (identity metrics, which agree
    with measuring it, also where it closed slits of the source); a level with LOD0's surface
    but a changed open boundary would have only its outline measured (boundary_quality; no
    level of this tile since slits are closed first, see tests/test_quality.py); a level the
    quadric collapse changed is measured in full."""
    from exporter.config import Config, config_from_dict
    from exporter.job import process_entry
    from exporter.quality import measure_lod
    from exporter.readers import load_entry, scan_folder
    from exporter.samplegen import generate_tile
    from exporter.simplify import build_mesh_chain

    tile = tmp_path / TILE.name
    generate_tile(tile, count=16, seed=3, tile=TILE, atlas_size=32)
    seen = {"exact": 0, "surface": 0, "changed": 0}
    for config in (Config(), config_from_dict({"simplify": {"planar_retriangulation": False}})):
        for entry in scan_folder(tile, config.readers).entries:
            record = process_entry(entry, config, str(tmp_path / "out"), "digest").record
            chain = build_mesh_chain(
                load_entry(entry, config.readers).parts, config.lods, config.simplify
            )
            for level in range(1, len(chain)):
                # texel_m: the atlas on the surface, not a metric of the mesh against LOD0
                quality = dict(record["lods"][level]["quality"])
                assert quality.pop("texel_m") > 0
                measured = measure_lod(chain[0].parts, chain[level].parts).to_manifest()
                surface = {
                    key: quality[key]
                    for key in ("hausdorff_rel", "silhouette_iou", "wall_coverage")
                }
                outline = {
                    key: quality[key]
                    for key in ("boundary_length_change", "new_holes", "triangle_ratio")
                }
                if chain[level].surface_exact:
                    seen["exact" if chain[level].exact else "surface"] += 1
                    assert surface == {
                        "hausdorff_rel": measured["hausdorff_rel"],  # certified, both
                        "silhouette_iou": 1.0,
                        "wall_coverage": 1.0,
                    }
                    assert measured["hausdorff_rel"] <= 5e-4 and measured["silhouette_iou"] > 0.99
                    assert outline == pytest.approx(
                        {key: measured[key] for key in outline}, abs=1e-12
                    )
                    if chain[level].exact:
                        assert (outline["boundary_length_change"], outline["new_holes"]) == (0.0, 0)
                else:
                    seen["changed"] += 1
                    # hausdorff_rel is the guard's certified bound (against LOD0 welded, plus the
                    # welding): within the bounds' gap of measure_lod's own certification, the
                    # guard's gap no finer than BUDGET_SHARE of the level's budget.
                    reported, own = quality.pop("hausdorff_rel"), measured.pop("hausdorff_rel")
                    positions = np.concatenate([p.positions for p in chain[0].parts])
                    diagonal = float(np.linalg.norm(np.ptp(positions, axis=0)))
                    share = BUDGET_SHARE * chain[level].tolerance / diagonal
                    assert abs(reported - own) <= 0.02 * max(reported, own) + 1e-5 + share
                    assert quality == pytest.approx(measured)
    assert seen["exact"] and seen["changed"], seen  # both paths ran


def _age(folder: Path, seconds: float) -> None:
    """Set every file's mtime ``seconds`` in the past (out of the racy window)."""
    when = time.time() - seconds
    for path in folder.iterdir():
        os.utime(path, (when, when))


def test_rerun_trusts_unchanged_stat_and_rehashes_touched_or_recent_files(
    tmp_path, small_tile, monkeypatch
):
    import exporter.pipeline as pipeline
    from exporter.config import Config

    tile = tmp_path / "tile"
    shutil.copytree(small_tile, tile)
    _age(tile, 3600)
    out = tmp_path / "out"
    assert pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 0
    hashed = []
    real_sha = pipeline._sha256_file
    monkeypatch.setattr(
        pipeline, "_sha256_file", lambda name: hashed.append(name) or real_sha(name)
    )

    # Unchanged: nothing is read again.
    assert pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 6 and hashed == []

    # Touched, same bytes: hashed once, reused, and its new stat recorded (not hashed next time).
    jpg = sorted(tile.glob("*.jpg"))[0]
    os.utime(jpg, (time.time() - 1800, time.time() - 1800))
    assert pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 6 and hashed == [str(jpg)]
    hashed.clear()
    assert pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 6 and hashed == []

    def rewrite_keeping_size_and_mtime(path: Path) -> None:
        stat = path.stat()
        data = bytearray(path.read_bytes())
        data[-3] ^= 0xFF
        path.write_bytes(bytes(data))
        os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))

    # A file hashed within the racy window of its mtime is hashed again even with its stat
    # unchanged: a second write in the same mtime tick is caught.
    recent = sorted(tile.glob("*.jpg"))[1]
    os.utime(recent, None)  # modified just now ...
    assert (
        pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 6
    )  # ... and hashed just after
    rewrite_keeping_size_and_mtime(recent)
    hashed.clear()
    racy = pipeline.export_tiles([tile], out, Config(), jobs=1)
    assert str(recent) in hashed and racy.reused == 5 and racy.buildings == 6

    # An old file rewritten with the same size and its old mtime put back by hand is trusted (as
    # make, rsync and git do); --force redoes such a building.
    rewrite_keeping_size_and_mtime(jpg)
    hashed.clear()
    assert (
        pipeline.export_tiles([tile], out, Config(), jobs=1).reused == 6 and str(jpg) not in hashed
    )
    assert pipeline.export_tiles([tile], out, Config(), jobs=1, force=True).reused == 0


def test_manifest_is_made_from_the_record_files_and_a_vanished_one_is_reported(
    tmp_path, small_tile
):
    import exporter.pipeline as pipeline
    from exporter.config import Config

    out = tmp_path / "out"
    pipeline.export_tiles([small_tile], out, Config(), jobs=1)
    manifest = manifest_of(out)
    tile_dir = out / manifest["tile"]["name"]
    folders = [b["folder"] for b in manifest["buildings"]]
    on_disk = [json.loads((tile_dir / f / "building.json").read_text())["record"] for f in folders]
    assert manifest["buildings"] == on_disk
    (tile_dir / folders[0] / "building.json").unlink()
    result = pipeline.write_tile_output(out, TILE, Config(), folders, [])
    rewritten = manifest_of(out)
    assert (
        result.buildings == len(folders) - 1
        and [b["folder"] for b in rewritten["buildings"]] == folders[1:]
    )
    assert len(rewritten["skipped"]) == 1 and "vanished" in rewritten["skipped"][0]["reason"]
    assert (tile_dir / folders[0] / "lod0.glb").is_file()  # its files are left alone


def test_the_manifest_removes_building_folders_of_earlier_runs_only(tmp_path, small_tile):
    import exporter.pipeline as pipeline
    from exporter.config import Config

    out = tmp_path / "out"
    pipeline.export_tiles([small_tile], out, Config(), jobs=1)
    tile_dir = out / manifest_of(out)["tile"]["name"]
    folders = sorted(p.name for p in tile_dir.iterdir() if (p / "building.json").is_file())
    (tile_dir / "notes").mkdir()  # not made by this tool: no record file
    (tile_dir / "notes" / "todo.txt").write_text("mine")
    pipeline.write_tile_output(out, TILE, Config(), folders[1:], [])
    assert not (tile_dir / folders[0]).exists()
    assert (tile_dir / "notes" / "todo.txt").read_text() == "mine"
    assert [b["folder"] for b in manifest_of(out)["buildings"]] == folders[1:]


def test_manifest_lines_copied_from_record_files_are_what_encoding_gives(tmp_path, small_tile):
    import exporter.pipeline as pipeline
    from exporter.config import Config
    from exporter.manifest import dumps

    out = tmp_path / "out"
    pipeline.export_tiles([small_tile], out, Config(), jobs=1)
    tile_dir = out / manifest_of(out)["tile"]["name"]
    folders = [b["folder"] for b in manifest_of(out)["buildings"]]
    files = [tile_dir / folder / "building.json" for folder in folders[:3]]
    data = [json.loads(path.read_text()) for path in files]
    data[0]["record"]["source"] = "서울/건물 1.xdo"  # written \uXXXX in the record file
    data[1]["record"]["problems"] = ["a \\users path"]  # a backslash before a u
    files[0].write_text(json.dumps(data[0]))
    files[1].write_text(json.dumps(data[1]))
    files[2].write_text(json.dumps(data[2], indent=2))  # not one line
    pipeline.write_tile_output(out, TILE, Config(), folders, [])
    text = (tile_dir / "lod_manifest.json").read_text(encoding="utf-8")
    assert text == dumps(json.loads(text))  # every line as encoding the record gives it
    assert "서울/건물 1.xdo" in text and [d["record"] for d in data[:3]] == [
        b for b in json.loads(text)["buildings"] if b["folder"] in folders[:3]
    ]


def test_record_file_members_come_with_their_exact_text():
    from exporter.json_members import top_level_values

    text = '{"tile": {"level": 15}, "record": {"id": "B1", "x": [1.5, -0.0, 1e-07]}, "files": []}'
    found = top_level_values(text)
    assert {key: value for key, (value, _) in found.items()} == json.loads(text)
    assert found["record"][1] == '{"id": "B1", "x": [1.5, -0.0, 1e-07]}'
    assert top_level_values(' {\n "a" :1 }\n') == {"a": (1, "1")}
    for bad in [
        "",
        "[]",
        '{"a": 1',
        '{"a" 1}',
        '{"a": 1} x',
        "{1: 2}",
        '{"a": 1,}',
        '{"a": 1 "b": 2}',
    ]:
        with pytest.raises(ValueError):
            top_level_values(bad)


def test_only_the_leading_members_are_read_until_the_keys_wanted():
    """A proxy record's summary fields come before megabytes of per-building lists: reading
    stops once every key wanted is read (the rest is not parsed, so not checked either)."""
    from exporter.json_members import top_level_values

    text = '{"hash": "h", "size": 3, "buildings": ["a", "b"], "values": [not json'
    head = top_level_values(text, frozenset({"hash", "size"}))
    assert {key: value for key, (value, _) in head.items()} == {"hash": "h", "size": 3}
    with pytest.raises(ValueError):  # the whole of it is no JSON
        top_level_values(text)
    # a key that never comes: everything read (and checked)
    with pytest.raises(ValueError):
        top_level_values(text, frozenset({"hash", "triangles"}))


def test_levels_report_their_error_budget_and_whether_they_shrank(tmp_path, small_tile):
    # Transitions 50/49/48 %: level 2's budget is barely above level 1's, so level 2 mostly finds
    # nothing more to collapse and says so, while level 1 shrinks (mesh caps at 1.0: the budget
    # alone decides).
    config = tmp_path / "lod.yaml"
    config.write_text(
        "lods:\n  - {transition: 50%, mesh: 1.0}\n  - {transition: 49%, mesh: 1.0}\n"
        "  - {transition: 48%, mesh: 1.0}\nsimplify: {max_screen_error_px: 0.5}\n"
    )
    out = tmp_path / "out"
    assert export([str(small_tile), "--out", str(out), "--config", str(config)]) == 0
    manifest = manifest_of(out)
    validate_manifest(manifest)
    flags = []
    for building in manifest["buildings"]:
        lods = building["lods"]
        assert "error_budget_m" not in lods[0] and "no_smaller_than_above" not in lods[0]
        ratios = [lods[1]["error_budget_m"] / lods[2]["error_budget_m"]]
        assert ratios[0] == pytest.approx(0.49 / 0.50, rel=1e-3)  # budget ~ 1 / transition above
        for above, level in zip(lods, lods[1:]):
            assert level["no_smaller_than_above"] == (level["triangles"] >= above["triangles"])
            flags.append(level["no_smaller_than_above"])
    assert True in flags and False in flags
    summary = manifest["summary"]["levels"]
    assert summary[2]["no_smaller_count"] == sum(
        b["lods"][2]["no_smaller_than_above"] for b in manifest["buildings"]
    )


def test_the_local_pool_takes_buildings_in_batches(monkeypatch):
    import exporter.pipeline as pipeline
    from exporter.job import EntryResult

    submitted: list[int] = []

    class Counting(pipeline.ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            submitted.append(len(args[0]))
            return super().submit(fn, *args, **kwargs)

    # Forked workers see the patched module: the "export" of an item is its number, back.
    monkeypatch.setattr(pipeline, "ProcessPoolExecutor", Counting)
    monkeypatch.setattr(
        pipeline, "process_entry", lambda n: EntryResult(tile=None, seconds={"n": n})
    )
    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the patched process_entry reaches the workers only when they are forked")
    results = list(pipeline._results(iter([(n,) for n in range(40)]), 2, 40))
    assert sorted(r.seconds["n"] for r in results) == list(range(40))
    # 40 buildings, 2 workers: batches sized to give each worker four more of what is left,
    # shrinking to single buildings at the end (the workers finish together), not 40 tasks.
    assert sum(submitted) == 40 and submitted[0] == 5 and submitted[-1] == 1
    assert submitted == sorted(submitted, reverse=True) and len(submitted) < 20


def slow_workers(monkeypatch, seconds: float) -> None:
    """Forked pool workers whose "export" of a task ``(n,)`` takes ``seconds`` and gives back
    ``n`` (skips where workers are not forked: they would not see the patch)."""
    import time

    import exporter.pipeline as pipeline
    from exporter.job import EntryResult

    def slow(n):
        time.sleep(seconds)
        return EntryResult(tile=None, seconds={"n": n})

    monkeypatch.setattr(pipeline, "process_entry", slow)
    if multiprocessing.get_start_method() != "fork":
        pytest.skip("the patched process_entry reaches the workers only when they are forked")


def test_idle_work_is_taken_while_every_worker_is_busy(monkeypatch):
    """A re-run's unchanged buildings (idle work: checks ending in finished results) are taken
    while the workers make the changed ones, not after them; a task met among them waits for
    the work to be handed out, and runs too."""
    import exporter.pipeline as pipeline
    from exporter.job import EntryResult

    slow_workers(monkeypatch, 0.05)
    pulled: list[str] = []

    def idle():
        for n in range(100, 106):
            pulled.append(f"idle {n}")
            yield (n,) if n == 103 else EntryResult(tile=None, seconds={"n": n})

    def work():
        for n in range(24):
            pulled.append(f"work {n}")
            yield (n,)

    order = [r.seconds["n"] for r in pipeline._results(work(), 2, 30, idle())]
    assert sorted(order) == list(range(24)) + list(range(100, 106))
    # every idle item was taken before the work ran out (the workers were busy), and its
    # results came back before the last of the work's
    assert pulled.index("idle 105") < pulled.index("work 23"), pulled
    assert max(order.index(n) for n in (100, 101, 102, 104, 105)) < order.index(23), order


def test_folders_scanned_in_processes_give_the_scans_of_one_process(tmp_path):
    """Several folders are scanned in forked processes: the same scans, in order, and the first
    unusable folder in order is the one named, as when they are scanned one after the other."""
    import exporter.pipeline as pipeline
    from exporter.config import ReaderOptions
    from exporter.errors import InputError
    from exporter.samplegen import generate_tile

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("folders are scanned in processes only where they can be forked")
    folders = [
        generate_tile(tmp_path / f"t{n}", 3, seed=n, tile=TileId(15, 279418 + n, 116112))
        for n in range(3)
    ]
    options = ReaderOptions()
    one = pipeline.scan_folders(folders, options, 1)
    several = pipeline.scan_folders(folders, options, 2)
    assert [s.folder for s in several] == [str(f) for f in folders]
    assert [[e.id for e in s.entries] for s in several] == [[e.id for e in s.entries] for s in one]
    assert [[e.inputs for e in s.entries] for s in several] == [
        [e.inputs for e in s.entries] for s in one
    ]
    missing = [tmp_path / "none1", folders[0], tmp_path / "none2"]
    with pytest.raises(InputError) as one_error:
        pipeline.scan_folders(missing, options, 1)
    with pytest.raises(InputError) as several_error:
        pipeline.scan_folders(missing, options, 2)
    assert str(several_error.value) == str(one_error.value) and "none1" in str(one_error.value)


def test_with_after_work_idle_work_waits_for_every_result_of_the_work(monkeypatch):
    """``after_work``: the idle items are taken only once every result of the work is back (the
    buildings run alone), then ``after_work`` is called once, then the idle items run."""
    import exporter.pipeline as pipeline
    from exporter.job import EntryResult

    slow_workers(monkeypatch, 0.02)
    events: list[str] = []

    def idle():
        for n in range(100, 104):
            events.append("idle")
            yield (n,) if n == 102 else EntryResult(tile=None, seconds={"n": n})

    def work():
        for n in range(12):
            yield (n,)

    results = pipeline._results(work(), 2, 16, idle(), lambda: events.append("after"))
    for result in results:
        events.append("work" if result.seconds["n"] < 100 else "result")
    assert events[:13] == ["work"] * 12 + ["after"], events
    assert events.count("after") == 1 and sorted(events[13:]) == ["idle"] * 4 + ["result"] * 4
