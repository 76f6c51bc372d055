"""VWorld tile addressing: lon/lat in degrees <-> (level, IDX, IDY) tiles.

Data form: longitudes and latitudes are plain floats in **degrees** on VWorld's sphere (lon in
[-180, 180], lat in [-90, 90]); a tile is an :class:`exporter.model.TileId`; tile bounds are
``(west, south, east, north)`` in degrees.

Level 0 tiles are 36 x 36 degrees (IDX 0-9 west to east from lon -180, IDY 0-4 south to north
from lat -90); each level splits a tile in four, so a level ``L`` tile spans
``36 / 2**L`` degrees and the grid has ``10 * 2**L`` columns and ``5 * 2**L`` rows::

    IDX = floor((lon + 180) / unit)      IDY = floor((lat + 90) / unit)

Buildings live at level 15 (bridges and large facilities at 14) in the tile holding their centre,
the centre being the mean of the min and max of their coordinates.

Sources: ``docs/reference/frames-and-placement.md`` (check value: Seoul City Hall, lon 126.9780
lat 37.5665, is tile IDX 279418, IDY 116113 at level 15); the VWorld paper's Table I.

Edge rules:
- lon = 180 belongs to the last column and lat = 90 to the last row (a closed east/north edge
  instead of a column or row past the end of the grid).
- A coordinate within ``BORDER_TOLERANCE`` degrees of a tile border counts as on the border
  (so ``idx * unit - 180`` computed with a rounding error still lands in tile ``idx``).
- Longitudes in (180, 360] or [-360, -180) are wrapped (0..360 data); other longitudes outside
  [-180, 180], latitudes outside [-90, 90] and non-finite values raise ``ValueError``, which callers turn into an error naming their file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .model import TileId

BUILDING_LEVEL = 15  # VWorld's building tiles (bridges and large facilities: 14)
LEVEL0_DEG = 36.0  # level 0 tile side, degrees
# Degrees (about 11 micrometres on the ground). Absolute rather than per tile width so a point
# snapped onto a border at one level is snapped onto it at every finer level (parent(tile_of(.., L))
# == tile_of(.., L - 1) holds exactly).
BORDER_TOLERANCE = 1e-10


def tile_size_deg(level: int) -> float:
    """Side of a tile at ``level`` in degrees (``36 / 2**level``; exact in binary floating point)."""
    _check_level(level)
    return LEVEL0_DEG / 2**level


def grid_shape(level: int) -> tuple[int, int]:
    """``(columns, rows)`` of the tile grid at ``level``: ``(10 * 2**level, 5 * 2**level)``."""
    _check_level(level)
    return 10 * 2**level, 5 * 2**level


def tile_of(lon: float, lat: float, level: int = BUILDING_LEVEL) -> TileId:
    """The tile at ``level`` holding the point ``lon``, ``lat`` (degrees); see the module's edge rules."""
    lon, lat = _check_lonlat(lon, lat)
    unit = tile_size_deg(level)
    columns, rows = grid_shape(level)
    idx = _cell(lon + 180.0, unit, columns)
    idy = _cell(lat + 90.0, unit, rows)
    return TileId(level, idx, idy)


def tile_bounds(tile: TileId) -> tuple[float, float, float, float]:
    """``(west, south, east, north)`` of ``tile`` in degrees."""
    _check_tile(tile)
    unit = tile_size_deg(tile.level)
    west = tile.idx * unit - 180.0
    south = tile.idy * unit - 90.0
    return west, south, west + unit, south + unit


def tile_center(tile: TileId) -> tuple[float, float]:
    """``(lon, lat)`` of the centre of ``tile`` in degrees."""
    _check_tile(tile)
    unit = tile_size_deg(tile.level)
    return (tile.idx + 0.5) * unit - 180.0, (tile.idy + 0.5) * unit - 90.0


