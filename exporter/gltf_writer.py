"""Write one level of one building as a self-contained binary glTF (``.glb``).

Input: the building's parts in the **local East/Up/North frame** (metres, x = East, y = Up,
z = North, triangles wound so ``(b - a) x (c - a)`` points outward; see ``exporter/model.py``).

Output frame, **glTF**: +X = West, +Y = Up, +Z = North. glTF is right-handed with counter-clockwise
front faces, so the writer negates X of positions and normals and reverses every triangle: the
exact inverse of what glTFast does on import (negate X, reverse winding), so the building arrives
in Unity as x = East, y = Up, z = North with outward faces still outward.

One mesh, one primitive per part (one material each), one node, ``"scene": 0`` (glTFast's editor
importer only creates a main object when the file names a default scene). Textures are embedded
as they are given (JPEG/PNG bytes, no re-encoding).

KTX2 (opt-in, ``textures.ktx2``; ``encode_glb(..., ktx2=...)``): each texture also gets a KTX2
image (Basis Universal, made by the given encoder, ``exporter/ktx2.py``) through the
``KHR_texture_basisu`` extension, with the JPEG/PNG kept as the texture's ``source``: the fallback
for clients without the extension, so it is listed in ``extensionsUsed`` only, not
``extensionsRequired`` (KHR_texture_basisu README, "Using Without a Fallback" is the other
choice). An image the encoder declines (``None``: sides not multiples of 4, which the extension
requires) keeps its JPEG/PNG alone.

Alpha (:func:`alpha_mode`, from the atlas's alpha histogram): a part whose colour has alpha below 1
is ``BLEND``. A textured part is ``OPAQUE`` when no atlas pixel is see-through (alpha at least
248 of 255, or no alpha channel), else ``MASK`` with ``alphaCutoff`` 0.5 unless partial alpha
(8..247) covers at least :data:`BLEND_SHARE` of the atlas *and* is translucency rather than the
rim of cut-outs, which makes it ``BLEND`` (glass, soft shadows): either the atlas has (almost) no
clear pixels (alpha 0..7) for it to be the rim of (fewer than :data:`RIM_CLEAR` per partial one),
or partial regions are wider than a rim (partial pixels with no clear or opaque pixel within
:data:`RIM` pixels cover at least :data:`BLEND_SHARE`). Reducing a binary cut-out (box or Lanczos,
as the texture stage does) leaves partial rims a few pixels wide around clear holes: those stay
``MASK`` so a building's levels render alike, and a 0.5 cutoff keeps the reduced edge where it was.
Holes reduced below ~2 pixels leave no clear pixel, and such a level is ``BLEND`` (a haze, which
is what the holes look like at that size).

The JSON document is built as plain dicts (:class:`_Document`) and written by ``json.dumps`` in C:
byte for byte what pygltflib's ``save_to_bytes`` writes for the same document built from its
dataclasses (same keys in the same order, empty values left out; ``tests/gltf_reference.py`` is
that formulation), at a fraction of the cost. The binary chunk is kept as its pieces, so the
(large) image bytes are copied once, into the GLB.
"""

from __future__ import annotations

import functools
import io
import json
import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pygltflib
from PIL import Image

from .mesh import _gltf_arrays
from .mesh.geometry import vertex_normals
from .model import Part, Texture

GLTF_MIMES = ("image/jpeg", "image/png")
BASISU = "KHR_texture_basisu"
# A texture's KTX2 bytes (Basis Universal), or None to keep its JPEG/PNG alone.
Ktx2Encoder = Callable[[Texture], "bytes | None"]

ALPHA_CUTOFF = 0.5  # glTF's default, written explicitly with MASK
CLEAR, SOLID = 7, 248  # alpha <= CLEAR counts as clear, >= SOLID as opaque (0..255)
RIM = 3  # pixels each side: partial alpha this close to clear/opaque pixels may be a resampled edge
BLEND_SHARE = 0.01  # share of the atlas's pixels that must be translucent for BLEND
RIM_CLEAR = 0.05  # clear pixels per partial pixel below which partial alpha surrounds no holes


