"""Deterministic VWorld-like sample buildings and tiles (for tests, benchmarks and the demo tile).

Data form: :func:`generate_buildings` returns :class:`exporter.model.Building` objects exactly as a
reader would: positions in each building's **local East/Up/North frame, metres** (x = East,
y = Up, z = North, origin at the centre of its bounding box at its base elevation), triangles wound
outward, UVs in glTF's convention, one JPEG texture atlas per part. Buildings are **floorless**
(no bottom faces; the open bottom edges at y = 0 outline the footprint), walls are cut into
floors x window bays, and triangle counts follow a log-normal distribution whose mean is
``mean_triangles`` (the paper's Seoul buildings: 326.29 on average, a long tail past 1 000).

Everything comes from ``seed``: building ``i`` draws from its own stream
``SeedSequence([seed, 2, i])`` (so it does not depend on ``count``) and the tile layout from
``SeedSequence([seed, 1])``; the same seed gives the same bytes.

Pipeline of :func:`generate_samples`: draw each building (kind, triangle budget, sizes) -> build
and fit its mesh to the budget -> turn it to the tile's street grid -> draw and encode its atlas
-> place the footprints in the tile -> set each reference point (lon/lat of the centre, terrain
elevation 20-60 m).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from ..mesh.geometry import vertex_normals
from ..model import Building, GeoPoint, Part, Texture, TileId
from . import atlas, layout
from . import kinds as kind_lib
from .kinds import KINDS
from .mesh import MeshBuilder

__all__ = [
    "KINDS",
    "Sample",
    "DEFAULT_TILE",
    "generate_buildings",
    "generate_samples",
    "generate_tile",
    "make_building",
    "triangle_budgets",
]

DEFAULT_TILE = TileId(15, 279418, 116113)  # Seoul City Hall's level-15 tile
SPREAD = 0.75  # sigma of log(triangles): about 3 % of buildings above 1 000 at mean 326
KIND_WEIGHTS = {
    "box_flat": 0.22,
    "box_gable": 0.1,
    "box_hip": 0.08,
    "box_mansard": 0.06,
    "l_shape": 0.12,
    "u_shape": 0.07,
    "t_shape": 0.07,
    "tower": 0.12,
    "dome": 0.06,
    "spire": 0.1,
}


@dataclass
class Sample:
    """A generated building with what the generator knows about it: its ``kind`` and ``footprints``
    (CCW rings (k, 2) of ``(x, z)`` metres in the building's local frame) for tests."""

    building: Building
    kind: str
    footprints: list[np.ndarray]
    budget: float


def triangle_budget(rng: np.random.Generator, mean: float) -> float:
    """One log-normal draw with mean ``mean`` triangles, clipped to [30, 12 x mean]."""
    return float(
        np.clip(mean * math.exp(SPREAD * rng.standard_normal() - SPREAD**2 / 2), 30.0, 12.0 * mean)
    )


def triangle_budgets(count: int, seed: int = 0, mean_triangles: float = 326.0) -> np.ndarray:
    """The per-building budgets :func:`generate_samples` aims at, (count,) triangles."""
    return np.array([triangle_budget(_building_rng(seed, i), mean_triangles) for i in range(count)])


def _building_rng(seed: int, i: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([seed, 2, i]))


def _rotate(points: np.ndarray, yaw: float, columns: tuple) -> np.ndarray:
    """Turn ``points`` about the vertical axis by ``yaw`` radians (East towards North), in the given (x, z) columns."""
    c, s = math.cos(yaw), math.sin(yaw)
    out = points.copy()
    x, z = points[:, columns[0]], points[:, columns[1]]
    out[:, columns[0]], out[:, columns[1]] = c * x - s * z, s * x + c * z
    return out


def _texture(rng: np.random.Generator, size: int, name: str, floors: int, bays: int) -> Texture:
    data = atlas.encode_jpeg(atlas.draw_atlas(rng, size, floors, bays))
    return Texture(data=data, mime="image/jpeg", width=size, height=size, name=name)


def _part(
    mb: MeshBuilder, groups, yaw: float, shift: np.ndarray, texture: Texture, name: str
) -> Part:
    positions, uvs, triangles = mb.arrays(groups)
    positions = _rotate(positions, yaw, (0, 2)) - shift
    return Part(
        positions=positions,
        triangles=triangles,
        normals=vertex_normals(positions, triangles),
        uvs=uvs,
        texture=texture,
        name=name,
    )


def make_building(
    rng: np.random.Generator,
    kind: str,
    budget: float = 326.0,
    atlas_size: int = 1024,
    building_id: str = "B0000",
    yaw: float = 0.0,
    two_part: bool = False,
) -> Sample:
    """One building of ``kind`` (see :data:`KINDS`) with about ``budget`` triangles.

    Its local origin is the centre of its East/North bounding box at its base; ``reference`` is a
    placeholder ``GeoPoint(0, 0, 0)`` until placed. ``two_part`` splits walls and roofs into two
    parts with one atlas each (VWorld 3.0.0.2 multi-mesh).
    """
    if kind not in kind_lib.DRAW:
        raise ValueError(f"unknown building kind {kind!r}; allowed: {', '.join(KINDS)}")
    params = kind_lib.DRAW[kind](rng, budget)
    mb, rings = kind_lib.fit_to_budget(kind, params, budget)
    turned = _rotate(np.vstack([p for p in mb.positions]), yaw, (0, 2))
    low, high = turned[:, [0, 2]].min(0), turned[:, [0, 2]].max(0)
    centre = (low + high) / 2
    shift = np.array([centre[0], 0.0, centre[1]])
    floors = int(params["floors"])
    bays = int(np.clip(params["perimeter"] / 4 / 3.4, 2, 16))
    if two_part:
        parts = [
            _part(
                mb,
                ["wall"],
                yaw,
                shift,
                _texture(rng, atlas_size, f"{building_id}_0.jpg", floors, bays),
                "facade",
            ),
            _part(
                mb,
                ["roof", "detail"],
                yaw,
                shift,
                _texture(rng, atlas_size, f"{building_id}_1.jpg", floors, bays),
                "roof",
            ),
        ]
    else:
        parts = [
            _part(
                mb,
                None,
                yaw,
                shift,
                _texture(rng, atlas_size, f"{building_id}.jpg", floors, bays),
                "",
            )
        ]
    footprints = [_rotate(ring, yaw, (0, 1)) - centre for ring in rings]
    building = Building(
        id=building_id, source=f"samplegen:{kind}", reference=GeoPoint(0.0, 0.0, 0.0), parts=parts
    )
    return Sample(building=building, kind=kind, footprints=footprints, budget=budget)


def _sample(
    seed: int,
    i: int,
    street: float,
    atlas_size: int,
    mean_triangles: float,
    kinds: Sequence[str] | None,
    two_part_share: float,
) -> Sample:
    """Building ``i`` of the tile, from its own random stream only (so workers can draw it)."""
    names, weights = list(KIND_WEIGHTS), np.array(list(KIND_WEIGHTS.values()))
    rng = _building_rng(seed, i)
    budget = triangle_budget(rng, mean_triangles)
    kind = (
        kinds[i % len(kinds)]
        if kinds
        else names[int(rng.choice(len(names), p=weights / weights.sum()))]
    )
    two_part = bool(rng.random() < two_part_share)
    yaw = street + math.pi / 2 * int(rng.integers(4)) + rng.normal(0.0, 0.03)
    return make_building(rng, kind, budget, atlas_size, f"B{i:04d}", yaw, two_part)


def generate_samples(
    count: int,
    seed: int = 0,
    tile: TileId = DEFAULT_TILE,
    atlas_size: int = 1024,
    mean_triangles: float = 326.0,
    kinds: Sequence[str] | None = None,
    two_part_share: float = 0.05,
    jobs: int = 1,
) -> list[Sample]:
    """:func:`generate_buildings` keeping each building's kind and footprint; ``kinds`` (optional) is
    cycled through instead of drawing kinds at random; ``jobs`` > 1 draws buildings (mostly JPEG
    encoding) in that many processes, with the same result."""
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    if atlas_size < 8:
        raise ValueError(f"atlas_size must be >= 8 pixels, got {atlas_size}")
    tile_rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
    street = tile_rng.uniform(0.0, math.pi / 2)  # the tile's street-grid bearing, radians
    elev_base, elev_slope = (
        tile_rng.uniform(25.0, 55.0),
        tile_rng.uniform(-0.04, 0.04, size=2),
    )  # metres, m/m
    draw = partial(
        _sample,
        seed,
        street=street,
        atlas_size=atlas_size,
        mean_triangles=mean_triangles,
        kinds=tuple(kinds) if kinds else None,
        two_part_share=two_part_share,
    )
    if jobs > 1 and count > 1:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            samples = list(pool.map(draw, range(count), chunksize=max(1, count // (4 * jobs))))
    else:
        samples = [draw(i) for i in range(count)]
    centres = layout.place(tile_rng, [s.footprints for s in samples], tile)
    lonlat = layout.to_lonlat(tile, centres)
    for s, (x, z), (lon, lat) in zip(samples, centres, lonlat):
        # float32 like VWorld's .dat altitude, so a written and re-read tile gives the same reference
        elev = float(np.float32(np.clip(elev_base + elev_slope @ [x, z], 20.0, 60.0)))
        s.building.reference = GeoPoint(float(lon), float(lat), elev)
        s.building.tile = tile
        s.building.lonlat_bounds = _lonlat_bounds(s.building, lon, lat)
    return samples


def _lonlat_bounds(building: Building, lon: float, lat: float) -> tuple:
    """(west, south, east, north) degrees of the building's East/North extent around its reference."""
    xz = np.vstack([p.positions[:, [0, 2]] for p in building.parts])
    scale = math.degrees(1.0) / layout.EARTH_RADIUS_M
    low, high = xz.min(0), xz.max(0)
    cos_lat = math.cos(math.radians(lat))
    return (
        lon + low[0] * scale / cos_lat,
        lat + low[1] * scale,
        lon + high[0] * scale / cos_lat,
        lat + high[1] * scale,
    )


def generate_buildings(
    count: int,
    seed: int = 0,
    tile: TileId = DEFAULT_TILE,
    atlas_size: int = 1024,
    mean_triangles: float = 326.0,
    *,
    kinds: Sequence[str] | None = None,
    two_part_share: float = 0.05,
    jobs: int = 1,
) -> list[Building]:
    """``count`` VWorld-like floorless buildings placed in ``tile`` (see the module doc)."""
    return [
        s.building
        for s in generate_samples(
            count, seed, tile, atlas_size, mean_triangles, kinds, two_part_share, jobs
        )
    ]


def generate_tile(
    folder,
    count: int,
    seed: int = 0,
    tile: TileId = DEFAULT_TILE,
    atlas_size: int = 1024,
    mean_triangles: float = 326.0,
    *,
    kinds: Sequence[str] | None = None,
    two_part_share: float = 0.05,
    jobs: int = 1,
) -> Path:
    """Write ``count`` generated buildings as a VWorld tile (``.dat``, ``.xdo``, ``.jpg``) into ``folder``; returns it."""
    from ..readers.vworld import write_tile  # the writer lives with the reader

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    buildings = generate_buildings(
        count,
        seed,
        tile,
        atlas_size,
        mean_triangles,
        kinds=kinds,
        two_part_share=two_part_share,
        jobs=jobs,
    )
    write_tile(
        folder, tile, buildings, version=2 if any(len(b.parts) > 1 for b in buildings) else 1
    )
    return folder
