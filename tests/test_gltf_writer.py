"""glTF writer: frame change (local East/Up/North -> glTF West/Up/North), winding, validity."""

import io

import numpy as np
import pygltflib
import pytest
from PIL import Image

from exporter.gltf_writer import glb_bytes, unit_normals_or_up
from exporter.mesh.geometry import vertex_normals
from exporter.model import Part, Texture


def jpeg(size=(32, 16), colour=(180, 90, 40)):
    buffer = io.BytesIO()
    Image.new("RGB", size, colour).save(buffer, "JPEG")
    return Texture(buffer.getvalue(), "image/jpeg", size[0], size[1], "facade.jpg")


def east_wall():
    """A wall facing East (+x in local East/Up/North), wound outward: cross points +x."""
    positions = [[2, 0, -1], [2, 0, 1], [2, 3, 1], [2, 3, -1]]
    triangles = [[0, 2, 1], [0, 3, 2]]
    uvs = [[0, 1], [1, 1], [1, 0], [0, 0]]
    return Part(positions=positions, triangles=triangles, uvs=uvs, texture=jpeg())


def read_glb(data):
    gltf = pygltflib.GLTF2.load_from_bytes(data)
    blob = gltf.binary_blob()

    def array(index, dtype, width):
        accessor = gltf.accessors[index]
        view = gltf.bufferViews[accessor.bufferView]
        raw = blob[view.byteOffset : view.byteOffset + view.byteLength]
        return np.frombuffer(raw, dtype=dtype).reshape(-1, width)

    return gltf, array


def test_local_outward_faces_stay_outward_in_gltf_and_after_gltfast_import():
    part = east_wall()
    assert (
        np.cross(*(part.positions[part.triangles[0, 1:]] - part.positions[part.triangles[0, 0]]))[0]
        > 0
    )
    gltf, array = read_glb(glb_bytes([part], "wall"))
    primitive = gltf.meshes[0].primitives[0]
    positions = array(primitive.attributes.POSITION, np.float32, 3)
    indices = array(primitive.indices, np.uint16, 3)
    # glTF frame: +X = West, so an East-facing wall sits at x = -2 and faces -x (CCW front faces).
    assert np.allclose(positions[:, 0], -2)
    a, b, c = (positions[indices[:, i]] for i in range(3))
    assert np.all(np.cross(b - a, c - a)[:, 0] < 0)
    normals = array(primitive.attributes.NORMAL, np.float32, 3)
    assert np.allclose(normals, [[-1, 0, 0]] * 4, atol=1e-6)
    # What glTFast does: negate X, reverse winding -> back in local East/Up/North, facing +x.
    unity = positions * [-1, 1, 1]
    reversed_ = indices[:, [0, 2, 1]]
    a, b, c = (unity[reversed_[:, i]] for i in range(3))
    assert np.all(np.cross(b - a, c - a)[:, 0] > 0)


def test_file_is_self_contained_with_default_scene_material_and_texture():
    part = east_wall()
    data = glb_bytes([part, part], "b")
    gltf, _ = read_glb(data)
    assert gltf.scene == 0 and gltf.scenes[0].nodes == [0]
    assert len(gltf.meshes[0].primitives) == 2
    assert len(gltf.images) == 1, "a texture shared by two parts is embedded once"
    assert gltf.images[0].mimeType == "image/jpeg" and gltf.buffers[0].uri is None
    image_view = gltf.bufferViews[gltf.images[0].bufferView]
    blob = gltf.binary_blob()
    assert (
        blob[image_view.byteOffset : image_view.byteOffset + image_view.byteLength]
        == part.texture.data
    )


def test_untextured_part_and_missing_normals_are_valid(gltf_validator, tmp_path):
    part = Part(
        positions=[[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]],
        triangles=[[0, 2, 1]],
        color=(0.5, 0.5, 0.5, 1),
    )
    path = tmp_path / "plain.glb"
    path.write_bytes(glb_bytes([part, east_wall()], "plain"))
    report = gltf_validator([path])[0]
    assert report["errors"] == 0, report["messages"]


def test_vertex_normals_are_unit_and_isolated_vertices_point_up():
    normals = unit_normals_or_up(
        vertex_normals(
            np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [9, 9, 9]], float), np.array([[0, 2, 1]])
        )
    )
    assert np.allclose(np.linalg.norm(normals, axis=1), 1)
    assert np.allclose(normals[0], [0, 1, 0]) and np.allclose(normals[3], [0, 1, 0])


def test_empty_level_and_non_gltf_texture_are_refused():
    with pytest.raises(ValueError, match="no triangles"):
        glb_bytes([Part(positions=np.zeros((0, 3)), triangles=np.zeros((0, 3)))], "empty")
    part = east_wall()
    part.texture = Texture(b"BM...", "image/bmp", 4, 4, "x.bmp")
    with pytest.raises(ValueError, match="image/jpeg or image/png"):
        glb_bytes([part], "bmp")
