"""Globe placement (exporter/placement.py): equations 1-2, the Fig. 5 rotation, quaternions and the
tile-relative placement that must compose back to the globe one.

Frames: lon/lat degrees, elev metres; the Unity globe frame is left-handed, y up, in Unity units.
Expected values are worked out in the tests from the paper's formulas written out by hand, never by
calling the code under test.
"""

from __future__ import annotations

import json
import math

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exporter.config import GlobeOptions
from exporter.model import GeoPoint, TileId
from exporter.placement import (
    apply_placement,
    building_placement,
    compose,
    enu_matrix,
    enu_offset,
    fig5_rotation,
    globe_position,
    quaternion_from_matrix,
    quaternion_multiply,
    quaternion_to_matrix,
    relative_placement,
    rotate,
    tile_placement,
)
from exporter.tiles import tile_center, tile_of

R = 6378137.0
UR = 1000.0  # a small globe so hand values are easy to read
GLOBE = GlobeOptions(unity_radius=UR, earth_radius=R)
S2 = math.sqrt(0.5)

# (lon, lat) places: equator/prime meridian, 90 E, Seoul, south-west, near both poles, antimeridian
PLACES = [
    (0.0, 0.0),
    (90.0, 0.0),
    (126.9780, 37.5665),
    (-58.38, -34.60),
    (12.0, 89.95),
    (-120.0, -89.9),
    (179.999, 10.0),
]
LONS = st.floats(min_value=-180.0, max_value=180.0, allow_nan=False)
LATS = st.floats(min_value=-90.0, max_value=90.0, allow_nan=False)


def eq2(lon_deg, lat_deg, elev_m, ur=UR, r=R):
    """The paper's equations 1-2 written out with the math module (Unity globe frame, Unity units)."""
    h = ur + elev_m * ur / r
    lon, lat = math.radians(lon_deg), math.radians(lat_deg)
    return np.array(
        [h * math.cos(lat) * math.sin(lon), h * math.sin(lat), -h * math.cos(lat) * math.cos(lon)]
    )


# --------------------------------------------------------------------------- equations 1-2


@pytest.mark.parametrize(
    "lon, lat, elev, expected",
    [
        (0.0, 0.0, 0.0, (0.0, 0.0, -UR)),  # equator / prime meridian: -z
        (90.0, 0.0, 0.0, (UR, 0.0, 0.0)),  # 90 E: +x
        (180.0, 0.0, 0.0, (0.0, 0.0, UR)),  # antimeridian: +z
        (-90.0, 0.0, R, (-2 * UR, 0.0, 0.0)),  # 90 W, one Earth radius up: h = 2 UR
        (0.0, 90.0, 0.0, (0.0, UR, 0.0)),  # north pole: +y
        (
            -45.0,
            -45.0,
            0.0,
            (-0.5 * UR, -S2 * UR, -0.5 * UR),
        ),  # south-west: cos45 * sin(-45) = -1/2
        (30.0, 60.0, 0.0, (0.25 * UR, math.sqrt(3) / 2 * UR, -math.sqrt(3) / 4 * UR)),
    ],
)
def test_globe_position_hand_values(lon, lat, elev, expected):
    assert globe_position(lon, lat, elev, GLOBE) == pytest.approx(expected, abs=1e-9 * UR)


@pytest.mark.parametrize(
    "lon, lat, elev", [(126.9780, 37.5665, 38.5), (-70.6, -33.45, 570.0), (151.2, -89.99, 2835.0)]
)
def test_globe_position_against_written_out_formula(lon, lat, elev):
    assert globe_position(lon, lat, elev, GLOBE) == pytest.approx(
        eq2(lon, lat, elev), rel=1e-14, abs=1e-12
    )
    metres = GlobeOptions(unity_radius=R, earth_radius=R)  # 1 Unity unit = 1 m: |p| = R + elev
    assert np.linalg.norm(globe_position(lon, lat, elev, metres)) == pytest.approx(
        R + elev, abs=1e-6
    )


def test_seoul_by_hand_numbers():
    # table values: cos(37.5665 deg) = 0.792646, sin = 0.609682; sin(126.978 deg) = 0.798867,
    # cos = -0.601508 (so z = -h cos(lat) cos(lon) is positive: Seoul is on the +z side)
    x, y, z = globe_position(126.9780, 37.5665, 0.0, GLOBE)
    assert (x, y, z) == pytest.approx(
        (0.792646 * 0.798867 * UR, 0.609682 * UR, 0.792646 * 0.601508 * UR), rel=2e-6
    )


