"""CityJSON reader: ``*.city.json`` / ``*.json`` (CityJSON 1.0, 1.1, 2.0) and ``*.city.jsonl``
(CityJSONSeq) files -> one :class:`~exporter.model.Building` per CityObject of type ``Building``.

Sources: CityJSON specifications 1.1 and 2.0 (https://www.cityjson.org/specs/), CityJSONSeq
(https://www.cityjson.org/cityjsonseq/); polygon triangulation with mapbox earcut on the plane
found by Newell's method.

Data form and the choices made:

- **Geometry kept**: MultiSurface, CompositeSurface, Solid, MultiSolid, CompositeSolid of the
  Building and of its ``BuildingPart`` / ``BuildingInstallation`` children (recursively), all merged
  into the *same* building and grouped into one :class:`Part` per texture (plus one untextured
  part), so the simplifier sees one connected mesh per material. Points, lines and template
  instances are ignored (template instances noted in ``problems``).
- **LoD**: the highest LoD present on the building or any of its children is used (``"2.2"`` >
  ``"2"`` > ``"1.3"``); objects without geometry at that LoD contribute nothing (noted).
- **Semantics**: ``GroundSurface`` polygons are dropped when ``ReaderOptions.drop_ground_surfaces``
  (VWorld-style floorless models).
- **Coordinates**: vertices ``v * transform.scale + transform.translate`` are in the file's CRS:
  ``metadata.referenceSystem``; ``ReaderOptions.crs`` only for a file that declares none (a file
  declaring another CRS keeps it, noted; ``readers.check_crs_option`` refuses a run where no file
  lacks one), ``ReaderOptions.override_crs`` in place of any declared one
  (noted in each building's problems); a file with none is refused, never guessed. A building
  with a vertex that is not finite, or far from its other vertices (:mod:`exporter.plausible`),
  is skipped alone. They go to lon/lat with pyproj (heights unchanged, see
  :mod:`exporter.geodesy`) and then to the building's local East/Up/North metres on the
  6378137 m sphere around the reference point: centre of the building's lon/lat box at its
  lowest height.
- **Winding**: CityJSON rings are counter-clockwise seen from outside in the right-handed
  (East, North, Up) source frame; (East, Up, North) is a reflection of it, so every triangle is
  oriented so that ``(b - a) x (c - a)`` in the local frame opposes the ring's Newell normal
  there, i.e. points outward.
- **Textures**: the first texture theme found in the file is used (a note names the others).
  Images are resolved relative to the JSON file, then in an ``appearances/`` folder next to it
  (where cjio and the CityJSON example data keep them), and kept as their encoded bytes. CityJSON
  texture coordinates have their origin at the image's bottom-left (CityGML's convention); they
  are flipped (``v -> 1 - v``) to glTF's top-left convention. A surface whose texture is missing
  or malformed goes to the untextured part and a problem is noted.
- **Attributes**: the building CityObject's ``attributes``, every member, through
  :func:`exporter.attributes.clean_attributes` (nested objects flattened with dotted keys, lists
  as JSON text; a key repeated in the JSON text keeps its last value, as the JSON parser does).
- **Ids, tiles**: ``Entry.key`` is the CityObject id; ``Entry.tile`` the level-15 tile holding the
  centre of the lon/lat box.

Files are parsed once per process (cache keyed by path, mtime, size and CRS), so scanning and
loading many buildings of one file do not re-parse it.
"""

from __future__ import annotations

import json
import os
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mapbox_earcut
import numpy as np

from .. import geodesy
from ..attributes import clean_attributes
from ..config import ReaderOptions
from ..errors import InputError, ReadError
from ..mesh.geometry import cross3
from ..model import Building, Part, Skipped, Texture
from ..plausible import vertex_problem
from ..tiles import building_tile
from . import Entry, Scan
from .confine import OutsideInput, confined
from .crs import choose_crs
from .images import TextureFileError, read_texture_file

