"""Per-stage micro-benchmark of the per-building pipeline: simplify, quality and write.

Reads every building of a folder once, then times ``build_mesh_lods``, ``measure_lod`` (levels >= 1
against LOD0) and ``glb_bytes`` (every level) over all buildings, in milliseconds per building.
``--baseline DIR`` runs the same on another checkout of the project (e.g. ``git archive HEAD~3 |
tar -x -C /tmp/base``) in the same process, one stage after the other, and prints after/before
ratios: the machine is shared, so only ratios measured in one run mean anything.

    python benchmarks/bench_stages.py /tmp/perf100 --baseline /tmp/base --profile simplify

where ``/tmp/perf100`` is ``exporter.samplegen.generate_tile('/tmp/perf100', count=100, seed=3,
atlas_size=1024)``.

Measured (issue 8, 2 shared cores, best of 3, baseline = commit 4e6dace in the same run): simplify
0.37x, quality 0.78x (every level >= 1 measured), write (``glb_bytes`` only) 0.47x; the exported
files are byte-identical to the baseline's on that tile.

The quality column times ``measure_lod`` on every level; the pipeline itself measures only the
levels the simplifier did not report exact (``exact_quality`` / ``boundary_quality`` for the
others), so the export's quality stage is much smaller (see ``bench_throughput.py``).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time
from pathlib import Path

from checkouts import load_exporter


def _load(root: Path) -> dict:
    return load_exporter(root, ("config", "readers", "simplify", "quality", "gltf_writer"))


def _stages(modules, folder: str, repeat: int, profile: str | None) -> dict[str, float]:
    config = modules["config"].Config()
    scan = modules["readers"].scan_folder(folder, config.readers)
    buildings = [modules["readers"].load_entry(entry, config.readers) for entry in scan.entries]
    times = {}
    profiler = cProfile.Profile()

    def timed(stage, run):
        best = float("inf")
        for _ in range(repeat):
            if profile == stage:
                profiler.enable()
            start = time.perf_counter()
            result = run()
            best = min(best, time.perf_counter() - start)
            if profile == stage:
                profiler.disable()
        times[stage] = 1000 * best / len(buildings)
        return result

    levels = timed(
        "simplify",
        lambda: [
            modules["simplify"].build_mesh_lods(b.parts, config.lods, config.simplify)
            for b in buildings
        ],
    )

    def quality():
        # The source side is cached per building, as in one export: every cache emptied per run.
        for name in ("_CACHE", "_OUTLINES", "_SURFACES"):
            cache = getattr(modules["quality"], name, None)
            if cache is not None:
                cache.clear()
        return [
            [modules["quality"].measure_lod(chain[0], chain[k]) for k in range(1, len(chain))]
            for chain in levels
        ]

    timed("quality", quality)
    timed(
        "write",
        lambda: [
            [
                modules["gltf_writer"].glb_bytes(parts, f"b{i}_LOD{k}")
                for k, parts in enumerate(chain)
            ]
            for i, chain in enumerate(levels)
        ],
    )
    if profile:
        pstats.Stats(profiler).sort_stats("cumulative").print_stats(35)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--baseline", help="another checkout of the project to compare with")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs per stage")
    parser.add_argument(
        "--profile",
        choices=("simplify", "quality", "write"),
        help="cProfile one stage (this checkout)",
    )
    args = parser.parse_args()
    here = Path(__file__).resolve().parents[1]
    checkouts = [_load(here)] + ([_load(Path(args.baseline))] if args.baseline else [])
    # Alternate the two checkouts run by run (best of each) so load on the machine hits both alike.
    best = [dict() for _ in checkouts]
    for run in range(args.repeat):
        for which, modules in enumerate(checkouts):
            profile = args.profile if which == 0 and run == 0 else None
            for stage, value in _stages(modules, args.folder, 1, profile).items():
                best[which][stage] = min(value, best[which].get(stage, float("inf")))
    after, before = best[0], (best[1] if args.baseline else None)
    for stage, value in after.items():
        line = f"{stage:9s} {value:7.2f} ms/building"
        if before:
            line += f"   baseline {before[stage]:7.2f}   ratio {value / before[stage]:.2f}"
        print(line)


if __name__ == "__main__":
    main()
