"""Read back what the exporter wrote: a ``.glb``'s bounds, and its meshes as numpy arrays.

Data form: positions in the **glTF frame** of the file (+X = West, +Y = Up, +Z = North, metres),
float64 copies of the stored float32; triangles (m, 3) int64 as stored (counter-clockwise front
faces); uvs (n, 2) float32 (origin top-left); one :class:`GlbPrimitive` per glTF primitive.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..gltf_writer import union_bounds

_COMPONENTS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


@dataclass
class GlbPrimitive:
    positions: np.ndarray  # (n, 3) float64 metres, glTF frame
    triangles: np.ndarray  # (m, 3) int64
    uvs: np.ndarray | None  # (n, 2) float32 or None
    image: bytes | None  # the base colour texture's encoded bytes (JPEG/PNG)
    mime: str
    color: tuple  # base colour factor (r, g, b, a)


def _chunks(data: bytes, name: str, whole: bool = True) -> tuple[dict, bytes]:
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2 or (whole and length > len(data)):
        raise ValueError(f"{name}: not a complete glTF 2.0 binary file")
    json_length, kind = struct.unpack_from("<I4s", data, 12)
    if kind != b"JSON":
        raise ValueError(f"{name}: first chunk is not JSON")
    header = json.loads(data[20 : 20 + json_length])
    offset = 20 + json_length
    blob = b""
    if whole and offset + 8 <= length:
        blob_length, _ = struct.unpack_from("<I4s", data, offset)
        blob = data[offset + 8 : offset + 8 + blob_length]
    return header, blob


def read_header(path: str | Path) -> dict:
    """The JSON chunk of the ``.glb`` at ``path`` (reads only the file's start)."""
    with open(path, "rb") as handle:
        start = handle.read(20)
        if len(start) < 20:
            raise ValueError(f"{path}: too short for a glTF binary file")
        json_length = struct.unpack_from("<I", start, 12)[0]
        return _chunks(start + handle.read(json_length), str(path), whole=False)[0]


def position_bounds(header: dict) -> tuple[np.ndarray, np.ndarray]:
    """(low (3,), high (3,)) glTF-frame metres over every primitive's POSITION min/max."""
    lows, highs = [], []
    for mesh in header.get("meshes", []):
        for primitive in mesh["primitives"]:
            accessor = header["accessors"][primitive["attributes"]["POSITION"]]
            lows.append(accessor["min"])
            highs.append(accessor["max"])
    if not lows:
        raise ValueError("no positions")
    return union_bounds(lows, highs)


def _accessor(header: dict, blob: bytes, index: int) -> np.ndarray:
    accessor = header["accessors"][index]
    view = header["bufferViews"][accessor["bufferView"]]
    dtype = np.dtype(_COMPONENTS[accessor["componentType"]])
    width = _WIDTH[accessor["type"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride", 0) or dtype.itemsize * width
    if stride != dtype.itemsize * width:
        raise ValueError("interleaved buffer views are not written by this project")
    array = np.frombuffer(blob, dtype, accessor["count"] * width, start)
    return array.reshape(accessor["count"], width) if width > 1 else array


def read_primitives(path: Path) -> list[GlbPrimitive]:
    """Every triangle primitive of the ``.glb`` at ``path`` (one mesh node, as the writer makes)."""
    header, blob = _chunks(Path(path).read_bytes(), str(path))
    out = []
    for mesh in header.get("meshes", []):
        for primitive in mesh["primitives"]:
            if primitive.get("mode", 4) != 4:
                continue
            attributes = primitive["attributes"]
            positions = _accessor(header, blob, attributes["POSITION"]).astype(np.float64)
            triangles = (
                _accessor(header, blob, primitive["indices"]).astype(np.int64).reshape(-1, 3)
            )
            material = header.get("materials", [{}])[primitive.get("material", 0)]
            pbr = material.get("pbrMetallicRoughness", {})
            image, mime, uvs = None, "", None
            if "baseColorTexture" in pbr and "TEXCOORD_0" in attributes:
                source = header["textures"][pbr["baseColorTexture"]["index"]]["source"]
                record = header["images"][source]
                view = header["bufferViews"][record["bufferView"]]
                start = view.get("byteOffset", 0)
                image = bytes(blob[start : start + view["byteLength"]])
                mime = record.get("mimeType", "image/jpeg")
                uvs = _accessor(header, blob, attributes["TEXCOORD_0"]).astype(np.float32)
            color = tuple(float(c) for c in pbr.get("baseColorFactor", (1.0, 1.0, 1.0, 1.0)))
            out.append(GlbPrimitive(positions, triangles, uvs, image, mime, color))
    return out
