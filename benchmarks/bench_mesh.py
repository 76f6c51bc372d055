"""The mesh stage per building (simplify + guard + quality metrics), this checkout against another
one in the same process, building by building, with an identity check of the results.

Usage: ``python benchmarks/bench_mesh.py TILE --baseline CHECKOUT [--repeat 2] [--limit N]``.
The mesh stage is what ``pipeline.process_entry`` runs between reading and writing, textures left
out: ``build_mesh_chain`` on the building's parts, then each level's quality the way the pipeline
picks it (``exact_quality``, ``boundary_quality`` or ``measure_lod`` with the guard's bound). Each
building runs in both checkouts one after the other, ``--repeat`` times (best CPU time of each),
so load on the shared machine hits both alike. Prints per-building milliseconds (median, mean,
p95, max) of both and their ratios, and whether every level has the same triangles, the same
``exact`` / ``surface_exact`` flags and the same quality dict (else: how many levels' certified
bound is tighter, looser). A tile is e.g. ``exporter.samplegen.generate_tile('/tmp/t300',
count=300, seed=3, atlas_size=256)``; a CityJSON file or folder works too.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
from checkouts import load_exporter, use_checkout

NAMES = ("config", "readers", "simplify", "quality")


def mesh_stage(modules: dict, parts: list, config) -> tuple[list, list]:
    """The chain and its levels' quality dicts, as ``process_entry`` makes them."""
    quality = modules["quality"]
    chain = modules["simplify"].build_mesh_chain(parts, config.lods, config.simplify)
    levels = [level.parts for level in chain]
    qualities: list = [{"triangle_ratio": 1.0}]
    for k in range(1, len(levels)):
        same = [(p.positions.tobytes(), p.triangles.tobytes()) for p in levels[k]] == [
            (p.positions.tobytes(), p.triangles.tobytes()) for p in levels[k - 1]
        ]
        if k > 1 and same:
            qualities.append(qualities[-1])
        elif chain[k].exact:
            qualities.append(quality.exact_quality(levels[0], levels[k]))
        elif chain[k].surface_exact:
            qualities.append(quality.boundary_quality(levels[0], levels[k]))
        else:
            qualities.append(quality.measure_lod(levels[0], levels[k], chain[k].deviation))
    return chain, qualities


def _plain(quality) -> dict:
    """A level's quality as a dict (a dict before issue 24, a ``LevelQuality`` after)."""
    return quality if isinstance(quality, dict) else dataclasses.asdict(quality)


def _summary(chain: list) -> list:
    return [
        (
            tuple((p.positions.tobytes(), p.triangles.tobytes()) for p in level.parts),
            level.exact,
            level.surface_exact,
        )
        for level in chain
    ]


def _stats(ms: np.ndarray) -> str:
    return (
        f"median {np.median(ms):6.2f}  mean {ms.mean():6.2f}  p95 {np.percentile(ms, 95):7.2f}"
        f"  max {ms.max():7.1f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--baseline", required=True, help="another checkout to compare with")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--limit", type=int, default=0)
    parser.add_argument("--crs", default="EPSG:7415", help="CRS of CityJSON files declaring none")
    args = parser.parse_args()
    here = Path(__file__).resolve().parents[1]
    roots = {"this": here, "baseline": Path(args.baseline)}
    checkouts = {name: load_exporter(root, NAMES) for name, root in roots.items()}
    modules = checkouts["this"]
    use_checkout(here)
    config = modules["config"].Config()
    readers = dataclasses.replace(config.readers, crs=args.crs)
    scan = modules["readers"].scan_folder(args.folder, readers)
    entries = scan.entries[: args.limit or None]
    buildings = [modules["readers"].load_entry(entry, readers) for entry in entries]
    # The kernels' first call (compile or cache load) is not a building's cost.
    for name, mods in checkouts.items():
        use_checkout(roots[name])
        mesh_stage(mods, buildings[0].parts, config)
    times = {name: np.full(len(buildings), np.inf) for name in checkouts}
    results: dict[str, list] = {name: [] for name in checkouts}
    for i, building in enumerate(buildings):
        for run in range(args.repeat):
            for name, mods in checkouts.items():
                use_checkout(roots[name])
                start = time.process_time()
                out = mesh_stage(mods, building.parts, config)
                times[name][i] = min(times[name][i], time.process_time() - start)
                if run == 0:
                    results[name].append(out)
    this, base = 1000 * times["this"], 1000 * times["baseline"]
    print(f"{len(buildings)} buildings, CPU time per building, best of {args.repeat}")
    print(f"this      {_stats(this)}")
    print(f"baseline  {_stats(base)}")
    print(
        f"ratio     median {np.median(this) / np.median(base):.2f}  mean {this.mean() / base.mean():.2f}"
        f"  p95 {np.percentile(this, 95) / np.percentile(base, 95):.2f}"
    )
    same_mesh = same_quality = tighter = looser = 0
    for (chain_t, q_t), (chain_b, q_b) in zip(results["this"], results["baseline"]):
        same_mesh += _summary(chain_t) == _summary(chain_b)
        q_t, q_b = [_plain(q) for q in q_t[1:]], [_plain(q) for q in q_b[1:]]
        same_quality += q_t == q_b
        for a, b in zip(q_t, q_b):
            tighter += a["hausdorff_rel"] < b["hausdorff_rel"]
            looser += a["hausdorff_rel"] > b["hausdorff_rel"]
    print(
        f"same levels (triangles, flags) {same_mesh}/{len(buildings)}  same quality "
        f"{same_quality}/{len(buildings)}  levels with a tighter bound {tighter}, looser {looser}"
    )


if __name__ == "__main__":
    main()
