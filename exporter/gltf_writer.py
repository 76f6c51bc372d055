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

The JSON document is written as text (:class:`_Document`: each object's JSON built as it is
added, numbers by ``repr`` and strings by json's own ASCII escaping, which is what ``json.dumps``
writes): byte for byte what pygltflib's ``save_to_bytes`` writes for the same document built from
its dataclasses (same keys in the same order, empty values left out; ``tests/gltf_reference.py``
is that formulation), at a fraction of the cost of building dicts and dumping them. The binary
chunk is kept as its pieces, so the (large) image bytes are copied once, into the GLB.
"""

from __future__ import annotations

import functools
import io
import json
import math
import struct

import numpy as np
import pygltflib
from PIL import Image

from .mesh import _gltf_arrays
from .mesh.geometry import unit_vectors, vertex_normals
from .model import Part

GLTF_MIMES = ("image/jpeg", "image/png")

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


def gltf_arrays(part: Part) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """``part``'s vertex data in glTF (West, Up, North): (n, 3) float32 positions (metres), (n, 3)
    float32 unit normals (its own when it has one per vertex, else area-weighted ones of its
    triangles; +Y where a row has no direction), the flat index array (uint16, or uint32 past
    65535 vertices) with every triangle reversed, and that index array's glTF component type.

    One pass per array in C (``exporter/mesh/c/gltf_arrays.c``), the same bits as the numpy
    formulation (:func:`local_to_gltf_positions`, :func:`unit_normals_or_up`,
    :func:`local_to_gltf_triangles`; ``tests/gltf_reference.py`` checks it)."""
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


# The JSON text of a str as json.dumps writes it (ensure_ascii: quoted, non-ASCII as \\u escapes).
_string = json.encoder.encode_basestring_ascii


def _number(value: float) -> str:
    """The JSON text of ``float(value)`` as json.dumps writes it (repr); a ValueError for NaN and
    infinities, as ``json.dumps(allow_nan=False)`` raises."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"Out of range float values are not JSON compliant: {value!r}")
    return repr(value)


def _numbers(values) -> str:
    """The JSON array of ``values`` as floats (:func:`_number`)."""
    return "[" + ",".join([_number(v) for v in values]) + "]"


def _named(text: str, name: str | None) -> str:
    """The JSON object of the members ``text`` with ``"name"`` last when ``name`` is non-empty
    (glTF leaves empty names out)."""
    return f'{{{text},"name":{_string(name)}}}' if name else f"{{{text}}}"


def _array(items: list[str]) -> str:
    return "[" + ",".join(items) + "]"


