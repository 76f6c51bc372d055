"""CityGML reader: ``*.gml`` / ``*.gml.gz`` / ``*.xml`` (CityGML 1.0 and 2.0; 3.0's building
module where its element names match) -> one :class:`~exporter.model.Building` per top-level
``bldg:Building``, its ``BuildingPart`` and ``BuildingInstallation`` children merged into it (as
the CityJSON reader does).

Sources: OGC CityGML 1.0 (08-007r1) and 2.0 (12-019) encoding standards, GML 3.1.1 geometry.

- **Streaming**: files are read with lxml ``iterparse``; each top-level building is handled when
  its end tag arrives and then released with everything before it, so memory follows the largest
  building, not the file. CityModel-level ``app:appearanceMember`` s (which come after the
  buildings they texture) are read in a first pass, keeping only the chosen theme's texture
  coordinates and colours. Loading walks the file forward with a per-process cursor, so buildings
  asked for in file order cost one pass per process.
- **Geometry**: the ``lod{0..4}{Solid,MultiSurface,Geometry,FootPrint,RoofEdge}`` properties of
  the building, its parts, installations and thematic surfaces (``boundedBy``), interiors
  (``interiorRoom``...) left out. One LoD per building: the highest present at or below
  ``ReaderOptions.citygml_lod`` (default 2), else the lowest present (noted). Solids,
  Composite/MultiSurfaces, ``OrientableSurface`` (``-`` flips it), ``Surface`` patches, triangles
  and ``xlink:href`` references to polygons elsewhere in the file are followed (another
  building's are fetched by one more pass at scan, only when there are some, and travel in the
  Entry); a polygon reached twice (a solid referencing its thematic surfaces) counts once.
- **Semantics**: polygons under a ``GroundSurface`` are dropped when
  ``ReaderOptions.drop_ground_surfaces`` (VWorld-style floorless models, as for CityJSON).
- **Coordinates**: ``srsName`` on the geometry or its nearest ancestor, else the building's or the
  CityModel's ``gml:Envelope``, else ``ReaderOptions.crs`` (``--crs``, never overriding a declared
  one; a conflict is listed in ``Scan.crs_conflicts`` as for CityJSON); ``ReaderOptions.override_crs``
  (``--override-crs``) in place of any declared one, noted. Forms: ``EPSG:x``, OGC URNs (with or without version), compound URNs
  (``urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783``), OGC URLs, ``...epsg.xml#x`` and the
  German AdV ``urn:adv:crs:ETRS89_UTM32*...``. Coordinates are in the CRS's own axis order
  (EPSG:6697 and 4326 are latitude first) and are swapped to easting/longitude first before
  pyproj; then lon/lat/height, then the building's local East/Up/North metres exactly as the
  CityJSON reader does (:mod:`exporter.geodesy`).
- **Winding**: an exterior ring is counter-clockwise seen from outside (GML, as CityJSON); faces
  are oriented with :func:`~exporter.readers.cityjson.triangulate_polygon`.
- **Appearance**: the first theme of the CityModel's appearances, else of the buildings'.
  ``ParameterizedTexture`` with a ``TexCoordList`` per ring (bottom-left origin, flipped to
  glTF's top-left) and ``X3DMaterial`` diffuse colour and transparency. Images resolve as for
  CityJSON; a building's images are packed into one atlas (:mod:`exporter.readers.atlas`). A
  missing image or texture coordinates that do not match their ring cost the surface its texture,
  with a problem noted.
- **Bad polygons** (fewer than 3 distinct points, text or NaN coordinates, self-intersecting or
  non-planar rings, dangling ``xlink:href``) are left out and counted in ``problems``.
- **Attributes** (``Building.attributes``, rules of :mod:`exporter.attributes`): ``gml_id``,
  ``name`` (the first ``gml:name``), ``measured_height`` (metres, float), ``function``, ``usage``,
  ``year_of_construction`` (int), ``roof_type``, ``storeys_above_ground`` (int) of the top-level
  building (its parts' own are not merged in), and its generic attributes by their own names:
  ``gen:stringAttribute``/``dateAttribute``/``uriAttribute`` as text, ``intAttribute`` as int,
  ``doubleAttribute``/``measureAttribute`` as float (a value that is not a number of its type
  is kept as text), ``genericAttributeSet`` members as ``set.name``; CityGML 3.0's
  ``genericAttribute`` wrapper likewise. A repeated element (several ``function``) keeps the
  first.
"""

from __future__ import annotations

import copy
import gzip
import os
import re
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from .. import geodesy
from ..attributes import clean_attributes
from ..config import ReaderOptions
from ..errors import InputError, ReadError
from ..mesh.geometry import cross3
from ..model import Building, Part, Skipped, Texture
from ..tiles import building_tile
from . import Entry, Scan
from .atlas import pack_parts
from .cityjson import _load_texture, _part, _resolve_image, newell_normal, triangulate_polygon
from .confine import OutsideInput
from .crs import choose_crs

FORMAT = "citygml"
SUFFIXES = (".gml", ".gml.gz", ".xml", ".xml.gz")
CRS_HINT = "pass --crs EPSG:<code> (e.g. --crs EPSG:25832) or set readers.crs in the config"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
GML_IDS = ("{http://www.opengis.net/gml}id", "{http://www.opengis.net/gml/3.2}id")
LOD_PROPERTY = re.compile(r"^lod([0-4])(Solid|MultiSurface|Geometry|FootPrint|RoofEdge)$")
POLYGONS = ("Polygon", "PolygonPatch", "Triangle", "Rectangle")
INTERIOR = ("interiorRoom", "interiorBuildingInstallation", "interiorFurniture", "appearance")
GROUND = "GroundSurface"
# Watched end tags: buildings, the CityModel's envelope and its members (released when done).
WATCH = (
    "{*}Building",
    "{*}Envelope",
    "{*}cityObjectMember",
    "{*}featureMember",
    "{*}appearanceMember",
)
MAX_DEPTH = 64  # nesting / xlink chains deeper than this are refused (cycles)
SMALL_RING = 12  # rings up to this many points are checked in plain Python
MAX_RING_CHECK = 512  # rings with more points skip the O(k^2) self-intersection test (k^2 arrays)
_CACHE_SIZE = 4
_SNIFF_BYTES = 65536


def _local(tag: Any) -> str:
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def _gml_id(element) -> str | None:
    return element.get(GML_IDS[0]) or element.get(GML_IDS[1])


