"""Hierarchical tile proxies (issue 37; issue 34's proxy items): a parent's proxy is built from its
children's proxies, its certified error still bounds a dense measure against the LOD0 below it,
every vertex keeps its building, the texel is measured on the surface, the bytes do not depend
on where the proxies were built, and a changed tile rebuilds only its own proxy and its
ancestors'."""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from exporter.config import Config, TilesetOptions
from exporter.mesh.distance import SurfaceIndex
from exporter.model import TileId
from exporter.pipeline import export_tiles
from exporter.samplegen import generate_tile
from exporter.texel import texel_size_m
from exporter.tileset import write_tileset
from exporter.tileset.glb import read_primitives
from exporter.tileset.proxy import (
    PROXY_TEXEL_FACTOR,
    LevelSource,
    atlas_sizes,
    finest_fitting,
    owner_runs,
    owners_of,
)
from tests import test_tileset
from tests.tileset_check import content_mesh, load, structural_problems, walk

# Four level-15 tiles in two level-14 tiles, under one level-13 tile: two levels of parents.
TILES = [
    TileId(15, 279416, 116112),
    TileId(15, 279417, 116112),
    TileId(15, 279418, 116112),
    TileId(15, 279419, 116112),
]
TOP = "13_69854_29028"


def make_inputs(root: Path, seed: int = 0) -> list[Path]:
    return [
        generate_tile(
            root / tile.name, 3, seed=seed + i, tile=tile, atlas_size=64, mean_triangles=80
        )
        for i, tile in enumerate(TILES)
    ]


@pytest.fixture(scope="module")
def quad(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("quad")
    out = root / "out"
    export_tiles(make_inputs(root / "in"), out, Config(), jobs=1)
    return out


def proxy_files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "tileset_proxies").iterdir())}


def records(out: Path) -> dict[str, dict]:
    return {p.stem: json.loads(p.read_text()) for p in (out / "tileset_proxies").glob("*.json")}


def test_two_levels_of_parents_are_valid_and_every_error_bounds_the_lod0_below(quad):
    tileset = load(quad)
    assert structural_problems(quad, tileset) == []
    proxies = sorted(v.uri for v in walk(tileset) if (v.uri or "").startswith("tileset_proxies/"))
    assert proxies == [
        f"tileset_proxies/{name}.glb"
        for name in [TOP, "14_139708_58056", "14_139709_58056"] + [t.name for t in TILES]
    ]
    # The dense measure of the simpler fixture, on proxies made of proxies made of proxies.
    test_tileset.test_every_proxy_error_bounds_its_distance_to_the_lod0_below_it(quad)


def test_a_parent_reads_its_children_s_proxies_not_the_buildings(quad, tmp_path, monkeypatch):
    from exporter.tileset import proxy

    out = tmp_path / "out"
    shutil.copytree(quad, out)
    read: list[str] = []
    real = proxy.read_primitives

    def recorded(path):
        read.append(Path(path).relative_to(out).as_posix())
        return real(path)

    monkeypatch.setattr(proxy, "read_primitives", recorded)
    result = write_tileset(out, TilesetOptions(), force=True)
    assert result.proxies_built == 7
    from_proxies = sorted(name for name in read if name.startswith("tileset_proxies/"))
    # Each parent reads each child proxy once; the leaves read their buildings' levels
    assert from_proxies == sorted(
        f"tileset_proxies/{name}.glb"
        for name in ["14_139708_58056", "14_139709_58056"] + [t.name for t in TILES]
    )
    # Each building's levels once each: its coarsest (the geometry, 12 buildings), then finer
    # ones as the atlas grows (LOD1's 32 px fill a 32 px cell; LOD0's 64 px, the finest, a 64 px
    # one), never more than its three levels
    assert len(read) == len(set(read))
    assert 12 < len(read) - len(from_proxies) <= 36
    assert all(
        name.endswith(("/lod0.glb", "/lod1.glb", "/lod2.glb"))
        for name in read
        if name not in from_proxies
    )
    assert proxy_files(out) == proxy_files(quad)  # force rebuilds the same bytes


