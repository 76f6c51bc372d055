"""The certified Hausdorff bound on a whole merged tile: memory and time on one large mesh.

A generated VWorld tile is exported; every building's LOD2 and LOD0 files are merged into one mesh
each in the tile's glTF frame (as ``exporter/tileset/proxy.py`` merges them; metres), and
``hausdorff_bounds(LOD0, LOD2)`` runs in a child process under an address-space limit, so a
memory blow-up is a ``MemoryError`` (or a signal, reported as such) instead of the machine's
memory. Prints the bounds (metres), wall seconds and the child's peak RSS (MiB), for this
checkout and optionally another (``--baseline``, run the same way, alternated).

Usage: ``python benchmarks/bench_merged_bound.py [--buildings 1248] [--limit-gib 8]
[--baseline CHECKOUT] [--workdir DIR]`` (1,248 buildings: export ~20 s with 2 jobs, bound ~100 s,
peak 1.3 GiB; 0.3.4 and main before the fix stopped with a 7.36 GiB request).
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

CHILD = """
import json, os, resource, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
# By path, not by ImportError: an editable install's finder would supply a missing subpackage.
if os.path.exists(os.path.join(sys.argv[1], "exporter", "mesh", "hausdorff.py")):
    from exporter.mesh.hausdorff import Surface, hausdorff_bounds
else:  # checkouts before the mesh layer (0.3.4)
    from exporter.hausdorff import Surface, hausdorff_bounds
import exporter
assert exporter.__file__.startswith(sys.argv[1]), exporter.__file__
a, b = np.load(sys.argv[2]), np.load(sys.argv[3])
started = time.perf_counter()
low, high = hausdorff_bounds(Surface(a["positions"], a["faces"]), (b["positions"], b["faces"]), rtol=0.05)
print(json.dumps({"bounds": [low, high], "seconds": time.perf_counter() - started,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def merged_levels(work: Path, count: int, jobs: int) -> tuple[Path, Path]:
    """Generate and export a ``count``-building tile under ``work``; the .npz files of its merged
    LOD0 and LOD2 (positions (n, 3) metres in the tile's glTF frame, faces (m, 3))."""
    import numpy as np

    from exporter.config import Config
    from exporter.model import TileId
    from exporter.pipeline import export_tiles
    from exporter.samplegen import generate_tile
    from exporter.tileset import frames
    from exporter.tileset.proxy import ProxyInput, merged_inputs
    from exporter.tileset.tree import tile_world

    tile, out = work / "tile", work / "out"
    if not list(tile.glob("*.dat")):
        generate_tile(tile, count=count, seed=0, atlas_size=256)
    if not out.is_dir():
        export_tiles([str(tile)], str(out), Config(), jobs=jobs, force=True)
    files = []
    for level in (0, 2):
        inputs, world = [], None
        for manifest in sorted(out.glob("*/lod_manifest.json")):
            folder = manifest.parent
            world = tile_world(TileId(*map(int, folder.name.split("_"))))
            for record in json.loads(manifest.read_text(encoding="utf-8"))["buildings"]:
                found = [lod["file"] for lod in record.get("lods", []) if lod["level"] == level]
                if found:
                    centre = record["center"]
                    place = frames.world_matrix(centre["lon"], centre["lat"], centre["elev"])
                    inputs.append(ProxyInput(place, folder / found[0], 0.0, 0.0, ""))
        assert world is not None, "the export wrote no tile"
        primitives, _ = merged_inputs(inputs, world)
        offsets = np.cumsum([0] + [len(p.positions) for p in primitives])
        path = work / f"lod{level}.npz"
        np.savez(
            path,
            positions=np.concatenate([p.positions for p in primitives]),
            faces=np.concatenate([p.triangles + offsets[i] for i, p in enumerate(primitives)]),
        )
        print(f"LOD{level}: {len(inputs)} buildings, {offsets[-1]} vertices")
        files.append(path)
    return files[0], files[1]


def run(checkout: Path, lod0: Path, lod2: Path, limit_gib: float) -> dict:
    """One bound in a child process limited to ``limit_gib`` GiB of address space."""

    def limit() -> None:
        size = int(limit_gib * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (size, size))

    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-X", "faulthandler", "-c", CHILD, str(checkout), str(lod0), str(lod2)],
        capture_output=True,
        text=True,
        preexec_fn=limit,
        env={**os.environ, "PYTHONPATH": str(checkout)},
    )
    if done.returncode != 0:
        tail = done.stderr.strip().splitlines()[-1:] or [""]
        return {"failed": done.returncode, "last": tail[0], "wall": time.perf_counter() - started}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buildings", type=int, default=1248)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--limit-gib", type=float, default=8.0)
    parser.add_argument("--baseline", help="another checkout, run the same way")
    parser.add_argument("--workdir", help="keep the tile, export and merged meshes here")
    args = parser.parse_args()
    work = Path(args.workdir or tempfile.mkdtemp(prefix="vworld-lod-merged-"))
    work.mkdir(parents=True, exist_ok=True)
    lod0, lod2 = merged_levels(work, args.buildings, args.jobs)
    checkouts = [("this", REPO)] + ([("baseline", Path(args.baseline))] if args.baseline else [])
    for name, checkout in checkouts:
        print(name, json.dumps(run(checkout, lod0, lod2, args.limit_gib)))


if __name__ == "__main__":
    main()