def parent(tile: TileId) -> TileId:
    """The level ``L - 1`` tile containing ``tile``; ValueError for level 0."""
    _check_tile(tile)
    if tile.level == 0:
        raise ValueError(f"tile {tile.name}: level 0 tiles have no parent")
    return TileId(tile.level - 1, tile.idx // 2, tile.idy // 2)


def children(tile: TileId) -> list[TileId]:
    """The four level ``L + 1`` tiles of ``tile``: south-west, south-east, north-west, north-east."""
    _check_tile(tile)
    level, i, j = tile.level + 1, 2 * tile.idx, 2 * tile.idy
    return [
        TileId(level, i, j),
        TileId(level, i + 1, j),
        TileId(level, i, j + 1),
        TileId(level, i + 1, j + 1),
    ]


def center_of(lonlat: Sequence[float]) -> tuple[float, float]:
    """Centre ``(lon, lat)`` in degrees of a ``(west, south, east, north)`` box or of a ``(lon, lat)`` point.

    The centre is the mean of the min and max (the paper's rule). A box whose ``west`` is east of
    its ``east`` crosses the 180 degree meridian; its centre is taken across it.
    """
    values = [float(v) for v in lonlat]
    if len(values) == 2:
        return values[0], values[1]
    if len(values) != 4:
        raise ValueError(
            f"expected (lon, lat) or (west, south, east, north) in degrees, got {len(values)} numbers"
        )
    west, south, east, north = values
    if south > north:
        raise ValueError(f"box south {south!r} is north of north {north!r} (degrees)")
    if west > east:  # crosses the antimeridian
        east += 360.0
    lon = 0.5 * (west + east)
    if lon > 180.0:
        lon -= 360.0
    return lon, 0.5 * (south + north)


def building_tile(lonlat_bounds: Sequence[float], level: int = BUILDING_LEVEL) -> TileId:
    """The tile at ``level`` holding the centre of a building's ``(west, south, east, north)`` box (degrees)."""
    lon, lat = center_of(lonlat_bounds)
    return tile_of(lon, lat, level)


def check_tile(
    data_tile: TileId | None, lonlat: Sequence[float], level: int = BUILDING_LEVEL
) -> tuple[TileId, str | None]:
    """The tile to file a building under, and a message for the manifest when the data disagrees.

    ``lonlat`` is the building's ``(west, south, east, north)`` box or its centre ``(lon, lat)``
    in degrees. Without a ``data_tile`` the tile holding the centre at ``level`` is used. With
    one, the data's own tile is kept (VWorld's files are the authority, see the module notes);
    when its level/IDX/IDY do not hold the centre the returned message says so and names the
    tile that does.
    """
    lon, lat = center_of(lonlat)
    if data_tile is None:
        return tile_of(lon, lat, level), None
    _check_tile(data_tile)
    expected = tile_of(lon, lat, data_tile.level)
    if expected == data_tile:
        return data_tile, None
    message = (
        f"the data's tile {data_tile.name} does not hold the building centre "
        f"(lon {lon:.7f}, lat {lat:.7f}), which is in tile {expected.name}; kept the data's tile"
    )
    if data_tile.level > 0 and tile_of(lon, lat, data_tile.level - 1) == TileId(
        data_tile.level - 1, data_tile.idx, data_tile.idy
    ):
        message += f" (its IDX/IDY match the level {data_tile.level - 1} tile unit)"
    return data_tile, message


# --------------------------------------------------------------------------- checks and helpers


def _cell(offset: float, unit: float, count: int) -> int:
    """Index of the cell of width ``unit`` holding ``offset`` (degrees from the grid origin),
    clamped to ``[0, count - 1]``; offsets within BORDER_TOLERANCE of a border snap onto it."""
    nearest = round(offset / unit)
    if abs(offset - nearest * unit) <= BORDER_TOLERANCE:  # nearest * unit is exact: unit = 9 * 2**k
        return min(max(nearest, 0), count - 1)
    return min(max(int(math.floor(offset / unit)), 0), count - 1)


def _check_level(level: int) -> None:
    if isinstance(level, bool) or not isinstance(level, int) or not 0 <= level <= 30:
        raise ValueError(f"tile level {level!r}: expected an integer in 0..30")


def _check_tile(tile: TileId) -> None:
    _check_level(tile.level)
    columns, rows = grid_shape(tile.level)
    if not (0 <= tile.idx < columns and 0 <= tile.idy < rows):
        raise ValueError(
            f"tile {tile.name}: IDX must be in 0..{columns - 1} and IDY in 0..{rows - 1} at level {tile.level}"
        )


def _check_lonlat(lon: float, lat: float) -> tuple[float, float]:
    lon, lat = float(lon), float(lat)
    if not (math.isfinite(lon) and math.isfinite(lat)):
        raise ValueError(f"lon {lon!r}, lat {lat!r}: not finite (degrees expected)")
    tolerance = 1e-9  # degrees: rounding error of computed poles
    if not -90.0 - tolerance <= lat <= 90.0 + tolerance:
        raise ValueError(
            f"lat {lat!r}: outside -90..90 degrees (swapped lon/lat, or projected metres?)"
        )
    if abs(lon) > 360.0:
        raise ValueError(
            f"lon {lon!r}: outside -360..360 degrees (projected metres instead of degrees?)"
        )
    if 180.0 < abs(lon) <= 180.0 + tolerance:
        lon = math.copysign(180.0, lon)
    elif abs(lon) > 180.0:  # 0..360 data
        lon = (lon + 180.0) % 360.0 - 180.0
    return lon, min(max(lat, -90.0), 90.0)