def test_every_vertex_keeps_its_building(quad):
    """Per proxy, each vertex lies within the proxy's error of its owner building's LOD0 (the
    feature id survives merging and simplification) and the owners cover every vertex."""
    visits = {
        v.uri.split("/")[-1][:-4]: v
        for v in walk(load(quad))
        if (v.uri or "").startswith("tileset_proxies/")
    }
    lod0 = {}
    for visit in walk(load(quad)):
        if visit.uri and "/lod0" in visit.uri:
            tile, folder = visit.uri.split("/")[:2]
            manifest = json.loads((quad / tile / "lod_manifest.json").read_text())
            ids = {b["folder"]: b["id"] for b in manifest["buildings"]}
            lod0[f"{tile}/{ids[folder]}"] = content_mesh(quad, visit)
    for name, record in records(quad).items():
        positions, faces = content_mesh(quad, visits[name])
        owners = owners_of(record["owners"], len(positions))
        assert sorted(set(owners.tolist())) == list(range(len(record["buildings"])))
        origin = positions.mean(axis=0)
        error = visits[name].tile["geometricError"]
        for index, building in enumerate(record["buildings"]):
            own = positions[owners == index] - origin
            reference = lod0[building]
            distance = SurfaceIndex(reference[0] - origin, reference[1]).max_distance(own)
            assert distance <= error, (name, building)
    # A leaf holds its own tile's buildings; the top all twelve.
    assert all(b.startswith(f"{TILES[0].name}/") for b in records(quad)[TILES[0].name]["buildings"])
    assert len(records(quad)[TOP]["buildings"]) == 12


def test_each_proxy_s_error_is_at_least_half_its_atlas_texel_on_the_surface(quad):
    for visit in walk(load(quad)):
        if not (visit.uri or "").startswith("tileset_proxies/"):
            continue
        (primitive,) = read_primitives(quad / visit.uri)
        assert primitive.image is not None and primitive.uvs is not None
        size = Image.open(io.BytesIO(primitive.image)).size
        texel = texel_size_m(primitive.positions, primitive.triangles, primitive.uvs, size)
        assert texel > 0
        assert visit.tile["geometricError"] >= 0.5 * texel


def test_the_finest_level_that_fits_fills_a_cell_by_filtering_down(quad, tmp_path):
    levels = [LevelSource("a", 2.0, 16), LevelSource("b", 1.0, 32), LevelSource("c", 0.0, 64)]
    assert finest_fitting(levels, 8).file == "a"
    assert finest_fitting(levels, 17).file == "b"
    assert finest_fitting(levels, 64).file == "c"
    assert finest_fitting(levels, 500).file == "c"  # nothing that large: the finest there is
    untextured = [LevelSource("a", 2.0, 0), LevelSource("c", 0.0, 0)]
    assert finest_fitting(untextured, 8).file == "a"
    # In an export: each leaf is its buildings' coarsest levels (triangles as the manifest says),
    # textured from the finest level whose texture fills the cell.
    out = tmp_path / "out"
    shutil.copytree(quad, out)
    for size in (16, 2048):  # cells of 8 px (LOD2's 16 px fit) and, at most, 1024 px
        write_tileset(out, TilesetOptions(proxy_atlas_size=size, proxy_error_ratio=0.0))
        for tile in TILES:
            manifest = json.loads((out / tile.name / "lod_manifest.json").read_text())
            buildings = sorted(manifest["buildings"], key=lambda b: b["id"])  # the cells' order
            coarsest = [max(b["lods"], key=lambda lod: lod["level"]) for b in buildings]
            assert records(out)[tile.name]["triangles"] == sum(c["triangles"] for c in coarsest)
            (proxy,) = read_primitives(out / "tileset_proxies" / f"{tile.name}.glb")
            assert proxy.image is not None
            atlas = np.asarray(Image.open(io.BytesIO(proxy.image)).convert("RGB"), np.float64)
            # three buildings: two cells a side; at most 2048 px, the atlas grows until its
            # texels are within a quarter of the error the tile is shown at (its buildings'
            # coarsest levels' geometricError: their LOD2 atlas's texels x 4): 64 px, cells of
            # 32 px, which LOD1's 32 px fill (LOD2's 16 px would be scaled up)
            assert atlas.shape[0] == (16 if size == 16 else 64)
            cell = atlas.shape[0] // 2
            for index, building in enumerate(buildings if size == 2048 else []):
                row, col = divmod(index, 2)
                got = atlas[row * cell : (row + 1) * cell, col * cell : (col + 1) * cell]
                by_level = {}
                for lod in building["lods"]:
                    (level,) = read_primitives(out / tile.name / lod["file"])
                    assert level.image is not None
                    image = Image.open(io.BytesIO(level.image)).convert("RGB")
                    scaled = image.resize((cell, cell), Image.Resampling.BOX)
                    by_level[lod["level"]] = np.abs(np.asarray(scaled, np.float64) - got).mean()
                # LOD1 fills a 32 px cell: its texture (not the coarsest level's, scaled up)
                assert by_level[1] == min(by_level.values()), by_level


