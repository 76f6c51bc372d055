"""End to end orientation: a known asymmetric building through the glTF writer, glTFast's import
and the placement must land north-east side up on the globe with every face pointing outward.

The building, in local East/Up/North metres (x = East, y = Up, z = North), floorless:
an L of a 10 m high bar along the south (x -20..20, z -20..0) and a 40 m high wing on the
north-east square (x 0..20, z 0..20); the notch is the north-west square. Each face carries the
direction it must face (East, West, North, South or Up).

The check does what Unity does: read the raw accessors of the written ``.glb`` (pygltflib, no
mesh processing that could reorder), apply glTFast's conversion (negate X, reverse each
triangle), then place the result with the globe placement and with tile root ∘ relative
placement. Expected directions on the globe are worked out here from the paper's eq. 2 by finite
differences (East = increasing longitude, North = increasing latitude, Up = away from the Earth's
centre); positions are turned back into lon/lat/elev by inverting eq. 2.
"""

from __future__ import annotations

import math

import numpy as np
import pygltflib
import pytest

from exporter import gltf_writer
from exporter.config import GlobeOptions
from exporter.model import Building, GeoPoint, Part
from exporter.placement import (
    apply_placement,
    building_placement,
    relative_placement,
    tile_placement,
)
from exporter.tiles import tile_of

R = 6378137.0
LOCAL_DIRECTIONS = {
    "E": (1, 0, 0),
    "W": (-1, 0, 0),
    "N": (0, 0, 1),
    "S": (0, 0, -1),
    "U": (0, 1, 0),
}
GLTF_COMPONENTS = {
    pygltflib.FLOAT: np.float32,
    pygltflib.UNSIGNED_SHORT: np.uint16,
    pygltflib.UNSIGNED_INT: np.uint32,
}
GLTF_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}


# --------------------------------------------------------------------------- the building


def quad(corners, facing):
    """Two triangles of a planar quad (corners in cyclic order), wound so the numerical cross
    product points to ``facing`` (one of LOCAL_DIRECTIONS): the model's outward convention."""
    corners = np.asarray(corners, dtype=float)
    tris = [[0, 1, 2], [0, 2, 3]]
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    if normal @ LOCAL_DIRECTIONS[facing] < 0:
        tris = [[0, 2, 1], [0, 3, 2]]
    return corners, tris, [facing, facing]


def box_part(name, faces):
    """A Part from ``(corners, facing)`` quads; returns it and the facing of each triangle."""
    positions, triangles, facing = [], [], []
    for corners, face in faces:
        c, t, f = quad(corners, face)
        triangles += [[len(positions) + i for i in tri] for tri in t]
        positions += list(c)
        facing += f
    return Part(positions=np.array(positions), triangles=np.array(triangles), name=name), facing


def wall_x(x, z0, z1, y0, y1, facing):
    return [(x, y0, z0), (x, y0, z1), (x, y1, z1), (x, y1, z0)], facing


def wall_z(z, x0, x1, y0, y1, facing):
    return [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)], facing


def roof(x0, x1, z0, z1, y):
    return [(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)], "U"


def l_building(ref: GeoPoint) -> tuple[Building, list[list[str]]]:
    bar, bar_facing = box_part(
        "bar",
        [
            wall_z(-20, -20, 20, 0, 10, "S"),
            wall_x(20, -20, 0, 0, 10, "E"),
            wall_x(-20, -20, 0, 0, 10, "W"),
            wall_z(0, -20, 0, 0, 10, "N"),  # the notch's wall, facing north
            roof(-20, 20, -20, 0, 10),
        ],
    )
    wing, wing_facing = box_part(
        "wing",
        [
            wall_x(20, 0, 20, 0, 40, "E"),
            wall_z(20, 0, 20, 0, 40, "N"),
            wall_x(0, 0, 20, 0, 40, "W"),
            wall_z(0, 0, 20, 10, 40, "S"),  # above the bar's roof
            roof(0, 20, 0, 20, 40),
        ],
    )
    building = Building(id="L", source="test", reference=ref, parts=[bar, wing])
    return building, [bar_facing, wing_facing]


# --------------------------------------------------------------------------- what Unity sees


def accessor_array(gltf, blob: bytes, index: int) -> np.ndarray:
    accessor = gltf.accessors[index]
    view = gltf.bufferViews[accessor.bufferView]
    dtype = np.dtype(GLTF_COMPONENTS[accessor.componentType])
    width = GLTF_WIDTH[accessor.type]
    assert view.byteStride in (None, 0, width * dtype.itemsize), "interleaved data not expected"
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    return np.frombuffer(blob, dtype=dtype, count=accessor.count * width, offset=start).reshape(
        accessor.count, width
    )


def glb_as_unity_imports(data: bytes) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per primitive: Unity-local positions (n, 3) and triangles (m, 3) after glTFast's conversion."""
    gltf = pygltflib.GLTF2.load_from_bytes(data)
    blob = gltf.binary_blob()
    out = []
    for primitive in gltf.meshes[0].primitives:
        positions = accessor_array(gltf, blob, primitive.attributes.POSITION).astype(np.float64)
        triangles = accessor_array(gltf, blob, primitive.indices).reshape(-1, 3).astype(np.int64)
        positions[:, 0] *= -1.0  # glTFast: negate X ...
        triangles = triangles[:, [0, 2, 1]]  # ... and reverse the winding
        out.append((positions, triangles))
    return out