# --------------------------------------------------------------------------- rotations


def direction_of_increase(lon, lat, d_lon, d_lat):
    """Unit direction of moving along the surface by (d_lon, d_lat) degrees, by central differences of eq. 2."""
    step = eq2(lon + d_lon, lat + d_lat, 0.0) - eq2(lon - d_lon, lat - d_lat, 0.0)
    return step / np.linalg.norm(step)


@pytest.mark.parametrize("lon, lat", PLACES)
def test_enu_columns_are_east_up_north_of_the_globe(lon, lat):
    m = enu_matrix(lon, lat)
    assert np.linalg.det(m) == pytest.approx(1.0, abs=1e-12)  # proper rotation
    assert m.T @ m == pytest.approx(np.eye(3), abs=1e-12)
    up = eq2(lon, lat, 0.0) / UR
    assert m @ [0, 1, 0] == pytest.approx(up, abs=1e-12)  # local y -> outward normal
    if abs(lat) < 89.95:
        north = direction_of_increase(lon, lat, 0.0, 1e-4)
        east = direction_of_increase(lon, lat, 1e-4, 0.0)
        assert m @ [0, 0, 1] == pytest.approx(north, abs=1e-7)  # local z -> increasing latitude
        assert m @ [1, 0, 0] == pytest.approx(east, abs=1e-7)  # local x -> increasing longitude


def test_enu_at_the_poles_points_north_along_the_meridian():
    # at the north pole "north" is the limit along the meridian lon: towards where lat would grow past 90
    lon = 40.0
    m = enu_matrix(lon, 90.0)
    assert m @ [0, 1, 0] == pytest.approx([0, 1, 0], abs=1e-12)
    below = direction_of_increase(lon, 89.999, 0.0, 1e-4)  # north just below the pole
    assert m @ [0, 0, 1] == pytest.approx(below, abs=1e-4)
    assert np.linalg.det(enu_matrix(lon, -90.0)) == pytest.approx(1.0)


@pytest.mark.parametrize("lon, lat", PLACES + [(10.0, 90.0), (10.0, -90.0), (-180.0, 0.0)])
def test_fig5_two_step_rotation_equals_enu(lon, lat):
    m = fig5_rotation(lon, lat)
    assert m == pytest.approx(enu_matrix(lon, lat), abs=1e-12)
    assert np.linalg.det(m) == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=200, deadline=None)
@given(LONS, LATS)
def test_fig5_equals_enu_everywhere(lon, lat):
    assert fig5_rotation(lon, lat) == pytest.approx(enu_matrix(lon, lat), abs=1e-9)


# --------------------------------------------------------------------------- quaternions


def test_unity_angle_axis_convention():
    # Unity: Quaternion.AngleAxis(90, up) * forward == right; AngleAxis(a, n) = [n sin(a/2), cos(a/2)]
    q = [0.0, S2, 0.0, S2]
    assert rotate(q, [0, 0, 1]) == pytest.approx([1, 0, 0], abs=1e-15)
    assert quaternion_to_matrix(q) @ [1, 0, 0] == pytest.approx([0, 0, -1], abs=1e-15)


def test_quaternion_of_enu_at_lon0_lat0_by_hand():
    # columns East (1,0,0), Up (0,0,-1), North (0,1,0): a -90 degree turn about x
    q = quaternion_from_matrix(enu_matrix(0.0, 0.0))
    assert q == pytest.approx([-S2, 0.0, 0.0, S2], abs=1e-15)
    assert building_placement(GeoPoint(0.0, 0.0, 0.0), GLOBE)["rotation"] == pytest.approx(
        [-S2, 0, 0, S2], abs=1e-15
    )


@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0.3, -0.2, 0.9)])
@pytest.mark.parametrize("angle", [0.0, 1e-9, 1.0, math.pi - 1e-9, math.pi])
def test_quaternion_from_matrix_near_identity_and_half_turns(axis, angle):
    n = np.array(axis, dtype=float) / np.linalg.norm(axis)
    expected = np.append(n * math.sin(angle / 2), math.cos(angle / 2))
    q = quaternion_from_matrix(quaternion_to_matrix(expected))
    # q and -q are the same rotation; the conversion returns w >= 0
    assert q == pytest.approx(expected, abs=1e-8) or q == pytest.approx(-expected, abs=1e-8)
    assert q[3] >= 0.0
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)


