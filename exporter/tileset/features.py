"""A proxy's buildings told apart: per-vertex feature ids (glTF ``EXT_mesh_features``) resolving to
a property table of the buildings merged in it (``EXT_structural_metadata``).

Sources: the glTF extensions' specifications,
https://github.com/CesiumGS/glTF/tree/3d-tiles-next/extensions/2.0/Vendor/EXT_mesh_features and
.../EXT_structural_metadata (property table binary layout: values, UINT32 string offsets,
booleans as a little-endian bitstream; every buffer view 8-byte aligned).

Pure functions: :func:`with_features` takes a GLB's bytes (one mesh, one primitive: what
:func:`exporter.gltf_writer.glb_bytes` writes for a proxy), the feature id of every vertex of
that primitive (its order) and one record per feature (:func:`.metadata.building_values`), and
returns the GLB with

- a ``_FEATURE_ID_0`` vertex attribute (FLOAT scalars: whole numbers, 4 bytes per vertex, the
  core spec's 4-byte vertex alignment without a stride) and ``EXT_mesh_features``
  ``featureIds: [{featureCount, attribute: 0, propertyTable: 0}]`` on the primitive;
- ``EXT_structural_metadata`` with its own schema (the ``building`` class of these records,
  types decided from their values, :mod:`.metadata`) and one property table, row ``i`` =
  feature ``i``. A property a building lacks is the class property's ``noData`` (``""``, the
  type's lowest integer, ``-1.7976931348623157e308``); a boolean property some building lacks
  is written as STRING (booleans have no ``noData``).

The tileset's own schema (tileset.json) is typed over every building; a proxy's over its own, so
a property mixed across the whole export (integers here, text there) may be INT32 in one proxy
and STRING in the tileset.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from .glb import _chunks
from .metadata import CLASS, as_type, class_properties, kind_of

ARRAY_BUFFER = 34962
FLOAT = 5126
NO_DATA = {
    "STRING": "",
    "INT32": -(2**31),
    "INT64": -(2**63),
    "FLOAT64": -1.7976931348623157e308,
}
_NUMPY = {"INT32": "<i4", "INT64": "<i8", "FLOAT64": "<f8"}


def _glb(document: dict, blob: bytes) -> bytes:
    text = json.dumps(document, allow_nan=False, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    header = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + 8 + len(blob))
    return b"".join(
        [header, struct.pack("<I", len(text)), b"JSON", text]
        + [struct.pack("<I", len(blob)), b"BIN\x00", blob]
    )


def table_columns(records: list[dict], properties: dict[str, dict]) -> dict[str, list[bytes]]:
    """property id -> its binary buffers (values, then string offsets for STRING) for the
    property table of ``records``; ``properties`` (the class's) gain ``noData`` where a record
    lacks one (booleans some record lacks turn STRING first)."""
    columns: dict[str, list[bytes]] = {}
    for pid, item in properties.items():
        present = [pid in record for record in records]
        kind = kind_of(item)
        if kind == "BOOLEAN" and not all(present):
            item.pop("componentType", None)
            item["type"] = kind = "STRING"
        if not all(present):
            item["noData"] = NO_DATA[kind]
        values = [
            as_type(record[pid][1], kind) if pid in record else NO_DATA.get(kind)
            for record in records
        ]
        if kind == "STRING":
            encoded = [str(v).encode("utf-8") for v in values]
            offsets = np.cumsum([0] + [len(e) for e in encoded]).astype("<u4")
            columns[pid] = [b"".join(encoded), offsets.tobytes()]
        elif kind == "BOOLEAN":
            bits = np.packbits(np.array(values, dtype=bool), bitorder="little")
            columns[pid] = [bits.tobytes()]
        else:
            columns[pid] = [np.array(values, dtype=_NUMPY[kind]).tobytes()]
    return columns


def with_features(glb: bytes, feature_ids: np.ndarray, records: list[dict]) -> bytes:
    """``glb`` (one mesh, one primitive) with ``feature_ids`` ((n,) ints in [0, len(records)),
    one per vertex of the primitive) as ``EXT_mesh_features`` resolving to a property table of
    ``records`` (``EXT_structural_metadata``); see the module doc."""
    document, blob = _chunks(glb, "proxy")
    primitive = document["meshes"][0]["primitives"][0]
    count = document["accessors"][primitive["attributes"]["POSITION"]]["count"]
    ids = np.asarray(feature_ids).reshape(-1)
    if len(ids) != count or (len(ids) and not 0 <= ids.min() <= ids.max() < len(records)):
        raise ValueError(f"{len(ids)} feature ids for {count} vertices and {len(records)} records")
    pieces = [blob]
    size = len(blob)

    def view(data: bytes, target: int | None = None) -> int:
        nonlocal size
        padding = -size % 8  # EXT_structural_metadata: 8-byte aligned views
        pieces.append(bytes(padding))
        item = {"buffer": 0, "byteOffset": size + padding, "byteLength": len(data)}
        if target is not None:
            item["target"] = target
        pieces.append(data)
        size += padding + len(data)
        document["bufferViews"].append(item)
        return len(document["bufferViews"]) - 1

    document["accessors"].append(
        {
            "bufferView": view(ids.astype("<f4").tobytes(), ARRAY_BUFFER),
            "byteOffset": 0,
            "componentType": FLOAT,
            "count": int(count),
            "type": "SCALAR",
        }
    )
    primitive["attributes"]["_FEATURE_ID_0"] = len(document["accessors"]) - 1
    primitive.setdefault("extensions", {})["EXT_mesh_features"] = {
        "featureIds": [{"featureCount": len(records), "attribute": 0, "propertyTable": 0}]
    }
    properties = class_properties(records)
    table: dict = {}
    for pid, buffers in table_columns(records, properties).items():
        table[pid] = {"values": view(buffers[0])}
        if len(buffers) > 1:
            table[pid].update({"stringOffsets": view(buffers[1]), "stringOffsetType": "UINT32"})
    document.setdefault("extensions", {})["EXT_structural_metadata"] = {
        "schema": {"id": "vworld_lod", "classes": {CLASS: {"properties": properties}}},
        "propertyTables": [
            {"name": "buildings", "class": CLASS, "count": len(records), "properties": table}
        ],
    }
    used = document.setdefault("extensionsUsed", [])
    used += [e for e in ("EXT_mesh_features", "EXT_structural_metadata") if e not in used]
    blob_out = b"".join(pieces)
    blob_out += bytes(-len(blob_out) % 4)
    document["buffers"][0]["byteLength"] = len(blob_out)
    return _glb(document, blob_out)
