"""The in-memory building model every reader produces and every later stage consumes.

Frames and units (see ``docs/ARCHITECTURE.md`` and ``docs/reference/frames-and-placement.md``):

- ``Part.positions`` are in the **building-local East/Up/North frame, metres**
  (x = East, y = Up, z = North), origin at ``Building.reference`` (the building's
  centre lon/lat at its base elevation). This is Unity's local frame (left-handed).
- Winding: for every triangle ``(a, b, c)`` the numerical cross product
  ``(b - a) x (c - a)`` of local positions points **outward** (Unity's convention:
  ``Mesh.RecalculateNormals`` gives outward normals). The glTF writer negates X and
  reverses each triangle, the exact inverse of what glTFast does on import.
- ``Part.uvs`` use glTF's convention: origin at the image's top-left, v grows downward.
- ``Part.normals`` are unit vectors in the same local frame (optional).

Readers own no LoD logic: they fill this model and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class TileId:
    """A VWorld tile address: ``level`` (0 = 36 degree tiles), column ``idx``, row ``idy``."""

    level: int
    idx: int
    idy: int

    @property
    def name(self) -> str:
        """Folder name used in the output: ``<level>_<idx>_<idy>``."""
        return f"{self.level}_{self.idx}_{self.idy}"


@dataclass(frozen=True)
class GeoPoint:
    """A point on the globe: ``lon``/``lat`` in degrees (WGS84-style sphere), ``elev`` in metres."""

    lon: float
    lat: float
    elev: float


@dataclass
class Texture:
    """An encoded texture image, kept as its bytes so LOD0 can be written without re-encoding.

    ``mime`` is the encoded format (``image/jpeg``, ``image/png``, or another Pillow-readable type
    that the texture stage converts); ``width``/``height`` are in pixels as declared by the
    reader (the texture stage re-checks them when it decodes). ``name`` is the source's own name for
    it (file name), ``source`` the path it came from ("" when embedded).
    """

    data: bytes
    mime: str
    width: int
    height: int
    name: str = ""
    source: str = ""

    @property
    def has_alpha_channel(self) -> bool:
        """True when the encoded format can carry alpha (the texture stage decides if it is used)."""
        return self.mime == "image/png"


@dataclass
class Part:
    """One textured mesh of a building (one material).

    Shapes: ``positions`` (n, 3) float64 metres, local East/Up/North; ``triangles`` (m, 3) int64
    indices into positions, wound outward (see module doc); ``normals`` (n, 3) float32 or None;
    ``uvs`` (n, 2) float32 or None (glTF convention). ``color`` is the base colour RGBA in 0..1,
    used as the material factor (and alone when there is no texture).
    """

    positions: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    texture: Texture | None = None
    color: tuple = (1.0, 1.0, 1.0, 1.0)
    name: str = ""

    def __post_init__(self) -> None:
        self.positions = np.asarray(self.positions, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        if self.normals is not None:
            self.normals = np.asarray(self.normals, dtype=np.float32).reshape(-1, 3)
        if self.uvs is not None:
            self.uvs = np.asarray(self.uvs, dtype=np.float32).reshape(-1, 2)

    @property
    def triangle_count(self) -> int:
        return int(len(self.triangles))

    @property
    def vertex_count(self) -> int:
        return int(len(self.positions))


@dataclass
class Building:
    """One building as read from its source.

    ``reference`` is the origin of the local frame of every part (lon/lat in degrees, elev in
    metres). ``tile`` is the tile the *data* says the building belongs to (None when the source has
    no tile notion; the pipeline then uses the tile holding the centre). ``problems`` lists
    non-fatal findings (e.g. a missing texture) that go into the manifest.
    """

    id: str
    source: str
    reference: GeoPoint
    parts: list[Part]
    tile: TileId | None = None
    problems: list[str] = field(default_factory=list)
    # Geographic extent of the building (west, south, east, north) in degrees, when the reader knows
    # it; the tile a building belongs to is the one holding the centre of this box.
    lonlat_bounds: tuple | None = None
    # Source attributes kept for users: a flat dict of str -> str | int | float | bool made by
    # exporter.attributes.clean_attributes (every reader; docs/input.md "Attributes"); copied
    # into the manifest's building record when not empty.
    attributes: dict = field(default_factory=dict)

    @property
    def triangle_count(self) -> int:
        return sum(p.triangle_count for p in self.parts)

    @property
    def vertex_count(self) -> int:
        return sum(p.vertex_count for p in self.parts)


@dataclass
class Skipped:
    """A building (or file) that could not be used, reported in the manifest's ``skipped[]``."""

    source: str
    reason: str
    id: str | None = None
    tile: TileId | None = None
