"""A camera path from 3 km to 15 m towards one textured building, in CesiumJS: which content it
shows, how large one of that content's texels is on screen, and the texture memory (issue 34).

Two inputs: a generated VWorld tile (exporter.samplegen, ``--count`` buildings, ``--atlas`` px
atlases) and the real textured CityJSON of tests/data/real/rotterdam_textured. Each is exported
twice in the same run: by the code of ``--baseline`` (a git ref, default ``main``: its tree
extracted with ``git archive`` into ``--work``, the compiled kernels copied from this checkout,
whose C sources must be the ref's) and by this checkout. Both exports run as subprocesses
(``python -m exporter export``).

The target: the textured building nearest the centre of its tile's buildings. The camera looks
north at the centre of the target's south face (LOD0's box, glTF frame +X West, +Y Up, +Z North)
from ``--frames`` distances between 3,000 m and 15 m (evenly on a log scale), 20 degrees above
it. CesiumJS (tests/tileset_client/render.js, POSES mode: headless Chromium, ``--width`` x
``--height`` pixels, 16:9, CesiumJS's default 60 degree field of view, which is horizontal on a
landscape canvas: 36 degrees vertically; default 16 px maximum screen-space error) loads the
tileset afresh per view and reports the contents selected for the target (a proxy when
the target's own chain is not reached) and ``totalMemoryUsageInBytes``.

Per frame and tileset: the content, ``texel px`` = the content's on-surface texel size
(exporter/texel.py: the area-weighted median over its faces, read from the .glb itself; a proxy's
over its whole surface) x ``height / (2 d tan(fovy / 2))`` (:func:`tests.texel_views.screen_px`:
CesiumJS's own rule; 16/9 of what a 60 degree vertical field of view gives) at the distance ``d``
to the aimed point, and the memory in MB; then the new/baseline memory ratio. Last, the issue's targets:
lod0.glb at 15 m, every texel at most ``--sse`` px, memory within 2x the baseline's.

Usage: ``python benchmarks/bench_texel_path.py [--work /tmp/vworld-texel-path] [--baseline main]
[--count 60] [--atlas 512] [--frames 10] [--jobs 2] [--inputs generated,rotterdam_textured]
[--no-all-lod0]``
"""

from __future__ import annotations

import argparse
import io
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from exporter.model import TileId  # noqa: E402
from exporter.samplegen import generate_tile  # noqa: E402
from tests.texel_views import (  # noqa: E402
    camera_path,
    content_texel,
    fly,
    screen_px,
    target_building,
)
from tests.tileset_check import load  # noqa: E402

ROTTERDAM = REPO / "tests" / "data" / "real" / "rotterdam_textured"
TILE = TileId(15, 279418, 116113)


def baseline_tree(work: Path, ref: str) -> Path:
    """The exporter of git ``ref`` extracted into ``work/baseline/<ref>``, with this checkout's
    compiled kernels when the ref's C sources are the same (kernels added since are copied too,
    unused), else its own built there (``setup.py build_ext --inplace``, about a minute)."""
    diff = subprocess.run(
        ["git", "diff", "--quiet", "--diff-filter=MDR", ref, "--", "exporter/mesh/c"], cwd=REPO
    )
    target = work / "baseline" / ref.replace("/", "_")
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    archive = subprocess.run(
        ["git", "archive", "--format=tar", ref, "exporter", "setup.py"],
        cwd=REPO,
        capture_output=True,
        check=True,
    ).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(target, filter="data")
    if diff.returncode == 0:
        for built in (REPO / "exporter").rglob("*.so"):
            shutil.copy2(built, target / built.relative_to(REPO))
    else:
        subprocess.run(
            [sys.executable, "setup.py", "-q", "build_ext", "--inplace"],
            cwd=target, check=True, capture_output=True,
        )  # fmt: skip
    return target


def export(source_root: Path, folder: Path, out: Path, jobs: int) -> None:
    """``python -m exporter export folder --out out`` with the exporter of ``source_root``."""
    env = dict(os.environ, PYTHONPATH=str(source_root))
    subprocess.run(
        [sys.executable, "-m", "exporter", "export", str(folder), "--out", str(out), "--quiet",
         "--jobs", str(jobs), "--force"],
        cwd=source_root, env=env, check=True,
    )  # fmt: skip


def frames_of(
    out: Path, target: str, path: list, height: int, name: str = "tileset.json"
) -> list[dict]:
    """Per frame of tileset ``out/name``: distance, target content(s), its texel on screen (px),
    memory (bytes)."""
    texels: dict[str, float | None] = {}
    rows = []
    width = round(height * 16 / 9)
    views = fly(out, target, path, width, height, name)
    for (distance, _), view in zip(path, views):
        shown = view["target"]
        for uri in shown:
            if uri not in texels:
                texels[uri] = content_texel(out / uri)
        metres = [texels[u] for u in shown if texels[u] is not None]
        pixels = screen_px(max(metres), distance, width, height) if metres else 0.0
        rows.append(
            {"distance": distance, "content": ",".join(u.rsplit("/", 1)[-1] for u in shown) or "-",
             "texel_px": pixels, "memory": view["memory"], "errors": view["errors"]}
        )  # fmt: skip
    return rows


