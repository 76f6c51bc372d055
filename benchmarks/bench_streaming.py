"""The Unity streamer's resident texture memory and holes along a camera path (issue 35), the
streamer before issue 35 (every level of every building of each tile inside the load radius)
against this checkout's (one level per building by screen size, proxies kept until the
buildings show).

The city: ``--side`` x ``--side`` generated level-15 tiles (exporter.samplegen, ``--atlas`` px
LOD0 atlases) of ``--per-tile`` buildings each, exported once into ``--work`` (kept: a second run
reuses it) with its tileset proxies. Both streamers are the package's plain C# (Runtime/Plan),
compiled with mono's ``mcs`` beside the driver ``bench_streaming.cs``: the baseline from
``git show BASELINE:unity_package/Runtime/Plan/*.cs``. Their backends are fakes whose loads
complete on the next frame and which count texture bytes as Unity allocates them: each level's
``texture_size`` from its manifest and each proxy's images (read from its .glb) x
``--bytes-per-pixel`` (4: glTFast's RGBA32; 1: BC7/ASTC 4x4; 0.5: DXT1) x 4/3 (mip chain); the
new streamer's proxies without the finest mip levels it asks to leave out (``mipmapLimit``;
``--proxy-texture-sse``).

The camera path (scene frame East/Up/North at the city centre, metres; ``--speed`` m per frame):
from 600 m up, 1.5 km south of the centre, down to 20 m above the ground at the city's south
edge, north across the city at street level, then east, then up to 600 m and away north; a
``--warmup`` of still frames at the start. Load and unload radii ``--load`` / ``--load`` x 1.3.

Per frame (``--every N`` prints every Nth): resident texture bytes (levels + proxies) and holes
(tiles of the export showing neither a visible proxy over them nor every building their
LODGroups would draw at that distance); then the peaks, their ratio, and the holes summed.
Target (issue 35): peak resident bytes of the new streamer at most 1/8 of the baseline's; 0 holes.

``--main-thread``: instead, what stays on Unity's main thread per level load, measured outside
Unity on the same files: decoding each level's JPEG atlas (PIL's libjpeg; glTFast calls
``ImageConversion.LoadImage`` there) and building its mip chain (2x2 box filters, PIL's C
``reduce``, as ``Texture2D.Apply`` does natively), best of ``--repeat``, for one building's levels and one proxy.

Usage: ``python benchmarks/bench_streaming.py [--work /tmp/vworld-streaming] [--side 12]
[--per-tile 4] [--atlas 512] [--load 500] [--speed 5] [--every 25] [--baseline d76414f]
[--proxy-texture-sse 16] [--main-thread [--repeat 7]]``
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from exporter.config import Config  # noqa: E402
from exporter.model import GeoPoint, TileId  # noqa: E402
from exporter.pipeline import export_tiles  # noqa: E402
from exporter.placement import enu_offset  # noqa: E402
from exporter.samplegen import generate_tile  # noqa: E402
from exporter.tileset.glb import read_primitives  # noqa: E402

# The last commit before issue 35's streamer: TileStreamer queued every level of every building.
BASELINE = "d76414f89027b28b976cf8985616cf3f456c03ac"
FIRST_TILE = TileId(15, 279418, 116113)
EARTH_RADIUS_M = 6378137.0
SCREEN_HEIGHT_PX, FOV_DEG = 1080.0, 60.0


def make_city(work: Path, side: int, per_tile: int, atlas: int) -> Path:
    """Generate and export the city once (``work/out``); returns its tiles.json."""
    out = work / "out"
    if (out / "tiles.json").is_file():
        return out / "tiles.json"
    tiles = [
        TileId(15, FIRST_TILE.idx + dx, FIRST_TILE.idy + dy)
        for dx in range(side)
        for dy in range(side)
    ]
    folders = [
        generate_tile(work / "in" / t.name, per_tile, seed=i, tile=t, atlas_size=atlas)
        for i, t in enumerate(tiles)
    ]
    export_tiles(folders, out, Config(), jobs=1)
    return out / "tiles.json"


def texture_bytes(width: int, height: int, bytes_per_pixel: float) -> int:
    """Bytes Unity allocates for a width x height texture with its mip chain (+1/3)."""
    return math.ceil(width * height * bytes_per_pixel * 4.0 / 3.0)


def level_tables(index: dict, folder: Path, bytes_per_pixel: float) -> tuple[dict, dict]:
    """(bytes per "tile/building/level", [LODGroup.size, bounds centre East, Up, North] in metres
    per "tile/building") from the manifests: texture_size per level; LOD0's gltf_bounds (glTF
    +X West, so East is -x; 30 m and the origin without)."""
    level_bytes, sizes = {}, {}
    for entry in index["tiles"]:
        manifest = json.loads((folder / entry["manifest"]).read_text(encoding="utf-8"))
        for b in manifest["buildings"]:
            key = f"{entry['name']}/{b['id']}"
            bounds = b["lods"][0].get("gltf_bounds")
            if bounds:
                low, high = np.array(bounds["low"]), np.array(bounds["high"])
                mid = (low + high) / 2
                sizes[key] = [float(max(high - low)), float(-mid[0]), float(mid[1]), float(mid[2])]
            else:
                sizes[key] = [30.0, 0.0, 0.0, 0.0]
            for k, lod in enumerate(b["lods"]):
                w, h = lod["texture_size"]
                level_bytes[f"{key}/{k}"] = texture_bytes(w, h, bytes_per_pixel)
    return level_bytes, sizes


def proxy_images(index: dict, folder: Path) -> dict:
    """[width, height] of each proxy's distinct images (read from the .glb), per proxy name."""
    from PIL import Image

    table = {}
    for p in index.get("proxies", []):
        seen, sizes = set(), []
        for prim in read_primitives(folder / p["file"]):
            if prim.image is None:
                continue
            digest = hashlib.sha1(prim.image).digest()
            if digest in seen:
                continue
            seen.add(digest)
            sizes.append(list(Image.open(io.BytesIO(prim.image)).size))
        table[p["name"]] = sizes
    return table


