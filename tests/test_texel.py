"""exporter/texel.py: the on-surface texel size of a textured mesh."""

import math

import numpy as np

from exporter.texel import face_texels, texel_size_m, weighted_quantile

# A 4 m x 2 m wall in the local East/Up/North frame (metres), two triangles, mapped once onto the atlas.
WALL = np.array([[0, 0, 0], [4, 0, 0], [4, 2, 0], [0, 2, 0]], dtype=float)
WALL_UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=float)
WALL_FACES = np.array([[0, 1, 2], [0, 2, 3]])


def test_a_wall_mapped_once_has_sqrt_area_over_pixels():
    size = texel_size_m(WALL, WALL_FACES, WALL_UV, (512, 256))
    assert math.isclose(size, math.sqrt(8.0 / (512 * 256)))


def test_halving_the_atlas_per_side_doubles_the_texel():
    full = texel_size_m(WALL, WALL_FACES, WALL_UV, (1024, 1024))
    half = texel_size_m(WALL, WALL_FACES, WALL_UV, (512, 512))
    assert math.isclose(half, 2 * full)


def test_faces_without_uv_area_are_left_out_and_slivers_weigh_little():
    # A second wall mapped onto one point (flat colour) and a sliver mapped onto the whole atlas.
    positions = np.vstack([WALL, WALL + [0, 0, 5], [[0, 0, 9], [4, 0, 9], [4, 0.001, 9]]])
    uvs = np.vstack([WALL_UV, np.full((4, 2), 0.5), [[0, 1], [1, 1], [1, 0]]])
    faces = np.vstack([WALL_FACES, WALL_FACES + 4, [[8, 9, 10]]])
    sizes, areas = face_texels(positions, faces, uvs, (256, 256))
    assert len(sizes) == 3  # the point-mapped wall's two faces are gone
    assert math.isclose(
        texel_size_m(positions, faces, uvs, (256, 256)),
        texel_size_m(WALL, WALL_FACES, WALL_UV, (256, 256)),
    )


def test_weighted_quantile_follows_the_weights():
    assert weighted_quantile(np.array([1.0, 10.0]), np.array([3.0, 1.0])) == 1.0
    assert weighted_quantile(np.array([1.0, 10.0]), np.array([1.0, 3.0])) == 10.0
    assert math.isnan(weighted_quantile(np.zeros(0), np.zeros(0)))
