"""The simplifier's glue moved off per-call numpy work: compiled face areas and UV signs
(exporter/mesh/c/area.c), the slit pairs between back-to-back faces (exporter/mesh/c/facing.c)
and the exact-match shortcut of the split's normal lookup, each against the numpy form it
replaces, bit for bit, on generated buildings and on random and degenerate input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from exporter.mesh._foldover import expected as wedge_orientation
from exporter.mesh._foldover import flipped as flipped_faces
from exporter.mesh.geometry import cross_rows, row_norms
from exporter.mesh.raster import min_iou, rasterise
from exporter.mesh.slit_kernels import inside_sides
from exporter.mesh.slits import SLIT_M, _facing_partner, border_sides
from exporter.quality import joined
from exporter.samplegen import generate_buildings
from exporter.simplify import nearest_rows, uv_charts
from exporter.simplify.protect import face_areas
from exporter.simplify.quadric import uv_signs


def reference_face_areas(positions, faces):
    """The former numpy face_areas (protect.py before area.c)."""
    a, b, c = positions[faces[:, 0]], positions[faces[:, 1]], positions[faces[:, 2]]
    return 0.5 * row_norms(cross_rows(b - a, c - a))


def same_bits(x, y) -> bool:
    return x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


@pytest.fixture(scope="module")
def buildings():
    return generate_buildings(6, seed=11, atlas_size=16, two_part_share=0.5)


def test_face_areas_equal_numpy_on_generated_buildings(buildings):
    for building in buildings:
        for part in building.parts:
            got = face_areas(part.positions, part.triangles)
            assert same_bits(got, reference_face_areas(part.positions, part.triangles))


def test_face_areas_equal_numpy_on_random_and_degenerate_faces():
    rng = np.random.default_rng(5)
    for scale in (1e-9, 1e-3, 1.0, 1e3, 1e7):
        positions = rng.normal(size=(60, 3)) * scale
        positions[:5] = positions[5]  # repeated positions: zero-area faces
        positions[10:15] = positions[20] + np.outer(np.arange(5), [1.0, 2.0, 3.0]) * scale
        faces = rng.integers(0, 60, size=(400, 3))
        faces[:20, 1] = faces[:20, 0]  # repeated indices
        faces[20:40] = rng.integers(10, 15, size=(20, 3))  # collinear
        assert same_bits(face_areas(positions, faces), reference_face_areas(positions, faces))
        faces32 = faces.astype(np.int32)
        assert same_bits(face_areas(positions, faces32), reference_face_areas(positions, faces32))
    # float32 positions keep numpy's float32 arithmetic
    p32 = rng.normal(size=(30, 3)).astype(np.float32)
    f = rng.integers(0, 30, size=(50, 3))
    assert same_bits(face_areas(p32, f), reference_face_areas(p32, f))
    assert face_areas(np.zeros((0, 3)), np.zeros((0, 3), np.int64)).shape == (0,)


def test_face_areas_refuse_out_of_range_faces():
    with pytest.raises(ValueError, match="outside"):
        face_areas(np.zeros((3, 3)), np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="outside"):
        face_areas(np.zeros((3, 3)), np.array([[0, -1, 2]]))


def test_nearest_rows_give_the_tree_s_values():
    rng = np.random.default_rng(8)
    for _ in range(60):
        n = int(rng.integers(1, 80))
        src = np.round(rng.normal(size=(n, 5)), 1)
        src[rng.integers(0, n, n // 3)] = src[rng.integers(0, n, n // 3)]  # duplicates
        src[: n // 4, 0] = -0.0 * src[: n // 4, 0]  # signed zeros
        values = rng.integers(0, 3, size=(n, 3)).astype(np.float32)
        # Duplicate rows with equal values (the shortcut) and with different ones (the tree).
        query = np.concatenate(
            [
                src[rng.integers(0, n, 30)],
                src[rng.integers(0, n, 10)] + rng.normal(size=(10, 5)) * 1e-7,
            ]
        )
        query[:3, 0] = np.abs(query[:3, 0])
        nearest = nearest_rows(src, query, values)
        expected = cKDTree(src).query(query)[1]
        assert same_bits(values[nearest], values[expected])


def reference_facing_partner(positions, faces, sides, start, end, side, vertex):
    """The former numpy _facing_partner (slits.py before facing.c)."""
    if not len(side):
        return np.zeros(0, dtype=bool)
    border_faces = np.unique(sides // 3)
    a, b, c = (positions[faces[border_faces, i]] for i in range(3))
    normal = np.zeros((len(faces), 3))
    cross = cross_rows(b - a, c - a)
    normal[border_faces] = cross / np.maximum(row_norms(cross), 1e-30)[:, None]
    ends = np.concatenate([start, end])
    owner = np.concatenate([sides, sides])
    order = np.argsort(ends, kind="stable")
    ends, owner = ends[order], owner[order]
    lo = np.searchsorted(ends, vertex, "left")
    count = np.searchsorted(ends, vertex, "right") - lo
    pair = np.repeat(np.arange(len(side)), count)
    partner = owner[np.arange(len(pair)) - np.repeat(np.cumsum(count) - count, count) + lo[pair]]
    against = (normal[partner // 3] * normal[side[pair] // 3]).sum(axis=1) < -0.5
    facing = np.zeros(len(side), dtype=bool)
    facing[pair[against]] = True
    return facing


def _pairs(positions, faces, rng=None):
    """Inputs of _facing_partner: slit_points' own on a mesh, or random border sides and pairs."""
    sides = border_sides(faces, len(positions))
    start = faces.reshape(-1)[sides]
    end = faces[sides // 3, (sides % 3 + 1) % 3]
    if rng is None:
        points = np.unique(np.concatenate([start, end]))
        column, vertex, _ = inside_sides(positions, points, start, end, SLIT_M)
        return sides, start, end, sides[column], vertex
    count = int(rng.integers(0, 3 * len(sides) + 1))
    side = sides[rng.integers(0, len(sides), count)] if len(sides) else np.zeros(0, np.int64)
    return sides, start, end, side, rng.integers(0, len(positions), len(side))


def test_facing_partner_equals_numpy(buildings):
    rng = np.random.default_rng(3)
    meshes = [joined(b.parts)[:2] for b in buildings]
    for _ in range(30):
        positions = np.round(rng.normal(size=(12, 3)), 1)
        faces = rng.integers(0, 12, size=(int(rng.integers(1, 20)), 3))
        # back-to-back copies (reversed winding) and degenerate faces
        faces = np.concatenate([faces, faces[: len(faces) // 2, ::-1], [[0, 0, 1], [2, 2, 2]]])
        meshes.append((positions, faces))
    tested = 0
    for positions, faces in meshes:
        for args in (_pairs(positions, faces), _pairs(positions, faces, rng)):
            got = _facing_partner(positions, faces, *args)
            expected = reference_facing_partner(positions, faces, *args)
            assert same_bits(got, expected)
            tested += int(expected.sum())
    assert tested > 0  # some pairs do face each other


def test_facing_partner_refuses_bad_indices():
    positions, faces = np.zeros((3, 3)), np.array([[0, 1, 2]])
    one = np.array([0])
    with pytest.raises(ValueError, match="outside"):
        _facing_partner(positions, faces, np.array([3]), one, one, one, one)
    with pytest.raises(ValueError, match="outside"):
        _facing_partner(positions, faces, one, one, one, one, np.array([-1]))


def reference_uv_signs(corner_uvs):
    """The former numpy uv_signs (quadric.py before area.c)."""
    d1 = (corner_uvs[:, 1] - corner_uvs[:, 0]).astype(np.float64)
    d2 = (corner_uvs[:, 2] - corner_uvs[:, 0]).astype(np.float64)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    return np.sign(np.where(np.abs(cross) < 1e-12, 0.0, cross)).astype(np.int8)


def test_uv_signs_equal_numpy(buildings):
    rng = np.random.default_rng(6)
    uvs = [p.uvs[p.triangles] for b in buildings for p in b.parts if p.uvs is not None]
    scale = 10.0 ** rng.integers(-7, 2, size=(5000, 1, 1))
    random = (rng.random((5000, 3, 2)) * scale).astype(np.float32)
    random[:50, 1] = random[:50, 0]  # degenerate in UV
    random[50:60, 2] = np.nan
    for corner_uvs in [*uvs, random, np.zeros((0, 3, 2), np.float32)]:
        with np.errstate(invalid="ignore"):
            expected = reference_uv_signs(corner_uvs)
        assert same_bits(uv_signs(corner_uvs), expected)
    float64 = random[60:].astype(np.float64)  # other dtypes keep numpy's own arithmetic
    assert same_bits(uv_signs(float64), reference_uv_signs(float64))


@pytest.mark.parametrize("size", [1, 2, 128])
def test_rasterise_clips_rows_and_columns_as_numpy(size):
    """raster.c's integer ceil / floor with clipping, at their boundaries: coordinates on and
    next to 0, the last pixel and one past it (k +- 0.5, their neighbouring doubles) and far
    outside, against the numpy reference of tests/test_perf_quality.py (which parts from the
    kernel where slopes overflow: coordinates near 1e300 or infinite)."""
    from test_perf_quality import reference_rasterise

    top = size - 1.0
    edges = [-1e9, -1.5, -1.0, -0.5, -0.0, 0.0, 0.5, 1.0, top - 0.5, top, top + 0.5]
    edges += [top + 1.0, top + 1.5, 2.0**40, 1e9]
    edges += [k / 2 for k in range(-4, 2 * size + 4)]  # whole and half pixels everywhere
    values = np.array(edges + [np.nextafter(v, w) for v in edges for w in (-np.inf, np.inf)])
    rng = np.random.default_rng(size)
    for _ in range(100):
        xy = rng.choice(values, size=(30, 2))
        xy[::2] = rng.random((15, 2)) * (size + 2) - 1  # with ordinary corners
        faces = rng.integers(0, len(xy), size=(60, 3))
        with np.errstate(over="ignore", invalid="ignore"):  # the reference's far slopes
            expected = reference_rasterise(xy, faces, size)
        assert np.array_equal(rasterise(xy, faces, size), expected)


def test_uv_charts_refuse_out_of_range_faces():
    for bad in (-1, 3):
        with pytest.raises(ValueError, match="out of range"):
            uv_charts(np.array([[0, 1, 2], [0, 1, bad]]), 3)


def reference_cross_rows(u, v):
    """The numpy cross_rows (geometry.py; still its form for other dtypes and broadcasting)."""
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


def test_cross_rows_equal_numpy():
    rng = np.random.default_rng(9)
    u = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-9, 9, size=(500, 1))
    v = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-9, 9, size=(500, 1))
    v[:20] = u[:20] * 3.0  # parallel: zero up to rounding
    cases = [(u, v), (u[::-1], v[::2].repeat(2, axis=0)), (u[:0], v[:0])]  # strided, empty
    cases += [(u.astype(np.float32), v.astype(np.float32)), (u, v[:1]), (u[:1], v)]  # fallbacks
    for a, b in cases:
        assert same_bits(cross_rows(a, b), reference_cross_rows(a, b))


def reference_expected(wedge_faces, signs, w):
    """The former numpy orientation per wedge (meshopt.collapse before foldover.c)."""
    signs = np.repeat(signs.astype(np.int64), 3)
    low, high = np.full(w, 2), np.full(w, -2)
    np.minimum.at(low, wedge_faces.reshape(-1), signs)
    np.maximum.at(high, wedge_faces.reshape(-1), signs)
    return np.where(low == high, low, 0)


def reference_flipped(expected, out, signs):
    """The former numpy foldover test (meshopt.collapse before foldover.c)."""
    want = expected[out]
    agreed = np.where(want[:, 0] != 0, want[:, 0], np.where(want[:, 1] != 0, *want[:, 1:].T))
    return (agreed != 0) & (signs == -agreed)


def test_foldover_equals_numpy():
    rng = np.random.default_rng(12)
    for _ in range(50):
        w = int(rng.integers(1, 40))
        faces = rng.integers(0, w, size=(int(rng.integers(0, 60)), 3))
        signs = rng.integers(-1, 2, size=len(faces)).astype(np.int8)
        signs[: len(signs) // 2] = 1  # mostly agreeing wedges
        expected = wedge_orientation(faces, signs, w + 3)  # unused wedges: 0
        assert same_bits(expected, reference_expected(faces, signs, w + 3))
        out = rng.integers(0, w + 3, size=(int(rng.integers(0, 40)), 3))
        out_signs = rng.integers(-1, 2, size=len(out)).astype(np.int8)
        assert same_bits(
            flipped_faces(expected, out, out_signs), reference_flipped(expected, out, out_signs)
        )
    with pytest.raises(ValueError, match="outside"):
        wedge_orientation(np.array([[0, 1, 5]]), np.ones(1, np.int8), 5)
    with pytest.raises(ValueError, match="outside"):
        flipped_faces(np.zeros(3, np.int64), np.array([[0, 1, 3]]), np.ones(1, np.int8))


def reference_min_iou(source, level):
    """The former numpy min_iou (raster.py before raster.c's overlaps)."""
    unions = (source | level).sum(axis=(1, 2))
    overlaps = (source & level).sum(axis=(1, 2))
    return min(float(o / u) if u else 1.0 for o, u in zip(overlaps.tolist(), unions.tolist()))


def test_min_iou_equals_numpy():
    rng = np.random.default_rng(13)
    for density in (0.0, 0.01, 0.5, 1.0):
        a = rng.random((3, 32, 32)) < density
        b = rng.random((3, 32, 32)) < density
        b[1] = a[1]
        for x, y in ((a, b), (a, a), (a[:1], b[:1]), (np.zeros((3, 8, 8), bool), a[:, :8, :8])):
            assert min_iou(x, y) == reference_min_iou(x, y)
    with pytest.raises(ValueError):
        min_iou(a, b[:, :4])
