"""3D Tiles 1.1 metadata of the buildings: the ``building`` class, each building's values, and the
tileset's ``schema`` + each building content's ``metadata`` (the building's entity on every
level of its chain).

Sources: 3D Tiles 1.1 specification, "Metadata" (schema, classes, property types, groups;
https://docs.ogc.org/cs/22-025r4/22-025r4.html#toc31) and the 3D Metadata Specification
(https://github.com/CesiumGS/3d-tiles/tree/main/specification/Metadata).

Properties of a building: ``id`` (the manifest's building id), ``source_id`` (the source's own id:
CityGML ``gml_id``, VWorld ``key``, else the id), ``source_file`` (the file name it was read
from), ``height`` (metres: LOD0's extent along glTF +Y, up) and every attribute of the manifest
(docs/input.md "Attributes") under a property id: the attribute's name when it is a valid
identifier (``[A-Za-z_][A-Za-z0-9_]*``) other than those four, else the name with every other
character as ``_`` and 8 hex digits of its SHA-1 appended (``address.city`` ->
``address_city_6f1e…``); the property's ``name`` keeps the original. Types are decided from the
values present: all booleans -> BOOLEAN, all integers -> INT32 (INT64 past its range), numbers
-> FLOAT64, anything mixed -> STRING (values as their JSON text).
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable

CLASS = "building"
SCHEMA_ID = "vworld_lod"
FIXED = {
    "id": ("STRING", "the building's id in the export (its manifest record's id)"),
    "source_id": ("STRING", "the source's own id (CityGML gml:id, VWorld key, else the id)"),
    "source_file": ("STRING", "name of the file the building was read from"),
    "height": ("FLOAT64", "metres: the building's LOD0 extent along up"),
}
INT32 = (-(2**31), 2**31 - 1)
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def property_id(name: str) -> str:
    """The 3D Tiles property id of attribute ``name`` (module doc)."""
    if _IDENTIFIER.fullmatch(name) and name not in FIXED:
        return name
    digest = hashlib.sha1(name.encode("utf-8")).hexdigest()[:8]
    stem = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return f"{stem if stem[:1].isalpha() or stem[:1] == '_' else '_' + stem}_{digest}"


def building_values(
    building_id: str, source: str, height: float, attributes: dict
) -> dict[str, tuple[str, object]]:
    """property id -> (name, value) of one building (``height`` metres)."""
    values: dict[str, tuple[str, object]] = {
        "id": ("id", building_id),
        "source_id": (
            "source_id",
            str(attributes.get("gml_id") or attributes.get("key") or building_id),
        ),
        "source_file": ("source_file", source.replace("\\", "/").rsplit("/", 1)[-1]),
        "height": ("height", float(height)),
    }
    for name, value in attributes.items():
        values.setdefault(property_id(str(name)), (str(name), value))
    return values


def value_kinds(values: Iterable[object]) -> dict:
    """What decides a property's type, of ``values``: ``kinds`` (sorted: ``bool``, ``float``,
    ``int``, ``other``), and the smallest and largest integer (``low``, ``high``; None without
    integers). Kinds of two sets of values merge (:func:`merge_kinds`) into the kinds of both, so
    a type can be decided over tiles from small per-tile summaries."""
    values = values if isinstance(values, list) else list(values)
    # Classified by type, not value by value: a parent proxy's table is tens of thousands of
    # values, of a few types.
    kind_of_type = {t: _kind_of_type(t) for t in {type(v) for v in values}}
    kinds = set(kind_of_type.values())
    low = high = None
    if "int" in kinds:
        integer = {t for t, kind in kind_of_type.items() if kind == "int"}
        whole: list[int] = [v for v in values if type(v) in integer]  # type: ignore[misc]
        low, high = min(whole), max(whole)
    return {"kinds": sorted(kinds), "low": low, "high": high}


def _kind_of_type(kind: type) -> str:
    """:func:`value_kinds`' kind of values of type ``kind`` (a bool is no int here)."""
    if issubclass(kind, bool):
        return "bool"
    if issubclass(kind, int):
        return "int"
    return "float" if issubclass(kind, float) else "other"


def merge_kinds(a: dict, b: dict) -> dict:
    """:func:`value_kinds` of the values of ``a`` and ``b`` together."""
    lows = [v for v in (a["low"], b["low"]) if v is not None]
    highs = [v for v in (a["high"], b["high"]) if v is not None]
    return {
        "kinds": sorted(set(a["kinds"]) | set(b["kinds"])),
        "low": min(lows) if lows else None,
        "high": max(highs) if highs else None,
    }


def kinds_type(found: dict) -> str:
    """BOOLEAN, INT32, INT64, FLOAT64 or STRING of :func:`value_kinds` (module doc)."""
    kinds = set(found["kinds"])
    if kinds == {"bool"}:
        return "BOOLEAN"
    if kinds == {"int"}:
        return "INT32" if INT32[0] <= found["low"] and found["high"] <= INT32[1] else "INT64"
    if kinds and kinds <= {"int", "float"}:
        return "FLOAT64"
    return "STRING"


def as_type(value: object, kind: str) -> object:
    """``value`` as a JSON value of 3D Tiles type ``kind``."""
    if kind == "STRING":
        return value if isinstance(value, str) else json.dumps(value)
    if kind == "FLOAT64":
        return float(value)  # type: ignore[arg-type]
    return value