def alpha_mode(alpha: np.ndarray) -> str:
    """glTF ``alphaMode`` of an atlas with (h, w) uint8 ``alpha`` (0 clear .. 255 opaque), by the
    rule in the module docstring."""
    histogram = np.bincount(alpha.reshape(-1), minlength=256)
    if not histogram[:SOLID].any():
        return pygltflib.OPAQUE
    partial_count = int(histogram[CLEAR + 1 : SOLID].sum())
    if partial_count < BLEND_SHARE * alpha.size:
        return pygltflib.MASK
    if int(histogram[: CLEAR + 1].sum()) < RIM_CLEAR * partial_count:
        return pygltflib.BLEND
    # Imported here: few atlases get this far, and scipy.ndimage costs every process ~0.3 s to load
    # (an unchanged re-run of 300 buildings took 1.3 s, a quarter of it this import).
    from scipy import ndimage

    partial = (alpha > CLEAR) & (alpha < SOLID)
    # Partial pixels whose whole (2 RIM + 1)^2 neighbourhood is partial: no resampled edge.
    inner = ndimage.minimum_filter(partial.view(np.uint8), size=2 * RIM + 1, mode="nearest")
    translucent = int(np.count_nonzero(inner))
    return pygltflib.BLEND if translucent >= BLEND_SHARE * alpha.size else pygltflib.MASK


@functools.lru_cache(maxsize=8)
def texture_alpha_mode(data: bytes) -> str:
    """:func:`alpha_mode` of an encoded PNG/JPEG atlas; ``OPAQUE`` without an alpha channel. Cached:
    an atlas shared by many buildings is decoded once (the key is the bytes themselves, whose hash
    Python keeps on the object)."""
    alpha = texture_alpha(data)
    return pygltflib.OPAQUE if alpha is None else alpha_mode(alpha)


def texture_alpha(data: bytes) -> np.ndarray | None:
    """(h, w) uint8 alpha of an encoded PNG/JPEG, or None when it has no alpha channel (opaque;
    only the header is read then)."""
    with Image.open(io.BytesIO(data)) as image:
        if (
            image.mode not in ("RGBA", "LA", "PA", "La", "RGBa")
            and "transparency" not in image.info
        ):
            return None
        return np.asarray(image.convert("RGBA").getchannel("A"))


def gltf_arrays(part: Part) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """``part``'s vertex data in glTF (West, Up, North): (n, 3) float32 positions (metres), (n, 3)
    float32 unit normals (its own when it has one per vertex, else area-weighted ones of its
    triangles; +Y where a row has no direction), the flat index array (uint16, or uint32 past
    65535 vertices) with every triangle reversed, and that index array's glTF component type.

    One pass per array in C (``exporter/mesh/c/gltf_arrays.c``), the same bits as the numpy
    formulation kept in ``tests/gltf_reference.py`` (X negated after rounding to float32, normals
    made unit with rows without a direction +Y, each triangle (a, b, c) written (a, c, b))."""
    positions = np.asarray(part.positions).reshape(-1, 3)
    local = (
        part.normals
        if part.normals is not None and len(part.normals) == len(part.positions)
        else vertex_normals(part.positions, part.triangles)
    )
    small = len(positions) <= 65535
    out_positions, normals, indices = _gltf_arrays.arrays(
        positions,
        np.asarray(local).reshape(-1, 3),
        np.asarray(part.triangles).reshape(-1, 3),
        not small,
    )
    return (
        out_positions,
        normals,
        indices,
        pygltflib.UNSIGNED_SHORT if small else pygltflib.UNSIGNED_INT,
    )


def position_bounds(positions: np.ndarray) -> tuple[list[float], list[float]]:
    """The (3,) column maxima and minima of (n, 3) float32 ``positions`` (metres, any frame),
    exactly ``positions.max(axis=0)`` and ``.min(axis=0)``: one C pass, or numpy's own reduction
    when a bound is zero (numpy's pick between 0.0 and -0.0 depends on its loop) or there is none."""
    if len(positions):
        top, bottom = _gltf_arrays.bounds(positions)
        if 0.0 not in top and 0.0 not in bottom:
            return list(top), list(bottom)
    return positions.max(axis=0).tolist(), positions.min(axis=0).tolist()


