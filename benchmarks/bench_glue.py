"""The mesh stage's glue time: ``build_mesh_chain`` minus the guard's ``certify`` and the planar
stage (``retriangulate_planar_checked``), in milliseconds per building, for this checkout and a
baseline in one process (interleaved, best of N, CPU time), with an identity check of the chains.

    python benchmarks/bench_glue.py /tmp/perf100g --baseline /tmp/g-base

where ``/tmp/perf100g`` is ``exporter.samplegen.generate_tile('/tmp/perf100g', count=100, seed=3,
atlas_size=256)`` and ``/tmp/g-base`` a ``git archive`` of the baseline commit. The two stages
left out are timed by wrappers around their calls (one ``process_time`` pair each), so the glue is
what remains; only ratios measured in one run mean anything (2 shared cores).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from checkouts import load_exporter

ROOT = Path(__file__).resolve().parents[1]


def _load(root: Path) -> dict:
    return load_exporter(root, ("config", "readers", "simplify"))


class _Timed:
    """A wrapper adding the CPU seconds of every call of ``function`` to ``spent``."""

    def __init__(self, function, spent: list[float]) -> None:
        self.function, self.spent = function, spent

    def __call__(self, *args, **kwargs):
        start = time.process_time()
        try:
            return self.function(*args, **kwargs)
        finally:
            self.spent[0] += time.process_time() - start


def _runner(root: Path, folder: str):
    modules = _load(root)
    config = modules["config"].Config()
    readers = modules["readers"]
    buildings = [
        readers.load_entry(e, config.readers)
        for e in readers.scan_folder(folder, config.readers).entries
    ]
    simplify = modules["simplify"]
    spent = [0.0]
    simplify.certify = _Timed(simplify.certify, spent)
    simplify.retriangulate_planar_checked = _Timed(simplify.retriangulate_planar_checked, spent)

    def run() -> tuple[float, float, list]:
        spent[0] = 0.0
        start = time.process_time()
        chains = [
            simplify.build_mesh_chain(b.parts, config.lods, config.simplify) for b in buildings
        ]
        total = time.process_time() - start
        return total, total - spent[0], chains

    return run, len(buildings)


def _signature(chains) -> list:
    return [
        [
            (
                level.exact,
                level.surface_exact,
                level.deviation,
                [
                    tuple(
                        None if a is None else a.tobytes()
                        for a in (p.positions, p.triangles, p.uvs, p.normals)
                    )
                    for p in level.parts
                ],
            )
            for level in chain
        ]
        for chain in chains
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--baseline", required=True)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    runs = {"this": _runner(ROOT, args.folder), "base": _runner(Path(args.baseline), args.folder)}
    best = {name: [float("inf"), float("inf")] for name in runs}
    signatures = {}
    for _ in range(args.repeat):
        for name, (run, _count) in runs.items():
            total, glue, chains = run()
            best[name] = [min(best[name][0], total), min(best[name][1], glue)]
            signatures[name] = _signature(chains)
    count = runs["this"][1]
    for i, label in enumerate(("chain", "glue")):
        this, base = (1e3 * best[n][i] / count for n in ("this", "base"))
        print(f"{label:6} {this:7.2f} ms/building   baseline {base:7.2f}   ratio {this / base:.2f}")
    print("identical" if signatures["this"] == signatures["base"] else "DIFFERENT")


if __name__ == "__main__":
    main()
