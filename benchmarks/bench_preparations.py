"""Which Hausdorff surfaces the mesh stage prepares per building, and which it prepares twice.

Usage: ``python benchmarks/bench_preparations.py TILE [--limit N]``.
Runs the mesh stage per building as ``benchmarks/bench_mesh.py`` does (``build_mesh_chain``, then
each level's quality) and records every preparation with its milliseconds and its stage (simplify
= the guard inside ``build_mesh_chain``, quality after it): each piece of a
:class:`exporter.mesh.hausdorff.Surface` (index, regions, chains, face planes, trusted faces;
``R`` a reference, ``L`` a level), each :class:`exporter.mesh.distance.SurfaceIndex` (also
those the ``index`` pieces build) and each
:func:`exporter.mesh.coverage.region_certificate`. A preparation counts as a duplicate when the
same building prepared the same piece before for the same arrays: ``bytes`` (positions and faces
bit for bit: a prepared object could be handed over with every result unchanged) or ``geometry``
(the same triangles as corner coordinates, in any vertex and face order: the same surface, but
its bounds may differ in the last bits). Prints counts, milliseconds and buildings per piece.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import hashlib
import time
from collections.abc import Callable

import numpy as np
from bench_mesh import mesh_stage

from exporter import config, quality, readers, simplify
from exporter.mesh import coverage, distance, hausdorff
from exporter.simplify import guard

PIECES = ("index", "regions", "chains", "face_planes", "trusted")
# (stage, piece, bytes key, geometry key, seconds) of the running building
LOG: list[tuple[str, str, str, str, float]] = []
STAGE = ["simplify"]


def _digest(*arrays: np.ndarray) -> str:
    digest = hashlib.blake2b(digest_size=8)
    for array in arrays:
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def keys(positions: np.ndarray, faces: np.ndarray) -> tuple[str, str]:
    """``(bytes, geometry)`` keys of a mesh (positions (k, 3) metres, faces (m, 3))."""
    positions = np.asarray(positions, np.float64).reshape(-1, 3)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    corners = positions[faces]  # (m, 3, 3): each face's corners sorted, then the faces sorted
    corners = corners[np.arange(len(faces))[:, None], np.lexsort(corners.transpose(2, 0, 1)[::-1])]
    rows = corners.reshape(-1, 9)
    return _digest(positions, faces), _digest(rows[np.lexsort(rows.T[::-1])])


def _record(piece: str, mesh_keys: tuple[str, str], started: float) -> None:
    LOG.append((STAGE[0], piece, *mesh_keys, time.perf_counter() - started))


def _watch_piece(name: str) -> None:
    prop = getattr(hausdorff.Surface, name)

    def getter(self):
        if getattr(self, "_" + name) is not None:
            return prop.fget(self)
        started = time.perf_counter()
        value = prop.fget(self)
        kind = name + ("R" if self.reference else "L")
        _record(kind, keys(self.positions, self.faces), started)
        return value

    setattr(hausdorff.Surface, name, property(getter))


def instrument() -> None:
    """Wrap the preparations so that each one is logged (this process only)."""
    for name in PIECES:
        _watch_piece(name)
    index_init = distance.SurfaceIndex.__init__

    def init(self, positions, faces, *args, **kwargs):
        started = time.perf_counter()
        index_init(self, positions, faces, *args, **kwargs)
        _record("SurfaceIndex", keys(positions, faces), started)

    distance.SurfaceIndex.__init__ = init  # type: ignore[method-assign]
    certificate = coverage.region_certificate

    def certify(level, source, *args, **kwargs):
        started = time.perf_counter()
        result = certificate(level, source, *args, **kwargs)
        pairs = keys(*level), keys(*source)
        _record(
            "region_certificate", (pairs[0][0] + pairs[1][0], pairs[0][1] + pairs[1][1]), started
        )
        return result

    for module in (coverage, hausdorff, guard):
        module.region_certificate = certify  # type: ignore[attr-defined]


def _staged(build: Callable) -> Callable:
    def chain(*args, **kwargs):
        STAGE[0] = "simplify"
        levels = build(*args, **kwargs)
        STAGE[0] = "quality"
        return levels

    return chain


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder")
    parser.add_argument("--limit", type=int, default=0)
    parser.add_argument("--crs", default="EPSG:7415", help="CRS of CityJSON files declaring none")
    args = parser.parse_args()
    cfg = config.Config()
    options = dataclasses.replace(cfg.readers, crs=args.crs)
    entries = readers.scan_folder(args.folder, options).entries[: args.limit or None]
    buildings = [readers.load_entry(entry, options) for entry in entries]
    modules = {"simplify": simplify, "quality": quality}
    mesh_stage(modules, buildings[0].parts, cfg)  # first calls: not a building's cost
    instrument()
    modules["simplify"] = type(
        "Staged", (), {"build_mesh_chain": _staged(simplify.build_mesh_chain)}
    )
    total: collections.Counter = collections.Counter()
    seconds: collections.Counter = collections.Counter()
    twice = {kind: collections.Counter() for kind in ("bytes", "geometry")}
    twice_ms = {kind: collections.Counter() for kind in ("bytes", "geometry")}
    twice_buildings = {kind: collections.Counter() for kind in ("bytes", "geometry")}
    for building in buildings:
        LOG.clear()
        quality._CACHE.clear()  # each building's source prepared as in the pipeline
        mesh_stage(modules, building.parts, cfg)
        for column, kind in ((2, "bytes"), (3, "geometry")):
            first: dict = {}
            found = set()
            for row in LOG:
                stage, piece, seconds_taken = row[0], row[1], row[4]
                key = (piece, row[column])
                if key in first:
                    label = f"{piece} {first[key]} -> {stage}"
                    twice[kind][label] += 1
                    twice_ms[kind][label] += seconds_taken
                    found.add(label)
                else:
                    first[key] = stage
            for label in found:
                twice_buildings[kind][label] += 1
        for stage, piece, _, _, seconds_taken in LOG:
            total[stage, piece] += 1
            seconds[stage, piece] += seconds_taken
    print(f"{len(buildings)} buildings; preparations: count, ms")
    for stage, piece in sorted(total):
        print(
            f"  {stage:9s} {piece:20s} {total[stage, piece]:6d} {1e3 * seconds[stage, piece]:9.1f}"
        )
    for kind in ("bytes", "geometry"):
        print(f"prepared again for the same {kind}: count, ms, buildings")
        if not twice[kind]:
            print("  none")
        for label in sorted(twice[kind], key=lambda label: -twice_ms[kind][label]):
            print(
                f"  {label:40s} {twice[kind][label]:6d} {1e3 * twice_ms[kind][label]:9.1f}"
                f" {twice_buildings[kind][label]:6d}"
            )


if __name__ == "__main__":
    main()
