"""The input scan of a re-run: ``scan_folders`` over a block of generated VWorld-like tiles.

A re-run scans every folder before it finds what changed, a fixed cost that exporting the one
changed tile alone does not pay. For each ``--buildings`` size, ``--tiles`` generated level-15
tiles (``bench_city_scale``'s block and seeds; kept in ``--workdir`` between runs) are scanned
warm, in this process: serially (``jobs=1``) and with the fork pool (``--jobs``). With
``--baseline DIR`` (e.g. ``git archive`` of an earlier commit, with the compiled kernels copied
in) the same scans run with that checkout too, alternated with this one in every repeat; the
median seconds and their ratio (this / baseline) are printed. Also the pickled size of the scans
(what the pool's workers send back).

Usage: ``python benchmarks/bench_scan.py [--tiles 16] [--buildings 100,1248] [--jobs 2]
[--repeats 5] [--baseline DIR] [--workdir DIR]``.
"""

from __future__ import annotations

import argparse
import pickle
import statistics
import tempfile
import time
from pathlib import Path

from bench_city_scale import block, make_tiles
from checkouts import load_exporter, use_checkout

REPO = Path(__file__).resolve().parents[1]
MODULES: dict[Path, dict] = {}  # each checkout's exporter.config and exporter.pipeline


def scan_seconds(root: Path, folders: list[Path], jobs: int) -> float:
    """Seconds of one ``scan_folders`` of ``folders`` with the checkout at ``root``."""
    use_checkout(root)
    modules = MODULES[root]
    options = modules["config"].Config().readers
    started = time.perf_counter()
    modules["pipeline"].scan_folders(folders, options, jobs)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiles", type=int, default=16)
    parser.add_argument("--buildings", default="100,1248", help="buildings per tile, a list")
    parser.add_argument("--atlas", type=int, default=256)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--baseline", type=Path, help="another checkout, timed in the same run")
    parser.add_argument("--workdir", type=Path, help="where the tiles are kept (default: a temp)")
    args = parser.parse_args()
    work = args.workdir or Path(tempfile.mkdtemp(prefix="bench_scan_"))
    roots = {"this": REPO} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    for root in roots.values():
        MODULES[root] = load_exporter(root, ("config", "pipeline"))
    for size in (int(n) for n in args.buildings.split(",")):
        use_checkout(REPO)
        folders = make_tiles(work / str(size), block(args.tiles), size, args.atlas)
        modules = MODULES[REPO]
        scans = modules["pipeline"].scan_folders(folders, modules["config"].Config().readers, 1)
        size_mb = len(pickle.dumps(scans)) / 1e6
        del scans  # not kept through the timings (the collector would walk it)
        print(f"{args.tiles} tiles x {size} buildings: scans pickle to {size_mb:.1f} MB")
        for jobs in (1, args.jobs):
            seconds: dict[str, list[float]] = {label: [] for label in roots}
            for root in roots.values():
                scan_seconds(root, folders, jobs)  # warm: imports, the folders' pages
            for _ in range(args.repeats):
                for label, root in roots.items():
                    seconds[label].append(scan_seconds(root, folders, jobs))
            medians = {label: statistics.median(values) for label, values in seconds.items()}
            line = "  ".join(f"{label} {value:.3f} s" for label, value in medians.items())
            if "baseline" in medians:
                line += f"  ratio {medians['this'] / medians['baseline']:.2f}"
            print(f"  jobs={jobs}: {line}")


if __name__ == "__main__":
    main()
