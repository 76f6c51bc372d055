"""Frames of the 3D Tiles output: local East/North/Up -> Earth-centred WGS84, boxes between frames.

Data forms (every matrix 4 x 4 float64, acting on column vectors of homogeneous metres):

- **ECEF**: Earth-centred, Earth-fixed WGS84 (EPSG:4978) metres, z through the north pole.
- **tile frame** of a node: what its ``transform`` maps to ECEF (3D Tiles' z-up frame). For this
  project's files it is (West, South, Up): ``world(lon, lat, h) = ENU->ECEF(lon, lat, h) ·
  diag(-1, -1, 1, 1)`` (the glTF files are +X = West, +Y = Up, +Z = North).
- **glTF frame**: what the ``.glb`` files store (+X = West, +Y = Up, +Z = North); clients turn
  glTF's y-up into the tile frame's z-up with :data:`Y_UP` before the tile transform
  (3D Tiles 1.1, "glTF transforms": (x, y, z) -> (x, -z, y)).
- a **box**: ``(centre (3,), half_axes (3, 3))`` in some frame, rows are the half-axes; its
  ``corners`` are (8, 3).

All arithmetic is float64: a float32 ECEF coordinate is ~0.5 m coarse.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from pyproj import Transformer

# glTF y-up -> tile z-up, as the 3D Tiles 1.1 specification states it (row-major).
Y_UP = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
# East/North/Up -> (West, South, Up): this project's x = West, turned 180 degrees about Up.
WEST_SOUTH_UP = np.diag([-1.0, -1.0, 1.0, 1.0])


@lru_cache(maxsize=1)
def _geodetic_to_ecef() -> Transformer:
    # EPSG:4979 (WGS84 lon/lat/ellipsoidal height, 3D) -> EPSG:4978 (WGS84 geocentric).
    return Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


def ecef_of(lon: float, lat: float, height: float) -> np.ndarray:
    """(3,) ECEF metres of ``lon``/``lat`` (degrees) and ``height`` (metres) on WGS84."""
    x, y, z = _geodetic_to_ecef().transform(float(lon), float(lat), float(height))
    return np.array([x, y, z], dtype=np.float64)


def enu_to_ecef(lon: float, lat: float, height: float) -> np.ndarray:
    """4 x 4 matrix: local East/North/Up metres at (lon, lat degrees, height metres) -> ECEF.

    Columns: East (-sin lon, cos lon, 0), North (-sin lat cos lon, -sin lat sin lon, cos lat),
    Up (cos lat cos lon, cos lat sin lon, sin lat) (geodetic lat: Up is the ellipsoid's normal),
    translation the WGS84 geocentric position."""
    lam, phi = np.radians(float(lon)), np.radians(float(lat))
    sl, cl, sp, cp = np.sin(lam), np.cos(lam), np.sin(phi), np.cos(phi)
    out = np.eye(4)
    out[:3, 0] = (-sl, cl, 0.0)
    out[:3, 1] = (-sp * cl, -sp * sl, cp)
    out[:3, 2] = (cp * cl, cp * sl, sp)
    out[:3, 3] = ecef_of(lon, lat, height)
    return out


def world_matrix(lon: float, lat: float, height: float) -> np.ndarray:
    """4 x 4: a tile frame of this project's content at (lon, lat degrees, height metres) -> ECEF."""
    return enu_to_ecef(lon, lat, height) @ WEST_SOUTH_UP


def apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 3) points mapped by the 4 x 4 affine ``matrix``."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def apply_each(matrices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, k, 3): each point set of ``points`` (N, k, 3) mapped by its own 4 x 4 affine matrix of
    ``matrices`` (N, 4, 4). The same bits as :func:`apply` per set (numpy's matmul runs the same
    product per matrix), without a Python call per set."""
    return np.matmul(points, matrices[:, :3, :3].transpose(0, 2, 1)) + matrices[:, None, :3, 3]


def inverse_rigid(matrix: np.ndarray) -> np.ndarray:
    """Inverse of a rotation + translation 4 x 4 (exact transpose, no general inversion)."""
    out = np.eye(4)
    out[:3, :3] = matrix[:3, :3].T
    out[:3, 3] = -matrix[:3, :3].T @ matrix[:3, 3]
    return out


_PICK = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=bool)
# A box's corners from its centre and half-axes: centre + SIGNS @ half_axes.
SIGNS = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], np.float64)


def gltf_corners(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(8, 3) corners, in the tile frame, of the glTF-frame axis-aligned box ``low``..``high``."""
    corners = np.where(_PICK, np.asarray(high, np.float64), np.asarray(low, np.float64))
    return apply(Y_UP, corners)


def gltf_corners_each(lows: np.ndarray, highs: np.ndarray) -> np.ndarray:
    """(N, 8, 3): :func:`gltf_corners` of each box ``lows[i]``..``highs[i]`` ((N, 3) each), with
    the same bits."""
    corners = np.where(_PICK, highs[:, None, :], lows[:, None, :])
    return np.matmul(corners, Y_UP[:3, :3].T) + Y_UP[:3, 3]


def box_around(points: np.ndarray) -> list[float]:
    """3D Tiles ``box`` (12 numbers: centre, then three half-axis vectors) of the axis-aligned box
    around ``points`` (n, 3) in the node's tile frame."""
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2.0, (high - low) / 2.0
    axes = np.diag(half)
    return [float(v) for v in (*centre, *axes.reshape(-1))]


def box_corners(box: list[float]) -> np.ndarray:
    """(8, 3) corners of a 3D Tiles ``box`` (in its own frame)."""
    values = np.asarray(box, dtype=np.float64)
    centre, axes = values[:3], values[3:].reshape(3, 3)
    return centre + SIGNS @ axes


def column_major(matrix: np.ndarray) -> list[float]:
    """A 4 x 4 matrix as 3D Tiles stores it: 16 numbers, column by column."""
    return [float(v) for v in np.asarray(matrix, dtype=np.float64).T.reshape(-1)]
