"""Placement of buildings and tile roots on the paper's globe, as Unity placement dicts.

Data form:
- lon/lat in **degrees**, elevations in **metres**.
- **Unity globe frame**: the paper's left-handed, y-up frame centred on the Earth, in Unity units
  (``UR`` = Earth radius in Unity units, ``R`` = real radius in metres), equations 1-2::

      h = UR + elev * UR / R                                          (1)
      x = h cos(lat) sin(lon),  y = h sin(lat),  z = -h cos(lat) cos(lon)   (2)

- **Local East/Up/North frame** (building- or tile-local): metres, x = East, y = Up, z = North.
- Rotations are (3, 3) float64 matrices acting on column vectors, or quaternions ``[x, y, z, w]``
  (Unity's component order; ordinary quaternion arithmetic, which is what Unity computes:
  ``Quaternion.AngleAxis(90, up) * forward == right``).
- Placement dicts ``{"position": [x, y, z], "rotation": [x, y, z, w], "scale": s}`` of plain
  floats, composed like a Unity hierarchy (see :func:`compose`).

Placements (the contract of ``docs/ARCHITECTURE.md``):
- :func:`building_placement`: the building on the globe (Unity globe frame), scale ``UR / R``.
- :func:`tile_placement`: the tile root at the tile centre, elevation 0, East/Up/North there.
- :func:`relative_placement`: the building in its tile's East/Up/North frame, metres, scale 1;
  ``compose(tile_placement, relative_placement) == building_placement``.

Sources: the paper's equations 1-2 and Fig. 5 (turn about y, then about ``cross(y, c)`` by the
angle between y and the centre vector ``c``); ``docs/reference/frames-and-placement.md``;
S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and Control 1(3), 1978 (the
matrix-to-quaternion conversion); the haversine identity ``1 - cos c = 2 hav(c)`` for the
cancellation-free tile-relative offsets.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .config import GlobeOptions
from .model import GeoPoint, TileId
from .tiles import tile_center

Y_AXIS = np.array([0.0, 1.0, 0.0])


# --------------------------------------------------------------------------- globe frame (eq. 1-2)


def _cos_sin(lon: float, lat: float) -> tuple[float, float, float, float]:
    """``cos(lon), sin(lon), cos(lat), sin(lat)`` of ``lon``, ``lat`` (degrees), by numpy's trig
    (the numbers the placements have always used); the products built on them below are plain
    float arithmetic, the same IEEE operations as on numpy scalars at a fraction of the cost."""
    lam, phi = np.radians(lon), np.radians(lat)
    return float(np.cos(lam)), float(np.sin(lam)), float(np.cos(phi)), float(np.sin(phi))


def unit_position(lon: float, lat: float) -> np.ndarray:
    """(3,) unit vector from the Earth's centre to ``lon``, ``lat`` (degrees), Unity globe frame."""
    cos_lam, sin_lam, cos_phi, sin_phi = _cos_sin(lon, lat)
    return np.array([cos_phi * sin_lam, sin_phi, -cos_phi * cos_lam])


def globe_position(lon: float, lat: float, elev: float, globe: GlobeOptions) -> np.ndarray:
    """(3,) position of ``lon``, ``lat`` (degrees), ``elev`` (metres): Unity globe frame, Unity units (eq. 1-2)."""
    h = globe.unity_radius + elev * globe.unity_radius / globe.earth_radius
    return h * unit_position(lon, lat)


def enu_matrix(lon: float, lat: float) -> np.ndarray:
    """(3, 3) rotation whose columns are East, Up, North at ``lon``, ``lat`` (degrees) in the Unity globe frame.

    Maps local East/Up/North vectors to Unity globe vectors; determinant +1.
    """
    cos_lam, sin_lam, cos_phi, sin_phi = _cos_sin(lon, lat)
    # columns: East (cos lam, 0, sin lam), Up (unit_position), North (-sin phi sin lam, cos phi,
    # sin phi cos lam)
    return np.array(
        [
            [cos_lam, cos_phi * sin_lam, -sin_phi * sin_lam],
            [0.0, sin_phi, cos_phi],
            [sin_lam, -cos_phi * cos_lam, sin_phi * cos_lam],
        ]
    )


