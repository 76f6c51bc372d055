"""Micro-benchmark of the lossless planar stage (``retriangulate_planar_checked``).

Records the calls ``build_mesh_lods`` makes to the planar stage on every building of a folder
(welded as ``simplify._join`` welds them), then replays them against this checkout and, with
``--baseline DIR``, another checkout of the project, alternately (per call the best of ``--repeat``), and prints
milliseconds per building and the after/before ratio (the locks' ``nonmanifold_vertices``, computed
right before the stage as in the pipeline, included: the stage reuses its edges). With a baseline it also checks that both
return the same faces, UVs, sources and boundary flags bit for bit.

    python benchmarks/bench_planar.py /tmp/perf100p --baseline /tmp/planar-base --profile

where ``/tmp/perf100p`` is ``exporter.samplegen.generate_tile('/tmp/perf100p', count=100, seed=3,
atlas_size=256)`` and ``/tmp/planar-base`` e.g. ``git archive HEAD | tar -x -C /tmp/planar-base``.
"""

from __future__ import annotations

import argparse
import cProfile
import gc
import pstats
import time
from pathlib import Path

import numpy as np
from checkouts import load_exporter


def _load(root: Path) -> dict:
    return load_exporter(
        root, ("config", "readers", "simplify", "simplify.planar", "simplify.protect")
    )


def record_calls(modules, folder: str) -> list[tuple]:
    """The argument tuples of every planar-stage call that ``build_mesh_lods`` makes on the
    buildings of ``folder`` (copies, so replays cannot see each other's changes)."""
    config = modules["config"].Config()
    scan = modules["readers"].scan_folder(folder, config.readers)
    simplify = modules["simplify"]
    original = simplify.retriangulate_planar_checked
    calls = []

    def recording(*args):
        calls.append(tuple(None if a is None else np.array(a, copy=True) for a in args))
        return original(*args)

    simplify.retriangulate_planar_checked = recording
    try:
        for entry in scan.entries:
            building = modules["readers"].load_entry(entry, config.readers)
            simplify.build_mesh_lods(building.parts, config.lods, config.simplify)
    finally:
        simplify.retriangulate_planar_checked = original
    return calls


def _replay(modules, calls) -> list:
    """The planar stage on every call, its locks computed as ``_simplify_level`` computes them
    (``nonmanifold_vertices`` of the same face array, whose edges the stage then reuses)."""
    function = modules["simplify.planar"].retriangulate_planar_checked
    locks = modules["simplify.protect"].nonmanifold_vertices
    results = []
    for positions, faces, corner_uvs, face_chart, _ in calls:
        locked = locks(faces, len(positions))
        results.append(function(positions, faces, corner_uvs, face_chart, locked))
    return results


def _same(a, b) -> bool:
    return all(
        (x is None and y is None)
        or (
            x is not None
            and y is not None
            and np.asarray(x).dtype == np.asarray(y).dtype
            and np.array_equal(x, y)
        )
        for x, y in zip(a, b, strict=True)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--baseline", help="another checkout of the project to compare with")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--profile", action="store_true", help="cProfile this checkout's replay")
    args = parser.parse_args()
    here = Path(__file__).resolve().parents[1]
    modules = _load(here)
    calls = record_calls(modules, args.folder)
    buildings = len(
        modules["readers"].scan_folder(args.folder, modules["config"].Config().readers).entries
    )
    checkouts = [modules] + ([_load(Path(args.baseline))] if args.baseline else [])
    if args.baseline:
        outputs = [_replay(m, calls) for m in checkouts]
        same = all(_same(a, b) for a, b in zip(*outputs, strict=True))
        print(f"{len(calls)} calls, outputs identical to the baseline: {same}")
    # Per call the best of the runs (one call is a few ms: most runs of it see no preemption by
    # the machine's other jobs), summed over the calls.
    best = np.full((len(checkouts), len(calls)), np.inf)
    gc.disable()
    for _ in range(args.repeat):
        for i, checkout in enumerate(checkouts):
            copies = [tuple(None if a is None else a.copy() for a in call) for call in calls]
            for j, call in enumerate(copies):
                start = time.perf_counter()
                _replay(checkout, [call])
                best[i, j] = min(best[i, j], time.perf_counter() - start)
    gc.enable()
    best = best.sum(axis=1)
    line = f"planar {1000 * best[0] / buildings:6.2f} ms/building"
    if args.baseline:
        line += f"   baseline {1000 * best[1] / buildings:6.2f}   ratio {best[0] / best[1]:.2f}"
    print(line)
    if args.profile:
        profiler = cProfile.Profile()
        profiler.enable()
        _replay(checkouts[0], calls)
        profiler.disable()
        pstats.Stats(profiler).sort_stats("tottime").print_stats(30)


if __name__ == "__main__":
    main()