class _Document:
    """A GLB under construction: the JSON document's lists as the JSON text of their items, each
    object's keys in the glTF schema's order with absent and empty values left out, numbers and
    strings written as ``json.dumps`` writes them (what pygltflib writes for the same document;
    ``tests/gltf_reference.py``), and the binary chunk as a :class:`_Blob`."""

    def __init__(self) -> None:
        self.blob = _Blob()
        self.accessors: list[str] = []
        self.views: list[str] = []
        self.images: list[str] = []
        self.textures: list[str] = []
        self.materials: list[str] = []
        self.primitives: list[str] = []

    def view(self, data: bytes, target: int | None = None) -> int:
        offset, size = self.blob.append(data), len(data)
        target_text = "" if target is None else f',"target":{int(target)}'
        self.views.append(f'{{"buffer":0,"byteOffset":{offset},"byteLength":{size}{target_text}}}')
        return len(self.views) - 1

    def accessor(
        self,
        array: np.ndarray,
        component: int,
        kind: str,
        target: int | None,
        with_bounds: bool = False,
    ) -> int:
        view = self.view(array.tobytes(), target)
        text = (
            f'{{"bufferView":{view},"byteOffset":0,"componentType":{int(component)},'
            f'"normalized":false,"count":{len(array)},"type":{_string(kind)}'
        )
        if with_bounds:
            top, bottom = position_bounds(array)
            text += f',"max":{_numbers(top)},"min":{_numbers(bottom)}'
        self.accessors.append(text + "}")
        return len(self.accessors) - 1

    def texture(self, data: bytes, mime: str, name: str) -> int:
        """A texture of the embedded image ``data`` with the document's one sampler."""
        view = self.view(data)
        self.images.append(_named(f'"mimeType":{_string(mime)},"bufferView":{view}', name))
        self.textures.append(f'{{"sampler":0,"source":{len(self.images) - 1}}}')
        return len(self.textures) - 1

    def material(
        self, color, texture: int | None, alpha: str, cutoff: float | None, name: str
    ) -> int:
        """A material of base ``color`` (RGB[A] 0-1), base colour ``texture`` (index, or None),
        ``alpha`` mode and ``cutoff`` (None: left out), single sided."""
        pbr = f'"baseColorFactor":{_numbers(color)},"metallicFactor":0.0,"roughnessFactor":1.0'
        if texture is not None:
            pbr += f',"baseColorTexture":{{"index":{texture},"texCoord":0}}'
        text = f'"pbrMetallicRoughness":{{{pbr}}},"emissiveFactor":[0.0,0.0,0.0],"alphaMode":{_string(alpha)}'
        if cutoff is not None:
            text += f',"alphaCutoff":{_number(cutoff)}'
        self.materials.append(_named(text + ',"doubleSided":false', name))
        return len(self.materials) - 1

    def primitive(self, attributes: dict[str, int], indices: int, material: int) -> None:
        """A triangle-list primitive of the accessors ``attributes`` and ``indices``."""
        names = ",".join(f"{_string(key)}:{value}" for key, value in attributes.items())
        self.primitives.append(
            f'{{"attributes":{{{names}}},"indices":{indices},"mode":{pygltflib.TRIANGLES},'
            f'"material":{material}}}'
        )

    def json(self, name: str) -> str:
        """The document's JSON text: one mesh (the primitives), one node and one scene, all named
        ``name``; empty lists left out."""
        self.blob.align()
        members: list[tuple[str, str | list[str]]] = [
            ("accessors", self.accessors),
            ("asset", '{"generator":"vworld-lod","version":"2.0"}'),
            ("bufferViews", self.views),
            ("buffers", f'[{{"byteLength":{len(self.blob)}}}]'),
            ("images", self.images),
            ("materials", self.materials),
            ("meshes", "[" + _named(f'"primitives":{_array(self.primitives)}', name) + "]"),
            ("nodes", "[" + _named('"mesh":0', name) + "]"),
            ("samplers", [_SAMPLER] if self.textures else []),
            ("scene", "0"),
            ("scenes", f'[{{"name":{_string(name)},"nodes":[0]}}]' if name else '[{"nodes":[0]}]'),
            ("textures", self.textures),
        ]
        return (
            "{"
            + ",".join(
                f'"{key}":{value if isinstance(value, str) else _array(value)}'
                for key, value in members
                if value != []
            )
            + "}"
        )


# The document's one sampler (linear, mipmapped, repeating).
_SAMPLER = (
    f'{{"magFilter":{pygltflib.LINEAR},"minFilter":{pygltflib.LINEAR_MIPMAP_LINEAR},'
    f'"wrapS":{pygltflib.REPEAT},"wrapT":{pygltflib.REPEAT}}}'
)


def _glb(text: str, blob: _Blob) -> bytes:
    """The GLB container (header, JSON chunk padded with spaces, BIN chunk) of the JSON ``text``
    whose single buffer is ``blob`` (4-byte aligned views): byte for byte what pygltflib writes."""
    chunk = text.encode("utf-8")
    chunk += b" " * (-len(chunk) % 4)
    length = 12 + 8 + len(chunk) + 8 + len(blob)
    return b"".join(
        [
            b"glTF",
            struct.pack("<III", 2, length, len(chunk)),
            b"JSON",
            chunk,
            struct.pack("<I", len(blob)),
            b"BIN\x00",
            *blob.pieces,
        ]
    )


def glb_bytes(parts: list[Part], name: str) -> bytes:
    """Encode ``parts`` (local East/Up/North, outward winding) as a self-contained GLB.

    Parts without triangles are left out; a level must keep at least one triangle overall (the
    pipeline guarantees it). Textures must already be JPEG or PNG (the texture stage converts).
    """
    document = _Document()
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
        translucent = len(part.color) == 4 and part.color[3] < 1.0
        alpha = pygltflib.BLEND if translucent else pygltflib.OPAQUE
        texture_index = None
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
                    part.texture.data, part.texture.mime, part.texture.name
                )
            texture_index = texture_of_image[key]
            if alpha == pygltflib.OPAQUE and part.texture.has_alpha_channel:
                # (a translucent colour has made it BLEND already: that stays)
                alpha = texture_alpha_mode(bytes(part.texture.data))
        # Floorless buildings are open at the bottom, but their faces are wound outward: single
        # sided is right (and halves fill cost); the open bottom is never seen from outside.
        material = document.material(
            part.color,
            texture_index,
            alpha,
            ALPHA_CUTOFF if alpha == pygltflib.MASK else None,
            part.name or f"part{part_index}",
        )
        indices_accessor = document.accessor(
            indices, index_type, pygltflib.SCALAR, pygltflib.ELEMENT_ARRAY_BUFFER
        )
        document.primitive(attributes, indices_accessor, material)
    if not document.primitives:
        raise ValueError(f"{name}: nothing to write (no triangles)")
    return _glb(document.json(name), document.blob)
