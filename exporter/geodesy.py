"""Geodesy helpers: source CRS -> lon/lat/height, and lon/lat/height <-> local East/Up/North.

Data forms:

- ``lonlath``: (n, 3) float64 -- longitude and latitude in degrees, height in metres. Heights are
  kept in the source's vertical datum (e.g. NAP, LN02: metres above mean sea level, like VWorld's
  terrain), never converted to ellipsoidal heights: the globe is a sphere and the height is only
  ``elev`` in the placement formula ``h = R + elev``.
- ``local``: (n, 3) float64 -- the model's **local East/Up/North frame** in metres (x = East,
  y = Up, z = North) around a reference :class:`~exporter.model.GeoPoint`.
- ``ecef``: (n, 3) float64 -- Earth-centred Cartesian metres on the project's **sphere** of radius
  ``R`` (default 6378137 m, VWorld's and the placement's), right-handed: x towards (lat 0, lon 0),
  z towards the north pole.

The local frame is the one the placement stage (``docs/ARCHITECTURE.md``, "Frames") rotates onto
the globe: East/Up/North unit vectors at the reference lon/lat on the sphere. Converting through
the sphere's Cartesian frame (not the ellipsoid's) makes the two exact inverses, so a vertex read
here lands on its own lon/lat/height after placement, and walls shared by neighbouring buildings
meet. The price is the sphere's scale error against true ground distances (about 0.2 % at
mid-latitudes, 2 mm over 1 m), the same one the paper's spherical globe has everywhere.

Projected CRS -> lon/lat uses pyproj (PROJ) with ``always_xy=True``; a compound CRS (e.g.
EPSG:7415 = RD New + NAP height) is reduced to its horizontal part so heights pass through as
they are.
"""

from __future__ import annotations

import re
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from pyproj import CRS, Transformer
from pyproj.exceptions import CRSError, ProjError

from .model import GeoPoint

EARTH_RADIUS_M = 6378137.0  # VWorld's sphere; GlobeOptions.earth_radius defaults to it

# The forms CityJSON files use: OGC URLs, OGC URNs and plain authority codes.
_URL = re.compile(
    r"^https?://www\.opengis\.net/def/crs/(?P<auth>[A-Za-z]+)/[^/]*/(?P<code>[^/\s]+)/?$"
)
_URN = re.compile(r"^urn:ogc:def:crs:(?P<auth>[A-Za-z]+):[^:]*:(?P<code>[^:\s]+)$", re.IGNORECASE)


def normalise_crs_text(text: str) -> str:
    """``https://www.opengis.net/def/crs/EPSG/0/7415``, ``urn:ogc:def:crs:EPSG::7415`` and
    ``EPSG:7415`` all become ``EPSG:7415``; anything else is returned stripped (pyproj decides)."""
    text = str(text).strip()
    for pattern in (_URL, _URN):
        match = pattern.match(text)
        if match:
            return f"{match['auth'].upper()}:{match['code']}"
    return text


@lru_cache(maxsize=32)
def parse_crs(text: str) -> CRS:
    """The pyproj CRS named by ``text`` (any form of :func:`normalise_crs_text`).

    Raises ValueError with a readable reason when PROJ does not know it.
    """
    name = normalise_crs_text(text)
    try:
        return CRS.from_user_input(name)
    except CRSError as error:
        raise ValueError(f"unknown coordinate reference system {text!r} ({error})") from None


def horizontal_crs(crs: CRS) -> CRS:
    """The horizontal component of a compound CRS (RD New of RD New + NAP), else ``crs`` itself."""
    if crs.is_compound:
        for sub in crs.sub_crs_list:
            if sub.is_projected or sub.is_geographic:
                return sub
    return crs


@lru_cache(maxsize=32)
def _to_lonlat_transformer(text: str) -> Transformer:
    crs = horizontal_crs(parse_crs(text))
    if not (crs.is_projected or crs.is_geographic):
        raise ValueError(
            f"coordinate reference system {text!r} ({crs.name}) is neither projected nor geographic"
        )
    try:
        return Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    except ProjError as error:  # e.g. a CRS of the Moon or Mars: no operation to Earth's WGS84
        body = re.search(r"celestial body \((\w+) vs Earth\)", str(error))
        why = f"a CRS of {body.group(1)}, not of the Earth" if body else str(error).split(": (")[0]
        raise ValueError(
            f"coordinate reference system {text!r} ({crs.name}) cannot be converted to WGS84 "
            f"lon/lat: {why}"
        ) from None