def test_owner_runs_round_trip():
    owners = np.array([0, 0, 1, 1, 1, 0, 2])
    assert owner_runs(owners) == [[0, 2], [1, 3], [0, 1], [2, 1]]
    assert owners_of(owner_runs(owners), 7).tolist() == owners.tolist()
    with pytest.raises(ValueError):
        owners_of([[0, 2]], 3)


def test_the_same_bytes_from_one_job_a_pool_and_a_local_dask_cluster(quad, tmp_path):
    pytest.importorskip(
        "distributed", reason="dask.distributed not installed: pip install -e '.[test]'"
    )
    for name, kwargs in (("pool", {"jobs": 2}), ("dask", {"jobs": 2, "scheduler": "local"})):
        out = tmp_path / name
        shutil.copytree(quad, out)
        shutil.rmtree(out / "tileset_proxies")
        (out / "tileset.json").unlink()
        inputs = sorted((quad.parent / "in").iterdir())
        stats = export_tiles(inputs, out, Config(), **kwargs)
        assert stats.reused == 12
        assert stats.tileset is not None and stats.tileset.proxies_built == 7
        assert stats.tileset.proxies_on_workers >= 6, name  # the leaves and the level-14 pair
        assert proxy_files(out) == proxy_files(quad), name
        assert (out / "tileset.json").read_bytes() == (quad / "tileset.json").read_bytes()


def test_a_changed_tile_rebuilds_its_proxy_and_its_ancestors_only(quad, tmp_path):
    root = tmp_path / "in"
    shutil.copytree(quad.parent / "in", root)
    out = tmp_path / "out"
    shutil.copytree(quad, out)
    before = {p.name: p.stat().st_mtime_ns for p in (out / "tileset_proxies").glob("*.glb")}
    changed = TILES[3]
    shutil.rmtree(root / changed.name)
    generate_tile(root / changed.name, 3, seed=99, tile=changed, atlas_size=64, mean_triangles=80)
    stats = export_tiles(sorted(root.iterdir()), out, Config(), jobs=1)
    assert stats.tileset is not None and stats.tileset.proxies_built == 3
    after = {p.name: p.stat().st_mtime_ns for p in (out / "tileset_proxies").glob("*.glb")}
    same = {name for name in before if before[name] == after[name]}
    assert same == {f"{t.name}.glb" for t in TILES[:3]} | {"14_139708_58056.glb"}
    test_tileset.test_every_proxy_error_bounds_its_distance_to_the_lod0_below_it(out)
    assert os.path.exists(out / "tileset_proxies" / f"{TOP}.glb")


def test_the_clustering_bound_holds_densely_on_small_and_isolated_parts():
    """Boxes of several sizes (some smaller than a cell, one far from the rest) and a thin pole:
    the clustering's bound is at least the dense Hausdorff distance of input and output, every
    output vertex keeps its building, and the far small box is kept, not dropped."""
    import trimesh

    from exporter.tileset.cluster import cluster
    from tests.hausdorff_check import dense_hausdorff

    parts = [
        trimesh.creation.box((20, 12, 9)),
        trimesh.creation.box((0.8, 0.8, 0.8)).apply_translation((10.5, 6.5, 0)),  # on the roof edge
        trimesh.creation.box((0.3, 0.3, 8)).apply_translation((0, 0, 8.5)),  # a pole above the roof
        trimesh.creation.box((1.0, 1.0, 1.0)).apply_translation((60, 0, 0)),  # small, isolated
        trimesh.creation.box((7, 5, 3)).apply_translation((0, 20, 0)),
    ]
    positions = np.concatenate([p.vertices for p in parts])
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
    faces = np.concatenate([p.faces + offsets[i] for i, p in enumerate(parts)])
    owners = np.repeat(np.arange(len(parts)), [len(p.vertices) for p in parts])
    uvs = np.zeros((len(positions), 2))
    for cell in (0.5, 2.0, 6.0):
        done = cluster(positions, faces, uvs, owners, cell, keep_beyond=cell)
        assert np.all(np.diff(done.owners) >= 0)
        assert np.array_equal(done.owners, owners[done.source])
        measured = dense_hausdorff((positions, faces), (done.positions, done.faces), 6)
        assert measured <= done.bound + 1e-9, (cell, measured, done.bound)
        far = done.owners == 3
        assert far.any()  # the isolated box: kept (as it was or clustered)


