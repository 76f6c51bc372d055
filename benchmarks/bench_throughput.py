"""Throughput benchmark: a generated VWorld-like tile through the whole exporter (issue 8).

Reports, from one run on this machine (figures are ratios against baselines measured in the same
run, because the machines are shared and noisy):

- buildings/s with ``--jobs N`` (default: all cores) and with ``--jobs 1`` -> parallel speed-up;
- seconds per stage (read, simplify, textures, quality, write), summed over workers;
- peak memory (max RSS of the main process and of any worker) for a small and the full tile;
- the codec floor: the time just to decode each atlas in full and encode its smaller levels
  (Pillow, same scales and JPEG quality; resampling and file I/O not counted), summed over the
  atlases and divided by the number of processes -> export / codec floor; beside it the same
  floor with each atlas decoded at libjpeg's DCT scale for its largest smaller level (half size
  by default: the least decoding the levels need, and what the exporter does), a stricter floor;
- an unchanged re-run -> re-run / first run; the same export again with ``--force`` over its own
  output -> overwrite / first run (the file system frees the earlier files: on ext4 mounted with
  ``discard`` that costs the writer ~0.25 ms a file);
- scaling: seconds per building and peak memory at a small size (100) and a large size (5,000)
  vs the full size.

Usage: ``python benchmarks/bench_throughput.py [--buildings 1248] [--atlas 1024] [--small 100]
[--large 5000] [--rounds 1]`` (``--large 0`` leaves the large tile out; generating it takes
~3 min and ~1.1 GB).
Each measured export runs in its own child process so its peak memory is its own. Every export
measured against the floor writes into a new folder (a first export: the tileset's proxies are
built, not reused), with earlier outputs removed and everything synced before the clocks start,
so that no earlier output's deletion or write-back lands in a timed run.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def peak_rss_mb() -> tuple[float, float]:
    """Max resident set size (MiB) of this process and of its largest finished child.

    This process's own peak is read from ``/proc/self/status`` (VmHWM) where it exists: Linux
    keeps ``ru_maxrss`` across ``execve``, so a child started by ``subprocess`` from this
    benchmark's parent (which holds the generated tiles, ~150 MiB) reported the parent's peak as
    its own (0.3.0's "main process 173 MiB"; its real peak is ~54 MiB)."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    own = int(line.split()[1])  # kB
    except OSError:
        pass
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return own / 1024.0, children / 1024.0


def child_export(tile: str, out: str, jobs: int, force: bool) -> None:
    """Run one export in this (child) process and print its figures as JSON."""
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    started = time.perf_counter()
    stats = export_tiles([tile], out, Config(), jobs=jobs, force=force)
    main_mb, worker_mb = peak_rss_mb()
    print(
        json.dumps(
            {
                "seconds": time.perf_counter() - started,
                "buildings": stats.buildings,
                "skipped": stats.skipped,
                "reused": stats.reused,
                "stages": stats.seconds,
                "peak_rss_mb": max(main_mb, worker_mb),
                "peak_main_mb": main_mb,
                "peak_worker_mb": worker_mb,
            }
        )
    )


def run_export(tile: Path, out: Path, jobs: int, force: bool = False) -> dict:
    command = [
        sys.executable,
        __file__,
        "--child",
        str(tile),
        str(out),
        str(jobs),
        "1" if force else "0",
    ]
    result = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def _codec_one(args: tuple) -> tuple[float, float]:
    """Seconds spent just decoding one atlas and encoding its smaller levels: (decoded in full,
    decoded at libjpeg's DCT scale for the largest smaller level, as the exporter decodes). The
    reductions themselves are made outside the timed part: no resampling is counted."""
    from PIL import Image

    path, scales, quality = args
    started = time.perf_counter()
    with Image.open(path) as image:
        image.load()
        decoded = time.perf_counter() - started
        full = image.convert("RGB")
    sizes = [(max(1, round(full.width * s)), max(1, round(full.height * s))) for s in scales[1:]]
    started = time.perf_counter()
    with Image.open(path) as image:
        if sizes:
            image.draft("RGB", max(sizes))
        image.load()
        draft_decoded = time.perf_counter() - started
    reduced = [full.resize(size, Image.Resampling.BOX) for size in sizes]
    started = time.perf_counter()
    for level in reduced:
        level.save(io.BytesIO(), "JPEG", quality=quality)
    encoded = time.perf_counter() - started
    return decoded + encoded, draft_decoded + encoded


def codec_floor(tile: Path, jobs: int) -> tuple[float, float]:
    """The codec floor in wall seconds for ``jobs`` processes: the summed time to decode every
    atlas of the tile and encode its smaller levels (no resampling, no I/O), divided by ``jobs``;
    with the atlases decoded in full (the benchmark's floor) and at the reduced DCT scale."""
    from exporter.config import Config

    config = Config()
    scales = [spec.texture for spec in config.lods]
    tasks = [(str(p), scales, config.textures.jpeg_quality) for p in sorted(tile.glob("*.jpg"))]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        times = list(pool.map(_codec_one, tasks, chunksize=8))
    return sum(t[0] for t in times) / jobs, sum(t[1] for t in times) / jobs


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child_export(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5] == "1")
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--buildings", type=int, default=1248, help="buildings in the full tile (the paper's 1,248)"
    )
    parser.add_argument(
        "--small", type=int, default=100, help="buildings in the small tile (scaling baseline)"
    )
    parser.add_argument(
        "--large", type=int, default=5000, help="buildings in the large tile (scaling; 0: none)"
    )
    parser.add_argument("--atlas", type=int, default=1024, help="atlas size in pixels")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--rounds",
        type=int,
        default=1,
        help="full export and codec floor alternated this many times (the ratio per round, its "
        "median and best export / best floor: on a shared machine the floor alone varies ~30%%)",
    )
    parser.add_argument("--workdir", help="keep the generated tiles and output here")
    args = parser.parse_args()

    from exporter.samplegen import generate_tile

    work = Path(args.workdir or tempfile.mkdtemp(prefix="vworld-lod-bench-"))
    print(f"work folder: {work}")
    tiles = {}
    sizes = (("small", args.small), ("full", args.buildings)) + (
        (("large", args.large),) if args.large else ()
    )
    for name, count in sizes:
        tiles[name] = work / f"tile_{count}"
        if not list(tiles[name].glob("*.dat")):
            started = time.perf_counter()
            generate_tile(tiles[name], count=count, seed=args.seed, atlas_size=args.atlas)
            print(
                f"generated {count} buildings with {args.atlas}px atlases in {time.perf_counter() - started:.1f} s"
            )

    # Earlier outputs in a reused work folder go first: freeing their blocks (ext4 discards them)
    # must not land in a timed export.
    for stale in sorted(work.glob("out_*")):
        shutil.rmtree(stale, ignore_errors=True)
    os.sync()
    small = run_export(tiles["small"], work / "out_small", args.jobs, force=True)
    full = run_export(tiles["full"], work / "out_full", args.jobs, force=True)
    rerun = run_export(tiles["full"], work / "out_full", args.jobs)
    single = run_export(tiles["full"], work / "out_single", 1, force=True)
    large = (
        run_export(tiles["large"], work / "out_large", args.jobs, force=True)
        if args.large
        else None
    )
    floor, floor_reduced = codec_floor(tiles["full"], args.jobs)
    # Further rounds alternate the two, so that both see the same state of the machine; each
    # export writes a folder of its own (its write-back synced before the next clock starts).
    pairs = [(full["seconds"], floor)]
    reduced_floors = [floor_reduced]
    for round_ in range(1, args.rounds):
        os.sync()
        again = run_export(tiles["full"], work / f"out_round{round_}", args.jobs, force=True)
        floors = codec_floor(tiles["full"], args.jobs)
        pairs.append((again["seconds"], floors[0]))
        reduced_floors.append(floors[1])
    os.sync()
    # Last: replacing files frees the earlier ones, which would slow whatever ran next.
    overwrite = run_export(tiles["full"], work / "out_full", args.jobs, force=True)
    for round_ in range(1, args.rounds):
        shutil.rmtree(work / f"out_round{round_}", ignore_errors=True)

    n = full["buildings"]
    print()
    print(
        f"tile: {n} buildings ({full['skipped']} skipped), {args.atlas}px atlases, jobs={args.jobs}"
    )
    print(f"{'measure':44} {'value':>12}")
    rows = [
        ("export wall time (s)", f"{full['seconds']:.2f}"),
        ("buildings/s", f"{n / full['seconds']:.1f}"),
        ("codec floor wall time (s)", f"{floor:.2f}"),
        ("export / codec floor (target <= 2.0)", f"{full['seconds'] / floor:.2f}"),
        (
            "  floor with the reduced-scale decode (s)",
            f"{floor_reduced:.2f} ({full['seconds'] / floor_reduced:.2f}x)",
        ),
        (
            f"jobs {args.jobs} speed-up over jobs 1 (target >= 1.8)",
            f"{single['seconds'] / full['seconds']:.2f}",
        ),
        (
            "unchanged re-run / first run (target <= 0.05)",
            f"{rerun['seconds'] / full['seconds']:.3f}",
        ),
        (
            "--force over its own output / first run",
            f"{overwrite['seconds'] / full['seconds']:.2f}",
        ),
        (
            f"s per building: {args.buildings} vs {args.small} buildings",
            f"{(full['seconds'] / n) / (small['seconds'] / small['buildings']):.2f}",
        ),
        (f"peak memory MiB: {args.small} buildings", f"{small['peak_rss_mb']:.0f}"),
        (f"peak memory MiB: {args.buildings} buildings", f"{full['peak_rss_mb']:.0f}"),
        (
            f"  main / largest worker, {args.small}",
            f"{small['peak_main_mb']:.0f} / {small['peak_worker_mb']:.0f}",
        ),
        (
            f"  main / largest worker, {args.buildings}",
            f"{full['peak_main_mb']:.0f} / {full['peak_worker_mb']:.0f}",
        ),
        ("peak memory ratio full / small", f"{full['peak_rss_mb'] / small['peak_rss_mb']:.2f}"),
    ]
    if large:
        per_small = small["seconds"] / small["buildings"]
        rows += [
            (
                f"s per building: {args.large} vs {args.small} buildings",
                f"{(large['seconds'] / large['buildings']) / per_small:.2f}",
            ),
            (f"peak memory MiB: {args.large} buildings", f"{large['peak_rss_mb']:.0f}"),
            (
                f"  main / largest worker, {args.large}",
                f"{large['peak_main_mb']:.0f} / {large['peak_worker_mb']:.0f}",
            ),
            (
                "peak memory ratio large / small",
                f"{large['peak_rss_mb'] / small['peak_rss_mb']:.2f}",
            ),
        ]
    if len(pairs) > 1:
        ratios = sorted(seconds / floor for seconds, floor in pairs)
        rows += [
            (
                f"export / floor, {len(pairs)} alternated rounds",
                " ".join(f"{seconds / floor:.2f}" for seconds, floor in pairs),
            ),
            ("  export s", " ".join(f"{seconds:.2f}" for seconds, _ in pairs)),
            ("  floor s", " ".join(f"{floor:.2f}" for _, floor in pairs)),
            (
                "  export / reduced-decode floor",
                " ".join(f"{p[0] / r:.2f}" for p, r in zip(pairs, reduced_floors)),
            ),
            ("  median of the rounds", f"{ratios[len(ratios) // 2]:.2f}"),
            (
                "  best export / best floor",
                f"{min(p[0] for p in pairs) / min(p[1] for p in pairs):.2f}",
            ),
        ]
    for label, value in rows:
        print(f"{label:44} {value:>12}")
    total = sum(full["stages"].values()) or 1.0
    print(f"\nstage shares of worker time (jobs={args.jobs}):")
    for stage, seconds in full["stages"].items():
        print(
            f"  {stage:10} {seconds:8.2f} s  {seconds / total:6.1%}  ({1000 * seconds / n:.1f} ms/building)"
        )


if __name__ == "__main__":
    main()
