"""OUT/tileset.json (3D Tiles 1.1): structure, placement, certified errors, bad input, re-runs.

Checked independently of the exporter's tileset code (tests/tileset_check.py walks the JSON as
the specification says): placements against pyproj, errors against a dense sampled measure
(tests/hausdorff_check.py) of each content against the LOD0 of the buildings it stands for.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import pytest
from PIL import Image
from pyproj import Transformer

from exporter.config import Config, TilesetOptions
from exporter.model import TileId
from exporter.pipeline import export_tiles
from exporter.samplegen import generate_tile
from exporter.tiles import tile_of
from exporter.tileset import write_tileset
from exporter.tileset.glb import read_primitives
from tests.hausdorff_check import dense_hausdorff
from tests.tileset_check import (
    Y_UP,
    content_mesh,
    load,
    structural_problems,
    to_world,
    walk,
)

SEOUL = TileId(15, 279418, 116113)
EAST_OF_SEOUL = TileId(15, 279419, 116113)  # shares SEOUL's east border
BUSAN = tile_of(129.0756, 35.1796)


def make_tile(root: Path, tile: TileId, count: int, seed: int = 0) -> Path:
    return generate_tile(root / tile.name, count, seed=seed, tile=tile, atlas_size=64)


def export(folders: list[Path], out: Path, config: Config | None = None):
    return export_tiles(folders, out, config or Config(), jobs=1)


@pytest.fixture(scope="module")
def city(tmp_path_factory) -> Path:
    """Two tiles side by side (buildings on both sides of their border), 5 buildings each."""
    root = tmp_path_factory.mktemp("tileset")
    folders = [make_tile(root / "in", SEOUL, 5, 1), make_tile(root / "in", EAST_OF_SEOUL, 5, 2)]
    out = root / "out"
    export(folders, out)
    return out


def chains(visits) -> list[list]:
    """Each building's chain of visits (its coarsest level first), from their content URIs."""
    found = []
    for visit in visits:
        uri = visit.uri or ""
        parent_uri = (visit.parent.uri or "") if visit.parent else ""
        if uri.endswith(".glb") and "/lod" in uri and "/lod" not in parent_uri:
            chain = [visit]
            while chain[-1].children:
                chain.append(chain[-1].children[0])
            found.append(chain)
    return found


def manifest_buildings(out: Path) -> dict[str, dict]:
    """Manifest building records by their LOD0 file's path relative to OUT."""
    records = {}
    for path in out.glob("*/lod_manifest.json"):
        for record in json.loads(path.read_text())["buildings"]:
            records[f"{path.parent.name}/{record['lods'][0]['file']}"] = record
    return records


def test_the_tileset_follows_the_structural_rules_of_3d_tiles_1_1(city):
    tileset = load(city)
    assert structural_problems(city, tileset) == []
    visits = walk(tileset)
    # Drawing nothing is at least as wrong as the root's box is large (clients skip the whole
    # tileset while this error is small on screen).
    half_axes = np.array(tileset["root"]["boundingVolume"]["box"][3:]).reshape(3, 3)
    assert tileset["geometricError"] >= 2 * np.linalg.norm(half_axes).max()
    assert all(len(chain) >= 2 for chain in chains(visits))  # LOD0 under a coarser level
    proxies = [v for v in visits if v.uri and v.uri.startswith("tileset_proxies/")]
    # Two level-15 tiles and the level-14 tile above both (the quadtree, compressed).
    assert sorted(v.uri for v in proxies) == [
        "tileset_proxies/14_139709_58056.glb",
        "tileset_proxies/15_279418_116113.glb",
        "tileset_proxies/15_279419_116113.glb",
    ]
    assert len(chains(visits)) == 10


