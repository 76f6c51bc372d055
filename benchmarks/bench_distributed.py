"""The export on a Dask cluster against the local process pool (issue 15).

A generated multi-tile input (``exporter.samplegen.generate_tile`` for ``--tiles`` tiles) is
exported, every building redone (``force``), by:

- the local pool, ``--jobs W`` (the embedded default; the baseline);
- a real cluster started here: ``dask scheduler`` and ``dask worker --nthreads 1 --no-nanny``
  as separate processes on loopback, with 1 and with W workers, pinned (``taskset``) to the same
  W cores as the local pool, the scheduler and the client included.

Reported, each a ratio of times measured in the same run (the machine is shared and noisy), per
round (``--repeat`` rounds, each running the three configurations one after the other): W workers
vs 1 worker (target >= 1.7x for W = 2) and the cluster vs the local pool on the same cores
(target: within 15 %), with the cores the workers actually got (their CPU seconds / wall time)
and their CPU time per building, which tell the machine's share apart from the code's. Then the
batch size: the per-task overhead of the cluster (no-op tasks kept
in flight as the export keeps its batches: the client's and the scheduler's time per task)
against the work per building, and exports at several batch sizes, each against a local-pool run
made right after it.

Each export runs in its own client process (as a user's command would), started after the
cluster's workers are up; timings are the client's ``export_tiles`` wall time. The first round's
workers are fresh; later rounds' are warm (the exporter already imported).

Usage: ``python benchmarks/bench_distributed.py [--tiles 4] [--buildings 120] [--atlas 512]
[--workers 2] [--batches 1,4,16,64] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))


def child_export(spec: str) -> None:
    """Run one export in this (child) process; print its figures as JSON."""
    from exporter.config import Config
    from exporter.distributed import ClusterOptions
    from exporter.pipeline import export_tiles

    args = json.loads(spec)
    scheduler = (
        ClusterOptions(args["scheduler"], batch_size=args["batch"]) if args["scheduler"] else None
    )
    started = time.perf_counter()
    stats = export_tiles(
        args["tiles"], args["out"], Config(), jobs=args["jobs"], force=True, scheduler=scheduler
    )
    seconds = time.perf_counter() - started
    work = sum(stats.seconds.values())
    print(json.dumps({"seconds": seconds, "buildings": stats.buildings, "work_s": work}))


def run_export(tiles, out, cpus, jobs=1, scheduler=None, batch=16) -> dict:
    spec = json.dumps(
        {
            "tiles": [str(t) for t in tiles],
            "out": str(out),
            "jobs": jobs,
            "scheduler": scheduler,
            "batch": batch,
        }
    )
    command = ["taskset", "-c", cpus, sys.executable, __file__, "--child", spec]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    result = subprocess.run(command, capture_output=True, text=True, env=env)
    if result.returncode != 0:
        raise SystemExit(f"export failed: {result.stderr[-3000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def _process_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def workers_cpu_s(address: str) -> float:
    """CPU seconds the cluster's worker processes have used so far (summed): with the wall time,
    how many cores the workers actually got on the shared machine, and CPU time per building."""
    from distributed import Client

    with Client(address, timeout=10) as client:
        return sum(client.run(_process_cpu_s).values())


def task_overhead_ms(address: str, tasks: int = 400) -> float:
    """Milliseconds per no-op task through the scheduler, tasks kept in flight as the export
    keeps batches (two per worker): the client's and the scheduler's time per task, taken from
    the same cores as the work, on top of a batch's buildings."""
    from distributed import Client, as_completed

    def nothing(i: int) -> int:
        return i

    with Client(address, timeout=10) as client:
        workers = len(client.scheduler_info(n_workers=-1)["workers"])
        client.gather([client.submit(nothing, -i - 1, pure=False) for i in range(20)])  # warm
        started = time.perf_counter()
        running = as_completed()
        submitted = 0
        while submitted < 2 * workers:
            running.add(client.submit(nothing, submitted, pure=False))
            submitted += 1
        for future in running:
            future.result()
            if submitted < tasks:
                running.add(client.submit(nothing, submitted, pure=False))
                submitted += 1
        return (time.perf_counter() - started) / tasks * 1000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--child")
    parser.add_argument("--tiles", type=int, default=4)
    parser.add_argument("--buildings", type=int, default=120, help="buildings per tile")
    parser.add_argument("--atlas", type=int, default=512)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--batches", default="1,4,16,64")
    parser.add_argument("--repeat", type=int, default=3, help="rounds of the three configurations")
    args = parser.parse_args()
    if args.child:
        child_export(args.child)
        return

    from dask_cluster import DaskCluster

    from exporter.model import TileId
    from exporter.samplegen import generate_tile

    cpus = ",".join(str(c) for c in sorted(os.sched_getaffinity(0))[: args.workers])
    with tempfile.TemporaryDirectory(prefix="bench-distributed-") as tmp:
        root = Path(tmp)
        tiles = [
            generate_tile(
                root / "in" / f"t{i}",
                count=args.buildings,
                seed=100 + i,
                tile=TileId(15, 279418 + i % 4, 116113 + i // 4),
                atlas_size=args.atlas,
                jobs=args.workers,
            )
            for i in range(args.tiles)
        ]
        total = args.tiles * args.buildings
        print(f"{args.tiles} tiles x {args.buildings} buildings, atlas {args.atlas}, cores {cpus}")

        out = root / "out"
        batches = [int(b) for b in args.batches.split(",")]
        core_list = [int(c) for c in cpus.split(",")]
        sizes = sorted({1, args.workers})
        clusters = {}
        try:
            for workers in sizes:
                clusters[workers] = DaskCluster(root / f"dask{workers}", workers, cpus=core_list)
            # Rounds interleave the configurations so that the others' load drifts over all of
            # them alike; the first round's workers are fresh (they import the exporter in the
            # run, as the pool's processes do).
            rounds = []
            for round_index in range(args.repeat):
                times = {"local": run_export(tiles, out, cpus, jobs=args.workers)}
                for workers in sizes:
                    before = workers_cpu_s(clusters[workers].address)
                    times[workers] = run_export(
                        tiles, out, cpus, scheduler=clusters[workers].address
                    )
                    cpu_s = workers_cpu_s(clusters[workers].address) - before
                    times[workers]["cores"] = cpu_s / times[workers]["seconds"]
                    times[workers]["cpu_ms"] = cpu_s / total * 1000.0
                rounds.append(times)
                print(
                    f"  round {round_index + 1}: local pool {times['local']['seconds']:.2f} s, "
                    + ", ".join(
                        f"{w} worker(s) {times[w]['seconds']:.2f} s (got {times[w]['cores']:.2f} "
                        f"cores, {times[w]['cpu_ms']:.1f} CPU ms/building)"
                        for w in sizes
                    )
                )
            local = rounds[0]["local"]
            work_ms = local["work_s"] / total * 1000.0
            address = clusters[args.workers].address
            overhead = task_overhead_ms(address)
            print(
                f"  per-task overhead {overhead:.2f} ms (no-op tasks), work "
                f"{work_ms:.1f} ms/building (the pool's stage sums)"
            )
            batch_runs = {}
            for size in batches:
                batch_runs[size] = run_export(tiles, out, cpus, scheduler=address, batch=size)
                baseline = run_export(tiles, out, cpus, jobs=args.workers)
                ratio = batch_runs[size]["seconds"] / baseline["seconds"]
                batch_runs[size]["ratio"] = ratio
                print(
                    f"    batch {size:>3}: overhead ~{overhead / (size * work_ms):6.2%} of the "
                    f"work; export {batch_runs[size]['seconds']:.2f} s = {ratio:.3f} x the pool's"
                )
        finally:
            for cluster in clusters.values():
                cluster.close()

        def ratios(key: str) -> list[float]:
            if key == "speedup":
                return [r[1]["seconds"] / r[args.workers]["seconds"] for r in rounds]
            return [r[args.workers]["seconds"] / r["local"]["seconds"] for r in rounds]

        print(
            json.dumps(
                {
                    "buildings": total,
                    "cores": cpus,
                    f"speedup_{args.workers}_vs_1_workers": [
                        round(x, 3) for x in ratios("speedup")
                    ],
                    "cluster_vs_local_pool": [round(x, 3) for x in ratios("pool")],
                    "cores_obtained": {
                        str(w): [round(r[w]["cores"], 2) for r in rounds] for w in sizes
                    },
                    "worker_cpu_ms_per_building": {
                        str(w): [round(r[w]["cpu_ms"], 1) for r in rounds] for w in sizes
                    },
                    "per_task_overhead_ms": round(overhead, 2),
                    "work_ms_per_building": round(work_ms, 1),
                    "batch_vs_local_pool": {
                        str(size): round(run["ratio"], 3) for size, run in batch_runs.items()
                    },
                }
            )
        )


if __name__ == "__main__":
    main()
