"""A whole city through the tileset: draw calls, triangles and content bytes along a camera path,
with the tiles' HLOD proxies and with per-building chains only (issue 25).

The city: ``--side`` x ``--side`` generated level-15 tiles (exporter.samplegen) of
``--per-tile`` buildings each (default 4 x 4 x 250 = 4,000), exported once into ``--work``
(kept: a second run reuses it). The camera path: ``--frames`` views from 3 km above the city
centre, looking straight down, to street level (2 m above the lowest building base) looking
north, 10 degrees down; 1920 x 1080 pixels, 60 degree vertical field of view.

Per frame, the tiles a 3D Tiles client selects by the specification's screen-space-error rule at
``--sse`` pixels (Cesium's default 16): from the root, a visible tile (bounding sphere of its box
against the view frustum) is refined while ``geometricError * height / (distance * 2 tan(fov/2))``
exceeds the limit (distance to its box), else its content is drawn (REPLACE); a tile without
content that need not be refined draws nothing. Draw calls are the selected contents' glTF
primitives, triangles their index counts / 3, bytes their file sizes. "chains only" is the
same tileset without proxies (built in memory from the same manifests).

``--tile-check N`` (default 1,248; 0 skips it) also exports a generated N-building tile (1024 px
atlases, as bench_throughput.py) with the tileset off, then writes its tileset with proxies from
scratch in the same process: tileset seconds / export seconds.

Usage: ``python benchmarks/bench_city.py [--work /tmp/vworld-city] [--side 4] [--per-tile 250]
[--frames 12] [--sse 16] [--tile-check 1248] [--jobs 2]``
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import unquote

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from exporter.config import Config, TilesetOptions  # noqa: E402
from exporter.model import TileId  # noqa: E402
from exporter.pipeline import export_tiles  # noqa: E402
from exporter.samplegen import generate_tile  # noqa: E402
from exporter.tiles import tile_bounds  # noqa: E402
from exporter.tileset import write_tileset  # noqa: E402
from exporter.tileset.frames import ecef_of, enu_to_ecef  # noqa: E402
from exporter.tileset.glb import read_header  # noqa: E402
from exporter.tileset.tree import quadtree, read_buildings  # noqa: E402
from exporter.tileset.write import tileset_json  # noqa: E402
from tests.tileset_check import load  # noqa: E402

WIDTH, HEIGHT, FOV = 1920, 1080, math.radians(60.0)
FIRST_TILE = TileId(15, 279418, 116113)


def make_city(work: Path, side: int, per_tile: int, jobs: int) -> Path:
    """Generate and export the city once (``work/out``); later runs reuse it."""
    out = work / "out"
    if (out / "tileset.json").is_file():
        return out
    folders = []
    for i in range(side):
        for j in range(side):
            tile = TileId(15, FIRST_TILE.idx + i, FIRST_TILE.idy + j)
            folders.append(
                generate_tile(
                    work / "in" / tile.name,
                    per_tile,
                    seed=100 + i * side + j,
                    tile=tile,
                    atlas_size=256,
                    jobs=jobs,
                )
            )
    export_tiles(folders, out, Config(), jobs=jobs)
    return out


class Contents:
    """Draw calls, triangles and bytes of each content file (read once)."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.cache: dict[str, tuple[int, int, int]] = {}

    def __call__(self, uri: str) -> tuple[int, int, int]:
        if uri not in self.cache:
            path = self.out / unquote(uri)
            header = read_header(path)
            primitives = [p for m in header["meshes"] for p in m["primitives"]]
            triangles = sum(header["accessors"][p["indices"]]["count"] // 3 for p in primitives)
            self.cache[uri] = (len(primitives), triangles, path.stat().st_size)
        return self.cache[uri]


def flatten(tileset: dict) -> list[dict]:
    """Tiles with their world box (centre, half-axes in ECEF) and children indices."""
    nodes: list[dict] = []

    def visit(tile: dict, world: np.ndarray) -> int:
        if "transform" in tile:
            world = world @ np.array(tile["transform"]).reshape(4, 4).T
        box = np.array(tile["boundingVolume"]["box"])
        index = len(nodes)
        nodes.append(
            {
                "centre": world[:3, :3] @ box[:3] + world[:3, 3],
                "axes": box[3:].reshape(3, 3) @ world[:3, :3].T,
                # A tile referencing a tile's own tileset: clients always descend into it.
                "error": math.inf if "external" in tile else tile["geometricError"],
                "uri": tile.get("content", {}).get("uri"),
                "children": [],
            }
        )
        nodes[index]["children"] = [visit(c, world) for c in tile.get("children", [])]
        return index

    visit(tileset["root"], np.eye(4))
    return nodes


def path_heights(frames: int) -> list[float]:
    """Metres above the lowest building base, 3 km to 2 m, evenly on a log scale."""
    return [3000.0 * (2.0 / 3000.0) ** (k / max(frames - 1, 1)) for k in range(frames)]


def camera_path(
    out: Path, side: int, frames: int
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(position, forward, up) unit vectors and ECEF metres per frame: over the city centre looking
    straight down at 3 km, pitching up to 10 degrees down at street level, always aimed at the
    centre (from at most 300 m south of it)."""
    west, south, _, _ = tile_bounds(FIRST_TILE)
    last = TileId(15, FIRST_TILE.idx + side - 1, FIRST_TILE.idy + side - 1)
    _, _, east, north = tile_bounds(last)
    lon, lat = (west + east) / 2, (south + north) / 2
    ground = min(
        b["center"]["elev"]
        for m in out.glob("*/lod_manifest.json")
        for b in json.loads(m.read_text())["buildings"]
    )
    enu = enu_to_ecef(lon, lat, 0.0)[:3, :3]
    north_axis, up_axis = enu[:, 1], enu[:, 2]
    path = []
    heights = path_heights(frames)
    for k, height in enumerate(heights):
        t = k / max(frames - 1, 1)
        pitch = math.radians(-90.0 + 80.0 * t)
        back = min(height / math.tan(-pitch), 300.0)
        position = ecef_of(lon, lat, ground + height) - north_axis * back
        forward = north_axis * math.cos(pitch) + up_axis * math.sin(pitch)
        up = -north_axis * math.sin(pitch) + up_axis * math.cos(pitch)
        path.append((position, forward, up))
    return path


def frustum_planes(position, forward, up) -> list[tuple[np.ndarray, float]]:
    """Inward normals and offsets of the four side planes and the near plane."""
    right = np.cross(forward, up)
    half_v = FOV / 2
    half_h = math.atan(math.tan(half_v) * WIDTH / HEIGHT)
    normals = [
        forward,
        math.cos(half_h) * right + math.sin(half_h) * forward,
        -math.cos(half_h) * right + math.sin(half_h) * forward,
        math.cos(half_v) * up + math.sin(half_v) * forward,
        -math.cos(half_v) * up + math.sin(half_v) * forward,
    ]
    return [(n, float(n @ position)) for n in normals]


def box_distance(node: dict, position: np.ndarray) -> float:
    offset = position - node["centre"]
    excess = []
    for axis in node["axes"]:
        length = np.linalg.norm(axis)
        along = abs(offset @ axis / length) if length > 0 else 0.0
        excess.append(max(along - length, 0.0))
    return float(np.linalg.norm(excess))


def select(nodes: list[dict], camera, sse: float) -> list[str]:
    """Content URIs the specification's refinement rule draws from ``camera``."""
    position, forward, up = camera
    planes = frustum_planes(position, forward, up)
    scale = HEIGHT / (2.0 * math.tan(FOV / 2))
    drawn: list[str] = []

    def visit(index: int) -> None:
        node = nodes[index]
        radius = float(np.linalg.norm(node["axes"], axis=1).sum())
        if any(n @ node["centre"] - offset < -radius for n, offset in planes):
            return
        distance = max(box_distance(node, position), 1e-6)
        if node["error"] * scale / distance > sse and node["children"]:
            for child in node["children"]:
                visit(child)
        elif node["uri"] is not None:
            drawn.append(node["uri"])

    visit(0)
    return drawn


def measure(out: Path, tileset: dict, path, sse: float) -> list[tuple[int, int, int]]:
    contents, nodes = Contents(out), flatten(tileset)
    rows = []
    for camera in path:
        figures = [contents(uri) for uri in select(nodes, camera, sse)]
        rows.append(tuple(int(sum(f[i] for f in figures)) for i in range(3)))
    return rows


def tile_check(count: int, jobs: int) -> tuple[float, float, float]:
    """(export s with the tileset off, tileset s with proxies from scratch, without proxies)."""
    with tempfile.TemporaryDirectory(prefix="bench-city-") as scratch:
        root = Path(scratch)
        folder = generate_tile(
            root / "in" / FIRST_TILE.name, count, seed=0, atlas_size=1024, jobs=jobs
        )
        config = Config(tileset=TilesetOptions(enabled=False))
        started = time.perf_counter()
        export_tiles([folder], root / "out", config, jobs=jobs)
        exported = time.perf_counter() - started
        started = time.perf_counter()
        write_tileset(root / "out", TilesetOptions(proxies=False))
        plain = time.perf_counter() - started
        started = time.perf_counter()
        write_tileset(root / "out", TilesetOptions())
        return exported, time.perf_counter() - started, plain


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "vworld-city")
    parser.add_argument("--side", type=int, default=4)
    parser.add_argument("--per-tile", type=int, default=250)
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--sse", type=float, default=16.0)
    parser.add_argument("--tile-check", type=int, default=1248)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()

    out = make_city(args.work, args.side, args.per_tile, args.jobs)
    with_proxies = load(out)  # the tiles' own tilesets resolved, as a client holds them
    by_tile, left_out = read_buildings(out)
    chains_only = tileset_json(quadtree(by_tile), left_out)
    buildings = sum(len(v) for v in by_tile.values())
    path = camera_path(out, args.side, args.frames)
    proxied = measure(out, with_proxies, path, args.sse)
    chains = measure(out, chains_only, path, args.sse)
    print(
        f"city: {len(by_tile)} level-15 tiles, {buildings} buildings; SSE {args.sse:g} px, "
        f"{WIDTH}x{HEIGHT}, fov 60"
    )
    print(
        "| frame | height above ground (m) | draw calls proxies / chains | triangles proxies / chains | content MB proxies / chains |"
    )
    print("|---|---|---|---|---|")
    for k, (height, (d1, t1, b1), (d2, t2, b2)) in enumerate(
        zip(path_heights(args.frames), proxied, chains)
    ):
        print(
            f"| {k} | {height:.0f} | {d1} / {d2} | {t1:,} / {t2:,} | {b1 / 1e6:.1f} / {b2 / 1e6:.1f} |"
        )
    whole = proxied[0][0] / max(chains[0][0], 1)
    worse = [k for k, (p, c) in enumerate(zip(proxied, chains)) if p[0] > c[0]]
    print(f"whole-city view: draw calls proxies / chains = {whole:.5f} (done when <= 0.05)")
    print(f"frames with more draw calls than chains only: {worse or 'none'}")
    if args.tile_check:
        exported, proxies, plain = tile_check(args.tile_check, args.jobs)
        print(
            f"{args.tile_check}-building tile: export {exported:.1f} s (tileset off); tileset with "
            f"proxies {proxies:.2f} s = {proxies / exported:.3f} of the export (done when <= 0.25); "
            f"without proxies {plain:.2f} s"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