def all_lod0(out: Path) -> Path:
    """The new tileset with every building chain cut to its LOD0 (error 0), no proxy drawn and
    every tile without content refined at once (error 1e7 m), written beside it as
    ``all_lod0.json``: the memory of showing the finest level of everything in view, for scale
    (the tiles' own tilesets resolved into it: one file)."""
    tileset = load(out)

    def visit(node: dict) -> None:
        node.pop("external", None)  # load's record of the external tileset, not 3D Tiles
        uri = node.get("content", {}).get("uri", "")
        if "/lod" in uri:
            node["content"]["uri"] = uri.rsplit("/", 1)[0] + "/lod0.glb"
            node["geometricError"] = 0.0
            node.pop("children", None)
            return
        node.pop("content", None)  # a proxy: never drawn
        node["geometricError"] = 1e7
        for child in node.get("children", []):
            visit(child)

    visit(tileset["root"])
    tileset["geometricError"] = 1e7
    path = out / "all_lod0.json"
    path.write_text(json.dumps(tileset))
    return path


def run_input(name: str, folder: Path, work: Path, baseline: Path, args) -> bool:
    """Export ``folder`` with both codes, fly both tilesets; print the table; True when the
    targets hold."""
    outs = {"baseline": work / name / "baseline", "new": work / name / "new"}
    export(baseline, folder, outs["baseline"], args.jobs)
    export(REPO, folder, outs["new"], args.jobs)
    target, building = target_building(outs["new"])
    path = camera_path(building, args.frames)
    rows = {key: frames_of(out, target, path, args.height) for key, out in outs.items()}
    if args.all_lod0:
        all_lod0(outs["new"])
        every = frames_of(outs["new"], target, path, args.height, "all_lod0.json")
    else:  # the slowest view to render (every building's finest level): left out on request
        every = [{"memory": float("nan")} for _ in path]
    print(f"\n{name}: target {target} ({args.height} lines, {args.sse:g} px SSE)")
    print(f"{'distance m':>10} | {'baseline content':<18} {'texel px':>8} {'MB':>7} | "
          f"{'new content':<18} {'texel px':>8} {'MB':>7} | memory new/base | all-LOD0 MB, /base")  # fmt: skip
    for base, new, lod0 in zip(rows["baseline"], rows["new"], every):
        ratio = new["memory"] / base["memory"] if base["memory"] else float("nan")
        ratio0 = lod0["memory"] / base["memory"] if base["memory"] else float("nan")
        print(f"{base['distance']:10.1f} | {base['content']:<18} {base['texel_px']:8.2f} "
              f"{base['memory'] / 1e6:7.2f} | {new['content']:<18} {new['texel_px']:8.2f} "
              f"{new['memory'] / 1e6:7.2f} | {ratio:15.2f} | {lod0['memory'] / 1e6:7.2f} "
              f"{ratio0:5.2f}", flush=True)  # fmt: skip
    new_rows = rows["new"]
    last = new_rows[-1]["content"] == "lod0.glb"
    sharp = max(r["texel_px"] for r in new_rows) <= args.sse
    memory = max(n["memory"] / max(b["memory"], 1) for n, b in zip(new_rows, rows["baseline"]))
    errors = [e for r in new_rows for e in r["errors"]]
    print(f"targets: lod0.glb at {path[-1][0]:.0f} m: {last}; every texel <= {args.sse:g} px: "
          f"{sharp}; memory <= 2x baseline: {memory <= 2.0} (largest ratio {memory:.2f}); "
          f"client errors: {len(errors)}", flush=True)  # fmt: skip
    return last and sharp and memory <= 2.0 and not errors


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--work", type=Path, default=Path(tempfile.gettempdir()) / "vworld-texel-path"
    )
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--count", type=int, default=60)
    parser.add_argument("--atlas", type=int, default=512)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--sse", type=float, default=16.0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--inputs", default="generated,rotterdam_textured")
    parser.add_argument(
        "--no-all-lod0", dest="all_lod0", action="store_false",
        help="leave out the all-LOD0 view (for scale only; the slowest to render)",
    )  # fmt: skip
    args = parser.parse_args()
    inputs = args.inputs.split(",")
    args.work.mkdir(parents=True, exist_ok=True)
    baseline = baseline_tree(args.work, args.baseline)
    ok = True
    if "generated" in inputs:
        generated = generate_tile(
            args.work / "in" / TILE.name, args.count, seed=34, tile=TILE, atlas_size=args.atlas
        )
        ok = run_input("generated", generated, args.work, baseline, args)
    if "rotterdam_textured" in inputs:
        ok = run_input("rotterdam_textured", ROTTERDAM, args.work, baseline, args) and ok
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
