"""The fast paths of issue 8 give exactly what the straightforward formulations give.

Each test runs a fast function and a plain reference (the textbook or library formulation it
replaced) on random or small hand-made input and asserts equality bit for bit, so a future
"speed-up" that changes a result fails here. Coordinates are arbitrary metres (frame-free).
"""

import io

import numpy as np
import pytest
from gltf_reference import reference_glb_bytes
from PIL import Image
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import exporter.gltf_writer as gltf_writer
from exporter.mesh.distance import SurfaceIndex, point_triangle_distance
from exporter.mesh.geometry import cross_rows
from exporter.mesh.topology import unique_rows
from exporter.model import Part, Texture
from exporter.simplify import uv_charts


def reference_point_triangle_distance(points, tri):
    """Ericson 5.1.5 with np.where over (..., 3) arrays (the original implementation)."""
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    p = points
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - c
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = np.where(denom != 0, vb / denom, 0.0)
        w = np.where(denom != 0, vc / denom, 0.0)
        closest = a + ab * v[..., None] + ac * w[..., None]
        t = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
        closest = np.where(
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[..., None],
            b + t[..., None] * (c - b),
            closest,
        )
        t = np.clip(d2 / (d2 - d6), 0, 1)
        closest = np.where(
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0))[..., None], a + t[..., None] * ac, closest
        )
        t = np.clip(d1 / (d1 - d3), 0, 1)
        closest = np.where(
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0))[..., None], a + t[..., None] * ab, closest
        )
    closest = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, closest)
    closest = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, closest)
    closest = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, closest)
    distance = np.linalg.norm(p - closest, axis=-1)
    bad = np.isnan(distance)
    corners = np.minimum(
        np.minimum(np.linalg.norm(p - a, axis=-1), np.linalg.norm(p - b, axis=-1)),
        np.linalg.norm(p - c, axis=-1),
    )
    return np.where(bad, corners, distance)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 300.0, 1e6])
def test_point_triangle_distance_is_bit_identical_to_the_textbook_form(scale):
    rng = np.random.default_rng(int(scale * 1000))
    tri = rng.normal(size=(3000, 6, 3, 3)) * scale
    tri[::7, :, 2] = tri[::7, :, 1]  # degenerate: two corners equal
    tri[::11] = tri[::11, :, :1]  # degenerate: a point
    points = rng.normal(size=(3000, 1, 3)) * scale
    points[::5, 0] = tri[::5, 0, 1]  # on a corner
    fast = point_triangle_distance(points, tri)
    assert fast.shape == (3000, 6)
    assert np.array_equal(fast, reference_point_triangle_distance(points, tri))
    flat = point_triangle_distance(points[:, 0], tri[:, 0])
    assert np.array_equal(flat, reference_point_triangle_distance(points[:, 0], tri[:, 0]))


def random_mesh(rng, vertices=60, faces=120):
    positions = rng.normal(size=(vertices, 3)) * 10.0
    return positions, rng.integers(0, vertices, size=(faces, 3))


def test_surface_index_maxima_and_coverage_equal_every_exact_distance():
    rng = np.random.default_rng(5)
    for _ in range(5):
        positions, faces = random_mesh(rng)
        index = SurfaceIndex(positions, faces)
        points = np.vstack([rng.normal(size=(200, 3)) * 12.0, positions[:20]])
        exact = reference_point_triangle_distance(points[:, None, :], positions[faces][None]).min(
            axis=1
        )
        assert index.max_distance(points) == exact.max()
        assert np.array_equal(index.distance(points), exact)
        tolerance = float(np.median(exact))
        assert np.array_equal(index.within(points, tolerance), exact <= tolerance)


def test_uv_charts_match_the_face_face_graph():
    rng = np.random.default_rng(2)
    for _ in range(50):
        vertices = int(rng.integers(3, 200))
        faces = rng.integers(0, vertices, size=(int(rng.integers(1, 150)), 3))
        shared = coo_matrix(
            (np.ones(faces.size), (np.repeat(np.arange(len(faces)), 3), faces.reshape(-1))),
            shape=(len(faces), vertices),
        ).tocsr()
        _, expected = connected_components(shared @ shared.T, directed=False)
        assert np.array_equal(uv_charts(faces, vertices), expected)


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"return_counts": True},
        {"return_index": True, "return_counts": True},
        {"return_index": True, "return_inverse": True},
    ],
)
def test_unique_rows_matches_numpy_unique_axis_0(options):
    rng = np.random.default_rng(3)
    pairs = np.sort(rng.integers(0, 40, size=(500, 2)), axis=1)
    fast, slow = unique_rows(pairs, **options), np.unique(pairs, axis=0, **options)
    fast, slow = (fast, slow) if options else ((fast,), (slow,))
    for a, b in zip(fast, slow):
        assert np.array_equal(a.reshape(-1), b.reshape(-1))


def test_cross_rows_is_numpy_cross():
    rng = np.random.default_rng(4)
    u, v = rng.normal(size=(1000, 3)), rng.normal(size=(1000, 3))
    assert np.array_equal(cross_rows(u, v), np.cross(u, v))


def texture(mode, mime):
    buffer = io.BytesIO()
    Image.new(mode, (16, 8), (200, 100, 50, 128)[: len(mode)]).save(
        buffer, mime.split("/")[1].upper()
    )
    return Texture(buffer.getvalue(), mime, 16, 8, f"atlas.{mime.split('/')[1]}")


@pytest.mark.parametrize(
    "mime, mode, alpha",
    [
        ("image/jpeg", "RGB", "OPAQUE"),
        ("image/png", "RGBA", "BLEND"),  # alpha 128 everywhere: translucent
        ("image/png", "cut-out", "MASK"),  # clear and opaque halves
        (None, None, None),
    ],
)
def test_glb_bytes_are_pygltflib_bytes(mime, mode, alpha):
    quad = dict(
        positions=[[0, 0, 0], [2, 0, 0], [2, 3, 0], [0, 3, 0]],
        triangles=[[0, 1, 2], [0, 2, 3]],
        uvs=[[0, 1], [1, 1], [1, 0], [0, 0]],
    )
    atlas = None
    if mode == "cut-out":
        image = Image.new("RGBA", (16, 8), (200, 100, 50, 255))
        image.paste((0, 0, 0, 0), (0, 0, 8, 8))
        buffer = io.BytesIO()
        image.save(buffer, "PNG")
        atlas = Texture(buffer.getvalue(), "image/png", 16, 8, "atlas.png")
    elif mime:
        atlas = texture(mode, mime)
    parts = [
        Part(**quad, texture=atlas, name="wall"),
        Part(
            positions=np.array(quad["positions"]) + 5.0,
            triangles=quad["triangles"],
            color=(0.5, 0.5, 0.5, 0.4),
        ),
    ]
    fast = gltf_writer.glb_bytes(parts, "B1_LOD0")
    assert fast == reference_glb_bytes(parts, "B1_LOD0")
    if alpha is not None:
        assert f'"alphaMode":"{alpha}"'.encode() in fast
        assert (b'"alphaCutoff":0.5' in fast) == (alpha == "MASK")


def test_unique_points_matches_numpy_unique_axis_0():
    from exporter.mesh.geometry import unique_float_rows

    rng = np.random.default_rng(6)
    keys = np.round(rng.integers(-20, 20, size=(2000, 3)) * 1.37 / 1e-6)
    keys[::4] *= -1.0  # includes -0.0 next to 0.0
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    fast_first, fast_inverse = unique_float_rows(keys)
    assert np.array_equal(fast_first, first)
    assert np.array_equal(fast_inverse, inverse.reshape(-1))
