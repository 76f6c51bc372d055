"""Write one level of one building as a self-contained binary glTF (``.glb``) with pygltflib.

Input: the building's parts in the **local East/Up/North frame** (metres, x = East, y = Up,
z = North, triangles wound so ``(b - a) x (c - a)`` points outward; see ``exporter/model.py``).

Output frame, **glTF**: +X = West, +Y = Up, +Z = North. glTF is right-handed with counter-clockwise
front faces, so the writer negates X of positions and normals and reverses every triangle: the
exact inverse of what glTFast does on import (negate X, reverse winding), so the building arrives
in Unity as x = East, y = Up, z = North with outward faces still outward.

One mesh, one primitive per part (one material each), one node, ``"scene": 0`` (glTFast's editor
importer only creates a main object when the file names a default scene). Textures are embedded
as they are given (JPEG/PNG bytes, no re-encoding).

The document is built with pygltflib's dataclasses and serialised by :func:`_glb`: byte for byte
what pygltflib's ``save_to_bytes`` writes (same fields, same order, same empty-value pruning, same
``json.dumps`` options), but cheaply: ``json.dumps`` walks the dataclasses itself, asking
:func:`_pruned_fields` for one pruned dict per object (no deep copies, no intermediate document;
documents it does not cover go through :func:`_generic_json`, the plain formulation), and the
binary chunk is kept as its pieces, so the (large) image bytes are copied once, into the GLB.
"""

from __future__ import annotations

import dataclasses
import json
import struct

import numpy as np
import pygltflib
from pygltflib import GLTF2

from .mesh.geometry import unit_vectors, vertex_normals
from .model import Part

GLTF_MIMES = ("image/jpeg", "image/png")


def local_to_gltf_positions(positions: np.ndarray) -> np.ndarray:
    """(n, 3) local East/Up/North metres -> (n, 3) glTF (West, Up, North) metres, float32."""
    out = np.array(positions, dtype=np.float32, copy=True).reshape(-1, 3)
    out[:, 0] *= -1.0
    return out


def local_to_gltf_triangles(triangles: np.ndarray) -> np.ndarray:
    """Reverse each triangle (a, b, c) -> (a, c, b): negating X is a reflection, which would
    otherwise turn every face inside out."""
    triangles = np.asarray(triangles).reshape(-1, 3)
    return triangles[:, [0, 2, 1]]


def unit_normals_or_up(normals: np.ndarray) -> np.ndarray:
    """(n, 3) float32 unit normals; rows without a direction get +Y (up) so the glTF stays valid
    (the validator requires unit-length normals)."""
    out = unit_vectors(normals)
    out[~out.any(axis=1)] = (0.0, 1.0, 0.0)
    return out.astype(np.float32)


class _Blob:
    """The binary chunk as its pieces (views and the zero padding that 4-byte aligns them), so the
    GLB is assembled with one copy of the (large) image bytes; ``bytes(blob)`` is the chunk."""

    def __init__(self) -> None:
        self.pieces: list = []
        self.size = 0  # bytes

    def __len__(self) -> int:
        return self.size

    def __bytes__(self) -> bytes:
        return b"".join(self.pieces)

    def align(self) -> None:
        padding = -self.size % 4
        if padding:
            self.pieces.append(bytes(padding))
            self.size += padding

    def append(self, data: bytes) -> int:
        """Append ``data`` at the next 4-byte boundary; returns its byte offset."""
        self.align()
        offset = self.size
        self.pieces.append(data)
        self.size += len(data)
        return offset


class _GlbBuilder:
    """Accumulates buffer views and accessors into one binary chunk (4-byte aligned)."""

    def __init__(self) -> None:
        self.gltf = GLTF2(asset=pygltflib.Asset(version="2.0", generator="vworld-lod"))
        self.blob = _Blob()

    def _view(self, data: bytes, target: int | None = None) -> int:
        offset = self.blob.append(data)
        view = pygltflib.BufferView(buffer=0, byteOffset=offset, byteLength=len(data))
        if target is not None:
            view.target = target
        self.gltf.bufferViews.append(view)
        return len(self.gltf.bufferViews) - 1

    def accessor(
        self,
        array: np.ndarray,
        component: int,
        kind: str,
        target: int | None,
        with_bounds: bool = False,
    ) -> int:
        view = self._view(array.tobytes(), target)
        accessor = pygltflib.Accessor(
            bufferView=view, componentType=component, count=int(len(array)), type=kind
        )
        if with_bounds:
            accessor.min = [float(v) for v in array.min(axis=0)]
            accessor.max = [float(v) for v in array.max(axis=0)]
        self.gltf.accessors.append(accessor)
        return len(self.gltf.accessors) - 1

    def image(self, data: bytes, mime: str, name: str) -> int:
        view = self._view(data)
        self.gltf.images.append(pygltflib.Image(bufferView=view, mimeType=mime, name=name or None))
        return len(self.gltf.images) - 1