def test_every_building_stands_where_its_manifest_places_it(city):
    """The origin of every level's content, through the tileset's transforms, is within 1 cm of
    pyproj's EPSG:4979 -> EPSG:4978 position of the manifest's centre; glTF +X points West."""
    to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    records = manifest_buildings(city)
    found = 0
    for chain in chains(walk(load(city))):
        centre = records[unquote(chain[-1].uri)]["center"]
        expected = np.array(to_ecef.transform(centre["lon"], centre["lat"], centre["elev"]))
        lon, lat = np.radians(centre["lon"]), np.radians(centre["lat"])
        east = np.array([-np.sin(lon), np.cos(lon), 0.0])
        up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
        for visit in chain:
            matrix = visit.world @ Y_UP
            assert np.linalg.norm(to_world(matrix, np.zeros((1, 3)))[0] - expected) < 0.01
            assert matrix[:3, 0] @ east == pytest.approx(-1.0, abs=1e-9)  # glTF +X = West
            assert matrix[:3, 1] @ up == pytest.approx(1.0, abs=1e-9)  # glTF +Y = Up
        found += 1
    assert found == 10


def _local(points: np.ndarray, origin: np.ndarray) -> np.ndarray:
    return points - origin  # ECEF differences: small numbers for the distance queries


def test_building_levels_carry_the_manifest_bound_and_it_holds_densely(city):
    records = manifest_buildings(city)
    for chain in chains(walk(load(city))):
        lod0 = content_mesh(city, chain[-1])
        origin = lod0[0].mean(axis=0)
        reference = (_local(lod0[0], origin), lod0[1])
        # hausdorff_rel is relative to LOD0's box diagonal in the building's own (East/Up/North,
        # or the file's West/Up/North) axes, not ECEF's.
        own = np.concatenate([p.positions for p in read_primitives(city / unquote(chain[-1].uri))])
        diagonal = np.linalg.norm(own.max(axis=0) - own.min(axis=0))
        record = records[unquote(chain[-1].uri)]
        by_file = {
            f"{unquote(chain[-1].uri).split('/')[0]}/{lod['file']}": lod for lod in record["lods"]
        }
        assert chain[-1].tile["geometricError"] == 0.0
        for visit in chain[:-1]:
            error = visit.tile["geometricError"]
            lod = by_file[unquote(visit.uri)]
            certified = lod["quality"]["hausdorff_rel"] * diagonal
            # The level's error: its certified bound (+ float32 rounding) or its texture error.
            assert certified <= error <= max(certified * (1 + 1e-5) + 1e-4, lod["error_m"])
            assert error >= lod["error_m"]
            positions, faces = content_mesh(city, visit)
            assert dense_hausdorff((_local(positions, origin), faces), reference, 4) <= error


def test_every_proxy_error_bounds_its_distance_to_the_lod0_below_it(city):
    for visit in walk(load(city)):
        if not (visit.uri or "").startswith("tileset_proxies/"):
            continue
        below, stack = [], list(visit.children)
        while stack:
            node = stack.pop()
            if node.uri and not node.children and "/lod" in node.uri:
                below.append(content_mesh(city, node))
            stack += node.children
        offsets = np.cumsum([0] + [len(p) for p, _ in below])
        union_positions = np.concatenate([p for p, _ in below])
        origin = union_positions.mean(axis=0)
        union = (
            _local(union_positions, origin),
            np.concatenate([f + offsets[i] for i, (_, f) in enumerate(below)]),
        )
        positions, faces = content_mesh(city, visit)
        measured = dense_hausdorff((_local(positions, origin), faces), union, 3)
        assert measured <= visit.tile["geometricError"]
        assert visit.tile["geometricError"] >= max(c.tile["geometricError"] for c in visit.children)


def test_the_proxy_above_the_building_tiles_is_simplified(city):
    """It is a meshoptimizer collapse of the two level-15 proxies merged (the dense check above
    holds for it); the level-15 proxies are one level of each building merged as it is."""
    records = {p.stem: json.loads(p.read_text()) for p in (city / "tileset_proxies").glob("*.json")}
    below = sum(r["triangles"] for name, r in records.items() if name.startswith("15_"))
    assert records["14_139709_58056"]["triangles"] < below
    assert len(records["14_139709_58056"]["buildings"]) == 10  # every building keeps a part