QUATS = st.lists(
    st.floats(min_value=-1.0, max_value=1.0, allow_nan=False), min_size=4, max_size=4
).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=200, deadline=None)
@given(QUATS, QUATS)
def test_quaternion_arithmetic_matches_matrices(a, b):
    a = np.array(a) / np.linalg.norm(a)
    b = np.array(b) / np.linalg.norm(b)
    ma, mb = quaternion_to_matrix(a), quaternion_to_matrix(b)
    assert np.linalg.det(ma) == pytest.approx(1.0, abs=1e-12)
    assert quaternion_to_matrix(quaternion_multiply(a, b)) == pytest.approx(ma @ mb, abs=1e-12)
    assert quaternion_to_matrix(quaternion_from_matrix(ma)) == pytest.approx(ma, abs=1e-12)
    v = np.array([[1.0, 2.0, 3.0], [-0.5, 0.0, 4.0]])
    assert rotate(quaternion_multiply(a, b), v) == pytest.approx(rotate(a, rotate(b, v)), abs=1e-12)


# --------------------------------------------------------------------------- placement dicts

# building corners in local East/Up/North metres (a 30 x 60 x 20 m box, origin at its base centre)
CORNERS = np.array([[x, y, z] for x in (-15.0, 15.0) for y in (0.0, 60.0) for z in (-10.0, 10.0)])


def test_building_placement_is_eq2_enu_and_scale():
    ref = GeoPoint(126.9780, 37.5665, 38.5)
    p = building_placement(ref, GLOBE)
    assert set(p) == {"position", "rotation", "scale"}
    assert p["position"] == pytest.approx(eq2(ref.lon, ref.lat, ref.elev), rel=1e-14)
    assert p["scale"] == pytest.approx(UR / R, rel=1e-15)
    assert quaternion_to_matrix(p["rotation"]) == pytest.approx(
        enu_matrix(ref.lon, ref.lat), abs=1e-14
    )
    json.dumps(p)  # plain floats
    assert (
        all(type(v) is float for v in p["position"] + p["rotation"]) and type(p["scale"]) is float
    )
    # a local point 100 m up lands 100 m (in Unity units: 100 UR/R) further out along the normal
    top = apply_placement(p, [[0.0, 100.0, 0.0]])[0]
    assert top == pytest.approx(eq2(ref.lon, ref.lat, ref.elev + 100.0), rel=1e-13)


def test_tile_placement_at_the_tile_centre_on_the_ground():
    tile = TileId(15, 279418, 116113)
    unit = 36.0 / 2**15
    lon, lat = (279418 + 0.5) * unit - 180.0, (116113 + 0.5) * unit - 90.0
    p = tile_placement(tile, GLOBE)
    assert p["position"] == pytest.approx(eq2(lon, lat, 0.0), rel=1e-14)
    assert p["scale"] == pytest.approx(UR / R)
    assert quaternion_to_matrix(p["rotation"]) == pytest.approx(enu_matrix(lon, lat), abs=1e-14)


def test_relative_placement_at_the_tile_centre_is_straight_up():
    tile = TileId(15, 279418, 116113)
    lon, lat = tile_center(tile)
    p = relative_placement(GeoPoint(lon, lat, 42.0), tile, GLOBE)
    assert p["position"] == [0.0, 42.0, 0.0]  # exact: no cancellation of Earth-sized numbers
    assert p["rotation"] == pytest.approx([0, 0, 0, 1], abs=1e-15)
    assert p["scale"] == 1.0


def test_relative_offset_by_hand_near_the_tile_centre():
    # 0.001 degrees north on a sphere of R metres: R * 0.001 * pi / 180 = 111.3195 m, and a sag of
    # d^2 / (2R) = 0.00097 m below the tangent plane
    tile = TileId(15, 279418, 116113)
    lon, lat = tile_center(tile)
    east, up, north = relative_placement(GeoPoint(lon, lat + 0.001, 0.0), tile, GLOBE)["position"]
    arc = R * math.radians(0.001)
    assert north == pytest.approx(
        R * math.sin(math.radians(0.001)), rel=1e-10
    )  # lat + 0.001 - lat rounds
    assert north == pytest.approx(arc, rel=1e-9)
    assert up == pytest.approx(-(arc**2) / (2 * R), rel=1e-6)
    assert east == pytest.approx(0.0, abs=1e-12)


