"""Placing sample buildings inside one tile without overlapping footprints (while space allows).

Data form: positions are in the **tile-local East/North plane, metres** (x = East, z = North,
origin at the tile's centre); each building brings its footprint rings ((k, 2) ``(x, z)`` metres
around its own reference point). Geographic conversion uses VWorld's sphere (R = 6 378 137 m) and
the local equirectangular approximation, exact to millimetres over a 120 m tile.

Greedy dart throwing on an occupancy grid (``cell`` metres, footprints rasterised with Pillow),
largest footprint first: each building tries a batch of random centres and takes the first whose
footprint, grown by ``gap`` metres, covers no occupied cell; when none is free (more buildings than
the tile holds: a level-15 tile is about 97 x 122 m in Seoul, and the paper's 1 248-building tile is
far denser than that) it takes the candidate overlapping the fewest cells, so footprints then
overlap. Centres always stay inside the tile.
"""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw, ImageFilter

from ..geodesy import EARTH_RADIUS_M  # VWorld's sphere
from ..model import TileId
from ..tiles import tile_bounds, tile_center


def tile_extent_m(tile: TileId) -> tuple[float, float]:
    """Width (East) and height (North) of ``tile`` in metres at its centre latitude."""
    west, south, east, north = tile_bounds(tile)
    _, lat = tile_center(tile)
    scale = math.radians(1.0) * EARTH_RADIUS_M
    return (east - west) * scale * math.cos(math.radians(lat)), (north - south) * scale


def footprint_mask(
    rings: list[np.ndarray], cell: float, grow: int
) -> tuple[np.ndarray, np.ndarray]:
    """Boolean raster (rows = x cells, cols = z cells) of the rings, grown by ``grow`` cells, and the
    grid offset (2,) of the reference point inside it."""
    points = np.vstack(rings)
    low = np.floor(points.min(axis=0) / cell).astype(int) - grow - 1
    high = np.ceil(points.max(axis=0) / cell).astype(int) + grow + 1
    cells = high - low
    image = Image.new("L", (int(cells[1]), int(cells[0])))  # width = z cells, height = x cells

    draw = ImageDraw.Draw(image)
    for ring in rings:
        pixels = ring / cell - low
        draw.polygon([(float(z), float(x)) for x, z in pixels], fill=1, outline=1)
    if grow:
        image = image.filter(ImageFilter.MaxFilter(2 * grow + 1))
    return np.asarray(image, dtype=bool), -low


def place(
    rng: np.random.Generator,
    footprints: list[list[np.ndarray]],
    tile: TileId,
    gap: float = 2.0,
    candidates: int = 64,
    cell: float = 0.5,
) -> np.ndarray:
    """Tile-local centres (n, 2) ``(x, z)`` metres for buildings with these footprint rings."""
    width, height = tile_extent_m(tile)
    half = np.array([width, height]) / 2 * 0.999  # strictly inside the tile
    grow = int(math.ceil(gap / cell))
    masks = [footprint_mask(rings, cell, 0) for rings in footprints]
    grown = [footprint_mask(rings, cell, grow) for rings in footprints]
    margin = max([max(m.shape) for m, _ in grown], default=0) + 2
    shape = np.ceil(2 * half / cell).astype(int) + 2 * margin
    occupied = np.zeros(tuple(shape), dtype=bool)
    origin = np.array([margin, margin]) + half / cell  # grid index of the tile centre
    areas = [m.sum() for m, _ in masks]
    centres = np.zeros((len(footprints), 2))
    failures = (
        0  # consecutive buildings that found no free spot: the tile is full, stop searching hard
    )
    for i in np.argsort(-np.asarray(areas), kind="stable"):
        points = np.vstack(footprints[i])
        extent = np.maximum(-points.min(axis=0), points.max(axis=0))
        reach = half - np.minimum(
            extent, half * 0.95
        )  # keep the footprint in the tile when it fits
        trial = rng.uniform(-1.0, 1.0, size=(candidates if failures < 10 else 4, 2)) * reach
        mask, anchor = grown[i]
        overlaps = []
        for _j, centre in enumerate(trial):
            start = np.round(origin + centre / cell).astype(int) - anchor
            window = occupied[
                start[0] : start[0] + mask.shape[0], start[1] : start[1] + mask.shape[1]
            ]
            overlaps.append(int(np.count_nonzero(window & mask)))
            if overlaps[-1] == 0:
                break
        best = int(np.argmin(overlaps))
        failures = failures + 1 if overlaps[best] else 0
        centres[i] = trial[best]
        mask, anchor = masks[i]
        start = np.round(origin + trial[best] / cell).astype(int) - anchor
        occupied[start[0] : start[0] + mask.shape[0], start[1] : start[1] + mask.shape[1]] |= mask
    return centres


def to_lonlat(tile: TileId, xz: np.ndarray) -> np.ndarray:
    """Degrees (n, 2) ``(lon, lat)`` of tile-local ``(x, z)`` metres (n, 2)."""
    lon0, lat0 = tile_center(tile)
    scale = math.degrees(1.0) / EARTH_RADIUS_M
    return np.column_stack(
        [lon0 + xz[:, 0] * scale / math.cos(math.radians(lat0)), lat0 + xz[:, 1] * scale]
    )
