"""City-scale benchmark of the export's tail (issue 37): 1, 4, 16 and 64 generated tiles.

For each size, a square block of generated level-15 VWorld-like tiles (``--buildings`` per tile,
the same for every size so that per-tile figures compare) is exported into a fresh ``OUT`` in a
child process (``--jobs``), which prints:

- building work: seconds from the start to the last building's result (reading, simplifying,
  certifying and writing every building, on the workers; tiles completed before then have their
  manifests and leaf proxies made meanwhile);
- tail: seconds from there to the end (what is left of the manifests and leaf proxies, the parent
  proxies, ``tiles.json``, ``tileset.json``), its share of the export and its seconds per tile;
- peak RSS (MiB) of the main process (``VmHWM``) and of its largest worker (``RUSAGE_CHILDREN``);
- proxies built and how many of them ran on pool or cluster workers;
- CPU seconds of the export's process and its finished workers (pool or local cluster).

Then, on the 16-tile ``OUT``: an unchanged re-run (against the first export), then one tile
changed (regenerated with another seed) and re-exported with the 15 others unchanged, against
that changed tile alone, two ways: exported into an empty ``OUT``, and re-exported into an
``OUT`` holding only its previous version (issue 37's words); ``--repeats`` times (another seed
each time; the median ratios are quoted: one pair moves by +-30 % on a shared machine);
and with ``--scheduler local`` on the 4 tiles, the proxies counted on the Dask workers and the
output compared byte for byte with the local pool's.

``--baseline DIR``: also run every export with the exporter found in DIR (e.g. ``git archive``
of an earlier commit, with the compiled kernels copied in) in the same run, for ratios.

Usage: ``python benchmarks/bench_city_scale.py [--sizes 1,4,16,64] [--buildings 60]
[--atlas 256] [--jobs 2] [--repeats 3] [--baseline DIR] [--workdir DIR]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# A child runs the exporter its PYTHONPATH names first (this checkout or --baseline's).
sys.path.insert(len(sys.path) if "--child" in sys.argv else 0, str(REPO))

FIRST = (279416, 116112)  # level-15 (idx, idy) of the block's south-west tile (aligned to 8)


def child_export(folders: list[str], out: str, jobs: int, scheduler: str | None) -> None:
    """Run one export in this (child) process and print its figures as JSON."""
    from exporter import pipeline
    from exporter.config import Config

    marks: list[float] = []

    def last_building(done: int, total: int) -> None:
        if done == total:
            marks.append(time.perf_counter())

    started = time.perf_counter()
    stats = pipeline.export_tiles(
        folders, out, Config(), jobs=jobs, progress=last_building, scheduler=scheduler
    )
    ended = time.perf_counter()
    # After the exporter's import: bench_throughput puts this checkout first on the path.
    from benchmarks.bench_throughput import peak_rss_mb

    main_mb, worker_mb = peak_rss_mb()
    # CPU seconds of this process and its finished workers: less sensitive than wall seconds to
    # other work on a shared machine (what the overlap must not add to).
    cpu = sum(
        usage.ru_utime + usage.ru_stime
        for usage in map(resource.getrusage, (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    )
    tileset = stats.tileset
    print(
        json.dumps(
            {
                "seconds": ended - started,
                "work": (marks[0] if marks else ended) - started,
                "tail": ended - (marks[0] if marks else ended),
                "buildings": stats.buildings,
                "reused": stats.reused,
                "cpu": cpu,
                "main_mb": main_mb,
                "worker_mb": worker_mb,
                "proxies": tileset.proxies if tileset else 0,
                "built": tileset.proxies_built if tileset else 0,
                "on_workers": getattr(tileset, "proxies_on_workers", 0) if tileset else 0,
            }
        )
    )


def run_export(
    folders: list[Path], out: Path, jobs: int, scheduler: str | None = None, code: Path = REPO
) -> dict:
    command = [sys.executable, __file__, "--child", str(out), str(jobs), scheduler or "-"]
    env = {**os.environ, "PYTHONPATH": f"{code}{os.pathsep}{REPO}"}
    result = subprocess.run(
        command + [str(f) for f in folders], capture_output=True, text=True, env=env
    )
    if result.returncode:
        raise SystemExit(result.stderr[-3000:])
    return json.loads(result.stdout.strip().splitlines()[-1])


def block(count: int) -> list:
    """``count`` level-15 tiles (a square number, or 1) as a block from :data:`FIRST`."""
    from exporter.model import TileId

    side = max(1, math.isqrt(count))
    return [TileId(15, FIRST[0] + i, FIRST[1] + j) for j in range(side) for i in range(side)]


def make_tiles(work: Path, tiles: list, buildings: int, atlas: int) -> list[Path]:
    from exporter.samplegen import generate_tile

    folders = []
    for n, tile in enumerate(tiles):
        folder = work / "in" / tile.name
        if not list(folder.glob("*.dat")):
            generate_tile(folder, buildings, seed=n, tile=tile, atlas_size=atlas)
        folders.append(folder)
    return folders


def fresh(path: Path) -> Path:
    shutil.rmtree(path, ignore_errors=True)
    if path.exists():
        raise SystemExit(f"{path}: could not be removed")
    os.sync()
    return path


def row(label: str, result: dict, tiles: int) -> str:
    return (
        f"{label:14} {tiles:5d} {result['buildings']:7d} {result['work']:8.1f} "
        f"{result['tail']:7.2f} {result['tail'] / result['seconds']:6.1%} "
        f"{result['tail'] / tiles:8.3f} {result['main_mb']:7.0f} {result['worker_mb']:7.0f} "
        f"{result['built']:5d} {result['on_workers']:5d} {result.get('cpu', 0):7.1f}"
    )


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        scheduler = None if sys.argv[4] == "-" else sys.argv[4]
        child_export(sys.argv[5:], sys.argv[2], int(sys.argv[3]), scheduler)
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,4,16,64", help="tile counts (square numbers or 1)")
    parser.add_argument("--buildings", type=int, default=60, help="buildings per tile")
    parser.add_argument("--atlas", type=int, default=256, help="building atlas size, pixels")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--baseline", help="a source folder of the exporter to compare with")
    parser.add_argument(
        "--baseline-max", type=int, default=1 << 30, help="run --baseline up to this many tiles"
    )
    parser.add_argument("--no-dask", action="store_true", help="leave out --scheduler local")
    parser.add_argument(
        "--repeats", type=int, default=3, help="changed-tile re-runs measured (median quoted)"
    )
    parser.add_argument("--workdir", help="keep the generated tiles and output here")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    work = Path(args.workdir or tempfile.mkdtemp(prefix="vworld-lod-city-"))
    print(f"work folder: {work}; {args.buildings} buildings a tile, {args.atlas}px atlases")
    make_tiles(work, block(max(sizes)), args.buildings, args.atlas)

    def square(count: int) -> list[Path]:
        # block(n) lies inside block(max): every size is a square block from FIRST (the first n
        # of the largest block would be a strip, and its last tile not block(n)'s)
        return [work / "in" / tile.name for tile in block(count)]

    header = (
        f"{'code':14} {'tiles':>5} {'bldgs':>7} {'work s':>8} {'tail s':>7} {'tail%':>6} "
        f"{'tail/tile':>8} {'main MB':>7} {'wrkr MB':>7} {'built':>5} {'onwkr':>5} {'cpu s':>7}"
    )
    lines = [header]
    results: dict[tuple[str, int], dict] = {}
    codes = [("this", REPO)] + ([("baseline", Path(args.baseline))] if args.baseline else [])
    for count in sizes:
        folders = square(count)
        for name, code in codes:
            if name == "baseline" and count > args.baseline_max:
                continue
            out = fresh(work / f"out_{name}_{count}")
            results[(name, count)] = run_export(folders, out, args.jobs, code=code)
            lines.append(row(name, results[(name, count)], count))
            print(lines[-1], flush=True)

    if not args.no_dask:
        count = 4 if 4 in sizes else min(sizes)
        out = fresh(work / "out_dask")
        dask = run_export(square(count), out, args.jobs, scheduler="local")
        pool = work / f"out_this_{count}"
        same = all(
            (out / p.relative_to(pool)).read_bytes() == p.read_bytes()
            for p in sorted(pool.rglob("*"))
            if p.is_file()
        )
        lines.append(row("dask local", dask, count))
        lines.append(f"--scheduler local: output identical to the pool's: {same}")
        print("\n".join(lines[-2:]), flush=True)

    # One changed tile of 16 (or the largest size below) against that tile alone, --repeats times
    # (another change each time, the codes taking turns): a shared machine's noise moves a single
    # pair by +-30 %, so the median ratio is quoted.
    count = 16 if 16 in sizes else max(sizes)
    changed = block(count)[-1]
    from exporter.samplegen import generate_tile

    for name, code in codes:
        out = work / f"out_{name}_{count}"
        if (name, count) in results:  # nothing changed: every tile recognised as it is
            first = results[(name, count)]["seconds"]
            unchanged = run_export(square(count), out, args.jobs, code=code)
            lines.append(
                f"{name}: unchanged re-run of {count} tiles {unchanged['seconds']:.2f} s, "
                f"first export {first:.2f} s: {unchanged['seconds'] / first:.3f}x"
            )
            print(lines[-1], flush=True)
    # The tile alone two ways: exported into an empty OUT (a first export: no previous run to
    # read), and re-exported into an OUT that holds only its previous version (the issue's "that
    # tile alone with no other tiles in OUT", a re-run as the 16-tile one is).
    ratios: dict[str, list[float]] = {name: [] for name, _ in codes}
    again_ratios: dict[str, list[float]] = {name: [] for name, _ in codes}
    for name, code in codes:
        run_export([square(count)[-1]], fresh(work / f"out_{name}_again"), args.jobs, code=code)
    for repeat in range(args.repeats):
        folder = work / "in_changed" / changed.name
        shutil.rmtree(folder, ignore_errors=True)
        generate_tile(
            folder, args.buildings, seed=1000 + repeat, tile=changed, atlas_size=args.atlas
        )
        folders = square(count)[:-1] + [folder]
        os.sync()
        for name, code in codes:
            out = work / f"out_{name}_{count}"
            rerun = run_export(folders, out, args.jobs, code=code)
            alone = run_export([folder], fresh(work / f"out_{name}_alone"), args.jobs, code=code)
            again = run_export([folder], work / f"out_{name}_again", args.jobs, code=code)
            ratios[name].append(rerun["seconds"] / alone["seconds"])
            again_ratios[name].append(rerun["seconds"] / again["seconds"])
            lines.append(
                f"{name}: one changed tile of {count} re-exported in {rerun['seconds']:.2f} s "
                f"(tail {rerun['tail']:.2f} s, {rerun['built']} proxies built); that tile alone "
                f"into an empty OUT {alone['seconds']:.2f} s: {ratios[name][-1]:.2f}x; "
                f"re-exported alone {again['seconds']:.2f} s: {again_ratios[name][-1]:.2f}x"
            )
            print(lines[-1], flush=True)
    for name, found in ratios.items():
        if found:
            lines.append(
                f"{name}: one changed tile of {count} / that tile alone, median of {len(found)}: "
                f"{statistics.median(found):.2f}x into an empty OUT, "
                f"{statistics.median(again_ratios[name]):.2f}x re-exported alone (target <= 2)"
            )

    print()
    print("\n".join(lines))
    small = results[("this", min(sizes))]
    big = results[("this", max(sizes))]
    print(
        f"main peak RSS {max(sizes)} tiles / {min(sizes)}: {big['main_mb'] / small['main_mb']:.2f}x "
        "(target <= 1.5)"
    )
    if 4 in sizes:
        four = results[("this", 4)]
        print(
            f"tail per tile {max(sizes)} / 4 tiles: "
            f"{(big['tail'] / max(sizes)) / (four['tail'] / 4):.2f}x (target <= 1.5)"
        )


if __name__ == "__main__":
    main()