def exact_enu_offset(ref, origin):
    """The same offset with 40 significant digits: ENU(origin)^T (P(ref) - P(origin)), sphere radius R."""
    mpmath.mp.dps = 40

    def point(lon, lat, elev):
        lam, phi = mpmath.radians(mpmath.mpf(lon)), mpmath.radians(mpmath.mpf(lat))
        h = mpmath.mpf(R) + mpmath.mpf(elev)
        return [
            h * mpmath.cos(phi) * mpmath.sin(lam),
            h * mpmath.sin(phi),
            -h * mpmath.cos(phi) * mpmath.cos(lam),
        ]

    lam, phi = mpmath.radians(mpmath.mpf(origin.lon)), mpmath.radians(mpmath.mpf(origin.lat))
    east = [mpmath.cos(lam), 0, mpmath.sin(lam)]
    up = [mpmath.cos(phi) * mpmath.sin(lam), mpmath.sin(phi), -mpmath.cos(phi) * mpmath.cos(lam)]
    north = [-mpmath.sin(phi) * mpmath.sin(lam), mpmath.cos(phi), mpmath.sin(phi) * mpmath.cos(lam)]
    d = [
        a - b
        for a, b in zip(
            point(ref.lon, ref.lat, ref.elev), point(origin.lon, origin.lat, origin.elev)
        )
    ]
    return np.array([float(sum(a * b for a, b in zip(axis, d))) for axis in (east, up, north)])


@pytest.mark.parametrize("lon, lat", PLACES)
def test_relative_offset_agrees_with_40_digit_arithmetic(lon, lat):
    # 1e-10 m: subtracting two float64 globe positions (6.4e6 m) would err by about 3e-9 m
    tile = tile_of(lon, lat, 15)
    centre = GeoPoint(*tile_center(tile), 0.0)
    for d_lon, d_lat, elev in [
        (0.0003, -0.0004, 12.5),
        (-1e-7, 2e-7, 0.0),
        (0.0011, 0.0011, 310.0),
    ]:
        ref = GeoPoint(lon + d_lon, min(lat + d_lat, 90.0), elev)
        assert enu_offset(ref, centre, R) == pytest.approx(exact_enu_offset(ref, centre), abs=1e-10)


@pytest.mark.parametrize("lon, lat", PLACES + [(180.0, 45.0), (-180.0, -45.0)])
@pytest.mark.parametrize("unity_radius", [UR, R])
def test_tile_then_relative_equals_globe_placement(lon, lat, unity_radius):
    globe = GlobeOptions(unity_radius=unity_radius, earth_radius=R)
    tile = tile_of(lon, lat, 15)
    ref = GeoPoint(lon, lat, 57.25)
    direct = building_placement(ref, globe)
    composed = compose(tile_placement(tile, globe), relative_placement(ref, tile, globe))
    assert composed["scale"] == pytest.approx(direct["scale"], rel=1e-15)
    # same rotation (q and -q are the same one)
    assert quaternion_to_matrix(composed["rotation"]) == pytest.approx(
        quaternion_to_matrix(direct["rotation"]), abs=1e-12
    )
    a, b = apply_placement(composed, CORNERS), apply_placement(direct, CORNERS)
    assert np.max(np.linalg.norm(a - b, axis=1)) <= 1e-9 * unity_radius
    # and every corner is where eq. 2 puts its own lon/lat/elev: the roof corners are 60 m up
    assert np.linalg.norm(b, axis=1).max() == pytest.approx(
        np.linalg.norm(eq2(lon, lat, 57.25 + 60.0, unity_radius)), rel=1e-7
    )


@settings(max_examples=100, deadline=None)
@given(
    LONS,
    st.floats(min_value=-89.99, max_value=89.99),
    st.floats(min_value=-500.0, max_value=9000.0),
)
def test_composition_property_over_the_globe(lon, lat, elev):
    tile = tile_of(lon, lat, 15)
    ref = GeoPoint(lon, lat, elev)
    direct = building_placement(ref, GLOBE)
    composed = compose(tile_placement(tile, GLOBE), relative_placement(ref, tile, GLOBE))
    a, b = apply_placement(composed, CORNERS), apply_placement(direct, CORNERS)
    assert np.max(np.linalg.norm(a - b, axis=1)) <= 1e-9 * UR
    # within a level-15 tile the offset is at most about half a tile diagonal (< 100 m) plus elev
    rel = relative_placement(ref, tile, GLOBE)
    assert math.hypot(rel["position"][0], rel["position"][2]) < 100.0