def _inherited(element, attribute: str) -> str | None:
    """``attribute`` on ``element`` or its nearest ancestor that has it."""
    while element is not None:
        value = element.get(attribute)
        if value:
            return value
        element = element.getparent()
    return None


def _where(element) -> str:
    """``gml:Polygon GML_12`` or ``gml:Polygon (line 40)``: names an element in a problem."""
    gml_id = _gml_id(element)
    return (
        f"{_local(element.tag)} {gml_id}"
        if gml_id
        else f"{_local(element.tag)} (line {element.sourceline})"
    )


# --------------------------------------------------------------------------- coordinates

_ADV = re.compile(r"ETRS89_UTM(\d\d)", re.IGNORECASE)
_EPSG_XML = re.compile(r"epsg\.xml#(\d+)$", re.IGNORECASE)
_PART = re.compile(r"crs:([A-Za-z]+):[^:,]*:(\d+)", re.IGNORECASE)


def crs_of_srs_name(srs_name: str) -> str:
    """A CRS text pyproj reads (``EPSG:25832`` or compound ``EPSG:25832+5783``) for a GML
    ``srsName`` in any of the forms of the module doc; ValueError naming it when unknown."""
    text = srs_name.strip()
    adv = _ADV.search(text) if text.lower().startswith("urn:adv:") else None
    if adv:
        text = f"EPSG:258{adv[1]}"
    elif epsg_xml := _EPSG_XML.search(text):
        text = f"EPSG:{epsg_xml[1]}"
    elif text.lower().startswith("urn:ogc:def:crs,"):  # compound URN
        parts = _PART.findall(text)
        if not parts or any(auth.upper() != "EPSG" for auth, _ in parts):
            raise ValueError(f"unknown coordinate reference system {srs_name!r}")
        text = "EPSG:" + "+".join(code for _, code in parts)
    elif "def/crs-compound" in text:
        codes = re.findall(r"/EPSG/[^/]*/(\d+)", text)
        text = "EPSG:" + "+".join(codes) if codes else text
    else:
        text = geodesy.normalise_crs_text(text)
    geodesy.parse_crs(text)  # raises ValueError for an unknown one
    return text


@lru_cache(maxsize=32)
def latitude_first(crs_text: str) -> bool:
    """True when the CRS's horizontal axes are northing/latitude first (EPSG:4326, 6697...)."""
    crs = geodesy.horizontal_crs(geodesy.parse_crs(crs_text))
    axes = crs.axis_info
    return bool(axes) and axes[0].direction.lower() == "north"


def to_lonlath(xyz: np.ndarray, crs_text: str) -> np.ndarray:
    """Source coordinates (n, 3) in the CRS's axis order -> lonlath (n, 3) (degrees, metres)."""
    if latitude_first(crs_text):
        xyz = xyz[:, [1, 0, 2]]
    return geodesy.to_lonlath(xyz, crs_text)


# --------------------------------------------------------------------------- problems


@dataclass
class _Problems:
    """Counts of left-out polygons per reason, with the first one named."""

    counts: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    def add(self, reason: str, where: str) -> None:
        count, first = self.counts.get(reason, (0, where))
        self.counts[reason] = (count + 1, first)

    def messages(self) -> list[str]:
        return self.notes + [
            f"{count} polygon(s) left out: {reason} (first: {first})"
            for reason, (count, first) in self.counts.items()
        ]


# --------------------------------------------------------------------------- appearances


@dataclass
class _Appearance:
    """One theme's surface data: ``images`` URIs; ``textured`` polygon id -> (image index,
    {ring id: (k, 2) float64 texture coordinates, bottom-left origin, or None when malformed});
    ``colours`` target id -> RGBA 0..1."""

    images: list = field(default_factory=list)
    textured: dict = field(default_factory=dict)
    colours: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    def merged(self, other: _Appearance) -> _Appearance:
        """``self`` with ``other``'s entries where self has none (images renumbered)."""
        if not other.textured and not other.colours:
            return self
        result = _Appearance(list(self.images), dict(self.textured), dict(self.colours))
        shift = len(result.images)
        result.images += other.images
        for key, (index, rings) in other.textured.items():
            result.textured.setdefault(key, (index + shift, rings))
        for key, colour in other.colours.items():
            result.colours.setdefault(key, colour)
        return result


def _theme(appearance) -> str:
    for child in appearance:
        if _local(child.tag) == "theme":
            return (child.text or "").strip()
    return ""


def _numbers(text: str | None) -> np.ndarray | None:
    try:
        values = np.array((text or "").split(), dtype=np.float64)
    except ValueError:
        return None
    return values if np.all(np.isfinite(values)) else None


def _target_id(text: str | None) -> str:
    return (text or "").strip().lstrip("#")


def _read_surface_data(data, appearance: _Appearance) -> None:
    name = _local(data.tag)
    if name == "X3DMaterial":
        colour = _numbers(next((c.text for c in data if _local(c.tag) == "diffuseColor"), None))
        transparency = _numbers(
            next((c.text for c in data if _local(c.tag) == "transparency"), None)
        )
        rgb = colour if colour is not None and len(colour) == 3 else np.array([0.8, 0.8, 0.8])
        alpha = (
            1.0 - float(transparency[0]) if transparency is not None and len(transparency) else 1.0
        )
        rgba = tuple(float(v) for v in np.clip([*rgb, alpha], 0.0, 1.0))
        for target in data:
            if _local(target.tag) == "target":
                appearance.colours.setdefault(_target_id(target.text), rgba)
    elif name == "ParameterizedTexture":
        uri = next((c.text for c in data if _local(c.tag) == "imageURI"), None)
        if not uri or not uri.strip():
            appearance.notes.append(f"{_where(data)} has no imageURI: ignored")
            return
        index = len(appearance.images)
        appearance.images.append(uri.strip())
        for target in data:
            if _local(target.tag) != "target":
                continue
            rings = {}
            for coordinates in target.iter("{*}textureCoordinates"):
                values = _numbers(coordinates.text)
                rings[_target_id(coordinates.get("ring"))] = (
                    values.reshape(-1, 2) if values is not None and len(values) % 2 == 0 else None
                )
            if rings:
                appearance.textured.setdefault(_target_id(target.get("uri")), (index, rings))
            elif any(_local(c.tag) == "TexCoordGen" for c in target):
                appearance.notes.append(
                    "TexCoordGen (texture by world-to-texture matrix) not supported"
                )
    elif name in ("GeoreferencedTexture",) or data.get(XLINK_HREF):
        appearance.notes.append(
            f"{name or 'surfaceDataMember'} (xlink or georeferenced) not supported: ignored"
        )


