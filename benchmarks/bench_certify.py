"""The error guard's certification alone: its calls recorded on a tile, replayed against this
checkout and another one in the same process, interleaved; best of ``--repeat`` runs each.

Usage: ``python benchmarks/bench_certify.py TILE --baseline CHECKOUT [--repeat 7]``. Every
:func:`exporter.simplify.certify` call of ``build_mesh_chain`` over the tile's buildings is
recorded (reference, level, tolerance); each run prepares the references afresh (one per
building, as the pipeline does) and certifies every recorded level. Prints the CPU seconds of
both, their ratio and whether both gave the same ``(lower, upper)`` floats (or refusals).
Ratios only: the machines are shared and noisy. Single-threaded BLAS is advised
(``OPENBLAS_NUM_THREADS=1``).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path


def record(folder: str) -> tuple[list, list]:
    """The references (positions, faces) and the calls (reference number, positions, faces,
    tolerance metres) of the guard over the tile's buildings."""
    import exporter.simplify as simplify
    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder

    config = Config()
    refs: dict[int, tuple[int, object]] = {}
    calls = []
    certify = simplify.certify

    def spy(reference, positions, faces, tolerance):
        number = refs.setdefault(id(reference), (len(refs), reference))[0]
        calls.append((number, positions.copy(), faces.copy(), tolerance))
        return certify(reference, positions, faces, tolerance)

    simplify.certify = spy
    try:
        for entry in scan_folder(folder, config.readers).entries:
            building = load_entry(entry, config.readers)
            simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    finally:
        simplify.certify = certify
    references = [None] * len(refs)
    for number, reference in refs.values():
        references[number] = (reference.positions, reference.faces)  # type: ignore[attr-defined]
    return references, calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--baseline", required=True, help="another checkout to compare with")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    here = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(here))
    # The baseline's package under another name (its imports are relative).
    scratch = Path(tempfile.mkdtemp())
    shutil.copytree(Path(args.baseline) / "exporter", scratch / "exporter_base")
    sys.path.insert(0, str(scratch))
    try:
        import exporter_base.simplify.guard as base

        import exporter
        from exporter.simplify import guard as new

        assert Path(exporter.__file__).resolve().is_relative_to(here)
        references, calls = record(args.folder)
        times: dict[str, list[float]] = {"baseline": [], "this": []}
        results = {}
        for _ in range(args.repeat):
            for name, module in (("baseline", base), ("this", new)):
                prepared = [module.Reference(p, f) for p, f in references]
                start = time.process_time()
                out = [module.certify(prepared[i], p, f, tol) for i, p, f, tol in calls]
                times[name].append(time.process_time() - start)
                results[name] = out
        b, t = min(times["baseline"]), min(times["this"])
        same = results["baseline"] == results["this"]
        print(
            f"certify  {len(calls)} calls  this {t:.3f} s  baseline {b:.3f} s  ratio {t / b:.2f}"
            f"  identical {same}"
        )
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    main()