def test_proxies_pass_the_khronos_validator(city, gltf_validator):
    proxies = sorted((city / "tileset_proxies").glob("*.glb"))
    assert proxies
    for report in gltf_validator(proxies):
        assert report["errors"] == 0, report


def test_the_same_input_gives_the_same_bytes_and_a_rerun_rebuilds_nothing(city, tmp_path):
    again = tmp_path / "out"
    shutil.copytree(city.parent / "in", tmp_path / "in")
    stats = export(sorted((tmp_path / "in").iterdir()), again)
    assert (again / "tileset.json").read_bytes() == (city / "tileset.json").read_bytes()
    for tile in (SEOUL, EAST_OF_SEOUL):  # each tile's own (its summary names its manifest's
        # sha256, and the manifests name the inputs' paths, another folder here)
        own = (again / tile.name / "tileset.json").read_bytes()
        assert own == (city / tile.name / "tileset.json").read_bytes()
    for proxy in (city / "tileset_proxies").iterdir():
        assert (again / "tileset_proxies" / proxy.name).read_bytes() == proxy.read_bytes()
    assert stats.tileset is not None and stats.tileset.proxies_built == 3
    rerun = export(sorted((tmp_path / "in").iterdir()), again)
    assert rerun.tileset is not None and rerun.tileset.proxies_built == 0
    # One building's files gone from the east tile (its .dat still lists it: skipped): that
    # tile's proxy and the one above are rebuilt, the west tile's is kept.
    for path in (tmp_path / "in" / EAST_OF_SEOUL.name).glob("B0000.*"):
        path.unlink()
    rerun = export(sorted((tmp_path / "in").iterdir()), again)
    assert rerun.skipped == 1
    assert rerun.tileset is not None and rerun.tileset.proxies_built == 2
    assert structural_problems(again, load(again)) == []
    assert len(chains(walk(load(again)))) == 9