def read_appearance(appearance, theme: str, into: _Appearance) -> None:
    """Add the surface data of an ``app:Appearance`` element of ``theme`` to ``into``."""
    if _theme(appearance) != theme:
        return
    for member in appearance:
        if _local(member.tag) != "surfaceDataMember":
            continue
        if member.get(XLINK_HREF):
            into.notes.append("surfaceDataMember by xlink:href not supported: ignored")
        for data in member:
            if isinstance(data.tag, str):
                _read_surface_data(data, into)


# --------------------------------------------------------------------------- streaming


def _open(path: Path):
    return gzip.open(path, "rb") if path.name.lower().endswith(".gz") else path.open("rb")


def _release(element) -> None:
    """Free ``element``'s content and every earlier sibling of it and of its ancestors."""
    element.clear(keep_tail=True)
    node = element
    while node.getparent() is not None:
        parent = node.getparent()
        while node.getprevious() is not None:
            del parent[0]
        node = parent


def _is_top_building(element) -> bool:
    return "citygml" in element.tag and not any(
        _local(a.tag) == "Building" for a in element.iterancestors()
    )


def stream(path: Path, appearances: bool = False) -> Iterator[tuple[str, Any, str | None]]:
    """Yield ``("building", element, file srsName)`` per top-level building in file order (and
    ``("appearance", element, ...)`` per CityModel-level appearanceMember when asked); each
    element is released once the consumer asks for the next. Raises ``etree.XMLSyntaxError``
    where the XML breaks (after the buildings before it)."""
    file_srs: str | None = None
    with _open(path) as handle:
        events = etree.iterparse(
            handle,
            events=("end",),
            tag=WATCH,
            huge_tree=True,
            remove_comments=True,
            resolve_entities=False,
            no_network=True,
            load_dtd=False,
        )
        for _, element in events:
            name = _local(element.tag)
            if name == "Envelope":
                grand = element.getparent()
                grand = grand.getparent() if grand is not None else None
                if grand is not None and grand.getparent() is None and file_srs is None:
                    file_srs = element.get("srsName")
                continue
            if name == "Building":
                if _is_top_building(element):
                    yield "building", element, file_srs
                    _release(element)
                continue
            parent = element.getparent()
            if parent is not None and parent.getparent() is None:  # a CityModel member
                if appearances and name == "appearanceMember":
                    yield "appearance", element, file_srs
                _release(element)


def has_global_appearance(path: Path) -> bool:
    """True when the file mentions ``appearanceMember`` (CityModel-level appearances): a byte
    search, so files without them need no appearance pass."""
    needle, tail = b"appearanceMember", b""
    with _open(path) as handle:
        while chunk := handle.read(1 << 22):
            if needle in tail + chunk:
                return True
            tail = chunk[-len(needle) :]
    return False


def global_appearance(path: Path, theme: str | None) -> tuple[_Appearance, list[str]]:
    """The CityModel-level appearances of ``theme`` (the first theme found when None) and every
    theme seen, in order."""
    result, themes = _Appearance(), []
    for kind, element, _ in stream(path, appearances=True):
        if kind != "appearance":
            continue
        for appearance in element.iter("{*}Appearance"):
            name = _theme(appearance)
            if name not in themes:
                themes.append(name)
            read_appearance(appearance, theme if theme is not None else themes[0], result)
    return result, themes


def foreign_polygons(path: Path, wanted: set[str]) -> dict[str, bytes]:
    """The elements of ``wanted`` gml:ids found in any building of the file, each serialised on
    its own with its inherited ``srsName`` / ``srsDimension`` written on it (references from one
    building to another's polygons; a pass over the file, made only when there are some)."""
    found: dict[str, bytes] = {}
    try:
        for _, building, file_srs in stream(path):
            default = _envelope_srs(building) or file_srs
            for element in building.iter():
                gml_id = _gml_id(element) if isinstance(element.tag, str) else None
                if gml_id in wanted and gml_id not in found:
                    clone = copy.deepcopy(element)
                    for attribute, fallback in (("srsName", default), ("srsDimension", None)):
                        value = _inherited(element, attribute) or fallback
                        if value:
                            clone.set(attribute, value)
                    found[gml_id] = etree.tostring(clone)
            if len(found) == len(wanted):
                break
    except etree.XMLSyntaxError:  # the scan has reported it; keep what came before
        pass
    return found


# --------------------------------------------------------------------------- building geometry


@dataclass
class _Surface:
    """One polygon: ``rings`` (k, 3) float64 source coordinates in the CRS's axis order, exterior
    first, closing point removed; ``ring_ids`` their gml:ids; ``crs`` the pyproj text; ``flip``
    True when reached through a reversed OrientableSurface; ``colour`` RGBA or None."""

    element: Any
    rings: list
    ring_ids: list
    crs: str
    semantic: str | None
    flip: bool
    colour: tuple | None


def _candidates(element, semantic: str | None, out: list, depth: int = 0) -> None:
    """(LoD, semantic surface type or None, property element) of every geometry property below
    ``element`` (its parts, installations and thematic surfaces; interiors left out; nothing
    deeper than MAX_DEPTH)."""
    if depth > MAX_DEPTH:
        return
    for child in element:
        name = _local(child.tag)
        if not name or name in INTERIOR:
            continue
        match = LOD_PROPERTY.match(name)
        if match:
            out.append((int(match[1]), semantic, child))
            continue
        _candidates(child, name if name.endswith("Surface") else semantic, out, depth + 1)


def choose_lod(present: set[int], cap: int) -> int:
    """The highest LoD in ``present`` at or below ``cap``, else the lowest present."""
    below = [lod for lod in present if lod <= cap]
    return max(below) if below else min(present)