FORMAT = "cityjson"
BUILDING_TYPES = ("Building",)
CHILD_TYPES = ("BuildingPart", "BuildingInstallation")
# Nesting depth of the surface level in ``boundaries`` per geometry type.
SURFACE_DEPTH = {
    "MultiSurface": 1,
    "CompositeSurface": 1,
    "Solid": 2,
    "MultiSolid": 3,
    "CompositeSolid": 3,
}
GROUND = "GroundSurface"
CRS_HINT = "pass --crs EPSG:<code> (e.g. --crs EPSG:7415) or set readers.crs in the config"
OVERRIDE_HINT = "replace it with --override-crs EPSG:<code> or readers.override_crs"
_CACHE_SIZE = 4
_SNIFF_BYTES = 65536


# --------------------------------------------------------------------------- parsed documents


@dataclass
class _Chunk:
    """One vertex pool: the whole file for CityJSON, one feature for CityJSONSeq.

    ``xyz`` (n, 3) float64 source CRS coordinates (metres); ``lonlath`` (n, 3) lon/lat degrees,
    height metres; ``uv`` (k, 2) float64 texture coordinates as stored (bottom-left origin) or None;
    ``textures`` the appearance's texture objects.
    """

    xyz: np.ndarray
    lonlath: np.ndarray
    uv: np.ndarray | None
    textures: list


@dataclass
class _Document:
    path: Path
    crs: str
    chunks: list[_Chunk]
    objects: dict  # CityObject id -> (chunk index, CityObject dict)
    themes: list[str] = field(default_factory=list)
    declared_crs: str | None = None  # metadata.referenceSystem as written (None when absent)
    children: dict = field(
        default_factory=dict
    )  # id -> ids of its BuildingPart/Installation children
    broken: list[str] = field(default_factory=list)  # CityJSONSeq lines not read, and why

    @property
    def theme(self) -> str | None:
        return self.themes[0] if self.themes else None


_documents: OrderedDict[tuple, _Document] = OrderedDict()


def _fail(path: Path, problem: str) -> ReadError:
    return ReadError(str(path), problem)


class CrsError(ReadError):
    """A file's CRS is missing, unknown or contradicts the options: the whole run is refused."""