def proxy_bytes(images: dict, bytes_per_pixel: float) -> dict:
    """Bytes per proxy: its images (``proxy_images``) whole, as Unity allocates them."""
    return {
        name: sum(texture_bytes(w, h, bytes_per_pixel) for w, h in sizes)
        for name, sizes in images.items()
    }


def camera_path(index: dict, origin: GeoPoint, speed: float) -> list[list[float]]:
    """Scene positions (East, Up, North metres at origin), ``speed`` metres apart."""
    centres = np.array(
        [
            enu_offset(
                GeoPoint(t["center"]["lon"], t["center"]["lat"], 0.0), origin, EARTH_RADIUS_M
            )
            for t in index["tiles"]
        ]
    )
    south, north = float(centres[:, 2].min()), float(centres[:, 2].max())
    west, east = float(centres[:, 0].min()), float(centres[:, 0].max())
    ground = 20.0
    stops = [
        (0.0, 600.0, south - 1500.0),
        (0.0, ground, south),
        (0.0, ground, north),
        (east, ground, north),
        (east, 600.0, north + 300.0),
        (east, 600.0, north + 1500.0),
    ]
    del west
    path = [list(stops[0])]
    for a, b in zip(stops, stops[1:]):
        a_, b_ = np.array(a), np.array(b)
        steps = max(1, math.ceil(float(np.linalg.norm(b_ - a_)) / speed))
        path += [list(map(float, a_ + (b_ - a_) * i / steps)) for i in range(1, steps + 1)]
    return path