def property_kinds(records: list[dict[str, tuple[str, object]]]) -> dict[str, dict]:
    """Per property id of ``records`` (:func:`building_values`): its ``name`` and the
    :func:`value_kinds` of its values (what :func:`properties_of` types it from; JSON)."""
    names: dict[str, str] = {}
    for record in records:  # ids in first-seen order, each with its first name
        if not names.keys() >= record.keys():
            for pid, (name, _) in record.items():
                names.setdefault(pid, name)
    return {
        pid: {"name": names[pid], **value_kinds([r[pid][1] for r in records if pid in r])}
        for pid in names
    }


def merge_property_kinds(found: list[dict[str, dict]]) -> dict[str, dict]:
    """:func:`property_kinds` of several sets of buildings (each a :func:`property_kinds`, in
    order: a property keeps the first name seen) as of all of them together."""
    out: dict[str, dict] = {}
    for kinds in found:
        for pid, item in kinds.items():
            if pid in out:
                out[pid] = {"name": out[pid]["name"], **merge_kinds(out[pid], item)}
            else:
                out[pid] = item
    return out


def properties_of(kinds: dict[str, dict]) -> dict[str, dict]:
    """The ``building`` class's ``properties`` for :func:`property_kinds` ``kinds``, sorted by
    id (the fixed four first), each typed from its values' kinds."""
    properties = {}
    for pid in [*FIXED, *sorted(set(kinds) - set(FIXED))]:
        if pid not in kinds:
            continue
        kind = FIXED[pid][0] if pid in FIXED else kinds_type(kinds[pid])
        item: dict = {"name": kinds[pid]["name"]}
        if pid in FIXED:
            item["description"] = FIXED[pid][1]
        if kind in ("STRING", "BOOLEAN"):
            item["type"] = kind
        else:
            item.update({"type": "SCALAR", "componentType": kind})
        if pid in FIXED:
            item["required"] = True
        properties[pid] = item
    return properties


def class_properties(records: list[dict[str, tuple[str, object]]]) -> dict[str, dict]:
    """The ``building`` class's ``properties`` for ``records`` (:func:`building_values`), sorted
    by id (the fixed four first), each typed from its values."""
    return properties_of(property_kinds(records))


def fits(own: dict[str, dict], union: dict[str, dict]) -> bool:
    """True when every property of ``own`` (a class's ``properties``) is defined the same in
    ``union``: a tileset typed ``own`` reads the same against ``union``'s class (its groups'
    values have ``union``'s types)."""
    return all(union.get(pid) == item for pid, item in own.items())


def properties_digest(properties: dict[str, dict]) -> str:
    """sha256 of a class's ``properties`` (what a tile's tileset was typed with)."""
    text = json.dumps(properties, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def kind_of(item: dict) -> str:
    """A class property's BOOLEAN/STRING or component type."""
    return item.get("componentType") or item["type"]


def schema(properties: dict[str, dict]) -> dict:
    """The metadata ``schema`` with the ``building`` class of ``properties``
    (:func:`class_properties`, :func:`properties_of`)."""
    return {
        "id": SCHEMA_ID,
        "classes": {
            CLASS: {
                "name": "Building",
                "description": "a building of the export; its source attributes (docs/input.md)",
                "properties": properties,
            }
        },
    }


def entity(record: dict[str, tuple[str, object]], properties: dict[str, dict]) -> dict:
    """A metadata entity (group) of class ``building`` for one building's ``record``."""
    return {
        "class": CLASS,
        "properties": {
            pid: as_type(value, kind_of(properties[pid]))
            for pid, (_, value) in sorted(record.items())
        },
    }


def chain_values(chain) -> dict[str, tuple[str, object]]:
    """:func:`building_values` of a :class:`.tree.BuildingChain` (height from LOD0's glTF-frame
    bounds, +Y up, metres)."""
    lod0 = chain.levels[-1]
    return building_values(
        chain.id, chain.source, float(lod0.high[1] - lod0.low[1]), chain.attributes
    )


def add_metadata(tileset: dict, root, properties: dict[str, dict] | None = None) -> dict:
    """Give ``tileset`` (the JSON of the tree under ``root``, a :class:`.tree.Node`) its
    ``schema`` and every content of each building chain the building's metadata entity
    (``content.metadata``, 3D Tiles 1.1 content metadata); returns :func:`property_kinds` of its
    buildings. ``properties``: the class's properties to type the values with (default: typed
    from these buildings, :func:`class_properties`; a tile's tileset takes the export's union
    when its own types differ from it).

    Content metadata, not ``groups``: a building tile's tileset is an external tileset, and
    CesiumJS (1.145, ``findGroupMetadata``) looks a content's ``group`` up in the top-level
    tileset's groups only, while it reads content metadata with the top-level schema's class
    (which holds every tile's: :mod:`exporter.tileset`). Tiles without a building (quadtree
    tiles, proxies) get none: a proxy's buildings are told apart by its feature ids."""
    chains: list = []
    contents: list[list[dict]] = []  # per chain, its contents' JSON

    def visit(node, tile: dict, chain: int | None) -> None:
        if node.building is not None:
            chains.append(node.building)
            contents.append([])
            chain = len(chains) - 1
        if chain is not None and "content" in tile:
            contents[chain].append(tile["content"])
        for child, child_tile in zip(node.children, tile.get("children", [])):
            visit(child, child_tile, chain)

    visit(root, tileset["root"], None)
    if not chains:
        return {}
    records = [chain_values(chain) for chain in chains]
    kinds = property_kinds(records)
    if properties is None:
        properties = properties_of(kinds)
    tileset["schema"] = schema(properties)
    for record, found in zip(records, contents):
        metadata = entity(record, properties)
        for content in found:
            content["metadata"] = metadata
    return kinds