_FIELDS: dict[type, tuple[str, ...]] = {}
_SCALARS = frozenset({int, float, str, bool, type(None)})
_NUMBERS = frozenset({int, float, bool})  # never pruned (no __iter__)
_NESTED = frozenset({dict, list, tuple})  # list items the fast path leaves to the generic one


def _field_names(kind: type) -> tuple[str, ...] | None:
    """A dataclass's field names in declaration order (cached per type); None for other types."""
    names = _FIELDS.get(kind)
    if names is None and dataclasses.is_dataclass(kind):
        names = _FIELDS[kind] = tuple(f.name for f in dataclasses.fields(kind))
    return names


def _plain(value):
    """pygltflib's ``gltf_asdict`` without the deep copies: dataclasses to dicts (field order),
    ``Attributes`` as their ``__dict__``."""
    kind = type(value)
    if kind in _SCALARS:
        return value
    if kind is pygltflib.Attributes:
        return dict(value.__dict__)
    names = _field_names(kind)
    if names is not None:
        return {name: _plain(getattr(value, name)) for name in names}
    if kind is list or kind is tuple:
        return kind(_plain(v) for v in value)
    if kind is dict:
        return {k: _plain(v) for k, v in value.items()}
    return value


def _generic_json(gltf: GLTF2) -> str:
    """The JSON text exactly as pygltflib's ``gltf_to_json(separators=(",", ":"), indent=None)``."""
    data = pygltflib.delete_empty_keys(_plain(gltf))
    return json.dumps(
        data,
        cls=pygltflib.JsonEncoder,
        skipkeys=True,
        allow_nan=False,
        separators=(",", ":"),
        default=pygltflib.json_serial,
    )


class _Unusual(Exception):
    """Internal: a value :func:`_pruned_fields` does not cover; the generic path takes the document."""


def _pruned_fields(obj) -> dict:
    """``json.dumps`` default: one dataclass (or ``Attributes``) as a dict of its fields, pruned as
    ``delete_empty_keys`` prunes them (None and empty strings/lists/dicts dropped).

    Nested objects stay objects: the encoder calls back here for each, so there is no Python
    recursion and no intermediate copy of the document. Values whose pruning the two formulations
    could do differently (non-empty dicts, tuples, lists holding containers, non-JSON scalars) raise
    :class:`_Unusual`.
    """
    kind = type(obj)
    names = _field_names(kind)
    if kind is pygltflib.Attributes:
        items = obj.__dict__.items()
    elif names is None:
        raise _Unusual(kind.__name__)
    else:
        values = getattr(obj, "__dict__", None)
        if values is not None and tuple(values) == names:
            items = values.items()
        else:  # attributes besides the fields (or slots): the fields only, as asdict
            items = [(name, getattr(obj, name)) for name in names]
    out = {}
    for name, value in items:
        kind = type(value)
        if kind in _NUMBERS:
            out[name] = value
        elif value is None:
            continue
        elif kind is str or kind is list:
            if value:
                if kind is list and not _NESTED.isdisjoint(map(type, value)):
                    raise _Unusual(name)
                out[name] = value
        elif kind is dict:
            if value:
                raise _Unusual(name)
        elif name == "extensions":  # delete_empty_keys leaves what converts to a dict here unpruned
            raise _Unusual(name)
        elif kind is pygltflib.Attributes:
            if value.__dict__:  # converted to an empty dict, it would be pruned
                out[name] = value
        else:
            fields = _field_names(kind)
            if fields is None:
                raise _Unusual(name)
            if (
                fields
            ):  # no __iter__: kept unless it converts to {}; its own fields pruned by the callback
                out[name] = value
    return out


def _gltf_json(gltf: GLTF2) -> str:
    """The JSON text of ``gltf``, equal to :func:`_generic_json`'s (the encoder walks the
    dataclasses through :func:`_pruned_fields`; anything unusual goes the generic way)."""
    try:
        return json.dumps(
            gltf, skipkeys=True, allow_nan=False, separators=(",", ":"), default=_pruned_fields
        )
    except _Unusual:
        return _generic_json(gltf)


def _glb(gltf: GLTF2, blob: bytes | bytearray | _Blob) -> bytes:
    """The GLB container (header, JSON chunk padded with spaces, BIN chunk) of ``gltf`` whose
    single buffer is ``blob`` (4-byte aligned views): byte for byte what pygltflib writes."""
    text = _gltf_json(gltf).encode("utf-8")
    text += b" " * (-len(text) % 4)
    length = 12 + 8 + len(text) + 8 + len(blob)
    return b"".join(
        [
            b"glTF",
            struct.pack("<III", 2, length, len(text)),
            b"JSON",
            text,
            struct.pack("<I", len(blob)),
            b"BIN\x00",
            *(blob.pieces if isinstance(blob, _Blob) else [blob]),
        ]
    )