def _ring(ring, problems: _Problems) -> np.ndarray | None:
    """(k, 3) float64 points of a gml:LinearRing (posList, pos or coordinates), closing point
    removed; None (with a problem counted) when unusable."""
    where = _where(ring.getparent().getparent() if ring.getparent() is not None else ring)
    if _local(ring.tag) != "LinearRing":
        problems.add(f"ring type {_local(ring.tag)} not supported", where)
        return None
    children = [c for c in ring if isinstance(c.tag, str)]
    pos_list = next((c for c in children if _local(c.tag) == "posList"), None)
    if pos_list is not None:
        values, source = _numbers(pos_list.text), pos_list
    elif any(_local(c.tag) == "pos" for c in children):
        each = [_numbers(c.text) for c in children if _local(c.tag) == "pos"]
        ok = all(p is not None for p in each)
        values = np.concatenate(each) if ok and each else None  # type: ignore[arg-type]
        source = next(c for c in children if _local(c.tag) == "pos")
    elif any(_local(c.tag) == "coordinates" for c in children):
        text = next(c.text for c in children if _local(c.tag) == "coordinates") or ""
        values, source = _numbers(text.replace(",", " ")), ring
    else:
        problems.add("ring without posList, pos or coordinates", where)
        return None
    if values is None:
        problems.add("text, NaN or infinity in coordinates", where)
        return None
    dimension_text = _inherited(source, "srsDimension") or "3"
    dimension = int(dimension_text) if dimension_text.strip().isdigit() else 0
    if dimension not in (2, 3) or len(values) % dimension:
        problems.add(
            f"{len(values)} coordinates do not split into srsDimension {dimension_text}", where
        )
        return None
    points = values.reshape(-1, dimension)
    if dimension == 2:  # a flat ring: height 0
        points = np.column_stack([points, np.zeros(len(points))])
    if len(points) > 1 and np.array_equal(points[0], points[-1]):
        points = points[:-1]
    if len(set(map(tuple, points.tolist()))) < 3:
        problems.add("fewer than 3 distinct points", where)
        return None
    return points


class _Walker:
    """Collects the surfaces of geometry properties, following xlinks within the building."""

    def __init__(
        self,
        ids: dict,
        colours: dict,
        declared_default: str | None,
        problems: _Problems,
        options: ReaderOptions,
    ):
        self.ids, self.colours, self.declared_default = ids, colours, declared_default
        self.option_crs, self.override_crs = options.crs, options.override_crs
        self.problems = problems
        self.declared: set[str] = set()  # the srsNames the geometry declares, as written
        self.used_option = False  # some geometry declares none and is read in options.crs
        self.surfaces: list[_Surface] = []
        self.seen: dict = {}  # (element, flip) -> index in surfaces (elements kept alive here)
        self.followed: dict = {}  # (element, flip) reached by xlink:href (kept alive here)
        self.dangling: list[str] = []  # ids referenced but not in ``ids``
        self.crs_cache: dict = {}

    def crs(self, element) -> str:
        """The CRS to read ``element``'s coordinates in (:func:`.crs.choose_crs`: ``override_crs``,
        else the declared ``srsName``, else ``options.crs``)."""
        declared = _inherited(element, "srsName") or self.declared_default
        if declared is not None:
            self.declared.add(declared)
        elif not self.override_crs:
            self.used_option = self.option_crs is not None
        chosen = choose_crs(self.override_crs, declared, self.option_crs)
        if chosen is None:
            raise ValueError(f"declares no coordinate reference system (srsName); {CRS_HINT}")
        srs_name = chosen[0]
        if srs_name not in self.crs_cache:
            try:
                self.crs_cache[srs_name] = crs_of_srs_name(srs_name)
            except ValueError as error:
                raise ValueError(f"{error} (srsName on {_where(element)}); {CRS_HINT}") from None
        return self.crs_cache[srs_name]

    def walk(self, element, semantic: str | None, flip: bool, colour, depth: int = 0) -> None:
        if depth > MAX_DEPTH:
            self.problems.add(f"nesting or xlink chain deeper than {MAX_DEPTH}", _where(element))
            return
        href = element.get(XLINK_HREF)
        if href is not None:
            target = self.ids.get(href[1:]) if href.startswith("#") else None
            if target is None:
                self.problems.add("dangling xlink:href", f"{href} on {_local(element.tag)}")
                if href.startswith("#"):
                    self.dangling.append(href[1:])
                return
            if (target, flip) in self.followed:  # met before: its polygons are known (and no
                return  # reference cycle or diamond can make the walk exponential)
            self.followed[(target, flip)] = True
            self.walk(target, semantic, flip, colour, depth + 1)
            return
        gml_id = _gml_id(element)
        if gml_id is not None and gml_id in self.colours:
            colour = self.colours[gml_id]
        name = _local(element.tag)
        if name in POLYGONS:
            self.polygon(element, semantic, flip, colour)
            return
        if name == "OrientableSurface" and element.get("orientation", "+").strip() == "-":
            flip = not flip
        for child in element:
            if not isinstance(child.tag, str) or (
                name == "Solid" and _local(child.tag) == "interior"
            ):
                continue
            self.walk(child, semantic, flip, colour, depth + 1)

    def polygon(self, element, semantic: str | None, flip: bool, colour) -> None:
        key = (element, flip)
        if key in self.seen:
            known = self.surfaces[self.seen[key]]
            if known is not None:
                known.semantic = known.semantic or semantic
            return
        self.seen[key] = len(self.surfaces)
        boundaries = [c for c in element if _local(c.tag) in ("exterior", "outerBoundaryIs")]
        boundaries += [c for c in element if _local(c.tag) in ("interior", "innerBoundaryIs")]
        rings, ids = [], []
        for boundary in boundaries:
            ring = next((c for c in boundary if isinstance(c.tag, str)), None)
            points = _ring(ring, self.problems) if ring is not None else None
            if points is None:
                if ring is None:
                    self.problems.add("empty exterior or interior", _where(element))
                self.surfaces.append(None)  # type: ignore[arg-type]  # placeholder keeps order
                return
            rings.append(points)
            ids.append(_gml_id(ring))
        if not rings or _local(boundaries[0].tag) not in ("exterior", "outerBoundaryIs"):
            self.problems.add("polygon without exterior", _where(element))
            self.surfaces.append(None)  # type: ignore[arg-type]
            return
        self.surfaces.append(
            _Surface(element, rings, ids, self.crs(element), semantic, flip, colour)
        )


@dataclass
class _Read:
    """One building's surfaces at its chosen LoD, ground dropped; ``problems`` and attributes."""

    id: str
    surfaces: list
    problems: _Problems
    attributes: dict
    lod: int | None
    dangling: list = field(default_factory=list)  # xlink:href ids not found in the building
    declared: set = field(default_factory=set)  # srsNames its geometry declares, as written
    used_option: bool = False  # some of its geometry declares no CRS: read in options.crs


