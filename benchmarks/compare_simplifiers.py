"""Compare mesh simplifiers on the same VWorld-like buildings at the same triangle budgets.

Methods (every peer gets, per building and level, the triangle count this method produced):

- ``this method``: :func:`exporter.simplify.build_mesh_lods` with the default options;
- ``paper QEC only``: the same without the lossless planar stage (``planar_retriangulation``
  off): pymeshlab collapse, Table II locks, the 30 % filter and the error guard;
- ``pymeshlab QEC``: ``meshing_decimation_quadric_edge_collapse`` with its defaults on the welded
  building (positions only);
- ``fast-simplification``: the Fast-Quadric-Mesh-Simplification algorithm (PyPI
  ``fast-simplification``; positions only);
- ``gltfpack -si``: meshoptimizer's gltfpack (npm ``gltfpack``) on a .glb of the building
  (``-si R -noq``; its default error limit ``-se 0.01`` applies, so it may stop above the budget).

Prints one table of the quality metrics (:func:`exporter.quality.measure_lod`) per method and
level, the Table III row of this method (mean triangles per level and ratio to LOD0), and times
as ratios against pymeshlab QEC measured in the same run.

``--equal-error`` compares at equal certified error instead: per building and level, the budget is
this project's (``simplify.max_screen_error_px`` converted to metres, ``MeshLevel.tolerance``);
``this project (meshoptimizer)`` and ``this project (pymeshlab)`` are ``build_mesh_chain`` with
either engine; ``meshopt_simplify`` (vertices split by UV so seams are kept, border locked) and
``fast-simplification`` get their error parameter (meshopt's absolute ``target_error``, FQMS's
``target_reduction``) searched by bisection (10 steps) for the smallest result the guard
(``exporter.simplify.guard.exceeds``) accepts. Printed: triangles as a share of LOD0, the ratio to
meshopt_simplify, the share within budget, IoU / wall coverage minima, boundary change, new holes,
for the default configuration and ``protect_largest: 0%``. Peers' times include their search.

Usage::

    python benchmarks/compare_simplifiers.py --buildings 300 --seed 0
    python benchmarks/compare_simplifiers.py --equal-error --buildings 300 --seed 5
    python benchmarks/compare_simplifiers.py --equal-error --folder tests/data/real --crs EPSG:7415
    python benchmarks/compare_simplifiers.py --gltfpack ~/.cache/vworld-lod/npm/node_modules/.bin/gltfpack
    python benchmarks/compare_simplifiers.py --folder tests/data/real --crs EPSG:7415

gltfpack: ``npm install --prefix ~/.cache/vworld-lod/npm gltfpack`` (outside the repository);
found on PATH, in that folder or in ``benchmarks/.npm``; skipped with a note when absent.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from exporter.config import SimplifyOptions, default_lods
from exporter.model import Part
from exporter.quality import joined, measure_lod
from exporter.simplify import _join, build_mesh_chain, build_mesh_lods, meshopt
from exporter.simplify.guard import Reference, diagonal, exceeds

METRICS = (
    "triangle_ratio",
    "hausdorff_rel",
    "silhouette_iou",
    "wall_coverage",
    "boundary_length_change",
    "new_holes",
)


def count(parts: list[Part]) -> int:
    return sum(p.triangle_count for p in parts)


# --------------------------------------------------------------------------- peers (positions only)


def pymeshlab_qec(parts: list[Part], budget: int) -> list[Part]:
    import pymeshlab

    positions, faces = joined(parts)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(positions, faces.astype(np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=max(1, budget))
    mesh = ms.current_mesh()
    return [Part(mesh.vertex_matrix(), mesh.face_matrix())]


def fast_simplification(parts: list[Part], budget: int) -> list[Part]:
    import fast_simplification as fs

    positions, faces = joined(parts)
    reduction = 1.0 - budget / max(len(faces), 1)
    if reduction <= 0:
        return [Part(positions, faces)]
    points, triangles = fs.simplify(
        positions.astype(np.float32), faces.astype(np.int32), target_reduction=reduction
    )
    return [Part(points, triangles)]


def find_gltfpack(explicit: str | None) -> str | None:
    candidates = [
        explicit,
        shutil.which("gltfpack"),
        str(Path.home() / ".cache/vworld-lod/npm/node_modules/.bin/gltfpack"),
        str(Path(__file__).resolve().parent / ".npm/node_modules/.bin/gltfpack"),
    ]
    return next((c for c in candidates if c and os.access(c, os.X_OK)), None)


def gltfpack(parts: list[Part], budget: int, executable: str, workdir: Path) -> list[Part]:
    import trimesh

    positions, faces = joined(parts)
    source, target = workdir / "in.glb", workdir / "out.glb"
    trimesh.Trimesh(positions, faces, process=False).export(source)
    ratio = min(1.0, budget / max(len(faces), 1))
    subprocess.run(
        [executable, "-i", str(source), "-o", str(target), "-si", f"{ratio:.6f}", "-noq"],
        check=True,
        capture_output=True,
    )
    mesh = trimesh.load(target, force="mesh", process=False)
    return [Part(np.asarray(mesh.vertices), np.asarray(mesh.faces))]


# --------------------------------------------------------------------------- run


def load_folder(folder: str, crs: str | None) -> list:
    """Every building a reader finds in ``folder`` (e.g. tests/data/real CityJSON)."""
    from exporter.config import ReaderOptions
    from exporter.readers import load_entry, scan_folder

    options = ReaderOptions(crs=crs)
    return [load_entry(entry, options) for entry in scan_folder(folder, options).entries]


def run(
    count_buildings: int,
    seed: int,
    gltfpack_path: str | None,
    folder: str | None = None,
    crs: str | None = None,
) -> None:
    if folder:
        buildings = load_folder(folder, crs)[:count_buildings]
        where = f"{len(buildings)} buildings from {folder}"
    else:
        from exporter.samplegen import generate_buildings

        buildings = generate_buildings(count_buildings, seed=seed, atlas_size=16)
        where = f"{count_buildings} sample-generator buildings, seed {seed}"
    lods = default_lods()
    options = SimplifyOptions()
    paper_only = dataclasses.replace(options, planar_retriangulation=False)
    executable = find_gltfpack(gltfpack_path)
    methods = ["this method", "paper QEC only", "pymeshlab QEC", "fast-simplification"] + (
        ["gltfpack -si"] if executable else []
    )
    results = {(m, k): [] for m in methods for k in range(1, len(lods))}
    seconds = {m: 0.0 for m in methods}
    table3 = []
    measure_seconds, measure_calls = 0.0, 0
    with tempfile.TemporaryDirectory() as tmp:
        for building in buildings:
            source = building.parts
            start = time.perf_counter()
            levels = build_mesh_lods(source, lods, options)
            seconds["this method"] += time.perf_counter() - start
            start = time.perf_counter()
            paper_levels = build_mesh_lods(source, lods, paper_only)
            seconds["paper QEC only"] += time.perf_counter() - start
            table3.append([count(level) for level in levels])
            for k in range(1, len(lods)):
                budget = count(levels[k])
                outputs = {"this method": levels[k], "paper QEC only": paper_levels[k]}
                for name, peer in (
                    ("pymeshlab QEC", pymeshlab_qec),
                    ("fast-simplification", fast_simplification),
                ):
                    start = time.perf_counter()
                    outputs[name] = peer(source, budget)
                    seconds[name] += time.perf_counter() - start
                if executable:
                    start = time.perf_counter()
                    outputs["gltfpack -si"] = gltfpack(source, budget, executable, Path(tmp))
                    seconds["gltfpack -si"] += time.perf_counter() - start
                for name, parts in outputs.items():
                    start = time.perf_counter()
                    metrics = measure_lod(source, parts).to_manifest()
                    measure_seconds += time.perf_counter() - start
                    measure_calls += 1
                    metrics["budget_reached"] = float(count(parts) <= budget)
                    results[(name, k)].append(metrics)

    print(f"# {where}; budgets = this method's triangle counts")
    print(f"# mean source triangles {np.mean([t[0] for t in table3]):.1f}")
    header = f"{'method':<22}{'level':>6}{'tri ratio':>10}{'at budget':>10}{'hausdorff':>10}{'IoU mean':>9}{'IoU min':>8}{'cover mean':>11}{'cover min':>10}{'|boundary|':>11}{'holes':>6}"
    print(header)
    print("-" * len(header))
    for name in methods:
        for k in range(1, len(lods)):
            rows = results[(name, k)]

            def column(key, rows=rows):
                return np.array([r[key] for r in rows], dtype=float)

            print(
                f"{name:<22}{k:>6}{column('triangle_ratio').mean():>10.3f}{column('budget_reached').mean():>10.2f}"
                f"{column('hausdorff_rel').mean():>10.4f}{column('silhouette_iou').mean():>9.3f}{column('silhouette_iou').min():>8.3f}"
                f"{column('wall_coverage').mean():>11.3f}{column('wall_coverage').min():>10.3f}"
                f"{np.abs(column('boundary_length_change')).mean():>11.4f}{int(column('new_holes').sum()):>6}"
            )
    means = np.mean(table3, axis=0)
    ratios = np.mean(np.array(table3) / np.array(table3)[:, :1], axis=0)
    print(
        "\nTable III (this method): "
        + " | ".join(
            f"LOD{k} {m:.2f} tris ({m / means[0] * 100:.2f} %)" for k, m in enumerate(means)
        )
    )
    print(
        "mean of per-building ratios: "
        + " | ".join(f"LOD{k} {r * 100:.2f} %" for k, r in enumerate(ratios))
    )
    print(
        "paper (1,248 Seoul buildings): LOD0 326.29 | LOD1 220.14 (67.46 %) | LOD2 156.86 (48.07 %)"
    )
    base = seconds["pymeshlab QEC"] or 1e-9
    print(
        "\ntime per building relative to pymeshlab QEC (same run): "
        + ", ".join(f"{name} {seconds[name] / base:.1f}x" for name in methods)
    )
    print(
        f"measure_lod: {measure_seconds / max(measure_calls, 1) * 1000:.1f} ms per call (mean over {measure_calls} calls)"
    )
    if not executable:
        print(
            "gltfpack not found: npm install --prefix ~/.cache/vworld-lod/npm gltfpack (or pass --gltfpack PATH)"
        )


# --------------------------------------------------------------------------- equal error

SEARCH_STEPS = 10


def searched(run, low: float, high: float, reference, tolerance: float):
    """The smallest result of ``run(parameter) -> (positions, faces)`` that the guard accepts
    within ``tolerance`` metres of ``reference``: bisection on the parameter (larger = more
    aggressive) between ``low`` (assumed to pass; checked) and ``high``, ``SEARCH_STEPS`` steps;
    the source itself when nothing passes."""
    best = None
    for parameter in (low, high):
        positions, faces = run(parameter)
        if len(faces) and not exceeds(reference, positions, faces, tolerance):
            if best is None or len(faces) < len(best[1]):
                best = positions, faces
            if parameter == high:
                return best
    for _ in range(SEARCH_STEPS):
        middle = 0.5 * (low + high)
        positions, faces = run(middle)
        if len(faces) and not exceeds(reference, positions, faces, tolerance):
            low = middle
            if best is None or len(faces) < len(best[1]):
                best = positions, faces
        else:
            high = middle
    return best if best is not None else (reference.positions, reference.faces)


def plain_meshopt(source: list[Part], reference, tolerance: float):
    """``meshopt_simplify`` on the building (vertices split by UV: seams kept as meshopt does),
    border locked, its absolute error target searched until the guard accepts the result."""
    positions, faces, face_part, corner_uvs, _, _ = _join(source, 0.0)
    vertex_of, _, wedge_faces = meshopt._wedges(faces, corner_uvs, face_part, True)
    wedge_positions = (positions[vertex_of] - positions.min(axis=0)).astype(np.float32)

    def run(error):
        kept, _ = meshopt.simplify(wedge_faces.reshape(-1), wedge_positions, 0, error)
        return positions, vertex_of[kept.reshape(-1, 3).astype(np.int64)]

    return searched(run, 0.0, 4.0 * tolerance, reference, tolerance)


def fast_simplification_searched(source: list[Part], reference, tolerance: float):
    """fast-simplification (Fast-Quadric-Mesh-Simplification, positions only), its
    ``target_reduction`` searched until the guard accepts the result."""
    import fast_simplification as fs

    positions, faces = joined(source)

    def run(reduction):
        if reduction <= 0:
            return positions, faces
        points, triangles = fs.simplify(
            positions.astype(np.float32), faces.astype(np.int32), target_reduction=reduction
        )
        return np.asarray(points, np.float64), np.asarray(triangles, np.int64)

    return searched(run, 0.0, 0.99, reference, tolerance)


def equal_error(buildings: list, where: str) -> None:
    """Per method, level and configuration: the triangles (share of LOD0) each method needs to stay
    within this project's certified budget per level (the guard is the judge for every method),
    with the quality metrics of the result."""
    lods = default_lods()
    configs = {
        "default": SimplifyOptions(),
        "protect_largest 0%": SimplifyOptions(protect_largest=0.0),
    }
    for label, options in configs.items():
        methods = [
            "this project (meshoptimizer)",
            "this project (pymeshlab)",
            "meshopt_simplify",
            "fast-simplification",
        ]
        rows = {(m, k): [] for m in methods for k in range(1, len(lods))}
        seconds = dict.fromkeys(methods, 0.0)
        for building in buildings:
            start = time.perf_counter()
            chain = build_mesh_chain(building.parts, lods, options)
            seconds[methods[0]] += time.perf_counter() - start
            start = time.perf_counter()
            other = build_mesh_chain(
                building.parts, lods, dataclasses.replace(options, engine="pymeshlab")
            )
            seconds[methods[1]] += time.perf_counter() - start
            source = chain[0].parts
            reference = Reference(*_join(source, 0.0)[:2])
            for k in range(1, len(lods)):
                tolerance = chain[k].tolerance
                outputs = {methods[0]: chain[k].parts, methods[1]: other[k].parts}
                for name, peer in (
                    (methods[2], plain_meshopt),
                    (methods[3], fast_simplification_searched),
                ):
                    start = time.perf_counter()
                    positions, faces = peer(source, reference, tolerance)
                    seconds[name] += time.perf_counter() - start
                    outputs[name] = [Part(positions, faces)]
                for name, parts in outputs.items():
                    metrics = measure_lod(source, parts).to_manifest()
                    metrics["within"] = float(not exceeds(reference, *joined(parts), tolerance))
                    # Independent of the guard: measure_lod's own sampled distance over the budget.
                    metrics["over"] = (
                        metrics["hausdorff_rel"] * diagonal(reference.positions) / tolerance
                    )
                    rows[(name, k)].append(metrics)
        print(f"\n## equal certified error, {label}: {where}")
        print("budget per level: simplify.max_screen_error_px at the transition of the level above")
        print(
            "| method | level | triangles (share of LOD0) | ratio to meshopt_simplify | within budget | measured / budget max | IoU min | coverage min | max abs boundary change | new holes | time (x meshopt_simplify) |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for name in methods:
            for k in range(1, len(lods)):
                column = lambda key, r=rows[(name, k)]: np.array([m[key] for m in r], float)
                peer = np.array([m["triangle_ratio"] for m in rows[("meshopt_simplify", k)]])
                ratio = column("triangle_ratio").mean()
                print(
                    f"| {name} | LOD{k} | {ratio * 100:.1f} % | {ratio / peer.mean():.2f}x | {column('within').mean() * 100:.0f} % | {column('over').max():.2f} "
                    f"| {column('silhouette_iou').min():.3f} | {column('wall_coverage').min():.3f} "
                    f"| {np.abs(column('boundary_length_change')).max():.4f} | {int(column('new_holes').sum())} "
                    f"| {seconds[name] / max(seconds['meshopt_simplify'], 1e-9):.1f}x |"
                )
        ours = [np.mean([m["triangle_ratio"] for m in rows[(methods[0], k)]]) for k in (1, 2)]
        print(f"LOD2 / LOD1 mean triangle ratio ({methods[0]}): {ours[1] / ours[0]:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--buildings",
        type=int,
        default=300,
        help="number of sample-generator buildings (default 300)",
    )
    parser.add_argument("--seed", type=int, default=0, help="sample-generator seed (default 0)")
    parser.add_argument("--gltfpack", default=None, help="path of the gltfpack executable")
    parser.add_argument(
        "--folder",
        default=None,
        help="read the buildings from this input folder instead (any reader format)",
    )
    parser.add_argument(
        "--crs",
        default=None,
        help="CRS for input files that declare none (with --folder), e.g. EPSG:7415",
    )
    parser.add_argument(
        "--equal-error",
        action="store_true",
        help="compare the triangles each method needs within the same certified error budget",
    )
    args = parser.parse_args()
    if args.equal_error:
        if args.folder:
            buildings = load_folder(args.folder, args.crs)[: args.buildings]
            where = f"{len(buildings)} buildings from {args.folder}"
        else:
            from exporter.samplegen import generate_buildings

            buildings = generate_buildings(args.buildings, seed=args.seed, atlas_size=16)
            where = f"{args.buildings} sample-generator buildings, seed {args.seed}"
        equal_error(buildings, where)
        return
    run(args.buildings, args.seed, args.gltfpack, args.folder, args.crs)


if __name__ == "__main__":
    main()