# --------------------------------------------------------------------------- the globe, worked out here


def eq2(lon_deg, lat_deg, elev_m, ur):
    h = ur + elev_m * ur / R
    lon, lat = math.radians(lon_deg), math.radians(lat_deg)
    return np.array(
        [h * math.cos(lat) * math.sin(lon), h * math.sin(lat), -h * math.cos(lat) * math.cos(lon)]
    )


def inverse_eq2(p, ur):
    """(lon deg, lat deg, elev m) of Unity globe point p."""
    x, y, z = p
    h = math.sqrt(x * x + y * y + z * z)
    return math.degrees(math.atan2(x, -z)), math.degrees(math.asin(y / h)), (h - ur) * R / ur


def geographic_directions(lon, lat, ur):
    """Unit East/West/North/South/Up on the globe at lon/lat (degrees), by differences of eq. 2."""
    d = 1e-5
    east = eq2(lon + d, lat, 0, ur) - eq2(lon - d, lat, 0, ur)
    north = eq2(lon, lat + d, 0, ur) - eq2(lon, lat - d, 0, ur)
    up = eq2(lon, lat, 0, ur)
    east, north, up = (v / np.linalg.norm(v) for v in (east, north, up))
    return {"E": east, "W": -east, "N": north, "S": -north, "U": up}


PLACES = [
    GeoPoint(126.9780, 37.5665, 31.0),
    GeoPoint(-58.3816, -34.6037, 25.0),
    GeoPoint(179.9995, 64.1, 12.0),
]


@pytest.fixture(scope="module")
def written():
    """The .glb bytes of the L building (the local geometry does not depend on the place)."""
    building, facing = l_building(PLACES[0])
    return building, facing, gltf_writer.glb_bytes(building.parts, "L")


def test_fixture_is_wound_outward_in_the_local_frame(written):
    building, facing, _ = written
    for part, part_facing in zip(building.parts, facing):
        a, b, c = (part.positions[part.triangles[:, i]] for i in range(3))
        normals = np.cross(b - a, c - a)
        expected = np.array([LOCAL_DIRECTIONS[f] for f in part_facing])
        assert np.all(np.einsum("ij,ij->i", normals, expected) > 0)


def test_glb_round_trip_keeps_the_building_in_unity_local_frame(written):
    building, _, data = written
    imported = glb_as_unity_imports(data)
    assert len(imported) == len(building.parts)
    for (positions, triangles), part in zip(imported, building.parts):
        # same corners, same triangles up to the order glTFast restores
        assert positions[triangles] == pytest.approx(part.positions[part.triangles], abs=1e-6)


@pytest.mark.parametrize("ref", PLACES, ids=["seoul", "buenos_aires", "antimeridian"])
@pytest.mark.parametrize("unity_radius", [R, 1000.0])
def test_wing_is_north_east_and_faces_point_outward_on_the_globe(written, ref, unity_radius):
    building, facing, data = written
    globe = GlobeOptions(unity_radius=unity_radius, earth_radius=R)
    tile = tile_of(ref.lon, ref.lat, 15)
    direct = building_placement(ref, globe)
    root, child = tile_placement(tile, globe), relative_placement(ref, tile, globe)
    directions = geographic_directions(ref.lon, ref.lat, unity_radius)

    imported = glb_as_unity_imports(data)
    for (positions, triangles), part_facing, name in zip(imported, facing, ["bar", "wing"]):
        on_globe = apply_placement(direct, positions)
        via_tile = apply_placement(root, apply_placement(child, positions))
        assert np.max(np.linalg.norm(on_globe - via_tile, axis=1)) <= 1e-9 * unity_radius

        for world in (on_globe, via_tile):
            a, b, c = (world[triangles[:, i]] for i in range(3))
            normals = np.cross(b - a, c - a)  # Unity-order triangle, numerically
            normals /= np.linalg.norm(normals, axis=1)[:, None]
            expected = np.array([directions[f] for f in part_facing])
            # every face points the geographic way it was built to, i.e. outward
            assert np.min(np.einsum("ij,ij->i", normals, expected)) > 0.9999
            if name == "wing":  # convex: also away from the wing's own centre
                centre = world.mean(axis=0)
                out = (a + b + c) / 3.0 - centre
                assert np.all(np.einsum("ij,ij->i", normals, out) > 0)

        if name == "wing":
            # the wing's roof centre: 10 m east, 10 m north and 40 m above the reference point
            top = apply_placement(direct, [[10.0, 40.0, 10.0]])[0]
            lon, lat, elev = inverse_eq2(top, unity_radius)
            d_lon = (lon - ref.lon + 180.0) % 360.0 - 180.0
            east_m = math.radians(d_lon) * R * math.cos(math.radians(ref.lat))
            north_m = math.radians(lat - ref.lat) * R
            assert east_m == pytest.approx(10.0, abs=1e-3) and north_m == pytest.approx(
                10.0, abs=1e-3
            )
            assert elev == pytest.approx(ref.elev + 40.0, abs=1e-3)
            # and the wing's mean lies north-east of the building's reference point, above the ground
            w_lon, w_lat, w_elev = inverse_eq2(on_globe.mean(axis=0), unity_radius)
            assert (
                (w_lon - ref.lon + 180.0) % 360.0 - 180.0 > 0
                and w_lat > ref.lat
                and w_elev > ref.elev
            )