def plan_sources(baseline: str | None, into: Path) -> Path:
    """Runtime/Plan of this checkout (baseline None) or of the baseline commit, in a folder."""
    plan = REPO / "unity_package" / "Runtime" / "Plan"
    if baseline is None:
        return plan
    into.mkdir(parents=True, exist_ok=True)
    names = subprocess.run(
        [
            "git",
            "-C",
            str(REPO),
            "ls-tree",
            "--name-only",
            f"{baseline}:unity_package/Runtime/Plan",
        ],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    for name in names:
        if name.endswith(".cs"):
            text = subprocess.run(
                ["git", "-C", str(REPO), "show", f"{baseline}:unity_package/Runtime/Plan/{name}"],
                capture_output=True,
                check=True,
            ).stdout
            (into / name).write_bytes(text)
    return into


def compile_driver(work: Path, baseline: str) -> dict[str, Path]:
    """The driver compiled against the baseline's streamer ("old") and this checkout's ("new")."""
    mcs = shutil.which("mcs")
    if not mcs or not shutil.which("mono"):
        raise SystemExit("mono's mcs and mono are needed: apt-get install mono-mcs mono-runtime")
    driver = Path(__file__).with_suffix(".cs")
    built = {}
    for kind, source in (
        ("old", plan_sources(baseline, work / "baseline_plan")),
        ("new", plan_sources(None, work)),
    ):
        exe = work / f"bench_streaming_{kind}.exe"
        args = [mcs, "-nologo", f"-out:{exe}", "-r:System.Core.dll"]
        args += ["-define:NEW"] if kind == "new" else []
        args += [str(driver)] + sorted(str(p) for p in source.glob("*.cs"))
        result = subprocess.run(args, capture_output=True, text=True, timeout=300)
        if result.returncode != 0:
            raise SystemExit(f"mcs failed for {kind}:\n{result.stdout}\n{result.stderr}")
        built[kind] = exe
    return built


def run_driver(exe: Path, spec_path: Path) -> list[tuple[int, int, int, int, int, int]]:
    """(frame, resident, level bytes, proxy bytes, holes, loads started) per frame."""
    result = subprocess.run(
        ["mono", str(exe), str(spec_path)], capture_output=True, text=True, timeout=1200
    )
    if result.returncode != 0:
        raise SystemExit(f"{exe.name} failed:\n{result.stdout[-2000:]}\n{result.stderr[-4000:]}")
    rows = []
    for line in result.stdout.splitlines():
        if line.startswith("FRAME "):
            rows.append(tuple(int(v) for v in line.split()[1:]))
    return rows


def measure(
    work: Path,
    side: int,
    per_tile: int,
    atlas: int,
    load: float,
    speed: float,
    bytes_per_pixel: float,
    warmup: int,
    baseline: str,
    budget_mib: float = 512.0,
    proxy_texture_sse: float | None = None,
) -> dict:
    """Both streamers along the path: {"old": rows, "new": rows, "frames": n}."""
    work.mkdir(parents=True, exist_ok=True)
    index_path = make_city(work, side, per_tile, atlas)
    index = json.loads(index_path.read_text(encoding="utf-8"))
    lons = [t["center"]["lon"] for t in index["tiles"]]
    lats = [t["center"]["lat"] for t in index["tiles"]]
    origin = GeoPoint((min(lons) + max(lons)) / 2, (min(lats) + max(lats)) / 2, 0.0)
    levels, sizes = level_tables(index, index_path.parent, bytes_per_pixel)
    images = proxy_images(index, index_path.parent)
    spec = {
        "index": str(index_path),
        "origin": {"lon": origin.lon, "lat": origin.lat},
        "settings": {
            "load": load,
            "unload": load * 1.3,
            "max": 4,
            "budget": budget_mib * 1024 * 1024,
            "bytes_per_pixel": bytes_per_pixel,
        },
        "screen_height": SCREEN_HEIGHT_PX,
        "fov": FOV_DEG,
        "warmup": warmup,
        "camera": camera_path(index, origin, speed),
        "level_bytes": levels,
        "building_size": sizes,
        "proxy_bytes": proxy_bytes(images, bytes_per_pixel),
        "proxy_images": images,
    }
    if proxy_texture_sse is not None:
        spec["proxy_texture_sse"] = proxy_texture_sse
    spec_path = work / "spec.json"
    spec_path.write_text(json.dumps(spec), encoding="utf-8")
    exes = compile_driver(work, baseline)
    return {kind: run_driver(exe, spec_path) for kind, exe in exes.items()}


def summary(rows: dict) -> dict:
    """Peaks (all textures, building levels, proxies), the new/old ratios and the holes summed."""
    peak = {k: max(r[1] for r in v) for k, v in rows.items()}
    levels = {k: max(r[2] for r in v) for k, v in rows.items()}
    proxies = {k: max(r[3] for r in v) for k, v in rows.items()}
    holes = {k: sum(r[4] for r in v) for k, v in rows.items()}
    frames_with_holes = {k: sum(1 for r in v if r[4]) for k, v in rows.items()}
    return {
        "peak": peak,
        "ratio": peak["new"] / peak["old"],
        "levels": levels,
        "levels_ratio": levels["new"] / levels["old"],
        "proxies": proxies,
        "holes": holes,
        "frames_with_holes": frames_with_holes,
        "loads": {k: v[-1][5] for k, v in rows.items()},
    }


def mip_chain(image):  # PIL.Image.Image -> list of its mip levels below it
    """The mip levels below an RGBA image, each a 2x2 box filter of the one above (PIL's C
    ``reduce``, as native as Unity's own mip generation)."""
    levels = []
    while image.width > 1 or image.height > 1:
        image = image.reduce((2 if image.width > 1 else 1, 2 if image.height > 1 else 1))
        levels.append(image)
    return levels


def main_thread_costs(index_path: Path, repeat: int) -> list[tuple[str, int, float, float]]:
    """(what, texels a side, decode ms, mip chain ms) for one building's levels and one proxy."""
    import time

    from PIL import Image

    index = json.loads(index_path.read_text(encoding="utf-8"))
    folder = index_path.parent
    entry = index["tiles"][0]
    manifest = json.loads((folder / entry["manifest"]).read_text(encoding="utf-8"))
    building = max(manifest["buildings"], key=lambda b: b["lods"][0]["texture_size"][0])
    files = [
        (f"LOD{k}", folder / Path(entry["manifest"]).parent / lod["file"])
        for k, lod in enumerate(building["lods"])
    ]
    proxy = min(index.get("proxies", []), key=lambda p: p["level"], default=None)
    if proxy:
        files.append((f"proxy (level {proxy['level']})", folder / proxy["file"]))
    rows = []
    for what, path in files:
        images = [p.image for p in read_primitives(path) if p.image is not None]
        if not images:
            continue
        best_decode = best_mips = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            rgba = Image.open(io.BytesIO(images[0])).convert("RGBA")  # glTFast's R8G8B8A8
            rgba.load()
            t1 = time.perf_counter()
            mip_chain(rgba)
            t2 = time.perf_counter()
            best_decode, best_mips = min(best_decode, t1 - t0), min(best_mips, t2 - t1)
        rows.append((what, int(rgba.width), best_decode * 1000, best_mips * 1000))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/vworld-streaming"))
    ap.add_argument("--side", type=int, default=12)
    ap.add_argument("--per-tile", type=int, default=4)
    ap.add_argument("--atlas", type=int, default=512)
    ap.add_argument("--load", type=float, default=500.0)
    ap.add_argument("--speed", type=float, default=5.0)
    ap.add_argument("--bytes-per-pixel", type=float, default=4.0)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--every", type=int, default=25)
    ap.add_argument("--baseline", default=BASELINE)
    ap.add_argument(
        "--proxy-texture-sse",
        type=float,
        default=None,
        help="StreamingSettings.ProxyTextureScreenSpaceError, px (0: proxies' textures whole)",
    )
    ap.add_argument("--main-thread", action="store_true")
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args()
    if a.main_thread:
        a.work.mkdir(parents=True, exist_ok=True)
        index_path = make_city(a.work, a.side, a.per_tile, a.atlas)
        print("| level load | texels a side | JPEG decode ms | mip chain ms |")
        print("|---|---|---|---|")
        for what, side, decode_ms, mips_ms in main_thread_costs(index_path, a.repeat):
            print(f"| {what} | {side} | {decode_ms:.1f} | {mips_ms:.1f} |")
        return
    rows = measure(
        a.work,
        a.side,
        a.per_tile,
        a.atlas,
        a.load,
        a.speed,
        a.bytes_per_pixel,
        a.warmup,
        a.baseline,
        proxy_texture_sse=a.proxy_texture_sse,
    )
    mib = 1024.0 * 1024.0
    print("resident texture MiB (levels + proxies) and holes per frame, before issue 35 | now")
    print(
        f"{'frame':>6} {'MiB':>7} {'levels':>7} {'holes':>5} | {'MiB':>7} {'levels':>7} {'holes':>5}"
    )
    for old, new in zip(rows["old"], rows["new"]):
        if old[0] % a.every == 0 or old[4] or new[4]:
            print(
                f"{old[0]:6d} {old[1] / mib:7.1f} {old[2] / mib:7.1f} {old[4]:5d} | "
                f"{new[1] / mib:7.1f} {new[2] / mib:7.1f} {new[4]:5d}"
            )
    s = summary(rows)
    print(
        f"peak resident textures: before {s['peak']['old'] / mib:.1f} MiB, now "
        f"{s['peak']['new'] / mib:.1f} MiB: {s['ratio']:.3f}x (target <= 0.125)"
    )
    print(
        f"  building levels: before {s['levels']['old'] / mib:.1f} MiB, now "
        f"{s['levels']['new'] / mib:.1f} MiB: {s['levels_ratio']:.3f}x; proxies: before "
        f"{s['proxies']['old'] / mib:.1f} MiB, now {s['proxies']['new'] / mib:.1f} MiB"
    )
    print(
        f"holes (tile-frames): before {s['holes']['old']} in {s['frames_with_holes']['old']} "
        f"frames, now {s['holes']['new']} in {s['frames_with_holes']['new']} frames (target 0); "
        f"loads started: before {s['loads']['old']}, now {s['loads']['new']}"
    )


if __name__ == "__main__":
    main()
