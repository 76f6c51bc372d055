"""The export outside the mesh stage: CPU per building of read, textures, write, the pool and the
main process, against the codec floor, this checkout against another (issue 24).

The mesh stage (``build_mesh_chain`` and the quality calls) of every building of the tile is run
once and recorded; each measured export then replays those results instead of computing them, so
what is left is everything else the export does (same output files). CPU time, not wall time: the
machines are shared, and another session's load changes wall time far more than the work does.
Each measured export runs in its own child process, checkouts alternated in every round.

Usage: ``python benchmarks/bench_overhead.py TILE --baseline CHECKOUT [--jobs 2] [--rounds 2]``
(TILE: a generated VWorld-like folder, e.g. ``bench_throughput.py --workdir``'s ``tile_300``).
Prints per export: CPU ms per building of each stage (summed over workers), of the workers outside
the stages (the pool), of the main process, the total, and total / codec floor, where the floor is
the CPU time to decode each atlas in full and encode its smaller levels (``bench_throughput.py``'s
floor, in CPU time), per building.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import pickle
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MESH_CALLS = ("build_mesh_chain", "measure_lod", "exact_quality", "boundary_quality")


def record(tile: str, out: str, path: str) -> None:
    """Export ``tile`` once (one job) and pickle every building's mesh-stage results to ``path``."""
    import exporter.job as job
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    results: dict = {}
    current: list = [None]
    load = job.load_entry

    def load_recording(entry, options):
        current[0] = entry.id
        results[entry.id] = {"chain": None, "quality": []}
        return load(entry, options)

    def recording(name: str):
        call = getattr(job, name)

        def wrapped(*args):
            value = call(*args)
            if name == "build_mesh_chain":
                results[current[0]]["chain"] = value
            else:
                results[current[0]]["quality"].append(value)
            return value

        return wrapped

    job.load_entry = load_recording
    for name in MESH_CALLS:
        setattr(job, name, recording(name))
    export_tiles([tile], out, Config(), jobs=1, force=True)
    with open(path, "wb") as handle:
        pickle.dump(results, handle, protocol=pickle.HIGHEST_PROTOCOL)


def replay(tile: str, out: str, jobs: int, path: str) -> None:
    """Export ``tile`` with the recorded mesh stage (forked workers inherit the patches); print
    the CPU figures as JSON."""
    import exporter.job as job
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    with open(path, "rb") as handle:
        results = pickle.load(handle)
    current: list = [None, 0]
    load = job.load_entry

    def load_replaying(entry, options):
        current[0], current[1] = entry.id, 0
        return load(entry, options)

    def quality(*args):
        current[1] += 1
        return results[current[0]]["quality"][current[1] - 1]

    job.load_entry = load_replaying
    job.degenerate_only = lambda parts: False
    job.build_mesh_chain = lambda *args: results[current[0]]["chain"]
    job.measure_lod = job.exact_quality = job.boundary_quality = quality
    job.time = types.SimpleNamespace(perf_counter=time.process_time)  # stage times in CPU
    started = time.process_time()
    stats = export_tiles([tile], out, Config(), jobs=jobs, force=True)
    own = resource.getrusage(resource.RUSAGE_SELF)
    workers = resource.getrusage(resource.RUSAGE_CHILDREN)
    main = own.ru_utime + own.ru_stime - started
    stages = dict(stats.seconds)
    if jobs > 1:
        pool = workers.ru_utime + workers.ru_stime - sum(stages.values())
    else:  # one job: the stages run in this process
        pool, main = 0.0, main - sum(stages.values())
    print(json.dumps({"buildings": stats.buildings, "stages": stages, "pool": pool, "main": main}))


def floor_cpu(tile: Path, scales: list[float], quality: int) -> float:
    """CPU seconds to decode every atlas of ``tile`` in full and encode its smaller levels (the
    reductions themselves not counted), as bench_throughput's codec floor."""
    from PIL import Image

    total = 0.0
    for path in sorted(tile.glob("*.jpg")):
        started = time.process_time()
        with Image.open(path) as image:
            image.load()
            total += time.process_time() - started
            full = image.convert("RGB")
        for scale in scales[1:]:
            level = full.resize(
                (max(1, round(full.width * scale)), max(1, round(full.height * scale))),
                Image.Resampling.BOX,
            )
            started = time.process_time()
            level.save(io.BytesIO(), "JPEG", quality=quality)
            total += time.process_time() - started
    return total


def child(root: str, *args: str) -> dict:
    environment = dict(os.environ, PYTHONPATH=root)
    command = [sys.executable, __file__, *args]
    result = subprocess.run(command, env=environment, capture_output=True, text=True, check=True)
    lines = result.stdout.strip().splitlines()
    return json.loads(lines[-1]) if lines else {}


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] in ("--record", "--replay"):
        if sys.argv[1] == "--record":
            record(*sys.argv[2:5])
        else:
            replay(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tile", type=Path)
    parser.add_argument("--baseline", type=Path, required=True, help="the other checkout")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()

    from exporter.config import Config

    config = Config()
    work = Path(tempfile.mkdtemp(prefix="vworld-lod-overhead-"))
    try:
        recorded = str(work / "mesh.pickle")
        child(str(REPO), "--record", str(args.tile), str(work / "record"), recorded)
        checkouts = {"this": str(REPO), "baseline": str(args.baseline.resolve())}
        print(
            f"{'round':5} {'checkout':9} {'read':>6} {'tex':>6} {'write':>6} {'pool':>6} "
            f"{'main':>6} {'total':>6} {'floor':>6} {'ratio':>6}  (CPU ms per building)"
        )
        for round_ in range(args.rounds):
            scales = [spec.texture for spec in config.lods]
            floor = floor_cpu(args.tile, scales, config.textures.jpeg_quality)
            for name, root in checkouts.items():
                out = work / f"out_{name}"
                shutil.rmtree(out, ignore_errors=True)
                found = child(root, "--replay", str(args.tile), str(out), str(args.jobs), recorded)
                n = found["buildings"]
                ms = {key: 1000.0 * value / n for key, value in found["stages"].items()}
                pool, main_ms = 1000.0 * found["pool"] / n, 1000.0 * found["main"] / n
                total = sum(ms.values()) + pool + main_ms
                floor_ms = 1000.0 * floor / n
                print(
                    f"{round_:5} {name:9} {ms['read']:6.2f} {ms['textures']:6.2f} "
                    f"{ms['write']:6.2f} {pool:6.2f} {main_ms:6.2f} {total:6.2f} "
                    f"{floor_ms:6.2f} {total / floor_ms:6.2f}",
                    flush=True,
                )
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
