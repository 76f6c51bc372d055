"""Every caller of a compiled kernel (exporter/mesh/*_kernels.py) checks the indices and shapes the
kernel follows without bounds checks (numba does none): a bad input is a ValueError, never a read
past an array (issue 24: "a compiled kernel never crashes the process")."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.distance_kernels import point_triangle_distance
from exporter.mesh.hausdorff import LOOSE, PLANE_SLACK_MAX, SHRINK, T_JUNCTION, Surface
from exporter.mesh.planar_bound_kernels import planar_bound
from exporter.mesh.raster_kernels import rasterise_views
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