# CityGML building properties kept as attributes: element name -> (attribute name, type).
BUILDING_ATTRIBUTES = {
    "name": ("name", str),
    "measuredHeight": ("measured_height", float),  # metres (uom as written)
    "function": ("function", str),
    "usage": ("usage", str),
    "yearOfConstruction": ("year_of_construction", int),
    "roofType": ("roof_type", str),
    "storeysAboveGround": ("storeys_above_ground", int),
}
# Generic attributes (gen:*Attribute of 1.0/2.0, gen:*Attribute inside genericAttribute of 3.0).
GENERIC_TYPES = {
    "stringAttribute": str,
    "intAttribute": int,
    "doubleAttribute": float,
    "measureAttribute": float,
    "dateAttribute": str,
    "uriAttribute": str,
}


def _typed(text: str | None, kind: type) -> Any:
    """``text`` stripped as ``kind`` (int, float or str); None when empty, text when it is not a
    number of that kind (kept rather than lost)."""
    text = (text or "").strip()
    if not text:
        return None
    if kind is str:
        return text
    try:
        return kind(text)
    except ValueError:
        try:
            number = float(text)
        except ValueError:
            return text
        return int(number) if kind is int and number.is_integer() else number


def _generic(element, prefix: str) -> Iterator[tuple[str, Any]]:
    """(name, typed value) pairs of a generic attribute element (sets flattened as
    ``set.name``)."""
    kind = _local(element.tag)
    kind = kind[0].lower() + kind[1:]  # 3.0 writes StringAttribute, 2.0 stringAttribute
    name = element.get("name")
    children = {_local(c.tag): c for c in element if isinstance(c.tag, str)}
    if name is None and "name" in children:
        name = (children["name"].text or "").strip()
    if not name:
        return
    if kind == "genericAttributeSet":
        for child in element:
            if isinstance(child.tag, str):
                yield from _generic(child, f"{prefix}{name}.")
        return
    if kind in GENERIC_TYPES and "value" in children:
        yield f"{prefix}{name}", _typed(children["value"].text, GENERIC_TYPES[kind])


def attribute_pairs(building, building_id: str) -> Iterator[tuple[str, Any]]:
    """(name, typed value) of a building element's attributes, in file order (module doc)."""
    yield "gml_id", building_id
    for child in building:
        name = _local(child.tag)
        if name in BUILDING_ATTRIBUTES:
            key, kind = BUILDING_ATTRIBUTES[name]
            value = _typed(child.text, kind)
            if value is not None:
                yield key, value
        elif name in GENERIC_TYPES or name == "genericAttributeSet":
            yield from _generic(child, "")
        elif name == "genericAttribute":  # CityGML 3.0: one attribute element inside
            for inner in child:
                if isinstance(inner.tag, str):
                    yield from _generic(inner, "")


def _attributes(building, building_id: str) -> tuple[dict, list[str]]:
    return clean_attributes(
        (k, v) for k, v in attribute_pairs(building, building_id) if v is not None
    )


def _envelope_srs(building) -> str | None:
    for child in building:
        if _local(child.tag) == "boundedBy":
            for envelope in child:
                if _local(envelope.tag) == "Envelope" and envelope.get("srsName"):
                    return envelope.get("srsName")
    return None


def read_building(
    building,
    ordinal: int,
    file_srs: str | None,
    options: ReaderOptions,
    colours: dict,
    foreign: dict | None = None,
) -> _Read:
    """The surfaces of a top-level building element at its chosen LoD (module doc); ``foreign``
    maps ids to elements it references outside itself (:func:`foreign_polygons`). Raises
    ValueError when its CRS is missing or unknown."""
    building_id = _gml_id(building) or f"building{ordinal}"
    problems = _Problems()
    found: list = []
    _candidates(building, None, found)
    attributes, notes = _attributes(building, building_id)
    problems.notes += notes
    read = _Read(building_id, [], problems, attributes, None)
    if not found:
        return read
    present = {lod for lod, _, _ in found}
    read.lod = choose_lod(present, options.citygml_lod)
    if read.lod > options.citygml_lod:
        problems.notes.append(
            f"no geometry at LoD {options.citygml_lod} or below; read LoD {read.lod}"
        )
    elif len(present) > 1:
        problems.notes.append(
            f"LoDs {', '.join(map(str, sorted(present)))} present; read LoD {read.lod}"
        )
    ids: dict = {}
    for element in building.iter():
        gml_id = _gml_id(element)
        if gml_id is not None:
            ids.setdefault(gml_id, element)
    for gml_id, element in (foreign or {}).items():
        ids.setdefault(gml_id, element)
    walker = _Walker(ids, colours, _envelope_srs(building) or file_srs, problems, options)
    for lod, semantic, prop in found:
        if lod == read.lod:
            walker.walk(prop, semantic, False, None)
    read.dangling = walker.dangling
    read.declared, read.used_option = walker.declared, walker.used_option
    if options.override_crs and walker.declared:
        problems.notes.append(
            f"read in {options.override_crs} in place of the declared "
            f"{', '.join(sorted(walker.declared))} (override_crs)"
        )
    dropped = 0
    for surface in walker.surfaces:
        if surface is None:
            continue
        if options.drop_ground_surfaces and surface.semantic == GROUND:
            dropped += 1
            continue
        read.surfaces.append(surface)
    if dropped:
        problems.notes.append(f"dropped {dropped} GroundSurface polygon(s)")
    return read


def _local_appearance(building, theme: str | None) -> tuple[list[str], _Appearance]:
    """The themes of the appearances inside a building element, and ``theme``'s surface data."""
    appearance, themes = _Appearance(), []
    for element in building.iter("{*}Appearance"):
        name = _theme(element)
        if name not in themes:
            themes.append(name)
        if theme is not None:
            read_appearance(element, theme, appearance)
    return themes, appearance


def _images_used(appearance: _Appearance, polygon_ids: set) -> list[str]:
    return [appearance.images[i] for k, (i, _) in appearance.textured.items() if k in polygon_ids]


# --------------------------------------------------------------------------- placement and mesh


def surface_lonlath(surfaces: list[_Surface]) -> list[list[np.ndarray]]:
    """Per surface, per ring: lonlath (k, 3), one pyproj call per CRS."""
    by_crs: dict[str, list] = {}
    for s, surface in enumerate(surfaces):
        for r, ring in enumerate(surface.rings):
            by_crs.setdefault(surface.crs, []).append((s, r, ring))
    out: list[list] = [[None] * len(s.rings) for s in surfaces]
    for crs, rings in by_crs.items():
        lonlath = to_lonlath(np.concatenate([ring for _, _, ring in rings]), crs)
        start = 0
        for s, r, ring in rings:
            out[s][r] = lonlath[start : start + len(ring)]
            start += len(ring)
    return out