def union_bounds(
    lows: list[list[float]], highs: list[list[float]]
) -> tuple[np.ndarray, np.ndarray]:
    """(low (3,), high (3,)) float64 over several primitives' POSITION ``min``/``max`` (metres,
    glTF frame): what a file's position bounds are, from its writer or from its header."""
    return np.min(np.array(lows, np.float64), axis=0), np.max(np.array(highs, np.float64), axis=0)


@dataclass(frozen=True)
class Glb:
    """An encoded GLB and its position bounds (glTF frame: +X = West, +Y = Up, +Z = North, metres;
    the float32 values its POSITION accessors' ``min``/``max`` store, over every primitive)."""

    data: bytes
    low: list[float]
    high: list[float]


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


def _named(item: dict, name: str | None) -> dict:
    """``item`` with ``"name"`` last when ``name`` is non-empty (glTF leaves empty names out)."""
    if name:
        item["name"] = name
    return item


class _Document:
    """A GLB under construction: the JSON document's lists as plain dicts, each object's keys in
    the glTF schema's order with absent and empty values left out (what pygltflib writes for the
    same document), and the binary chunk as a :class:`_Blob`."""

    def __init__(self) -> None:
        self.blob = _Blob()
        self.accessors: list[dict] = []
        self.views: list[dict] = []
        self.images: list[dict] = []
        self.textures: list[dict] = []
        self.materials: list[dict] = []
        self.samplers: list[dict] = []
        self.position_lows: list[list[float]] = []  # the POSITION accessors' min and max
        self.position_highs: list[list[float]] = []
        self.extensions_used: list[str] = []

    def view(self, data: bytes, target: int | None = None) -> int:
        item = {"buffer": 0, "byteOffset": self.blob.append(data), "byteLength": len(data)}
        if target is not None:
            item["target"] = target
        self.views.append(item)
        return len(self.views) - 1

    def accessor(
        self,
        array: np.ndarray,
        component: int,
        kind: str,
        target: int | None,
        with_bounds: bool = False,
    ) -> int:
        item = {
            "bufferView": self.view(array.tobytes(), target),
            "byteOffset": 0,
            "componentType": component,
            "normalized": False,
            "count": int(len(array)),
            "type": kind,
        }
        if with_bounds:
            top, bottom = position_bounds(array)
            high, low = [float(v) for v in top], [float(v) for v in bottom]
            item["max"], item["min"] = high, low
            self.position_highs.append(high)
            self.position_lows.append(low)
        self.accessors.append(item)
        return len(self.accessors) - 1

    def texture(self, data: bytes, mime: str, name: str, ktx2: bytes | None = None) -> int:
        """A texture of the embedded image ``data`` with the document's one sampler; with ``ktx2``
        bytes also a KTX2 image through ``KHR_texture_basisu`` (``data`` the fallback)."""
        if not self.samplers:
            self.samplers.append(
                {
                    "magFilter": pygltflib.LINEAR,
                    "minFilter": pygltflib.LINEAR_MIPMAP_LINEAR,
                    "wrapS": pygltflib.REPEAT,
                    "wrapT": pygltflib.REPEAT,
                }
            )
        self.images.append(_named({"mimeType": mime, "bufferView": self.view(data)}, name))
        texture: dict = {"sampler": 0, "source": len(self.images) - 1}
        if ktx2 is not None:
            self.images.append(
                _named(
                    {"mimeType": "image/ktx2", "bufferView": self.view(ktx2)},
                    name and f"{name}.ktx2",
                )
            )
            texture["extensions"] = {BASISU: {"source": len(self.images) - 1}}
            if BASISU not in self.extensions_used:
                self.extensions_used.append(BASISU)
        self.textures.append(texture)
        return len(self.textures) - 1

    def json(self, primitives: list[dict], name: str) -> dict:
        """The document of one mesh (``primitives``), one node and one scene, all named ``name``."""
        self.blob.align()
        document = {
            "accessors": self.accessors,
            "asset": {"generator": "vworld-lod", "version": "2.0"},
            "bufferViews": self.views,
            "buffers": [{"byteLength": len(self.blob)}],
            "extensionsUsed": self.extensions_used,
            "images": self.images,
            "materials": self.materials,
            "meshes": [_named({"primitives": primitives}, name)],
            "nodes": [_named({"mesh": 0}, name)],
            "samplers": self.samplers,
            "scene": 0,
            "scenes": [{"name": name, "nodes": [0]} if name else {"nodes": [0]}],
            "textures": self.textures,
        }
        return {key: value for key, value in document.items() if value != []}


