"""VWorld tile math (exporter/tiles.py): check values, edges of the grid, borders, round trips.

Coordinates are lon/lat in degrees; expected indices are worked out by hand in each test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exporter.model import TileId
from exporter.tiles import (
    BORDER_TOLERANCE,
    building_tile,
    center_of,
    check_tile,
    children,
    grid_shape,
    parent,
    tile_bounds,
    tile_center,
    tile_of,
    tile_size_deg,
)

LONS = st.floats(min_value=-180.0, max_value=180.0, allow_nan=False)
LATS = st.floats(min_value=-90.0, max_value=90.0, allow_nan=False)
LEVELS = st.integers(min_value=0, max_value=20)


def test_tile_size_halves_per_level_from_36_degrees():
    assert tile_size_deg(0) == 36.0
    assert tile_size_deg(1) == 18.0
    assert tile_size_deg(15) == 36.0 / 32768
    assert tile_size_deg(14) == 2 * tile_size_deg(15)
    assert grid_shape(0) == (10, 5)
    assert grid_shape(15) == (327680, 163840)


def test_seoul_city_hall_level_15_check_value():
    assert tile_of(126.9780, 37.5665, 15) == TileId(15, 279418, 116113)
    assert tile_of(126.9780, 37.5665) == TileId(15, 279418, 116113)  # buildings default to level 15


def test_hand_computed_tiles_at_coarse_levels():
    # level 0: (0 + 180) / 36 = 5, (0 + 90) / 36 = 2.5 -> (5, 2)
    assert tile_of(0.0, 0.0, 0) == TileId(0, 5, 2)
    # level 1 (18 degrees): (-75 + 180) / 18 = 5.83 -> 5; (-33.5 + 90) / 18 = 3.14 -> 3
    assert tile_of(-75.0, -33.5, 1) == TileId(1, 5, 3)
    # level 2 (9 degrees): (139.7 + 180) / 9 = 35.52 -> 35; (35.7 + 90) / 9 = 13.97 -> 13
    assert tile_of(139.7, 35.7, 2) == TileId(2, 35, 13)


def test_bounds_and_centre_of_seoul_tile():
    unit = 36.0 / 2**15
    west, south, east, north = tile_bounds(TileId(15, 279418, 116113))
    assert west == pytest.approx(279418 * unit - 180.0, abs=1e-12)
    assert south == pytest.approx(116113 * unit - 90.0, abs=1e-12)
    assert east - west == pytest.approx(unit, abs=1e-12)
    assert north - south == pytest.approx(unit, abs=1e-12)
    assert west <= 126.9780 <= east and south <= 37.5665 <= north
    lon, lat = tile_center(TileId(15, 279418, 116113))
    assert lon == pytest.approx(0.5 * (west + east), abs=1e-12)
    assert lat == pytest.approx(0.5 * (south + north), abs=1e-12)


@pytest.mark.parametrize("level", [0, 1, 15, 20])
def test_grid_edges_antimeridian_and_poles(level):
    columns, rows = grid_shape(level)
    assert tile_of(-180.0, -90.0, level) == TileId(level, 0, 0)
    # lon 180 and lat 90 close the last column / row instead of opening one past the end
    assert tile_of(180.0, 90.0, level) == TileId(level, columns - 1, rows - 1)
    assert tile_of(180.0, 0.0, level).idx == columns - 1
    assert tile_of(0.0, 90.0, level).idy == rows - 1
    assert tile_bounds(TileId(level, columns - 1, rows - 1))[2:] == pytest.approx(
        (180.0, 90.0), abs=1e-12
    )


def test_longitudes_past_180_wrap_and_rounding_past_the_edges_clamps():
    assert tile_of(190.0, 10.0, 3) == tile_of(-170.0, 10.0, 3)  # 0..360 data
    assert tile_of(359.0, 10.0, 3) == tile_of(-1.0, 10.0, 3)
    columns, rows = grid_shape(3)
    assert tile_of(math.nextafter(180.0, 200.0), 0.0, 3).idx == columns - 1  # rounding, not a wrap
    assert tile_of(0.0, math.nextafter(90.0, 100.0), 3).idy == rows - 1


@pytest.mark.parametrize(
    "lon, lat, words",
    [
        (0.0, 91.0, "lat 91"),
        (0.0, -95.0, "lat -95"),
        (200000.0, 10.0, "projected"),
        (float("nan"), 0.0, "not finite"),
    ],
)
def test_bad_coordinates_raise_clear_value_errors(lon, lat, words):
    with pytest.raises(ValueError, match=words):
        tile_of(lon, lat, 15)


def test_bad_tiles_and_levels_raise():
    with pytest.raises(ValueError, match="IDX must be in 0..9"):
        tile_bounds(TileId(0, 10, 0))
    with pytest.raises(ValueError, match="IDY"):
        tile_center(TileId(1, 0, -1))
    with pytest.raises(ValueError, match="level"):
        tile_size_deg(-1)
    with pytest.raises(ValueError, match="no parent"):
        parent(TileId(0, 3, 1))


def test_border_computed_with_rounding_error_lands_in_the_tile_it_starts():
    unit = tile_size_deg(15)
    for idx in (1, 279418, 163840, 327679):
        border = idx * unit - 180.0  # may carry a rounding error
        assert tile_of(border, 0.0, 15).idx == idx
        assert tile_of(math.nextafter(border, -1e9), 0.0, 15).idx == idx  # one ulp short
        assert tile_of(math.nextafter(border, 1e9), 0.0, 15).idx == idx
        # a real (not rounding) distance west of the border is the previous column
        assert tile_of(border - 1e-7, 0.0, 15).idx == idx - 1
    # a latitude border computed the other way round: (idy * unit) - 90 vs -90 + idy * unit
    idy = 116113
    assert tile_of(0.0, -90.0 + idy * unit, 15).idy == idy
    assert tile_of(0.0, (idy * 3 * unit) / 3 - 90.0, 15).idy == idy


def test_parent_and_children_by_hand():
    assert parent(TileId(15, 279418, 116113)) == TileId(14, 139709, 58056)
    assert children(TileId(0, 5, 2)) == [
        TileId(1, 10, 4),
        TileId(1, 11, 4),
        TileId(1, 10, 5),
        TileId(1, 11, 5),
    ]
    for child in children(TileId(7, 100, 33)):
        assert parent(child) == TileId(7, 100, 33)


def test_building_tile_uses_the_centre_of_min_and_max():
    unit = tile_size_deg(15)
    west = 279418 * unit - 180.0
    # a box reaching far into the western neighbour, whose centre still lies in 279418
    box = (west - 0.4 * unit, 37.5665, west + 0.6 * unit, 37.5666)
    assert building_tile(box) == TileId(15, 279418, 116113)
    # same box shifted so the centre crosses the border
    box = (west - 0.6 * unit, 37.5665, west + 0.3 * unit, 37.5666)
    assert building_tile(box) == TileId(15, 279417, 116113)
    assert building_tile(box, level=14) == TileId(14, 139708, 58056)


def test_centre_of_box_across_the_antimeridian():
    assert center_of((179.0, -1.0, -179.0, 1.0)) == pytest.approx((180.0, 0.0))
    assert center_of((178.0, 0.0, -179.0, 1.0)) == pytest.approx((179.5, 0.5))
    assert center_of((179.5, 0.0, -178.0, 1.0)) == pytest.approx((-179.25, 0.5))
    with pytest.raises(ValueError, match="south"):
        center_of((0.0, 2.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="expected"):
        center_of((0.0, 2.0, 1.0))


def test_check_tile_keeps_the_data_tile_and_explains_a_mismatch():
    seoul = (126.9780, 37.5665)
    # no data tile: the centre's tile at the requested level
    assert check_tile(None, seoul) == (TileId(15, 279418, 116113), None)
    assert check_tile(None, seoul, 14) == (TileId(14, 139709, 58056), None)
    # agreeing data tile: no message, also for a level 14 facility
    assert check_tile(TileId(15, 279418, 116113), seoul) == (TileId(15, 279418, 116113), None)
    assert check_tile(TileId(14, 139709, 58056), seoul) == (TileId(14, 139709, 58056), None)
    # the paper's Table I style index: level 15 name with level 14 IDX/IDY
    tile, message = check_tile(TileId(15, 139709, 58056), seoul)
    assert tile == TileId(15, 139709, 58056)
    assert "15_139709_58056" in message and "15_279418_116113" in message
    assert "level 14 tile unit" in message
    # a plainly wrong index: message, no level hint
    tile, message = check_tile(TileId(15, 1, 1), (126.97, 37.56, 126.98, 37.57))
    assert tile == TileId(15, 1, 1)
    assert "15_1_1" in message and "level 14" not in message


@settings(max_examples=300, deadline=None)
@given(LONS, LATS, LEVELS)
def test_point_lies_in_the_bounds_of_its_tile(lon, lat, level):
    tile = tile_of(lon, lat, level)
    west, south, east, north = tile_bounds(tile)
    tol = BORDER_TOLERANCE + 1e-12
    assert west - tol <= lon <= east + tol
    assert south - tol <= lat <= north + tol
    # and the tile's own centre maps back to the tile
    assert tile_of(*tile_center(tile), level) == tile


@settings(max_examples=300, deadline=None)
@given(LONS, LATS, st.integers(min_value=1, max_value=20))
def test_parent_of_tile_is_tile_at_the_coarser_level(lon, lat, level):
    tile = tile_of(lon, lat, level)
    assert parent(tile) == tile_of(lon, lat, level - 1)
    assert tile in children(parent(tile))


@settings(max_examples=200, deadline=None)
@given(st.integers(min_value=0, max_value=327679), st.integers(min_value=0, max_value=163839))
def test_every_border_and_corner_maps_to_the_tile_it_opens(idx, idy):
    tile = TileId(15, idx, idy)
    west, south, _, _ = tile_bounds(tile)
    assert tile_of(west, south, 15) == tile


@settings(max_examples=100, deadline=None)
@given(LONS, LATS)
def test_children_partition_their_parent(lon, lat):
    tile = tile_of(lon, lat, 10)
    west, south, east, north = tile_bounds(tile)
    boxes = np.array([tile_bounds(child) for child in children(tile)])
    assert boxes[:, 0].min() == pytest.approx(west) and boxes[:, 2].max() == pytest.approx(east)
    assert boxes[:, 1].min() == pytest.approx(south) and boxes[:, 3].max() == pytest.approx(north)
    area = np.sum((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1]))
    assert area == pytest.approx((east - west) * (north - south))