def axis_angle_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` (radians) about unit ``axis`` (Rodrigues; Unity's AngleAxis numerically)."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def fig5_rotation(lon: float, lat: float) -> np.ndarray:
    """(3, 3) the paper's Fig. 5 rotation of a model standing on the y axis to ``lon``, ``lat`` (degrees).

    Step 1 turns it about y by ``-lon`` radians (numerically, as Unity's ``AngleAxis``), which
    points its local z (North) along the centre's meridian, away from the centre's side of the
    axis; step 2 tips the pole down that meridian: about ``cross(y, c)`` by the angle between y
    and the centre vector ``c``, which takes y to ``c`` and that meridian direction to North.
    Equals :func:`enu_matrix` (tested).
    """
    c = unit_position(lon, lat)
    step1 = axis_angle_matrix(Y_AXIS, -np.radians(lon))
    axis = np.cross(Y_AXIS, c)
    sine = np.linalg.norm(axis)
    angle = np.arctan2(sine, c @ Y_AXIS)
    if sine < 1e-12:
        # At the poles cross(y, c) vanishes; its direction's limit is minus East there.
        lam = np.radians(lon)
        axis = np.array([-np.cos(lam), 0.0, -np.sin(lam)])
    else:
        axis = axis / sine
    return axis_angle_matrix(axis, angle) @ step1


# --------------------------------------------------------------------------- quaternions [x, y, z, w]


def quaternion_from_matrix(m: np.ndarray) -> np.ndarray:
    """(4,) unit quaternion ``[x, y, z, w]`` of rotation matrix ``m`` (3, 3), with ``w >= 0``.

    Shepperd's method: build from the largest of ``w, x, y, z`` so no division is by a small number.
    Plain float arithmetic in numpy's order (``np.trace`` sums left to right, ``np.argmax`` takes
    the first largest or first NaN); the length is numpy's (``dot``), so the bits are numpy's.
    """
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(m, dtype=np.float64).tolist()
    trace = (m00 + m11) + m22
    candidates = (trace, m00, m11, m22)
    k = 0
    for i in (1, 2, 3):
        value = candidates[i]
        if value > candidates[k] or (value != value and candidates[k] == candidates[k]):
            k = i
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + trace)  # 4w
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif k == 1:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)  # 4x
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif k == 2:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)  # 4y
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)  # 4z
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    quaternion = np.array(q)
    quaternion /= math.sqrt(quaternion.dot(quaternion))  # np.linalg.norm's own formula
    return -quaternion if quaternion[3] < 0.0 else quaternion


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix of quaternion ``[x, y, z, w]`` (normalised first)."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(4,) Hamilton product ``a * b`` of ``[x, y, z, w]`` quaternions (apply ``b`` first, like Unity's ``a * b``)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` (3,) or (n, 3) rotated by quaternion ``[x, y, z, w]`` (Unity's ``q * v``)."""
    return np.asarray(v, dtype=np.float64) @ quaternion_to_matrix(q).T


# --------------------------------------------------------------------------- placement dicts


def placement_dict(position, rotation, scale: float) -> dict:
    """A JSON-able placement: ``position`` (3,), ``rotation`` quaternion (4,), ``scale`` as plain floats."""
    return {
        "position": [float(v) for v in position],
        "rotation": [float(v) for v in rotation],
        "scale": float(scale),
    }


def building_placement(ref: GeoPoint, globe: GlobeOptions) -> dict:
    """The building's globe placement: its local East/Up/North metres -> Unity globe frame, Unity units."""
    return placement_dict(
        globe_position(ref.lon, ref.lat, ref.elev, globe),
        quaternion_from_matrix(enu_matrix(ref.lon, ref.lat)),
        globe.unity_radius / globe.earth_radius,
    )


def tile_placement(tile: TileId, globe: GlobeOptions) -> dict:
    """The tile root's globe placement: tile-local East/Up/North metres (centre, elev 0) -> Unity globe frame."""
    lon, lat = tile_center(tile)
    return building_placement(GeoPoint(lon, lat, 0.0), globe)


def enu_offset(ref: GeoPoint, origin: GeoPoint, earth_radius: float) -> np.ndarray:
    """(3,) East/Up/North metres of ``ref`` in the local frame at ``origin`` on a sphere of ``earth_radius`` metres.

    Exact sphere geometry written without subtracting two Earth-sized vectors: with
    ``d_lat``, ``d_lon`` the differences and ``hav(a) = sin^2(a/2)``,
    ``east = cos(lat) sin(d_lon)``, ``north = sin(d_lat) + 2 cos(lat) sin(lat0) hav(d_lon)``,
    ``up - 1 = -2 (hav(d_lat) + cos(lat) cos(lat0) hav(d_lon))``, all times ``R + elev``.
    """
    phi, phi0 = np.radians(ref.lat), np.radians(origin.lat)
    d_lam = np.radians(ref.lon - origin.lon)  # subtract in degrees first: exact for nearby points
    d_phi = np.radians(ref.lat - origin.lat)
    hav_lam = np.sin(0.5 * d_lam) ** 2
    hav_phi = np.sin(0.5 * d_phi) ** 2
    east = np.cos(phi) * np.sin(d_lam)
    north = np.sin(d_phi) + 2.0 * np.cos(phi) * np.sin(phi0) * hav_lam
    up_minus_one = -2.0 * (hav_phi + np.cos(phi) * np.cos(phi0) * hav_lam)
    radius = earth_radius + ref.elev
    # Up of the ref point is (R + elev) * up; the origin sits at R + origin.elev.
    up = (ref.elev - origin.elev) + radius * up_minus_one
    return np.array([radius * east, up, radius * north])


@functools.lru_cache(maxsize=64)
def _tile_frame(tile: TileId) -> tuple[GeoPoint, np.ndarray]:
    """The tile centre (elevation 0) and the transpose of its :func:`enu_matrix` (read-only):
    shared by every building of the tile."""
    lon, lat = tile_center(tile)
    turn = enu_matrix(lon, lat).T
    turn.flags.writeable = False
    return GeoPoint(lon, lat, 0.0), turn


def relative_placement(ref: GeoPoint, tile: TileId, globe: GlobeOptions) -> dict:
    """The building in its tile's East/Up/North frame: position in metres, curvature rotation, scale 1.

    ``compose(tile_placement(tile, globe), relative_placement(ref, tile, globe))`` equals
    ``building_placement(ref, globe)`` (to float64 rounding).
    """
    origin, origin_turn = _tile_frame(tile)
    position = enu_offset(ref, origin, globe.earth_radius)
    turn = origin_turn @ enu_matrix(ref.lon, ref.lat)
    return placement_dict(position, quaternion_from_matrix(turn), 1.0)


def compose(parent: dict, child: dict) -> dict:
    """The child's placement in the parent's frame, as a Unity hierarchy composes them.

    ``position = parent.position + parent.rotation * (parent.scale * child.position)``,
    ``rotation = parent.rotation * child.rotation``, ``scale = parent.scale * child.scale``.
    """
    q_parent = np.asarray(parent["rotation"], dtype=np.float64)
    position = np.asarray(parent["position"], dtype=np.float64) + rotate(
        q_parent, parent["scale"] * np.asarray(child["position"], dtype=np.float64)
    )
    rotation = quaternion_multiply(q_parent, np.asarray(child["rotation"], dtype=np.float64))
    return placement_dict(position, rotation, parent["scale"] * child["scale"])


def apply_placement(placement: dict, points: np.ndarray) -> np.ndarray:
    """(n, 3) ``points`` of the child frame mapped to the parent frame by ``placement`` (Unity's TransformPoint)."""
    points = np.asarray(points, dtype=np.float64)
    return np.asarray(placement["position"]) + rotate(
        placement["rotation"], placement["scale"] * points
    )