def check_crs(text: str) -> None:
    """Raise ValueError (with the reason) unless ``text`` names a CRS the readers can convert to
    lon/lat (known to PROJ, projected or geographic)."""
    _to_lonlat_transformer(text)


def to_lonlath(xyz: np.ndarray, crs_text: str, strict: bool = True) -> np.ndarray:
    """Source coordinates (n, 3) (easting, northing metres, height metres) -> lonlath (n, 3).

    Heights are returned unchanged (see module doc). Raises ValueError for an unknown CRS or,
    when ``strict``, coordinates PROJ cannot transform (infinite results); otherwise those rows
    stay non-finite for the caller to refuse per building.
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    lon, lat = _to_lonlat_transformer(crs_text).transform(xyz[:, 0], xyz[:, 1])
    out = np.column_stack(
        [np.asarray(lon, dtype=np.float64), np.asarray(lat, dtype=np.float64), xyz[:, 2]]
    )
    if strict and not np.all(np.isfinite(out)):
        raise ValueError(
            f"coordinates outside the area {crs_text!r} can transform (PROJ returned inf)"
        )
    return out


def sphere_ecef(lonlath: npt.ArrayLike, radius: float = EARTH_RADIUS_M) -> np.ndarray:
    """lonlath (n, 3) -> Cartesian metres (n, 3) on the sphere of ``radius`` metres (module doc)."""
    lonlath = np.asarray(lonlath, dtype=np.float64).reshape(-1, 3)
    lon, lat = np.radians(lonlath[:, 0]), np.radians(lonlath[:, 1])
    r = radius + lonlath[:, 2]
    return np.column_stack(
        [r * np.cos(lat) * np.cos(lon), r * np.cos(lat) * np.sin(lon), r * np.sin(lat)]
    )


def sphere_lonlath(ecef: np.ndarray, radius: float = EARTH_RADIUS_M) -> np.ndarray:
    """Inverse of :func:`sphere_ecef`: Cartesian metres (n, 3) -> lonlath (n, 3)."""
    ecef = np.asarray(ecef, dtype=np.float64).reshape(-1, 3)
    r = np.linalg.norm(ecef, axis=1)
    lon = np.degrees(np.arctan2(ecef[:, 1], ecef[:, 0]))
    lat = np.degrees(np.arcsin(np.clip(ecef[:, 2] / r, -1.0, 1.0)))
    return np.column_stack([lon, lat, r - radius])


def east_up_north(lon: float, lat: float) -> np.ndarray:
    """(3, 3) rows = East, Up, North unit vectors at (lon, lat) degrees, in the sphere's Cartesian
    frame (module doc). ``local = basis @ (ecef - origin)``."""
    lam, phi = np.radians(lon), np.radians(lat)
    return np.array(
        [
            [-np.sin(lam), np.cos(lam), 0.0],
            [np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)],
            [-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)],
        ]
    )


def lonlath_to_local(
    lonlath: np.ndarray, reference: GeoPoint, radius: float = EARTH_RADIUS_M
) -> np.ndarray:
    """lonlath (n, 3) -> local East/Up/North metres (n, 3) around ``reference`` on the sphere."""
    origin = sphere_ecef([[reference.lon, reference.lat, reference.elev]], radius)[0]
    return (sphere_ecef(lonlath, radius) - origin) @ east_up_north(reference.lon, reference.lat).T


def local_to_lonlath(
    local: np.ndarray, reference: GeoPoint, radius: float = EARTH_RADIUS_M
) -> np.ndarray:
    """Inverse of :func:`lonlath_to_local`: local East/Up/North metres (n, 3) -> lonlath (n, 3)."""
    origin = sphere_ecef([[reference.lon, reference.lat, reference.elev]], radius)[0]
    local = np.asarray(local, dtype=np.float64).reshape(-1, 3)
    return sphere_lonlath(origin + local @ east_up_north(reference.lon, reference.lat), radius)


def base_centre(lonlath: np.ndarray) -> tuple[GeoPoint, tuple]:
    """The building reference point -- centre of the lon/lat bounding box at the minimum height --
    and the box ``(west, south, east, north)`` in degrees, from lonlath (n, 3), n >= 1."""
    lonlath = np.asarray(lonlath, dtype=np.float64).reshape(-1, 3)
    low, high = lonlath.min(axis=0), lonlath.max(axis=0)
    reference = GeoPoint(
        float((low[0] + high[0]) / 2), float((low[1] + high[1]) / 2), float(low[2])
    )
    return reference, (float(low[0]), float(low[1]), float(high[0]), float(high[1]))
