"""Placing sample buildings inside one tile without overlapping footprints (while space allows).

Data form: positions are in the **tile-local East/North plane, metres** (x = East, z = North,
origin at the tile's centre); each building is reduced to the radius (metres) of the circle around
its footprint. Geographic conversion uses VWorld's sphere (R = 6 378 137 m) and the local
equirectangular approximation, exact to millimetres over a 120 m tile.

Greedy dart throwing, largest first: each building tries a batch of random centres and takes the
first whose circle clears every placed one by ``gap`` metres; when none does (more buildings than
the tile holds: a level-15 tile is about 97 x 122 m in Seoul, the paper's 1 248-building tile is
denser than that), it takes the candidate with the largest clearance, so footprints then overlap.
Centres always stay inside the tile.
"""
from __future__ import annotations

import math

import numpy as np

from ..model import TileId
from ..tiles import tile_bounds, tile_center

EARTH_RADIUS_M = 6378137.0  # VWorld's sphere


def tile_extent_m(tile: TileId) -> tuple[float, float]:
    """Width (East) and height (North) of ``tile`` in metres at its centre latitude."""
    west, south, east, north = tile_bounds(tile)
    _, lat = tile_center(tile)
    scale = math.radians(1.0) * EARTH_RADIUS_M
    return (east - west) * scale * math.cos(math.radians(lat)), (north - south) * scale


def place(rng: np.random.Generator, radii: np.ndarray, tile: TileId, gap: float = 2.0, candidates: int = 48) -> np.ndarray:
    """Tile-local centres (n, 2) ``(x, z)`` metres for circles of ``radii`` (n,) metres."""
    width, height = tile_extent_m(tile)
    half = np.array([width, height]) / 2 * 0.999  # strictly inside the tile
    centres = np.zeros((len(radii), 2))
    placed: list[int] = []
    for i in np.argsort(-np.asarray(radii), kind="stable"):
        reach = half - np.minimum(radii[i], half * 0.95)  # keep the footprint in the tile when it fits
        trial = rng.uniform(-1.0, 1.0, size=(candidates, 2)) * reach
        if placed:
            others = centres[placed]
            distance = np.linalg.norm(trial[:, None, :] - others[None], axis=2)
            clearance = (distance - radii[placed][None] - radii[i] - gap).min(axis=1)
            ok = np.flatnonzero(clearance >= 0)
            trial = trial[ok[0]] if len(ok) else trial[int(np.argmax(clearance))]
        else:
            trial = trial[0]
        centres[i] = trial
        placed.append(int(i))
    return centres


def to_lonlat(tile: TileId, xz: np.ndarray) -> np.ndarray:
    """Degrees (n, 2) ``(lon, lat)`` of tile-local ``(x, z)`` metres (n, 2)."""
    lon0, lat0 = tile_center(tile)
    scale = math.degrees(1.0) / EARTH_RADIUS_M
    return np.column_stack([lon0 + xz[:, 0] * scale / math.cos(math.radians(lat0)), lat0 + xz[:, 1] * scale])
