"""Every caller of a compiled kernel (exporter/mesh/*_kernels.py) checks the indices and shapes the
kernel follows (the C loops index without bounds checks; the kernels re-check what they index): a bad input is a ValueError, never a read
past an array (issue 24: "a compiled kernel never crashes the process")."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.boundary_kernels import border_loops, once_sides
from exporter.mesh.distance_kernels import point_triangle_distance
from exporter.mesh.edge_kernels import edge_counts, edge_key_order
from exporter.mesh.hausdorff import LOOSE, PLANE_SLACK_MAX, SHRINK, T_JUNCTION, Surface
from exporter.mesh.outline_kernels import outline_loops
from exporter.mesh.planar_bound_kernels import planar_bound
from exporter.mesh.planar_region_kernels import region_labels
from exporter.mesh.raster_kernels import rasterise_views
from exporter.mesh.slit_kernels import inside_sides
from exporter.mesh.split_kernels import split_fans
from exporter.mesh.straight_run_kernels import straight_runs

CONSTANTS = (SHRINK, PLANE_SLACK_MAX, LOOSE)


def test_planar_bound_checks_its_regions_and_shapes():
    target = Surface(np.eye(3), np.array([[0, 1, 2]]))
    tri = np.eye(3)[None]
    one = np.array([0])
    regions = target.regions
    regions.seg_start = regions.seg_start + 100  # segments past the end
    with pytest.raises(ValueError, match="inconsistent"):
        planar_bound(tri, one, one, regions, None, CONSTANTS)
    fresh = Surface(np.eye(3), np.array([[0, 1, 2]])).regions
    with pytest.raises(ValueError, match="shape"):
        planar_bound(tri, one, np.array([0, 0]), fresh, None, CONSTANTS)
    with pytest.raises(ValueError, match="one cap per triangle"):
        planar_bound(tri, one, one, fresh, np.zeros(3), CONSTANTS)
    fresh.region = fresh.region + 3  # a face's region beyond the planes
    with pytest.raises(ValueError, match="inconsistent"):
        planar_bound(tri, one, one, fresh, None, CONSTANTS)


def test_straight_runs_checks_matching_lengths():
    seg = np.zeros((2, 2, 2))
    ends = np.array([[0, 1], [1, 0]])
    with pytest.raises(ValueError, match="shape"):
        straight_runs(np.array([0]), seg, ends, np.ones(2, bool), np.zeros(2), T_JUNCTION)


def test_raster_and_distance_check_their_shapes():
    with pytest.raises(ValueError, match="views, n, 2"):
        rasterise_views(np.zeros((1, 3, 1)), np.array([[0, 1, 2]]), 8)
    with pytest.raises(ValueError, match="shapes"):
        point_triangle_distance(np.zeros((3, 4)), np.zeros((3, 3, 3)))


def test_band_kernels_check_their_rows():
    from exporter.mesh import _band

    rows = np.array([[0, 0, 1, 1], [1, 1, 0, -1], [0, 1, 0, -1]])  # region 1 between 0s
    region, a, b, side = (rows[:, c].copy() for c in range(4))
    order = np.argsort(a, kind="stable")
    with pytest.raises(ValueError, match="sorted"):
        _band.region_bands(
            region, a, b, side, order, np.zeros((3, 2)), np.ones(2, bool), np.zeros(2), 64, 0.5
        )
    with pytest.raises(ValueError, match="by_start"):  # a row past the end
        _band.region_bands(
            region[:2],
            a[:2],
            b[:2],
            side[:2],
            np.array([0, 5]),
            np.zeros((2, 2)),
            np.ones(2, bool),
            np.zeros(2),
            64,
            0.5,
        )
    out = np.zeros(3, np.int64)
    with pytest.raises(ValueError, match="by_start"):  # walk of rows 0..1 sent to row 2
        _band.walk(a, b, side, np.array([0, 2, 1]), a, 0, 2, 64, out, out.copy())
    with pytest.raises(ValueError, match="lo, hi"):
        _band.walk(a, b, side, order, a[order], 0, 4, 64, out, out.copy())
    with pytest.raises(ValueError, match="side"):
        _band.band_width(np.zeros(3), np.zeros(3), side[:2], 0.5)


def test_region_kernel_checks_its_faces():
    from exporter.mesh import _region

    points = np.eye(3)
    faces = np.array([[0, 1, 2]])
    one, empty, done = np.array([0]), np.zeros(0, np.int64), np.zeros(1, bool)
    constants = (0.0, 1.0, 1.0, 0.99, 1e-9, 64, 0.5, 1e-6, 4)
    with pytest.raises(ValueError, match="source holds 3"):
        _region.settle(points, faces, faces + 1, one, one, one, done, done.copy(), *constants)
    with pytest.raises(ValueError, match="rest_level holds 1"):
        _region.settle(points, faces, faces, one + 1, one, one, done, done.copy(), *constants)
    with pytest.raises(ValueError, match="region has 0"):  # one region per rest_source face
        _region.settle(points, faces, faces, one, one, empty, done, done.copy(), *constants)
    with pytest.raises(ValueError, match="done_source must be a writable"):
        _region.settle(points, faces, faces, one, one, one, done, np.zeros(1), *constants)


def test_edge_kernels_check_their_faces():
    with pytest.raises(ValueError, match=r"faces holds 5, outside \[0, 3\)"):
        edge_key_order(np.array([[0, 1, 5]]), 3)
    with pytest.raises(ValueError, match="faces must have 2 dimensions"):
        edge_counts(np.array([0, 1, 2]), 3)
    with pytest.raises(ValueError, match="faces has 4 along axis 1"):
        edge_counts(np.zeros((1, 4), np.int64), 3)


def test_boundary_kernels_check_their_faces():
    with pytest.raises(ValueError, match=r"faces holds 4, outside \[0, 4\)"):
        once_sides(np.array([[0, 1, 4]]), 3)  # ids up to vertex_count itself are allowed
    with pytest.raises(ValueError, match="vertex_count is negative"):
        border_loops(np.zeros((0, 3), np.int64), -1)


def test_planar_region_kernel_checks_its_edge_keys_and_groups():
    positions, faces = np.eye(3), np.array([[0, 1, 2]])
    keys, none = np.zeros(3, np.int64), np.zeros(0, np.int64)
    with pytest.raises(ValueError, match=r"order holds 3, outside \[0, 3\)"):
        region_labels(positions, faces, none, False, keys, np.array([0, 1, 3]), 0.9, 1e-3)
    with pytest.raises(ValueError, match="order has 2 along axis 0"):
        region_labels(positions, faces, none, False, keys, np.array([0, 1]), 0.9, 1e-3)
    with pytest.raises(ValueError, match="groups has 0 along axis 0"):
        region_labels(positions, faces, none, True, keys, np.array([0, 1, 2]), 0.9, 1e-3)
    with pytest.raises(ValueError, match=r"faces holds 3, outside \[0, 3\)"):
        region_labels(positions, faces + 3, none, False, keys, np.array([0, 1, 2]), 0.9, 1e-3)


def test_outline_kernel_checks_regions_and_vertices():
    half, keep = np.array([[0, 1], [1, 2], [2, 0]]), np.zeros(3, bool)
    with pytest.raises(ValueError, match=r"half_region holds 1, outside \[0, 1\)"):
        outline_loops(half, np.array([0, 0, 1]), 1, 3, keep)
    with pytest.raises(ValueError, match=r"half holds 2, outside \[0, 2\)"):
        outline_loops(half, np.zeros(3, np.int64), 1, 2, keep)
    with pytest.raises(ValueError, match=r"droppable \(2,\)"):
        outline_loops(half, np.zeros(3, np.int64), 1, 3, keep[:2])


def test_split_kernel_checks_its_sides_and_uvs():
    faces, uvs = np.array([[0, 1, 2], [2, 1, 3]]), np.zeros((2, 3, 2), np.float32)
    vertex, t = np.array([4, 5]), np.array([0.5, 0.5])
    with pytest.raises(ValueError, match="the sides are not sorted"):
        split_fans(faces, uvs, True, np.array([4, 0]), vertex, t)
    with pytest.raises(ValueError, match=r"side holds 6, outside \[0, 6\)"):
        split_fans(faces, uvs, True, np.array([0, 6]), vertex, t)
    with pytest.raises(ValueError, match="corner_uvs has 1 along axis 0"):
        split_fans(faces, uvs[:1], True, np.array([0, 4]), vertex, t)
    with pytest.raises(ValueError, match="t has 1 along axis 0"):
        split_fans(faces, uvs, False, np.array([0, 4]), vertex, t[:1])


def test_slit_kernel_checks_its_sides():
    positions, one = np.eye(3), np.array([0])
    with pytest.raises(ValueError, match="end has 2 along axis 0, expected 1"):
        inside_sides(positions, one, one, np.array([1, 2]), 1e-5)
    with pytest.raises(ValueError, match="positions has 2 along axis 1"):
        inside_sides(np.zeros((3, 2)), one, one, np.array([1]), 1e-5)


def test_gltf_arrays_kernel_checks_its_shapes():
    from exporter.mesh import _gltf_arrays

    positions, triangles = np.zeros((4, 3)), np.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="normals has 3 along axis 0"):
        _gltf_arrays.arrays(positions, np.zeros((3, 3), np.float32), triangles, False)
    with pytest.raises(ValueError, match="positions has 2 along axis 1"):
        _gltf_arrays.arrays(np.zeros((4, 2)), np.zeros((4, 3)), triangles, False)
    with pytest.raises(ValueError, match="triangles has 4 along axis 1"):
        _gltf_arrays.arrays(positions, np.zeros((4, 3)), np.zeros((1, 4), np.int64), False)
    with pytest.raises(ValueError, match="positions has 2 along axis 1"):
        _gltf_arrays.bounds(np.zeros((4, 2), np.float32))
    with pytest.raises(ValueError, match="empty"):
        _gltf_arrays.bounds(np.zeros((0, 3), np.float32))