def _read_json_lines(path: Path) -> list[tuple[int, Any]]:
    """(line number, record) of a CityJSON file (one record, line 1) or of each non-empty line of
    a ``.city.jsonl``; there a line that is not valid JSON gives (line number, ReadError) so that
    it costs its feature only (the header's is raised)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise _fail(path, f"cannot be read ({error.strerror or error})") from None
    except UnicodeDecodeError:
        raise _fail(path, "is not UTF-8 text") from None
    if not path.name.endswith(".jsonl"):
        try:
            return [(1, json.loads(text))]
        except json.JSONDecodeError as error:
            raise _fail(
                path, f"is not valid JSON (line {error.lineno}, column {error.colno}: {error.msg})"
            ) from None
    records: list[tuple[int, Any]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            records.append((number, json.loads(line)))
        except json.JSONDecodeError as error:
            problem = f"line {number} is not valid JSON (column {error.colno}: {error.msg})"
            if not records:  # the header: without it no feature can be read
                raise _fail(path, problem) from None
            records.append((number, _fail(path, problem)))
    return records


def _check_version(path: Path, header: dict) -> None:
    if not isinstance(header, dict) or header.get("type") != "CityJSON":
        raise _fail(path, 'is not a CityJSON file (no "type": "CityJSON")')
    version = str(header.get("version", ""))
    if version.split(".")[0] not in ("1", "2"):
        raise _fail(path, f"CityJSON version {version!r} is not supported; allowed: 1.0, 1.1, 2.0")


def _crs_of(path: Path, header: dict, options: ReaderOptions) -> str:
    """The CRS to read the file in (module doc); CrsError naming the file when there is none or
    it is unknown. A declared one always wins over ``options.crs`` (see ``Scan.crs_conflicts``)."""
    declared = (header.get("metadata") or {}).get("referenceSystem")
    chosen = choose_crs(options.override_crs, declared, options.crs)
    if chosen is None:
        raise CrsError(
            str(path),
            f"declares no coordinate reference system (metadata.referenceSystem); {CRS_HINT}",
        )
    crs, source = chosen
    hint = {
        "override": "check --override-crs / readers.override_crs",
        "declared": OVERRIDE_HINT,
        "option": CRS_HINT,
    }[source]
    try:
        geodesy.check_crs(crs)
    except ValueError as error:
        raise CrsError(str(path), f"{error}; {hint}") from None
    return crs


def _vertices(path: Path, raw: Any, transform: dict | None) -> np.ndarray:
    """(n, 3) float64 source-CRS coordinates from CityJSON ``vertices`` and ``transform``."""
    try:
        xyz = np.asarray(raw if raw else np.zeros((0, 3)), dtype=np.float64).reshape(-1, 3)
        if transform:
            xyz = xyz * np.asarray(transform["scale"], dtype=np.float64) + np.asarray(
                transform["translate"], dtype=np.float64
            )
    except (ValueError, TypeError, KeyError) as error:
        raise _fail(path, f"malformed vertices or transform ({error})") from None
    return xyz


def _chunk(path: Path, body: dict, transform: dict | None, crs: str, appearance: dict) -> _Chunk:
    xyz = _vertices(path, body.get("vertices"), transform)
    try:
        # Rows PROJ cannot convert (or NaN in the file) stay non-finite: they cost their
        # buildings only (_plan); a file none of whose vertices converts has the wrong CRS.
        lonlath = geodesy.to_lonlath(xyz, crs, strict=False) if len(xyz) else np.zeros((0, 3))
        if len(xyz) and not np.isfinite(lonlath).all(axis=1).any():
            raise ValueError(f"coordinates outside the area {crs!r} can transform")
    except ValueError as error:
        raise CrsError(
            str(path), f"coordinates cannot be converted to lon/lat: {error}; {CRS_HINT}"
        ) from None
    appearance = body.get("appearance") or appearance or {}
    uv = appearance.get("vertices-texture")
    try:
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2) if uv else None
    except (ValueError, TypeError):
        raise _fail(path, "malformed appearance.vertices-texture (expected [u, v] pairs)") from None
    return _Chunk(xyz, lonlath, uv, list(appearance.get("textures") or []))


def _parse(path: Path, options: ReaderOptions) -> _Document:
    records = _read_json_lines(path)
    if not records:
        raise _fail(path, "is empty")
    header = records[0][1]
    _check_version(path, header)
    crs = _crs_of(path, header, options)
    transform = header.get("transform")
    jsonl = path.name.endswith(".jsonl")
    bodies = records[1:] if jsonl else records
    document = _Document(
        path, crs, [], {}, declared_crs=(header.get("metadata") or {}).get("referenceSystem")
    )
    for number, body in bodies:
        try:
            if isinstance(body, ReadError):
                raise body
            if not isinstance(body, dict) or not isinstance(body.get("CityObjects"), dict):
                raise _fail(
                    path,
                    f"line {number} has no CityObjects mapping"
                    if jsonl
                    else "has no CityObjects mapping",
                )
            chunk = _chunk(path, body, transform, crs, header.get("appearance") or {})
        except CrsError:
            raise
        except ReadError as error:
            if not jsonl:
                raise
            # One broken feature of a CityJSONSeq costs that feature only (Scan.skipped).
            problem = (
                error.problem
                if error.problem.startswith("line ")
                else f"line {number}: {error.problem}"
            )
            document.broken.append(problem)
            continue
        document.chunks.append(chunk)
        for object_id, city_object in body["CityObjects"].items():
            document.objects[str(object_id)] = (len(document.chunks) - 1, city_object)
            for geometry in city_object.get("geometry") or []:
                for theme in (geometry.get("texture") or {}) if isinstance(geometry, dict) else {}:
                    if theme not in document.themes:
                        document.themes.append(theme)
    # Children are linked by "children" on the parent and/or "parents" on the child; use both.
    for object_id, (_, city_object) in document.objects.items():
        if city_object.get("type") not in CHILD_TYPES:
            continue
        for parent in city_object.get("parents") or []:
            document.children.setdefault(str(parent), []).append(object_id)
    for object_id, (_, city_object) in document.objects.items():
        for child in city_object.get("children") or []:
            child = str(child)
            if child in document.objects and document.objects[child][1].get("type") in CHILD_TYPES:
                if child not in document.children.setdefault(object_id, []):
                    document.children[object_id].append(child)
    return document


def _document(path: Path, options: ReaderOptions) -> _Document:
    """The parsed file, from the per-process cache when the file has not changed."""
    try:
        stat = path.stat()
    except OSError as error:
        raise _fail(path, f"cannot be read ({error.strerror or error})") from None
    key = (str(path.resolve()), stat.st_mtime_ns, stat.st_size, options.crs, options.override_crs)
    if key in _documents:
        _documents.move_to_end(key)
        return _documents[key]
    document = _parse(path, options)
    _documents[key] = document
    while len(_documents) > _CACHE_SIZE:
        _documents.popitem(last=False)
    return document


# --------------------------------------------------------------------------- building structure


def _lod_key(lod: Any) -> tuple:
    """``"2.2"`` -> (2, 2), ``2`` -> (2,), missing -> (-1,); compares LoDs numerically."""
    try:
        return tuple(int(p) for p in str(lod).split("."))
    except ValueError:
        return (-1,)


def _members(document: _Document, building_id: str) -> list[str]:
    """The building and its BuildingPart/BuildingInstallation descendants, building first."""
    seen, order, stack = set(), [], [building_id]
    while stack:
        object_id = stack.pop(0)
        if object_id in seen or object_id not in document.objects:
            continue
        seen.add(object_id)
        order.append(object_id)
        stack.extend(document.children.get(object_id, ()))
    return order


def _selected_geometries(
    document: _Document, building_id: str
) -> tuple[list[tuple[int, dict]], list[str]]:
    """(chunk index, geometry) pairs at the building's highest LoD, and notes about what was left out."""
    candidates, notes = [], []
    for object_id in _members(document, building_id):
        chunk, city_object = document.objects[object_id]
        for geometry in city_object.get("geometry") or []:
            if not isinstance(geometry, dict):
                continue
            if geometry.get("type") == "GeometryInstance":
                notes.append(
                    f"{object_id}: template geometry (GeometryInstance) is not supported and was left out"
                )
            elif geometry.get("type") in SURFACE_DEPTH:
                candidates.append((object_id, chunk, geometry))
    if not candidates:
        return [], notes
    best = max(_lod_key(g.get("lod")) for _, _, g in candidates)
    chosen = [(chunk, g) for _, chunk, g in candidates if _lod_key(g.get("lod")) == best]
    lods = sorted({str(g.get("lod")) for _, _, g in candidates}, key=_lod_key)
    if len(lods) > 1:
        notes.append(f"LoDs {', '.join(lods)} present; used the highest, {lods[-1]}")
    without = sorted(
        {oid for oid, _, _ in candidates}
        - {oid for oid, _, g in candidates if _lod_key(g.get("lod")) == best}
    )
    if without:
        notes.append(f"{', '.join(without)}: no geometry at LoD {lods[-1]}, left out")
    return chosen, notes