def _glb(document: dict, blob: _Blob) -> bytes:
    """The GLB container (header, JSON chunk padded with spaces, BIN chunk) of ``document`` whose
    single buffer is ``blob`` (4-byte aligned views): byte for byte what pygltflib writes."""
    text = json.dumps(document, allow_nan=False, separators=(",", ":")).encode("utf-8")
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
            *blob.pieces,
        ]
    )


def glb_bytes(parts: list[Part], name: str, ktx2: Ktx2Encoder | None = None) -> bytes:
    """Encode ``parts`` (local East/Up/North, outward winding) as a self-contained GLB
    (:func:`encode_glb`'s bytes)."""
    return encode_glb(parts, name, ktx2).data


def encode_glb(parts: list[Part], name: str, ktx2: Ktx2Encoder | None = None) -> Glb:
    """Encode ``parts`` (local East/Up/North, outward winding) as a self-contained GLB, with the
    position bounds it stores.

    Parts without triangles are left out; a level must keep at least one triangle overall (the
    pipeline guarantees it). Textures must already be JPEG or PNG (the texture stage converts).
    With ``ktx2``, each texture also carries the KTX2 image it makes (``KHR_texture_basisu``,
    the JPEG/PNG as fallback; see the module docstring).
    """
    document = _Document()
    primitives = []
    texture_of_image: dict[int, int] = {}
    for part_index, part in enumerate(parts):
        if part.triangle_count == 0:
            continue
        positions, normals, indices, index_type = gltf_arrays(part)
        attributes = {
            "POSITION": document.accessor(
                positions, pygltflib.FLOAT, pygltflib.VEC3, pygltflib.ARRAY_BUFFER, with_bounds=True
            ),
            "NORMAL": document.accessor(
                normals, pygltflib.FLOAT, pygltflib.VEC3, pygltflib.ARRAY_BUFFER
            ),
        }
        pbr: dict = {
            "baseColorFactor": [float(c) for c in part.color],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        }
        translucent = len(part.color) == 4 and part.color[3] < 1.0
        alpha = pygltflib.BLEND if translucent else pygltflib.OPAQUE
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
            attributes["TEXCOORD_0"] = document.accessor(
                uvs, pygltflib.FLOAT, pygltflib.VEC2, pygltflib.ARRAY_BUFFER
            )
            key = id(part.texture)
            if key not in texture_of_image:
                texture_of_image[key] = document.texture(
                    part.texture.data,
                    part.texture.mime,
                    part.texture.name,
                    ktx2(part.texture) if ktx2 is not None else None,
                )
            pbr["baseColorTexture"] = {"index": texture_of_image[key], "texCoord": 0}
            if alpha == pygltflib.OPAQUE and part.texture.has_alpha_channel:
                # (a translucent colour has made it BLEND already: that stays)
                alpha = texture_alpha_mode(bytes(part.texture.data))
        material = {
            "pbrMetallicRoughness": pbr,
            "emissiveFactor": [0.0, 0.0, 0.0],
            "alphaMode": alpha,
        }
        if alpha == pygltflib.MASK:
            material["alphaCutoff"] = ALPHA_CUTOFF
        # Floorless buildings are open at the bottom, but their faces are wound outward: single
        # sided is right (and halves fill cost); the open bottom is never seen from outside.
        material["doubleSided"] = False
        document.materials.append(_named(material, part.name or f"part{part_index}"))
        primitives.append(
            {
                "attributes": attributes,
                "indices": document.accessor(
                    indices, index_type, pygltflib.SCALAR, pygltflib.ELEMENT_ARRAY_BUFFER
                ),
                "mode": pygltflib.TRIANGLES,
                "material": len(document.materials) - 1,
            }
        )
    if not primitives:
        raise ValueError(f"{name}: nothing to write (no triangles)")
    low, high = union_bounds(document.position_lows, document.position_highs)
    return Glb(_glb(document.json(primitives, name), document.blob), low.tolist(), high.tolist())