def test_compose_follows_the_unity_hierarchy_rule_by_hand():
    parent = {
        "position": [1.0, 2.0, 3.0],
        "rotation": [0.0, S2, 0.0, S2],
        "scale": 2.0,
    }  # 90 deg about y
    child = {"position": [0.0, 0.0, 1.0], "rotation": [0.0, S2, 0.0, S2], "scale": 3.0}
    out = compose(parent, child)
    # forward (0,0,1) * 2 turned to right (2,0,0), added to (1,2,3)
    assert out["position"] == pytest.approx([3.0, 2.0, 3.0], abs=1e-15)
    assert out["rotation"] == pytest.approx([0.0, 1.0, 0.0, 0.0], abs=1e-15)  # 180 deg about y
    assert out["scale"] == 6.0


# --------------------------------------------------------------------------- plain-float fast paths


def numpy_enu_matrix(lon, lat):
    """The numpy formulation :func:`enu_matrix` replaced (trig per element, column_stack)."""
    lam, phi = np.radians(lon), np.radians(lat)
    east = [np.cos(lam), 0.0, np.sin(lam)]
    up = [np.cos(phi) * np.sin(lam), np.sin(phi), -np.cos(phi) * np.cos(lam)]
    north = [-np.sin(phi) * np.sin(lam), np.cos(phi), np.sin(phi) * np.cos(lam)]
    return np.column_stack([east, up, north])


def numpy_quaternion_from_matrix(m):
    """The numpy formulation :func:`quaternion_from_matrix` replaced (Shepperd's method)."""
    m = np.asarray(m, dtype=np.float64)
    trace = np.trace(m)
    k = int(np.argmax([trace, *np.diagonal(m)]))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    quaternion = np.array(q)
    quaternion /= np.linalg.norm(quaternion)
    return -quaternion if quaternion[3] < 0.0 else quaternion


def test_plain_float_placement_math_is_the_numpy_formulation_bit_for_bit():
    """enu_matrix, quaternion_from_matrix (every Shepperd branch, ties, signed zeros) and the
    tile-relative turn give numpy's exact bits (the record's placements are byte-identical)."""
    rng = np.random.default_rng(31)
    points = [(0.0, 0.0), (180.0, 90.0), (-180.0, -90.0), (127.0, 37.5)]
    points += list(zip(rng.uniform(-180, 180, 400).tolist(), rng.uniform(-90, 90, 400).tolist()))
    for lon, lat in points:
        assert enu_matrix(lon, lat).tobytes() == numpy_enu_matrix(lon, lat).tobytes()
    rotations = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(2000)]
    rotations = [m * np.sign(np.linalg.det(m)) for m in rotations]
    rotations += [np.diag(d) for d in ([1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0])]
    rotations += [np.eye(3), -np.eye(3) + 2 * np.diag([0.0, 0.0, 1.0]), np.zeros((3, 3))]
    rotations += [
        numpy_enu_matrix(lon, lat).T @ numpy_enu_matrix(127.0, 37.5) for lon, lat in points
    ]
    branches = set()
    for m in rotations:
        expected = numpy_quaternion_from_matrix(m)
        assert quaternion_from_matrix(m).tobytes() == expected.tobytes()
        branches.add(int(np.argmax([np.trace(m), *np.diagonal(m)])))
    assert branches == {0, 1, 2, 3}
    tile = TileId(15, 279418, 116113)
    lon, lat = tile_center(tile)
    for ref_lon, ref_lat in points[:50]:
        turn = numpy_enu_matrix(lon, lat).T @ numpy_enu_matrix(ref_lon, ref_lat)
        got = relative_placement(GeoPoint(ref_lon, ref_lat, 10.0), tile, GlobeOptions())
        expected = numpy_quaternion_from_matrix(turn).tolist()
        assert json.dumps(got["rotation"]) == json.dumps(expected)  # signed zeros too