def _surfaces(
    boundaries: Any, semantics: Any, texture: Any, depth: int
) -> Iterator[tuple[list, Any, Any]]:
    """Walk ``boundaries`` down to surfaces (lists of rings), in lockstep with the semantics and
    texture ``values`` arrays (either may be None at any level). Yields (rings, semantic index or
    None, per-ring texture values or None)."""
    if depth == 0:
        yield boundaries, semantics, texture
        return
    for i, child in enumerate(boundaries):
        sem = semantics[i] if isinstance(semantics, list) and i < len(semantics) else None
        tex = texture[i] if isinstance(texture, list) and i < len(texture) else None
        yield from _surfaces(child, sem, tex, depth - 1)


@dataclass
class _Polygon:
    """One surface to triangulate: ``rings`` lists of source vertex indices (outer first),
    ``uv_rings`` matching lists of indices into the chunk's texture vertices (or None),
    ``texture`` the appearance texture index (or None)."""

    chunk: int
    rings: list
    uv_rings: list | None
    texture: int | None


def _polygons(
    document: _Document, geometries: list[tuple[int, dict]], options: ReaderOptions
) -> tuple[list[_Polygon], list[str]]:
    polygons, notes, dropped, bad_texture, malformed = [], [], 0, 0, 0
    theme = document.theme
    for chunk, geometry in geometries:
        depth = SURFACE_DEPTH[geometry["type"]]
        semantic = geometry.get("semantics") or {}
        surface_types = [
            s.get("type") if isinstance(s, dict) else None for s in semantic.get("surfaces") or []
        ]
        tex_values = (
            ((geometry.get("texture") or {}).get(theme) or {}).get("values") if theme else None
        )
        for rings, sem, tex in _surfaces(
            geometry.get("boundaries") or [], semantic.get("values"), tex_values, depth
        ):
            if (
                options.drop_ground_surfaces
                and isinstance(sem, int)
                and 0 <= sem < len(surface_types)
                and surface_types[sem] == GROUND
            ):
                dropped += 1
                continue
            if (
                not isinstance(rings, list)
                or not rings
                or not all(isinstance(r, list) and len(r) >= 3 for r in rings)
            ):
                malformed += 1
                continue
            texture, uv_rings = None, None
            if (
                isinstance(tex, list)
                and tex
                and isinstance(tex[0], list)
                and tex[0]
                and tex[0][0] is not None
            ):
                ok = len(tex) == len(rings) and all(
                    isinstance(t, list)
                    and len(t) == len(r) + 1
                    and all(type(i) is int for i in t)  # JSON true is no index (bool is an int)
                    for t, r in zip(tex, rings)
                )
                if ok and all(t[0] == tex[0][0] for t in tex):
                    texture, uv_rings = int(tex[0][0]), [t[1:] for t in tex]
                else:
                    bad_texture += 1
            polygons.append(_Polygon(chunk, rings, uv_rings, texture))
    if dropped:
        notes.append(f"dropped {dropped} GroundSurface polygon(s)")
    if bad_texture:
        notes.append(f"{bad_texture} polygon(s) with malformed texture values exported untextured")
    if malformed:
        notes.append(
            f"{malformed} malformed polygon(s) (not a list of rings of 3 or more vertices) left out"
        )
    return polygons, notes