def glb_bytes(parts: list[Part], name: str) -> bytes:
    """Encode ``parts`` (local East/Up/North, outward winding) as a self-contained GLB.

    Parts without triangles are left out; a level must keep at least one triangle overall (the
    pipeline guarantees it). Textures must already be JPEG or PNG (the texture stage converts).
    """
    builder = _GlbBuilder()
    gltf = builder.gltf
    sampler_index = None
    primitives = []
    texture_of_image: dict[int, int] = {}
    for part_index, part in enumerate(parts):
        if part.triangle_count == 0:
            continue
        positions = local_to_gltf_positions(part.positions)
        normals_local = (
            part.normals
            if part.normals is not None and len(part.normals) == len(part.positions)
            else vertex_normals(part.positions, part.triangles)
        )
        normals = unit_normals_or_up(normals_local)
        normals[:, 0] *= -1.0
        triangles = local_to_gltf_triangles(part.triangles)
        index_type = pygltflib.UNSIGNED_SHORT if len(positions) <= 65535 else pygltflib.UNSIGNED_INT
        indices = triangles.astype(
            np.uint16 if index_type == pygltflib.UNSIGNED_SHORT else np.uint32
        ).reshape(-1)

        attributes = pygltflib.Attributes(
            POSITION=builder.accessor(
                positions, pygltflib.FLOAT, pygltflib.VEC3, pygltflib.ARRAY_BUFFER, with_bounds=True
            ),
            NORMAL=builder.accessor(
                normals, pygltflib.FLOAT, pygltflib.VEC3, pygltflib.ARRAY_BUFFER
            ),
        )
        material = pygltflib.Material(
            name=part.name or f"part{part_index}",
            pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                baseColorFactor=[float(c) for c in part.color],
                metallicFactor=0.0,
                roughnessFactor=1.0,
            ),
            # Floorless buildings are open at the bottom, but their faces are wound outward: single
            # sided is right (and halves fill cost); the open bottom is never seen from outside.
            doubleSided=False,
        )
        if len(part.color) == 4 and part.color[3] < 1.0:
            material.alphaMode = pygltflib.BLEND
        has_texture = (
            part.texture is not None
            and part.uvs is not None
            and len(part.uvs) == len(part.positions)
        )
        if has_texture and part.texture is not None:
            if part.texture.mime not in GLTF_MIMES:
                raise ValueError(
                    f"texture {part.texture.name!r} is {part.texture.mime}; glTF needs image/jpeg or image/png"
                )
            uvs = np.ascontiguousarray(part.uvs, dtype=np.float32)
            attributes.TEXCOORD_0 = builder.accessor(
                uvs, pygltflib.FLOAT, pygltflib.VEC2, pygltflib.ARRAY_BUFFER
            )
            if sampler_index is None:
                gltf.samplers.append(
                    pygltflib.Sampler(
                        magFilter=pygltflib.LINEAR,
                        minFilter=pygltflib.LINEAR_MIPMAP_LINEAR,
                        wrapS=pygltflib.REPEAT,
                        wrapT=pygltflib.REPEAT,
                    )
                )
                sampler_index = 0
            key = id(part.texture)
            if key not in texture_of_image:
                image = builder.image(part.texture.data, part.texture.mime, part.texture.name)
                gltf.textures.append(pygltflib.Texture(sampler=sampler_index, source=image))
                texture_of_image[key] = len(gltf.textures) - 1
            material.pbrMetallicRoughness.baseColorTexture = pygltflib.TextureInfo(
                index=texture_of_image[key]
            )
            if part.texture.mime == "image/png" and material.alphaMode is None:
                material.alphaMode = pygltflib.MASK  # transparent atlas pixels cut out, not blended
        gltf.materials.append(material)
        primitives.append(
            pygltflib.Primitive(
                attributes=attributes,
                indices=builder.accessor(
                    indices, index_type, pygltflib.SCALAR, pygltflib.ELEMENT_ARRAY_BUFFER
                ),
                material=len(gltf.materials) - 1,
                mode=pygltflib.TRIANGLES,
            )
        )
    if not primitives:
        raise ValueError(f"{name}: nothing to write (no triangles)")
    gltf.meshes.append(pygltflib.Mesh(name=name, primitives=primitives))
    gltf.nodes.append(pygltflib.Node(name=name, mesh=0))
    gltf.scenes.append(pygltflib.Scene(name=name, nodes=[0]))
    gltf.scene = 0
    builder.blob.align()
    gltf.buffers.append(pygltflib.Buffer(byteLength=len(builder.blob)))
    return _glb(gltf, builder.blob)