@pytest.fixture(scope="module")
def fine(tmp_path_factory) -> Path:
    """One tile of three buildings whose 256 px atlases are finer than a small proxy needs."""
    root = tmp_path_factory.mktemp("fine")
    folder = generate_tile(
        root / "in" / TILES[0].name, 3, seed=7, tile=TILES[0], atlas_size=256, mean_triangles=80
    )
    export_tiles([folder], root / "out", Config(), jobs=1)
    return root / "out"


def leaf_atlas(out: Path, options: TilesetOptions) -> tuple[int, float, dict]:
    """The one leaf proxy rebuilt with ``options``: its atlas side (pixels, from the file), its
    texel measured on the written file (metres) and its record; also checks its tileset error."""
    write_tileset(out, options, force=True)
    name = TILES[0].name
    (primitive,) = read_primitives(out / "tileset_proxies" / f"{name}.glb")
    assert primitive.image is not None and primitive.uvs is not None
    side, height = Image.open(io.BytesIO(primitive.image)).size
    assert side == height
    texel = texel_size_m(primitive.positions, primitive.triangles, primitive.uvs, (side, side))
    record = records(out)[name]
    assert record["atlas_px"] == side
    (visit,) = [v for v in walk(load(out)) if v.uri == f"tileset_proxies/{name}.glb"]
    error = visit.tile["geometricError"]
    assert error >= record["texel"] and error >= record["geometric"]
    assert error >= 0.5 * texel  # issue 34's bar on the atlas actually written
    return side, texel, record


def test_a_proxy_s_atlas_is_as_fine_as_its_error_lets_a_viewer_see(fine, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(fine, out)
    # Merged only (its bound: the coarsest levels', centimetres) against simplified on 6 m cells
    # (a bound of metres): the coarser proxy's texels may be coarser, its atlas smaller.
    exact = leaf_atlas(out, TilesetOptions(proxy_error_ratio=0.0))
    coarse = leaf_atlas(out, TilesetOptions(proxy_error_ratio=0.1))
    assert coarse[2]["geometric"] > 10 * exact[2]["geometric"]
    assert coarse[0] <= exact[0] < 2048  # (2048 for every proxy before 0.6.0)
    for side, texel, record in (exact, coarse):
        if side == 2048:
            continue
        # Below the maximum: texels within 1/4 of the error the tile is shown at (4 px where
        # the proxy switches at 16 px), unless the cells already hold their finest images whole
        # (LOD0's 256 px).
        shown = max(record["geometric"], record["shown_floor"])
        if side // 2 < 256:
            assert record["texel"] <= shown / PROXY_TEXEL_FACTOR
        # The smallest such size: half the side would double the texel, past 1/4 of that error
        if side // 2 > 64:
            assert 2 * texel > shown / PROXY_TEXEL_FACTOR
    # The record's texel is the one measured on the file (within the float32 rounding of the uvs)
    assert coarse[2]["texel"] == pytest.approx(coarse[1], rel=1e-3)


def test_proxy_atlas_size_is_the_largest_atlas(fine, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(fine, out)
    for largest in (64, 50):  # a power of two or not: never exceeded, taken when needed
        side, texel, record = leaf_atlas(
            out, TilesetOptions(proxy_error_ratio=0.0, proxy_atlas_size=largest)
        )
        assert side == largest
        shown = max(record["geometric"], record["shown_floor"])
        assert record["texel"] > shown / PROXY_TEXEL_FACTOR  # as fine as allowed
    assert atlas_sizes(3, 2048) == [64, 128, 256, 512, 1024, 2048]
    assert atlas_sizes(3, 100) == [64, 100] and atlas_sizes(3, 16) == [16]
    # 400 cells: 20 a side; 64 px would leave 3 px cells (under MIN_CELL_PX), so from 128 px
    assert atlas_sizes(400, 2048) == [128, 256, 512, 1024, 2048]