# --------------------------------------------------------------------------- triangulation


def newell_normal(points: np.ndarray) -> np.ndarray:
    """Area-weighted normal (3,) of a closed ring of points (k, 3) by Newell's method (unnormalised,
    length = twice the area; direction by the right-hand rule of the ring order)."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    # np.cross is slow on many tiny arrays; write the summed cross product out.
    x1, y1, z1 = np.append(x[1:], x[0]), np.append(y[1:], y[0]), np.append(z[1:], z[0])
    return np.array([(y * z1 - z * y1).sum(), (z * x1 - x * z1).sum(), (x * y1 - y * x1).sum()])


def triangulate_polygon(rings: list[np.ndarray], outward: np.ndarray) -> np.ndarray:
    """Triangles (m, 3) indexing the concatenated ``rings`` (each (k, 3) metres, outer first, holes
    after), every one oriented so ``(b - a) x (c - a)`` points along ``outward`` (3,).

    Earcut runs on the projection onto the plane perpendicular to ``outward``, in a 2D basis
    (u, v) with ``u x v = outward``; orientation is decided there (by each triangle's signed 2D
    area), which stays right for slightly non-planar real-world polygons.
    """
    points = np.concatenate(rings)
    normal = outward / np.linalg.norm(outward)
    u = cross3(normal, np.eye(3)[int(np.argmin(np.abs(normal)))])
    u /= np.linalg.norm(u)
    v = cross3(normal, u)
    flat = np.column_stack([(points - points[0]) @ u, (points - points[0]) @ v])
    if len(rings) == 1 and len(points) == 3:
        triangles = np.array([[0, 1, 2]], dtype=np.int64)
    else:
        ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
        triangles = np.asarray(
            mapbox_earcut.triangulate_float64(flat, ends), dtype=np.int64
        ).reshape(-1, 3)
    if len(triangles):
        a, b, c = flat[triangles[:, 0]], flat[triangles[:, 1]], flat[triangles[:, 2]]
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        triangles[area < 0] = triangles[area < 0][:, ::-1]
    return triangles


# --------------------------------------------------------------------------- parts


def _resolve_image(json_path: Path, name: str) -> Path | None:
    """The image file of a texture ``image`` entry: as given relative to the JSON file, else in an
    ``appearances/`` folder next to it (cjio's and the example data's layout). Raises
    :class:`~exporter.readers.confine.OutsideInput` when ``name`` leads outside the JSON file's
    folder (module :mod:`~exporter.readers.confine`)."""
    base = json_path.parent
    given = confined(name, base)
    for candidate in (given, base / "appearances" / Path(name).name, base / Path(name).name):
        if candidate.is_file():
            return confined(candidate.relative_to(base), base)
    return None


def _load_texture(json_path: Path, texture: Any) -> tuple[Texture | None, str | None, str | None]:
    """(Texture, its file, problem): the encoded bytes of appearance texture object ``texture``."""
    name = texture.get("image") if isinstance(texture, dict) else None
    if not isinstance(name, str):
        return None, None, "texture without an image entry: exported untextured"
    try:
        image_path = _resolve_image(json_path, name)
    except OutsideInput as refused:
        return None, None, f"texture refused: {refused}: exported untextured"
    if image_path is None:
        return None, None, f"texture {name} missing: exported untextured"
    try:
        return read_texture_file(image_path, Path(name).name), str(image_path), None
    except TextureFileError as problem:
        return None, str(image_path), f"texture {name} {problem}: exported untextured"


def _part(
    local: np.ndarray,
    uv: np.ndarray | None,
    corners: np.ndarray,
    texture: Texture | None,
    name: str,
) -> Part:
    """A Part from triangle corners (m*3, 2) = (vertex index, texture-vertex index or -1); corners
    sharing both indices become one vertex."""
    unique, inverse = np.unique(corners, axis=0, return_inverse=True)
    uvs = None
    if texture is not None and uv is not None:
        uvs = uv[unique[:, 1]].copy()
        uvs[:, 1] = 1.0 - uvs[:, 1]  # CityJSON bottom-left origin -> glTF top-left
    return Part(
        positions=local[unique[:, 0]],
        triangles=inverse.reshape(-1, 3),
        uvs=uvs,
        texture=texture,
        name=name,
    )


# --------------------------------------------------------------------------- contract


def is_cityjson_file(path: Path) -> bool:
    """True for ``*.city.json`` / ``*.city.jsonl`` (by name) and for a ``*.json`` / ``*.jsonl``
    whose first 64 KiB mention ``CityJSON`` or ``CityObjects``."""
    name = path.name.lower()
    if name.endswith((".city.json", ".city.jsonl")):
        return True
    if not name.endswith((".json", ".jsonl")) or name == "buildings.json":
        return False
    try:
        with path.open("rb") as handle:
            head = handle.read(_SNIFF_BYTES)
    except OSError:
        return False
    return b'"CityJSON"' in head or b'"CityObjects"' in head


def _candidate_files(folder: Path) -> list[Path]:
    # Names first: a tile folder of other data (hundreds of .xdo/.jpg) costs no stat or sort.
    named = (folder / n for n in os.listdir(folder) if n.lower().endswith((".json", ".jsonl")))
    return sorted(p for p in named if p.is_file() and is_cityjson_file(p))


def detect(folder: Path) -> bool:
    """True when the folder holds CityJSON files (:func:`is_cityjson_file`)."""
    return bool(_candidate_files(Path(folder)))


def _building_ids(document: _Document) -> list[str]:
    return [oid for oid, (_, obj) in document.objects.items() if obj.get("type") in BUILDING_TYPES]


def _used_vertices(document: _Document, polygons: list[_Polygon]) -> np.ndarray:
    """lonlath (n, 3) of every vertex the polygons use."""
    per_chunk: dict[int, list] = {}
    for polygon in polygons:
        per_chunk.setdefault(polygon.chunk, []).extend(i for ring in polygon.rings for i in ring)
    return np.concatenate(
        [
            document.chunks[c].lonlath[np.unique(np.asarray(ids, dtype=np.int64))]
            for c, ids in per_chunk.items()
        ]
    )


def _plan(
    document: _Document, building_id: str, options: ReaderOptions
) -> tuple[list[_Polygon], list[str]]:
    geometries, notes = _selected_geometries(document, building_id)
    polygons, more = _polygons(document, geometries, options)
    for polygon in polygons:
        count = len(document.chunks[polygon.chunk].xyz)
        # type() and not isinstance(): JSON true/false are Python bools, which are ints (1, 0).
        wrong = [i for ring in polygon.rings for i in ring if type(i) is not int]
        if wrong:
            raise _fail(
                document.path,
                f"building {building_id}: boundary index {json.dumps(wrong[0])[:40]} is not a "
                "vertex index (an integer)",
            )
        if any(not 0 <= i < count for ring in polygon.rings for i in ring):
            raise _fail(
                document.path,
                f"building {building_id}: vertex index out of range (file has {count} vertices)",
            )
    if polygons:
        used = _used_vertices(document, polygons)
        problem = vertex_problem(geodesy.sphere_ecef(used), options.max_vertex_distance_m)
        if problem:
            raise _fail(document.path, f"building {building_id}: {problem}")
    return polygons, notes + more


def scan(folder: Path, options: ReaderOptions) -> Scan:
    """List one Entry per Building of every CityJSON file in ``folder`` (each file parsed once),
    or of the one file ``folder`` names.

    A file without a CRS (and no ``options.crs``) raises InputError saying how to give one, as
    does a file given alone that cannot be read; other unreadable files are listed in
    ``Scan.skipped``.
    """
    folder = Path(folder)
    result = Scan(folder=str(folder), format=FORMAT)
    single = folder.is_file()
    for path in [folder] if single else _candidate_files(folder):
        try:
            document = _document(path, options)
        except ReadError as error:
            if single or isinstance(error, CrsError):
                raise InputError(str(error)) from None

            result.skipped.append(Skipped(source=str(path), reason=error.problem))
            continue
        declared = document.declared_crs
        if not declared:
            result.crs_option_used = True
        elif geodesy.normalise_crs_text(declared) != geodesy.normalise_crs_text(document.crs):
            result.notes.append(
                f"{path.name}: declares {declared}; read as {document.crs} (readers.override_crs / --override-crs)"
            )
        elif options.crs and geodesy.normalise_crs_text(declared) != geodesy.normalise_crs_text(
            options.crs
        ):
            result.crs_conflicts.append(f"{path}: declares {declared}, not {options.crs}")
            result.notes.append(
                f"{path.name}: declares {declared}; read in it (--crs / readers.crs is for files that declare none)"
            )
        result.skipped += [Skipped(source=str(path), reason=why) for why in document.broken]
        if len(document.themes) > 1:
            result.notes.append(
                f"{path.name}: texture themes {', '.join(document.themes)}; used the first, {document.theme}"
            )
        for building_id in _building_ids(document):
            try:
                polygons, _ = _plan(document, building_id, options)
            except ReadError as error:
                result.skipped.append(
                    Skipped(source=str(path), reason=error.problem, id=building_id)
                )
                continue
            if not polygons:
                result.skipped.append(
                    Skipped(
                        source=str(path),
                        reason="no surface geometry (after dropping ground surfaces)",
                        id=building_id,
                    )
                )
                continue
            reference, bounds = geodesy.base_centre(_used_vertices(document, polygons))
            images = {(p.chunk, p.texture) for p in polygons if p.texture is not None}
            inputs = [str(path)]
            for chunk, index in sorted(images):
                textures = document.chunks[chunk].textures
                name = (
                    textures[index].get("image")
                    if 0 <= index < len(textures) and isinstance(textures[index], dict)
                    else None
                )
                try:
                    found = _resolve_image(path, name) if isinstance(name, str) else None
                except OutsideInput:
                    found = None  # refused when the building is loaded (a problem)
                if found is not None and str(found) not in inputs:
                    inputs.append(str(found))
            try:
                tile = building_tile(bounds)
            except ValueError as error:  # e.g. a wrong CRS put the building off the globe
                result.skipped.append(
                    Skipped(
                        source=str(path),
                        reason=f"building {building_id}: {error} (is the CRS right?)",
                        id=building_id,
                    )
                )
                continue
            result.entries.append(
                Entry(
                    format=FORMAT,
                    id=building_id,
                    source=str(path),
                    tile=tile,
                    inputs=inputs,
                    key=building_id,
                )
            )
    return result


def load(entry: Entry, options: ReaderOptions) -> Building:
    """The building ``entry.key`` of file ``entry.source``; raises only ReadError."""
    path = Path(entry.source)
    document = _document(path, options)
    building_id = str(entry.key)
    if (
        building_id not in document.objects
        or document.objects[building_id][1].get("type") not in BUILDING_TYPES
    ):
        raise _fail(path, f"has no Building with id {building_id!r}")
    polygons, problems = _plan(document, building_id, options)
    if not polygons:
        raise _fail(
            path, f"building {building_id}: no surface geometry (after dropping ground surfaces)"
        )
    reference, bounds = geodesy.base_centre(_used_vertices(document, polygons))
    declared = document.declared_crs
    if declared and geodesy.normalise_crs_text(declared) != geodesy.normalise_crs_text(
        document.crs
    ):
        problems.append(
            f"read in {document.crs} in place of the declared {declared} (override_crs)"
        )
    if document.theme and len(document.themes) > 1:
        problems.append(
            f"texture themes {', '.join(document.themes)}; used the first, {document.theme}"
        )

    local = {
        c: geodesy.lonlath_to_local(document.chunks[c].lonlath, reference)
        for c in {p.chunk for p in polygons}
    }
    textures: dict[tuple, Texture | None] = {}
    groups: dict[tuple, list[np.ndarray]] = {}
    degenerate = 0
    for polygon in polygons:
        chunk = document.chunks[polygon.chunk]
        key: tuple = (polygon.chunk, -1)
        if polygon.texture is not None and chunk.uv is not None:
            key = (polygon.chunk, polygon.texture)
            if key not in textures:
                if not 0 <= polygon.texture < len(chunk.textures):
                    textures[key] = None
                    problems.append(
                        f"texture index {polygon.texture} not in appearance.textures: exported untextured"
                    )
                else:
                    texture, _, problem = _load_texture(path, chunk.textures[polygon.texture])
                    textures[key] = texture
                    if problem:
                        problems.append(problem)
            uv_ok = all(0 <= i < len(chunk.uv) for r in polygon.uv_rings or [] for i in r)
            if textures[key] is None or not uv_ok:
                key = (polygon.chunk, -1)
        vertex_ids = np.concatenate([np.asarray(r, dtype=np.int64) for r in polygon.rings])
        points = [local[polygon.chunk][np.asarray(r, dtype=np.int64)] for r in polygon.rings]
        # Rings are CCW from outside in (E, N, U); in (E, U, N) their Newell normal points inward.
        outward = -newell_normal(points[0])
        if not np.linalg.norm(outward) > 1e-12:
            degenerate += 1
            continue
        triangles = triangulate_polygon(points, outward)
        if not len(triangles):
            degenerate += 1
            continue
        uv_ids = (
            np.concatenate([np.asarray(r, dtype=np.int64) for r in polygon.uv_rings or []])
            if key[1] >= 0
            else np.full(len(vertex_ids), -1)
        )
        groups.setdefault(key, []).append(
            np.column_stack([vertex_ids[triangles.ravel()], uv_ids[triangles.ravel()]])
        )
    if degenerate:
        problems.append(f"{degenerate} degenerate polygon(s) (no area) left out")
    parts = []
    for key in sorted(groups, key=lambda k: (k[0], k[1] < 0, k[1])):
        texture = textures.get(key) if key[1] >= 0 else None
        name = texture.name if texture is not None else "untextured"
        parts.append(
            _part(
                local[key[0]],
                document.chunks[key[0]].uv,
                np.concatenate(groups[key]),
                texture,
                name,
            )
        )
    if not parts:
        raise _fail(path, f"building {building_id}: every polygon is degenerate")
    # CityJSON has no tile of its own: tile stays None and the pipeline files the building under the
    # tile holding the centre of lonlat_bounds (the same one scan put in Entry.tile).
    attributes, notes = source_attributes(document.objects[building_id][1].get("attributes"))
    return Building(
        id=building_id,
        source=str(path),
        reference=reference,
        parts=parts,
        tile=None,
        problems=problems + notes,
        lonlat_bounds=bounds,
        attributes=attributes,
    )


def source_attributes(raw: Any) -> tuple[dict, list[str]]:
    """A CityObject's ``attributes`` member after :func:`exporter.attributes.clean_attributes`
    (every member kept, nested objects flattened with dotted keys); a non-object is noted."""
    if raw is None:
        return {}, []
    if not isinstance(raw, dict):
        return {}, [f"attributes is a {type(raw).__name__}, not an object: left out"]
    return clean_attributes(raw.items())
