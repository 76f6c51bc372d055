"""Per-proxy cost by quadtree level (issue 37, "each proxy costs about its own budget").

Rebuilds every tile proxy of an existing export (``write_tileset(..., force=True)``, one
process, children before parents) in a copy of ``OUT`` and prints, per proxy: its level, inputs
(buildings or child proxies), input triangles, triangles, seconds of
:func:`exporter.tileset.proxy.make_proxy`, clustering passes, geometric error (metres,
certified against the LOD0 below), texel (metres) and atlas side (px). With ``--baseline DIR``
(a source folder of another exporter version, e.g. ``git archive`` of main with the compiled
``.so`` files copied in) the same is measured with that code in the same run, and each proxy's
figures are printed as ratios (this / baseline).

Make an export first, e.g. ``python benchmarks/bench_city_scale.py --sizes 16 --buildings 300
--no-dask --workdir /tmp/city`` (its ``OUT`` is kept in the workdir) or use any ``OUT``.

Usage: ``python benchmarks/bench_proxy_levels.py OUT [--baseline DIR] [--workdir DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def child(out: str) -> None:
    """Rebuild every proxy of ``out`` in this process, timing each; print one JSON line each."""
    from exporter.config import TilesetOptions
    from exporter.tileset import proxy, schedule, write_tileset

    passes: list[int] = []
    real_cluster = proxy.cluster

    def counted(*args, **kwargs):
        passes[-1] += 1
        return real_cluster(*args, **kwargs)

    proxy.cluster = counted
    real_make = schedule.make_proxy

    def timed(task, *args):
        passes.append(0)
        merged = proxy.merge_inputs(task)  # outside the timing: only its size is read
        started = time.perf_counter()
        record = real_make(task, *args)
        seconds = time.perf_counter() - started
        print(
            json.dumps(
                {
                    "tile": task.tile.name,
                    "level": task.tile.level,
                    "buildings": len(task.buildings),
                    "children": len(task.children),
                    "input_triangles": len(merged.faces),
                    "triangles": record.get("triangles"),
                    "seconds": seconds,
                    "passes": passes[-1],
                    "geometric": record.get("geometric"),
                    "texel": record.get("texel"),
                    "atlas_px": record.get("atlas_px"),
                    "too_large": bool(record.get("too_large")),
                }
            ),
            flush=True,
        )
        return record

    schedule.make_proxy = timed
    write_tileset(out, TilesetOptions(), force=True)


def measure(code: Path, source: Path, work: Path) -> dict[str, dict]:
    """Per proxy tile name, its figures, rebuilt by the exporter in ``code`` in a copy of
    ``source``."""
    out = work / "out"
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(source, out)
    env = dict(os.environ, PYTHONPATH=str(code))
    done = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--child", str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=code,
    )
    shutil.rmtree(out)
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    return {row["tile"]: row for row in rows}


def show(name: str, rows: dict[str, dict]) -> None:
    print(f"\n{name}")
    print(
        f"{'tile':>18} {'lvl':>3} {'in':>4} {'in tris':>8} {'tris':>7} {'s':>6} {'pass':>4} "
        f"{'geom m':>7} {'texel m':>7} {'atlas':>5}"
    )
    for tile in sorted(rows, key=lambda t: (-rows[t]["level"], t)):
        r = rows[tile]
        inputs = r["buildings"] or r["children"]
        print(
            f"{tile:>18} {r['level']:>3} {inputs:>4} {r['input_triangles']:>8} "
            f"{r['triangles'] if r['triangles'] is not None else '-':>7} {r['seconds']:>6.2f} "
            f"{r['passes']:>4} {r['geometric'] or 0:>7.2f} {r['texel'] or 0:>7.3f} "
            f"{r['atlas_px'] or 0:>5}"
        )
    print(f"total proxy seconds: {sum(r['seconds'] for r in rows.values()):.2f}")


def ratio(a, b) -> str:
    return f"{a / b:.2f}" if a and b else "-"


def compare(this: dict[str, dict], base: dict[str, dict]) -> None:
    print("\nthis / baseline, per level (mean of ratios over the level's proxies)")
    print(f"{'lvl':>3} {'n':>3} {'tris':>6} {'seconds':>7} {'geom':>6} {'atlas':>6}")
    for level in sorted({r["level"] for r in this.values()}, reverse=True):
        tiles = [t for t in this if this[t]["level"] == level and t in base]
        cols = []
        for key in ("triangles", "seconds", "geometric", "atlas_px"):
            values = [this[t][key] / base[t][key] for t in tiles if this[t][key] and base[t][key]]
            cols.append(f"{sum(values) / len(values):.2f}" if values else "-")
        print(f"{level:>3} {len(tiles):>3} {cols[0]:>6} {cols[1]:>7} {cols[2]:>6} {cols[3]:>6}")
    total = sum(r["seconds"] for r in this.values()), sum(r["seconds"] for r in base.values())
    print(f"all proxies' seconds: {total[0]:.2f} / {total[1]:.2f} = {ratio(*total)}")


def main() -> None:
    if "--child" in sys.argv:
        child(sys.argv[sys.argv.index("--child") + 1])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="an export's OUT (copied, never modified)")
    parser.add_argument("--baseline", help="a source folder of the exporter to compare with")
    parser.add_argument("--workdir", help="where the copies go (default: a temporary folder)")
    args = parser.parse_args()
    work = Path(args.workdir or tempfile.mkdtemp(prefix="bench_proxy_levels_"))
    work.mkdir(parents=True, exist_ok=True)
    this = measure(REPO, Path(args.out), work)
    show(f"this checkout ({REPO})", this)
    if args.baseline:
        base = measure(Path(args.baseline).resolve(), Path(args.out), work)
        show(f"baseline ({args.baseline})", base)
        compare(this, base)
    print(json.dumps({"this": this, **({"baseline": base} if args.baseline else {})}))


if __name__ == "__main__":
    main()
