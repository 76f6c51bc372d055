"""The plain formulation of ``exporter.gltf_writer.glb_bytes``, for the equality tests: the
document built with pygltflib's dataclasses and written by pygltflib's own ``save_to_bytes``
(what the writer did before it built the JSON itself). Frames as in the writer: local
East/Up/North in, glTF (West, Up, North) out."""

from __future__ import annotations

import numpy as np
import pygltflib

from exporter.gltf_writer import ALPHA_CUTOFF, texture_alpha_mode
from exporter.mesh.geometry import unit_vectors, vertex_normals


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


def reference_gltf_arrays(part):
    """The numpy formulation of ``gltf_writer.gltf_arrays`` (its C kernel gives the same bits)."""
    positions = local_to_gltf_positions(part.positions)
    local = (
        part.normals
        if part.normals is not None and len(part.normals) == len(part.positions)
        else vertex_normals(part.positions, part.triangles)
    )
    normals = unit_normals_or_up(local)
    normals[:, 0] *= -1.0
    small = len(positions) <= 65535
    indices = (
        local_to_gltf_triangles(part.triangles)
        .astype(np.uint16 if small else np.uint32)
        .reshape(-1)
    )
    return (
        positions,
        normals,
        indices,
        pygltflib.UNSIGNED_SHORT if small else pygltflib.UNSIGNED_INT,
    )


def reference_glb_bytes(parts, name: str) -> bytes:
    gltf = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="vworld-lod"))
    blob = bytearray()

    def view(data: bytes, target=None) -> int:
        blob.extend(bytes(-len(blob) % 4))
        item = pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data))
        if target is not None:
            item.target = target
        blob.extend(data)
        gltf.bufferViews.append(item)
        return len(gltf.bufferViews) - 1

    def accessor(array, component, kind, target, with_bounds=False) -> int:
        item = pygltflib.Accessor(
            bufferView=view(array.tobytes(), target),
            componentType=component,
            count=int(len(array)),
            type=kind,
        )
        if with_bounds:
            item.min = [float(v) for v in array.min(axis=0)]
            item.max = [float(v) for v in array.max(axis=0)]
        gltf.accessors.append(item)
        return len(gltf.accessors) - 1

    primitives = []
    texture_of_image: dict[int, int] = {}
    kept = [(index, part) for index, part in enumerate(parts) if part.triangle_count]
    for part_index, part in kept:
        positions, normals, indices, index_type = reference_gltf_arrays(part)
        attributes = pygltflib.Attributes(
            POSITION=accessor(positions, pygltflib.FLOAT, pygltflib.VEC3, 34962, True),
            NORMAL=accessor(normals, pygltflib.FLOAT, pygltflib.VEC3, 34962),
        )
        material = pygltflib.Material(
            name=part.name or f"part{part_index}",
            pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                baseColorFactor=[float(c) for c in part.color],
                metallicFactor=0.0,
                roughnessFactor=1.0,
            ),
            doubleSided=False,
        )
        if len(part.color) == 4 and part.color[3] < 1.0:
            material.alphaMode = pygltflib.BLEND
        if (
            part.texture is not None
            and part.uvs is not None
            and len(part.uvs) == len(part.positions)
        ):
            uvs = np.ascontiguousarray(part.uvs, dtype=np.float32)
            attributes.TEXCOORD_0 = accessor(uvs, pygltflib.FLOAT, pygltflib.VEC2, 34962)
            if not gltf.samplers:
                gltf.samplers.append(
                    pygltflib.Sampler(
                        magFilter=pygltflib.LINEAR,
                        minFilter=pygltflib.LINEAR_MIPMAP_LINEAR,
                        wrapS=pygltflib.REPEAT,
                        wrapT=pygltflib.REPEAT,
                    )
                )
            if id(part.texture) not in texture_of_image:
                gltf.images.append(
                    pygltflib.Image(
                        bufferView=view(part.texture.data),
                        mimeType=part.texture.mime,
                        name=part.texture.name or None,
                    )
                )
                gltf.textures.append(pygltflib.Texture(sampler=0, source=len(gltf.images) - 1))
                texture_of_image[id(part.texture)] = len(gltf.textures) - 1
            material.pbrMetallicRoughness.baseColorTexture = pygltflib.TextureInfo(
                index=texture_of_image[id(part.texture)]
            )
            if material.alphaMode == pygltflib.OPAQUE and part.texture.has_alpha_channel:
                material.alphaMode = texture_alpha_mode(bytes(part.texture.data))
                if material.alphaMode == pygltflib.MASK:
                    material.alphaCutoff = ALPHA_CUTOFF
        gltf.materials.append(material)
        primitives.append(
            pygltflib.Primitive(
                attributes=attributes,
                indices=accessor(indices, index_type, pygltflib.SCALAR, 34963),
                material=len(gltf.materials) - 1,
                mode=pygltflib.TRIANGLES,
            )
        )
    gltf.meshes.append(pygltflib.Mesh(name=name, primitives=primitives))
    gltf.nodes.append(pygltflib.Node(name=name, mesh=0))
    gltf.scenes.append(pygltflib.Scene(name=name, nodes=[0]))
    gltf.scene = 0
    blob.extend(bytes(-len(blob) % 4))
    gltf.buffers.append(pygltflib.Buffer(byteLength=len(blob)))
    gltf.set_binary_blob(bytes(blob))
    return b"".join(gltf.save_to_bytes())
