"""glTF writer: frame change (local East/Up/North -> glTF West/Up/North), winding, validity."""

import io

import numpy as np
import pygltflib
import pytest
from PIL import Image

from exporter.gltf_writer import glb_bytes, gltf_arrays
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
    # The writer's normals (glTF frame: X negated, which keeps length and +Y).
    normals = gltf_arrays(
        Part(
            positions=np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [9, 9, 9]], float),
            triangles=np.array([[0, 2, 1]]),
        )
    )[1]
    assert np.allclose(np.linalg.norm(normals, axis=1), 1)
    assert np.allclose(normals[0], [0, 1, 0]) and np.allclose(normals[3], [0, 1, 0])


def test_vertex_normals_sum_the_corners_as_add_at_does_bit_for_bit():
    """The writer's normals are part of every level's bytes: the bincount form sums each vertex's
    face normals in np.add.at's order (first corners, then second, then third)."""
    from exporter.mesh.geometry import triangle_cross, unit_vectors, vertex_normals

    rng = np.random.default_rng(7)
    for vertices, faces in [(4, 0), (3, 1), (500, 2000), (20_000, 40_000)]:
        positions = rng.normal(size=(vertices, 3)) * 1e3
        triangles = rng.integers(0, vertices, (faces, 3))
        summed = np.zeros((vertices, 3))
        for k in range(3):
            np.add.at(summed, triangles[:, k], triangle_cross(positions, triangles))
        expected = unit_vectors(summed) if faces else np.zeros((vertices, 3))
        found = vertex_normals(positions, triangles)
        assert found.tobytes() == expected.tobytes()


def test_empty_level_and_non_gltf_texture_are_refused():
    with pytest.raises(ValueError, match="no triangles"):
        glb_bytes([Part(positions=np.zeros((0, 3)), triangles=np.zeros((0, 3)))], "empty")
    part = east_wall()
    part.texture = Texture(b"BM...", "image/bmp", 4, 4, "x.bmp")
    with pytest.raises(ValueError, match="image/jpeg or image/png"):
        glb_bytes([part], "bmp")


# --------------------------------------------------------------------------- alpha


def png(alpha: np.ndarray, mode: str = "RGBA") -> Texture:
    """A PNG atlas with the given (h, w) uint8 alpha over a brick colour."""
    height, width = alpha.shape
    rgba = np.zeros((height, width, 4), np.uint8)
    rgba[..., :3] = (150, 70, 40)
    rgba[..., 3] = alpha
    image = Image.fromarray(rgba, "RGBA")
    buffer = io.BytesIO()
    (image if mode == "RGBA" else image.convert(mode)).save(buffer, "PNG")
    return Texture(buffer.getvalue(), "image/png", width, height, "atlas.png")


def windows(size: int = 256) -> np.ndarray:
    """A facade atlas with cut-out windows: binary alpha, 16 clear 23 x 31 holes at odd pixels
    (so that reductions cut through them)."""
    alpha = np.full((size, size), 255, np.uint8)
    for y in range(17, size - 40, 64):
        for x in range(19, size - 30, 64):
            alpha[y : y + 31, x : x + 23] = 0
    return alpha


def written_material(texture: Texture, color=(1, 1, 1, 1)) -> pygltflib.Material:
    """The material of a wall textured with ``texture``, read back from the written GLB."""
    part = east_wall()
    part.texture, part.color = texture, color
    gltf, _ = read_glb(glb_bytes([part], "wall"))
    return gltf.materials[gltf.meshes[0].primitives[0].material]


def test_cut_out_atlas_is_masked_at_every_reduction():
    alpha = windows()
    material = written_material(png(alpha))
    assert material.alphaMode == "MASK" and material.alphaCutoff == 0.5
    # Reduced levels have partial rims along the holes (Lanczos and box, as the texture stage
    # makes them): still a cut-out, not translucency.
    for size in (128, 64, 32):  # windows down to 3 x 4 pixels
        for method in (Image.LANCZOS, Image.BOX, Image.BILINEAR):
            reduced = np.asarray(Image.fromarray(alpha).resize((size, size), method))
            assert ((reduced > 7) & (reduced < 248)).mean() > 0.02, "the reduction made rims"
            material = written_material(png(reduced))
            assert (material.alphaMode, material.alphaCutoff) == ("MASK", 0.5), (size, method)


def test_translucent_atlas_is_blended_and_opaque_ones_stay_opaque():
    glass = windows()
    glass[glass == 0] = 110  # tinted glass instead of holes
    for size in (256, 64, 32):  # the panes down to 3 x 4 pixels
        reduced = np.asarray(Image.fromarray(glass).resize((size, size), Image.LANCZOS))
        material = written_material(png(reduced))
        assert material.alphaMode == "BLEND" and material.alphaCutoff is None, size
    # Glass beside cut-out holes: the wide translucent panes decide.
    glass[:, :128] = windows()[:, :128]
    assert written_material(png(glass)).alphaMode == "BLEND"
    # A palette PNG with one transparent index is a cut-out too.
    assert written_material(png(windows(), mode="P")).alphaMode == "MASK"
    for texture in (png(np.full((64, 64), 255, np.uint8)), png(windows(), mode="RGB"), jpeg()):
        material = written_material(texture)
        assert material.alphaMode == "OPAQUE" and material.alphaCutoff is None, texture.name
    # A translucent colour stays BLEND whatever the atlas.
    assert written_material(png(windows()), color=(1, 1, 1, 0.5)).alphaMode == "BLEND"


def test_alpha_modes_are_valid_gltf(gltf_validator, tmp_path):
    glass = windows()
    glass[glass == 0] = 110
    parts = []
    for texture in (png(windows()), png(glass)):
        part = east_wall()
        part.texture = texture
        parts.append(part)
    path = tmp_path / "alpha.glb"
    path.write_bytes(glb_bytes(parts, "alpha"))
    report = gltf_validator([path])[0]
    assert report["errors"] == 0, report["messages"]