def ring_crossings(flat: np.ndarray) -> bool:
    """True when two non-adjacent edges of the closed 2D ring ``flat`` (k, 2) cross properly
    (each edge's endpoints strictly on both sides of the other's line)."""
    k = len(flat)
    if k < 4 or k > MAX_RING_CHECK:
        return False
    if k > SMALL_RING:
        return _crossings_array(flat)
    points = flat.tolist()  # a few points: plain floats beat numpy's per-call cost
    edges = [(points[i], points[(i + 1) % k]) for i in range(k)]
    return any(
        _apart(*edges[i], *edges[j]) and _apart(*edges[j], *edges[i])
        for i in range(k)
        for j in range(i + 2, k if i else k - 1)
    )


def _apart(p: list, q: list, r: list, s: list) -> bool:
    """True when r and s lie strictly on opposite sides of the line through p and q."""
    a = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    b = (q[0] - p[0]) * (s[1] - p[1]) - (q[1] - p[1]) * (s[0] - p[0])
    return a < 0 < b or b < 0 < a


def _crossings_array(flat: np.ndarray) -> bool:
    """:func:`ring_crossings` for every edge pair at once ((k, k) arrays)."""
    a, b = flat, np.roll(flat, -1, axis=0)

    def orient(p, q, r):  # sign of (q - p) x (r - p) for every edge pair
        return np.sign(
            (q[:, None, 0] - p[:, None, 0]) * (r[None, :, 1] - p[:, None, 1])
            - (q[:, None, 1] - p[:, None, 1]) * (r[None, :, 0] - p[:, None, 0])
        )

    # Edge i's endpoints against edge j's line and the reverse: both pairs strictly apart.
    apart = orient(a, b, a) * orient(a, b, b) < 0
    return bool((apart & apart.T & _non_adjacent(len(flat))).any())


@lru_cache(maxsize=64)
def _non_adjacent(k: int) -> np.ndarray:
    """(k, k) bool: edge pairs of a closed k-ring that share no corner."""
    i, j = np.indices((k, k))
    gap = np.abs(i - j)
    return (gap > 1) & (gap < k - 1)


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = cross3(normal, np.eye(3)[int(np.argmin(np.abs(normal)))])
    u /= np.linalg.norm(u)
    return u, cross3(normal, u)


def check_polygon(rings: list[np.ndarray], outward: np.ndarray) -> str | None:
    """Why the polygon (rings (k, 3) local metres, ``outward`` its Newell normal) cannot be used,
    or None: a ring off its best-fit plane by more than 5 cm + 2 % of the polygon's size, a
    self-crossing ring (in that plane), or no area."""
    points = rings[0] if len(rings) == 1 else np.concatenate(rings)
    centred = points - points.mean(axis=0)
    size = float(np.ptp(points, axis=0).max())
    length = float(np.linalg.norm(outward))
    if length > 1e-3 * size * size:
        normal = outward / length
    else:  # Newell's normal vanishes for a bow-tie: the least-squares plane's instead
        normal = np.linalg.eigh(centred.T @ centred)[1][:, 0]
    if float(np.ptp(centred @ normal)) > 0.05 + 0.02 * size:
        return "non-planar ring"
    u, v = _plane_basis(normal)
    for ring in rings:
        if ring_crossings(np.column_stack([ring @ u, ring @ v])):
            return "self-intersecting ring"
    if not np.linalg.norm(outward) > 1e-12:
        return "no area"
    return None


def _uv_rings(surface: _Surface, appearance: _Appearance, problems: _Problems):
    """(image index, [uv (k, 2) per ring]) for a textured surface, else None (a problem counted
    when its coordinates do not match its rings)."""
    gml_id = _gml_id(surface.element)
    entry = appearance.textured.get(gml_id) if gml_id else None
    if entry is None:
        return None
    index, by_ring = entry
    uvs = []
    for ring, ring_id in zip(surface.rings, surface.ring_ids):
        uv = by_ring.get(ring_id) if ring_id else None
        if uv is None and len(surface.rings) == 1 and len(by_ring) == 1:
            uv = next(iter(by_ring.values()))
        if uv is not None and len(uv) == len(ring) + 1:
            uv = uv[:-1]
        if uv is None or len(uv) != len(ring):
            problems.notes.append(
                f"texture coordinates of {_where(surface.element)} do not match its rings: exported untextured"
            )
            return None
        uvs.append(uv)
    return index, uvs