def test_force_rebuilds_every_proxy_and_a_damaged_proxy_file_is_rebuilt(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    folders = sorted((city.parent / "in").iterdir())
    proxies = sorted((out / "tileset_proxies").glob("*.glb"))
    old = 10**18  # ns: 2001
    for proxy in proxies:
        os.utime(proxy, ns=(old, old))
    forced = export_tiles(folders, out, Config(), jobs=1, force=True)
    assert forced.tileset is not None and forced.tileset.proxies_built == 3
    for proxy in proxies:  # rebuilt to the same bytes: left as they were
        assert proxy.stat().st_mtime_ns == old
        assert proxy.read_bytes() == (city / "tileset_proxies" / proxy.name).read_bytes()
    # A proxy file cut short (its record intact) is rebuilt by a plain re-run.
    damaged = proxies[0]
    damaged.write_bytes(damaged.read_bytes()[:100])
    rerun = export(folders, out)
    assert rerun.reused == 10
    assert rerun.tileset is not None and rerun.tileset.proxies_built == 1
    assert damaged.read_bytes() == (city / "tileset_proxies" / damaged.name).read_bytes()


def test_one_building_gives_a_valid_tileset(tmp_path):
    export([make_tile(tmp_path / "in", SEOUL, 1)], tmp_path / "out")
    tileset = load(tmp_path / "out")
    assert structural_problems(tmp_path / "out", tileset) == []
    assert len(chains(walk(tileset))) == 1


def test_two_cities_far_apart_hang_under_one_root(tmp_path):
    folders = [make_tile(tmp_path / "in", SEOUL, 2, 3), make_tile(tmp_path / "in", BUSAN, 2, 4)]
    export(folders, tmp_path / "out")
    tileset = load(tmp_path / "out")
    assert structural_problems(tmp_path / "out", tileset) == []
    assert len(chains(walk(tileset))) == 4
    assert {v.uri for v in walk(tileset) if v.uri and "proxies" in v.uri} >= {
        f"tileset_proxies/{SEOUL.name}.glb",
        f"tileset_proxies/{BUSAN.name}.glb",
    }


def test_a_tile_whose_buildings_all_failed_is_left_out_and_said_so(tmp_path):
    broken = make_tile(tmp_path / "in", EAST_OF_SEOUL, 2, 5)
    for xdo in broken.glob("*.xdo"):
        xdo.write_bytes(b"not an xdo file")
    export([make_tile(tmp_path / "in", SEOUL, 2, 6), broken], tmp_path / "out")
    tileset = load(tmp_path / "out")
    assert structural_problems(tmp_path / "out", tileset) == []
    assert not any(EAST_OF_SEOUL.name in (v.uri or "") for v in walk(tileset))
    assert any(EAST_OF_SEOUL.name in line for line in tileset["extras"]["left_out"])


def _forget_tile_tileset(tile_dir: Path) -> None:
    """Remove a tile's tileset summary: the tileset trusts it (and reads none of the tile's
    buildings) while the manifest and the tile's tileset are those it was written with; an
    export re-run redoes a building whose files were removed or damaged (their CRC-32) and
    writes its tile's tileset again. Without it the tile's tileset is made again from the
    manifest, checking every level file."""
    (tile_dir / ".tileset_summary.json").unlink()


def test_deleted_building_files_are_never_referenced(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    gone = sorted((out / SEOUL.name).glob("*/lod0.glb"))[0].parent
    shutil.rmtree(gone)
    _forget_tile_tileset(out / SEOUL.name)
    result = write_tileset(out, TilesetOptions())
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    assert not any(f"{SEOUL.name}/{gone.name}/" in (v.uri or "") for v in walk(tileset))
    assert any(gone.name in line for line in result.left_out)
    assert result.proxies_built == 2  # the west tile's proxy and the one above


def test_every_level_record_states_its_file_s_position_bounds_exactly(city):
    from exporter.tileset.glb import position_bounds, read_header

    levels = 0
    for path in city.glob("*/lod_manifest.json"):
        for record in json.loads(path.read_text())["buildings"]:
            for lod in record["lods"]:
                low, high = position_bounds(read_header(path.parent / lod["file"]))
                assert lod["gltf_bounds"] == {"low": low.tolist(), "high": high.tolist()}
                levels += 1
    assert levels >= 20


def _counted(monkeypatch, module, name: str) -> list[str]:
    """The paths ``module.name(path)`` is called with from now on (it still runs)."""
    calls: list[str] = []
    real = getattr(module, name)

    def counted(path):
        calls.append(str(path))
        return real(path)

    monkeypatch.setattr(module, name, counted)
    return calls


def _without_bounds(out: Path, keep: int) -> None:
    """Remove ``gltf_bounds`` from every level record of ``out``'s manifests but the first
    ``keep`` buildings' of each (as 0.4.1 wrote them)."""
    for path in out.glob("*/lod_manifest.json"):
        manifest = json.loads(path.read_text())
        for record in manifest["buildings"][keep:]:
            for lod in record["lods"]:
                del lod["gltf_bounds"]
        path.write_text(json.dumps(manifest))


def test_recorded_bounds_spare_the_file_reads_and_old_records_give_the_same_tileset(
    city, tmp_path, monkeypatch
):
    from exporter.tileset import tree

    out = tmp_path / "out"
    shutil.copytree(city, out)
    _without_bounds(out, keep=2)  # 2 buildings per tile keep theirs
    read = _counted(monkeypatch, tree, "read_header")
    write_tileset(out, TilesetOptions())
    assert (out / "tileset.json").read_bytes() == (city / "tileset.json").read_bytes()
    assert len(read) == 2 * 3 * 3  # 3 buildings of each tile without bounds, 3 levels each


def test_bad_recorded_bounds_are_not_trusted(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    bad = [
        {"low": [1.0, 2.0], "high": [3.0, 4.0, 5.0]},
        {"low": [1.0, 2.0, 3.0], "high": [0.0, 4.0, 5.0]},  # low > high
        {"low": [1.0, "2", 3.0], "high": [4.0, 4.0, 5.0]},
        {"low": [1.0, 2.0, 3.0], "high": [4.0, True, 5.0]},
        {"low": [1.0, 2.0, 3.0], "high": [4.0, 1e400, 5.0]},  # json: Infinity
        {"low": [1.0, 2.0, 3.0]},
        [1.0, 2.0, 3.0],
    ]
    changed = 0
    for path in out.glob("*/lod_manifest.json"):
        manifest = json.loads(path.read_text())
        for record in manifest["buildings"]:
            for lod in record["lods"]:
                lod["gltf_bounds"] = bad[changed % len(bad)]
                changed += 1
        path.write_text(json.dumps(manifest))
    assert changed >= len(bad)
    result = write_tileset(out, TilesetOptions())
    assert (out / "tileset.json").read_bytes() == (city / "tileset.json").read_bytes()
    assert result.left_out == []


def test_a_missing_or_damaged_level_file_is_left_out_though_its_record_has_bounds(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    first, second = sorted((out / SEOUL.name).glob("*/lod1.glb"))[:2]
    first.unlink()
    second.write_bytes(second.read_bytes()[:16])  # truncated: not the size its record states
    _forget_tile_tileset(out / SEOUL.name)
    result = write_tileset(out, TilesetOptions())
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    uris = {unquote(v.uri) for v in walk(tileset) if v.uri}
    for path in (first, second):
        name = f"{SEOUL.name}/{path.parent.name}"
        assert f"{name}/lod1.glb" not in uris and f"{name}/lod0.glb" in uris
        assert any(line.startswith(f"{name}: LOD1 file") for line in result.left_out)


def test_an_export_reads_each_of_its_manifests_once_for_the_tileset(tmp_path, monkeypatch):
    from exporter import tile_index

    read = _counted(monkeypatch, tile_index, "_manifest_facts")
    out = tmp_path / "out"
    export([make_tile(tmp_path / "in", SEOUL, 2, 9)], out)  # this run's tile: facts known
    assert read == []
    assert len(chains(walk(load(out)))) == 2


def test_batched_building_chains_give_the_bits_of_the_node_by_node_path(city, monkeypatch):
    from exporter.tileset import frames, write
    from exporter.tileset.tree import quadtree, read_buildings

    by_tile, left_out = read_buildings(city)
    # Every chain keeps its three levels (their atlases differ): shorten one to batch two lengths.
    next(iter(by_tile.values()))[0].levels.pop(1)
    lengths = {len(chain.levels) for chains in by_tile.values() for chain in chains}
    assert len(lengths) > 1  # batches of several lengths
    tops = quadtree(by_tile)
    batched = write.tileset_json(tops, left_out)
    assert len(tops) == 1  # the two tiles under their common ancestor
    for top in write.building_tops(tops[0]):
        node, chain = top, top.building
        assert chain is not None
        for level in chain.levels:
            assert node is not None and node.corners is not None
            one = frames.apply(chain.world, frames.gltf_corners(level.low, level.high))
            assert np.array_equal(node.corners, one)
            node = node.children[0] if node.children else None
    monkeypatch.setattr(write, "finish_chains", lambda tops: None)  # finish() does every node
    single = write.tileset_json(quadtree(by_tile), left_out)
    assert json.dumps(batched) == json.dumps(single)


def test_the_export_tail_runs_without_cyclic_gc_and_restores_it(tmp_path, monkeypatch):
    import gc

    from exporter import pipeline

    seen: list[bool] = []
    real = pipeline.write_tileset

    def watched(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    def broken(*args, **kwargs):
        seen.append(gc.isenabled())
        raise OSError("disk full")

    monkeypatch.setattr(pipeline, "write_tileset", watched)
    folder = make_tile(tmp_path / "in", SEOUL, 1, 10)
    export([folder], tmp_path / "out")
    monkeypatch.setattr(pipeline, "write_tileset", broken)
    with pytest.raises(OSError):
        export([folder], tmp_path / "out2")
    assert seen == [False, False] and gc.isenabled()
    assert (tmp_path / "out2" / "tiles.json").is_file()  # still written when the tileset fails


def test_the_switch_turns_the_tileset_off_and_removes_nothing_else(tmp_path):
    config = Config(tileset=TilesetOptions(enabled=False))
    stats = export([make_tile(tmp_path / "in", SEOUL, 1)], tmp_path / "out", config)
    assert stats.tileset is None
    assert not (tmp_path / "out" / "tileset.json").exists()
    assert (tmp_path / "out" / "tiles.json").is_file()


def test_without_proxies_the_tiles_have_no_content_and_no_proxy_files(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    write_tileset(out, TilesetOptions(proxies=False))
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    assert not any("proxies" in (v.uri or "") for v in walk(tileset))
    assert not list((out / "tileset_proxies").glob("*"))


def test_a_proxy_over_the_size_cap_is_coarsened_with_an_error_that_still_holds(city, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(city, out)
    before = {p.stem: json.loads(p.read_text()) for p in (out / "tileset_proxies").glob("*.json")}
    cap = max(r["triangles"] for n, r in before.items() if n.startswith("15_")) - 1
    # Clustered on coarser cells until within half the cap, with the larger error that costs.
    write_tileset(out, TilesetOptions(proxy_max_triangles=cap))
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    after = {p.stem: json.loads(p.read_text()) for p in (out / "tileset_proxies").glob("*.json")}
    assert after.keys() == before.keys()
    for name, record in after.items():
        assert record["triangles"] <= cap // 2
        assert record["geometric"] >= before[name]["geometric"]
    test_every_proxy_error_bounds_its_distance_to_the_lod0_below_it(out)
    # Two triangles at most: whatever is left out or kept, the errors still hold.
    write_tileset(out, TilesetOptions(proxy_max_triangles=2))
    assert structural_problems(out, load(out)) == []
    for path in (out / "tileset_proxies").glob("*.json"):
        assert json.loads(path.read_text()).get("triangles", 0) <= 2
    test_every_proxy_error_bounds_its_distance_to_the_lod0_below_it(out)


def test_tiles_of_earlier_runs_stay_in_the_tileset(tmp_path):
    out = tmp_path / "out"
    export([make_tile(tmp_path / "in", SEOUL, 1, 7)], out)
    export([make_tile(tmp_path / "in", EAST_OF_SEOUL, 1, 8)], out)  # a second run, another tile
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    uris = [chain[-1].uri for chain in chains(walk(tileset))]
    assert sorted(uri.split("/")[0] for uri in uris) == [SEOUL.name, EAST_OF_SEOUL.name]


def test_the_atlas_gives_each_primitive_a_cell_and_a_broken_texture_its_colour():
    from exporter.tileset.proxy import CellTextures, atlas_uvs, fineness_of, pack_atlas

    good = io.BytesIO()
    Image.new("RGB", (64, 64), (0, 0, 255)).save(good, "PNG")
    images = [good.getvalue(), b"not an image"]
    atlas, plain = pack_atlas(images, [(1, 1, 1, 1), (1, 0, 0, 1)], 64)
    assert plain.tolist() == [False, True]  # the broken one: its colour
    pixels = CellTextures(Path(".")).pixels(images)
    assert pixels.tolist() == [64, 0]
    assert fineness_of(pixels, 32).tolist() == [1.0, 1.0]  # 64 px into a 32 px cell: filtered down
    assert fineness_of(pixels, 128).tolist() == [
        0.5,
        1.0,
    ]  # into 128 px: its texels are twice a cell's
    assert atlas.getpixel((10, 10)) == (0, 0, 255) and atlas.getpixel((42, 10)) == (255, 0, 0)
    # Cell-grid uvs ((column, row) + the uv in the cell) into the atlas, inset half a texel; the
    # colour cell's vertices at its centre.
    grid = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [1.5, 0.7]])
    uvs = atlas_uvs(grid, np.array([0, 0, 1, 1]), plain, 2, 64)
    assert uvs.tolist() == [[1 / 128, 1 / 128], [63 / 128, 63 / 128], [0.75, 0.25], [0.75, 0.25]]


def test_a_jpeg_cell_is_decoded_at_a_reduced_scale_and_keeps_its_source_s_texel_size():
    from exporter.tileset.proxy import CellTextures, fineness_of, pack_atlas

    rows = np.linspace(0, 255, 256, dtype=np.uint8)
    pixels = np.stack(
        [
            np.add.outer(rows, rows) // 2,
            np.tile(rows, (256, 1)),
            255 - np.tile(rows[:, None], (1, 256)),
        ],
        axis=-1,
    )
    jpeg = io.BytesIO()
    Image.fromarray(pixels.astype(np.uint8), "RGB").save(jpeg, "JPEG", quality=90)
    atlas, plain = pack_atlas([jpeg.getvalue()], [(1, 1, 1, 1)], 48)
    assert not plain.any()
    # the texel size is the source's (256 px from its header), not the reduced decode's
    assert CellTextures(Path(".")).pixels([jpeg.getvalue()]).tolist() == [256]
    assert fineness_of(np.array([256]), 48).tolist() == [1.0]
    with Image.open(io.BytesIO(jpeg.getvalue())) as image:
        image.draft("RGB", (48, 48))
        assert image.size == (64, 64)  # libjpeg's 1/4 scale: the smallest not below the cell
        scaled = np.asarray(image.resize((48, 48), Image.Resampling.BOX), np.int16)
    with Image.open(io.BytesIO(jpeg.getvalue())) as image:
        full = np.asarray(image.resize((48, 48), Image.Resampling.BOX), np.int16)
    cell = np.asarray(atlas, np.int16)
    assert np.array_equal(cell, scaled)
    assert np.abs(cell - full).mean() < 2.0  # the same picture as a full decode, within JPEG noise


def test_a_proxy_input_broken_after_it_was_read_leaves_that_proxy_out(city, tmp_path, monkeypatch):
    from exporter.tileset import proxy

    out = tmp_path / "out"
    shutil.copytree(city, out)
    shutil.rmtree(out / "tileset_proxies")
    real = proxy.read_primitives

    def broken(path):
        if EAST_OF_SEOUL.name in str(path):
            raise ValueError(f"{path}: not a complete glTF 2.0 binary file")
        return real(path)

    monkeypatch.setattr(proxy, "read_primitives", broken)
    result = write_tileset(out, TilesetOptions())
    tileset = load(out)
    assert structural_problems(out, tileset) == []
    uris = {v.uri for v in walk(tileset) if v.uri and "proxies" in v.uri}
    assert uris == {f"tileset_proxies/{SEOUL.name}.glb"}  # neither the east one nor the one above
    assert any(EAST_OF_SEOUL.name in line for line in result.left_out)
    assert len(chains(walk(tileset))) == 10


def _proxy_visits(out: Path) -> dict[str, object]:
    """tileset.json's proxy tiles by tile name."""
    return {
        Path(unquote(v.uri)).stem: v
        for v in walk(load(out))
        if v.uri and v.uri.startswith("tileset_proxies/")
    }


def test_tiles_json_lists_the_proxies_for_the_unity_streamer(city):
    from exporter.tile_index import validate_index

    index = json.loads((city / "tiles.json").read_text())
    validate_index(index)
    proxies = {p["name"]: p for p in index["proxies"]}
    visits = _proxy_visits(city)
    assert sorted(proxies) == sorted(visits) and len(proxies) == 3
    top = proxies["14_139709_58056"]
    assert top["children"] == [SEOUL.name, EAST_OF_SEOUL.name] and top["tiles"] == []
    assert proxies[SEOUL.name]["children"] == [] and proxies[SEOUL.name]["tiles"] == [SEOUL.name]
    for name, entry in proxies.items():
        assert entry["file"] == unquote(visits[name].uri)
        assert (
            entry["geometric_error"] == visits[name].tile["geometricError"]
        )  # tileset.json's, metres
        # radius_m: a sphere about the frame's origin holding every vertex of the proxy
        primitives = read_primitives(city / entry["file"])
        points = np.vstack([p.positions for p in primitives])
        assert np.linalg.norm(points, axis=1).max() <= entry["radius_m"] + 1e-6
        # atlas_px: its atlas's side as written (proxies' atlases differ in size)
        (image,) = [p.image for p in primitives]
        assert image is not None and (entry["atlas_px"],) * 2 == Image.open(io.BytesIO(image)).size


def test_a_proxy_in_unity_stands_where_tileset_json_puts_it(city):
    """The Unity placement of each proxy's frame (tiles.json) and tileset.json's transform agree:
    the origin within 1 cm (Unity globe -> lon/lat/elev on the sphere, tileset -> pyproj's
    EPSG:4978 -> EPSG:4979), the axes (glTF +X West, +Y Up, +Z North) within 1e-9."""
    from exporter.placement import apply_placement, enu_matrix, rotate

    to_geodetic = Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)
    index = json.loads((city / "tiles.json").read_text())
    visits = _proxy_visits(city)
    for entry in index["proxies"]:
        place, globe = entry["placement"], entry["globe"]
        matrix = visits[entry["name"]].world @ Y_UP  # glTF frame -> ECEF
        lon, lat, h = to_geodetic.transform(*to_world(matrix, np.zeros((1, 3)))[0])
        # Unity: glTFast turns glTF (+X West) into Unity local (+X East) by negating x.
        unity = apply_placement(place, np.zeros((1, 3)))[0]
        radius = np.linalg.norm(unity)
        u_lat = np.degrees(np.arcsin(unity[1] / radius))
        u_lon = np.degrees(np.arctan2(unity[0], -unity[2]))
        u_elev = (radius - globe["unity_radius"]) * globe["earth_radius_m"] / globe["unity_radius"]
        metres_per_degree = np.radians(1.0) * globe["earth_radius_m"]
        assert abs(u_lat - lat) * metres_per_degree < 0.01
        assert abs(u_lon - lon) * metres_per_degree * np.cos(np.radians(lat)) < 0.01
        assert abs(u_elev - h) < 0.01
        # Axes: Unity local East/Up/North -> globe frame equals East/Up/North at the centre; in
        # the tileset, glTF +X/+Y/+Z are West/Up/North there.
        axes = rotate(place["rotation"], np.eye(3)).T
        assert np.allclose(axes, enu_matrix(lon, lat), atol=1e-9)
        lam, phi = np.radians(lon), np.radians(lat)
        east = np.array([-np.sin(lam), np.cos(lam), 0.0])
        up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
        assert matrix[:3, 0] @ east == pytest.approx(-1.0, abs=1e-9)
        assert matrix[:3, 1] @ up == pytest.approx(1.0, abs=1e-9)


def test_tiles_json_lists_a_proxy_only_when_its_file_and_children_are_there(city, tmp_path):
    from exporter.tile_index import build_index

    out = tmp_path / "out"
    shutil.copytree(city, out)
    records = write_tileset(out, TilesetOptions()).proxies_index
    assert [p["name"] for p in build_index(out, proxies=records)["proxies"]] == [
        "14_139709_58056",
        SEOUL.name,
        EAST_OF_SEOUL.name,
    ]
    (out / "tileset_proxies" / f"{SEOUL.name}.glb").unlink()
    # Its parent would refine into a hole: left out too; the other tile's proxy stays.
    assert [p["name"] for p in build_index(out, proxies=records)["proxies"]] == [EAST_OF_SEOUL.name]
    write_tileset(out, TilesetOptions(proxies=False))
    assert "proxies" not in build_index(out, proxies=[])


def test_an_export_without_proxies_writes_a_tiles_json_without_them(tmp_path):
    config = Config(tileset=TilesetOptions(proxies=False))
    export([make_tile(tmp_path / "in", SEOUL, 1)], tmp_path / "out", config)
    assert "proxies" not in json.loads((tmp_path / "out" / "tiles.json").read_text())