def build_parts(
    path: Path, read: _Read, appearance: _Appearance, lonlath: list, reference
) -> tuple[list[Part], list[str]]:
    """Triangulated parts (one per image, colour) of the building's surfaces (module doc)."""
    problems = read.problems
    pool = np.concatenate([ring for rings in lonlath for ring in rings])
    unique, inverse = np.unique(pool, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    local = geodesy.lonlath_to_local(unique, reference)
    uv_pool: list[np.ndarray] = []
    uv_count = 0
    textures: dict[str, Texture | None] = {}  # by image URI: one Texture per image file
    unusable: list[str] = []  # problems of images that could not be used
    groups: dict[tuple, list[np.ndarray]] = {}
    ends = np.cumsum([len(ring) for rings in lonlath for ring in rings])
    ring_ids = np.split(inverse, ends[:-1])
    start = 0
    for surface, rings in zip(read.surfaces, lonlath):
        ids, start = ring_ids[start : start + len(rings)], start + len(rings)
        points = [local[i] for i in ids]
        outward = -newell_normal(points[0]) * (-1.0 if surface.flip else 1.0)
        reason = check_polygon(points, outward)
        if reason is not None:
            problems.add(reason, _where(surface.element))
            continue
        triangles = triangulate_polygon(points, outward)
        if not len(triangles):
            problems.add("no area", _where(surface.element))
            continue
        vertex_ids = np.concatenate(ids)
        key: tuple = (1, "", surface.colour or (1.0, 1.0, 1.0, 1.0))  # textured groups first
        uv_ids = np.full(len(vertex_ids), -1)
        textured = _uv_rings(surface, appearance, problems)
        if textured is not None:
            index, uvs = textured
            uri = appearance.images[index]
            if uri not in textures:
                texture, _, problem = _load_texture(path, {"image": uri})
                textures[uri] = texture
                if problem:
                    unusable.append(problem)
            if textures[uri] is not None:
                key = (0, uri, (1.0, 1.0, 1.0, 1.0))
                stacked = np.concatenate(uvs)
                uv_pool.append(stacked)
                uv_ids = np.arange(uv_count, uv_count + len(stacked))
                uv_count += len(stacked)
        groups.setdefault(key, []).append(
            np.column_stack([vertex_ids[triangles.ravel()], uv_ids[triangles.ravel()]])
        )
    if len(unusable) > 1:
        unusable = [f"{len(unusable)} texture images unusable (first: {unusable[0]})"]
    problems.notes += unusable
    uv_all = np.concatenate(uv_pool) if uv_pool else None
    parts = []
    for key in sorted(groups):
        texture = textures.get(key[1]) if key[0] == 0 else None
        part = _part(
            local,
            uv_all,
            np.concatenate(groups[key]),
            texture,
            texture.name if texture else "untextured",
        )
        part.color = key[2]
        parts.append(part)
    parts, problem = pack_parts(parts, f"{read.id}_atlas")
    return parts, [problem] if problem else []


# --------------------------------------------------------------------------- contract


def is_citygml_file(path: Path) -> bool:
    """True for ``*.gml`` / ``*.gml.gz`` (by name) and for ``*.xml`` / ``*.xml.gz`` whose first
    64 KiB mention a CityGML namespace."""
    name = path.name.lower()
    if name.endswith(SUFFIXES[:2]):
        return True
    if not name.endswith(SUFFIXES[2:]):
        return False
    try:
        with _open(path) as handle:
            head = handle.read(_SNIFF_BYTES)
    except (OSError, EOFError):
        return False
    return b"opengis.net/citygml" in head


def _candidate_files(folder: Path) -> list[Path]:
    # Names first: a tile folder of other data (hundreds of .xdo/.jpg) costs no stat or sort.
    named = (folder / n for n in os.listdir(folder) if n.lower().endswith(SUFFIXES))
    return sorted(p for p in named if p.is_file() and is_citygml_file(p))


def detect(folder: Path) -> bool:
    """True when the folder holds CityGML files (:func:`is_citygml_file`)."""
    return bool(_candidate_files(Path(folder)))


def _syntax(error: Exception) -> str:
    line = getattr(error, "lineno", None)
    message = getattr(error, "msg", None) or str(error)
    return f"invalid XML{f' at line {line}' if line else ''}: {message}"


@dataclass
class _FileScan:
    entries: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    crs_option_used: bool = False  # see Scan.crs_option_used
    crs_conflicts: list = field(default_factory=list)  # see Scan.crs_conflicts


_NO_GEOMETRY = "no surface geometry (after dropping ground surfaces, if asked)"


def _all_lonlath(surfaces: list[_Surface]) -> np.ndarray:
    """lonlath (n, 3) of every ring point of ``surfaces`` ((0, 3) for none)."""
    rings = [r for rings in surface_lonlath(surfaces) for r in rings]
    return np.concatenate(rings) if rings else np.zeros((0, 3))


def _tile(lonlath: np.ndarray):
    return building_tile(geodesy.base_centre(lonlath)[1])


def _skipped(source: str, element, name, error: Exception) -> Skipped:
    gml_id = _gml_id(element) if element is not None else str(name)
    why = str(error) if isinstance(error, ValueError) else f"unexpected {error!r}"
    return Skipped(source=source, reason=f"building {gml_id or name}: {why}", id=gml_id)


def _foreign_surfaces(found: tuple, options: ReaderOptions) -> list[_Surface]:
    """The surfaces of elements referenced from another building (:func:`foreign_polygons`)."""
    elements = {gml_id: etree.fromstring(data) for gml_id, data in found}
    walker = _Walker(elements, {}, None, _Problems(), options)
    for element in elements.values():
        walker.walk(element, None, False, None)
    return [s for s in walker.surfaces if s is not None]


def _crs_notes(path: Path, declared: set[str], options: ReaderOptions, out: _FileScan) -> None:
    """The CityJSON reader's notes and ``crs_conflicts`` for a file declaring ``declared``: an
    override is noted; a declared CRS other than ``options.crs`` is kept, noted and listed as a
    conflict (``readers.check_crs_option`` refuses the run when no file lacks a CRS)."""
    names = sorted(declared)
    if options.override_crs and names:
        out.notes.append(
            f"{path.name}: declares {', '.join(names)}; read as {options.override_crs} "
            "(readers.override_crs / --override-crs)"
        )
        return
    wanted = geodesy.normalise_crs_text(options.crs) if options.crs else None
    other = [n for n in names if wanted is not None and _crs_text(n) != wanted]
    if other:
        out.crs_conflicts.append(f"{path}: declares {other[0]}, not {options.crs}")
        out.notes.append(
            f"{path.name}: declares {other[0]}; read in it (--crs / readers.crs is for files "
            "that declare none)"
        )


def _crs_text(srs_name: str) -> str:
    """:func:`crs_of_srs_name`, or the name itself when unknown (its buildings were skipped)."""
    try:
        return crs_of_srs_name(srs_name)
    except ValueError:
        return srs_name


def _scan_file(path: Path, options: ReaderOptions) -> _FileScan:
    out = _FileScan()
    global_app, themes = (
        global_appearance(path, None) if has_global_appearance(path) else (_Appearance(), [])
    )
    theme = themes[0] if themes else None
    pending = []  # (entry, {theme: image URIs}) until the theme is known
    declared: set[str] = set()  # the srsNames the file's geometry declares, as written
    # Shared by the entries (a file may list 10^5 buildings): the path, its one-item inputs
    # list (replaced, never appended to) and the TileIds.
    source = str(path)
    only_source = [source]
    tiles: dict = {}
    try:
        for ordinal, (_, element, file_srs) in enumerate(stream(path)):
            local_themes, _ = _local_appearance(element, None)
            for name in local_themes:
                if name not in themes:
                    themes.append(name)
            try:
                read = read_building(element, ordinal, file_srs, options, {})
                if not read.surfaces and not read.dangling:
                    raise ValueError(_NO_GEOMETRY)
                declared |= read.declared
                out.crs_option_used |= read.used_option
                lonlath = _all_lonlath(read.surfaces)
                # A building referencing another's polygons is placed once they are found.
                tile = None if read.dangling else _tile(lonlath)
                tile = tiles.setdefault(tile, tile)  # one TileId object per tile
            except Exception as error:  # one broken building never stops the file
                out.skipped.append(_skipped(source, element, ordinal, error))
                continue
            used = {_gml_id(s.element) for s in read.surfaces} - {None}
            images: dict[str, list] = {}
            for name in local_themes:
                _, own = _local_appearance(element, name)
                images[name] = _images_used(own, used)
            if theme is not None:
                images.setdefault(theme, []).extend(_images_used(global_app, used))
            entry = Entry(
                format=FORMAT,
                id=read.id,
                source=source,
                tile=tile,
                inputs=only_source,
                key=(ordinal, read.id),
            )
            pending.append((entry, images, read.dangling, lonlath if read.dangling else None))
    except etree.XMLSyntaxError as error:
        where = f"{_syntax(error)}"
        if not pending and not out.skipped:
            raise ReadError(str(path), where) from None
        out.skipped.append(
            Skipped(source=str(path), reason=f"{where}; buildings after it not read")
        )
    theme = themes[0] if themes else None
    for note in dict.fromkeys(global_app.notes):  # the CityModel's appearances: once per file
        out.notes.append(f"{path.name}: {note}")
    if len(themes) > 1:
        out.notes.append(
            f"{path.name}: appearance themes {', '.join(map(repr, themes))}; used the first, {theme!r}"
        )
    _crs_notes(path, declared, options, out)
    wanted = {gml_id for _, _, dangling, _ in pending for gml_id in dangling}
    foreign = foreign_polygons(path, wanted) if wanted else {}
    for entry, images, dangling, placed in pending:
        found = tuple((i, foreign[i]) for i in dict.fromkeys(dangling) if i in foreign)
        entry.key = (*entry.key, theme, found)
        if entry.tile is None:
            try:
                extra = _foreign_surfaces(found, options)
                if not extra and (placed is None or not len(placed)):
                    raise ValueError(_NO_GEOMETRY)
                entry.tile = _tile(np.concatenate([placed, _all_lonlath(extra)]))
            except Exception as error:
                out.skipped.append(_skipped(source, None, entry.id, error))
                continue
        for uri in dict.fromkeys(images.get(theme or "", []) if theme is not None else []):
            try:
                image = _resolve_image(path, uri)
            except OutsideInput:
                continue  # refused when the building is loaded (a problem)
            if image is not None and str(image) not in entry.inputs:
                entry.inputs = [*entry.inputs, str(image)]  # never the shared list
        out.entries.append(entry)
    if not out.entries and out.skipped:
        raise ReadError(str(path), f"no building could be read: {out.skipped[0].reason}")
    return out


def scan(folder: Path, options: ReaderOptions) -> Scan:
    """List one Entry per top-level Building of every CityGML file in ``folder`` (or of the one
    file it names). A file of which nothing can be read raises InputError when given alone and is
    listed in ``Scan.skipped`` in a folder; a building that cannot be read is listed there too."""
    folder = Path(folder)
    result = Scan(folder=str(folder), format=FORMAT)
    single = folder.is_file()
    for path in [folder] if single else _candidate_files(folder):
        try:
            found = _scan_file(path, options)
        except (ReadError, OSError, EOFError, gzip.BadGzipFile) as error:
            problem = error.problem if isinstance(error, ReadError) else f"cannot be read ({error})"
            if single:
                raise InputError(f"{path}: {problem}") from None
            result.skipped.append(Skipped(source=str(path), reason=problem))
            continue
        result.add(found)
    return result


class _Cursor:
    """A forward-only walk over one file's buildings in one process (see module doc)."""

    def __init__(self, path: Path):
        self.path, self.pid = path, os.getpid()
        self.events = stream(path)
        self.next = 0

    def building(self, ordinal: int):
        while True:
            kind, element, file_srs = next(self.events)
            self.next += 1
            if self.next - 1 == ordinal:
                return element, file_srs


_cursors: OrderedDict[tuple, _Cursor] = OrderedDict()
_appearances: OrderedDict[tuple, _Appearance] = OrderedDict()


def _remember(cache: OrderedDict, key: tuple, value) -> None:
    cache[key] = value
    while len(cache) > _CACHE_SIZE:
        cache.popitem(last=False)


def _building_element(path: Path, key: tuple, ordinal: int):
    cursor = _cursors.pop(key, None)
    if cursor is None or cursor.pid != os.getpid() or cursor.next > ordinal:
        cursor = _Cursor(path)
    element = cursor.building(ordinal)
    _remember(_cursors, key, cursor)
    return element


def load(entry: Entry, options: ReaderOptions) -> Building:
    """The building ``entry.key`` = (ordinal, id, theme, polygons of other buildings it
    references) of file ``entry.source``; raises only ReadError."""
    path = Path(entry.source)
    ordinal, building_id, theme, found = entry.key
    try:
        stat = path.stat()
        file_key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
        appearance = _Appearance()
        if theme is not None:
            if file_key + (theme,) not in _appearances:
                table = global_appearance(path, theme)[0] if has_global_appearance(path) else None
                _remember(_appearances, file_key + (theme,), table or _Appearance())
            appearance = _appearances[file_key + (theme,)]
        element, file_srs = _building_element(path, file_key, ordinal)
    except StopIteration:
        raise ReadError(
            str(path), f"has no building number {ordinal} (changed since it was listed?)"
        ) from None
    except etree.XMLSyntaxError as error:
        raise ReadError(str(path), f"{_syntax(error)} (before building {building_id})") from None
    except (OSError, EOFError) as error:
        raise ReadError(str(path), f"cannot be read ({error})") from None
    if (_gml_id(element) or f"building{ordinal}") != building_id:
        raise ReadError(
            str(path), f"building {ordinal} is not {building_id} (changed since it was listed?)"
        )
    _, local = _local_appearance(element, theme)
    appearance = local.merged(appearance)
    try:
        foreign = {gml_id: etree.fromstring(data) for gml_id, data in found}
        read = read_building(element, ordinal, file_srs, options, appearance.colours, foreign)
        if not read.surfaces:
            raise ValueError(_NO_GEOMETRY)
        lonlath = surface_lonlath(read.surfaces)
    except ValueError as error:
        raise ReadError(str(path), f"building {building_id}: {error}") from None
    reference, bounds = geodesy.base_centre(np.concatenate([r for rings in lonlath for r in rings]))
    parts, notes = build_parts(path, read, appearance, lonlath, reference)
    if not parts:
        raise ReadError(
            str(path),
            f"building {building_id}: every polygon was left out ({'; '.join(read.problems.messages())})",
        )
    return Building(
        id=building_id,
        source=str(path),
        reference=reference,
        parts=parts,
        tile=None,
        problems=read.problems.messages() + list(dict.fromkeys(local.notes)) + notes,
        lonlat_bounds=bounds,
        attributes=read.attributes,
    )
