"""The compiled planar regions (:mod:`exporter.mesh.planar_region_kernels`) label every face as
the former numpy form did (kept here as the reference: its normals, centroids and tests float for
float, components by lowest face): on generated buildings with and without UV charts, on random
grids whose faces sit at the coplanarity limits (normals ~1 degree apart, heights ~1 mm off), at
global-frame coordinates; bad vertex ids are errors, not crashes. Metres."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.component_kernels import lowest_member
from exporter.mesh.geometry import cross_rows, row_norms, sorted_edge_keys
from exporter.mesh.topology import COPLANAR_COS, PLANE_M, planar_regions


def reference_planar_regions(positions, faces, groups=None):
    """The former numpy body of ``topology.planar_regions``."""
    m = len(faces)
    a, b, c = (positions[faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a)
    normal /= np.maximum(row_norms(normal)[:, None], 1e-30)
    keys, order = sorted_edge_keys(faces, len(positions))
    owner = order // 3
    same = keys[1:] == keys[:-1]
    f, g = owner[:-1][same], owner[1:][same]
    if groups is not None:
        keep = groups[f] == groups[g]
        f, g = f[keep], g[keep]
    centroid = (0.0 + a + b + c) / 3
    coplanar = ((normal[f] * normal[g]).sum(1) > COPLANAR_COS) & (
        np.abs(((centroid[g] - a[f]) * normal[f]).sum(1)) < PLANE_M
    )
    lowest = lowest_member(m, f[coplanar], g[coplanar])
    root = lowest == np.arange(m)
    return (np.cumsum(root) - 1)[lowest]


def _same(positions, faces, groups=None):
    got = planar_regions(positions, faces, groups)
    expected = reference_planar_regions(positions, faces, groups)
    assert got.dtype == np.int64
    assert np.array_equal(got, expected)
    return len(np.unique(got))


def test_generated_buildings_give_the_former_regions():
    from exporter import samplegen
    from exporter.simplify import _join

    for building in samplegen.generate_buildings(20, seed=5):
        positions, faces, _, _, charts, _ = _join(building.parts, 0.0)
        regions = _same(positions, faces, charts)
        assert 1 < regions < len(faces)  # walls cut into bays merge, the walls stay apart
        _same(positions, faces)


def _grid(rng, n, tilt, lift, offset):
    """An n x n grid of quads (two triangles each) whose vertices get random normal tilts and
    heights of the given scales (radians, metres), shifted by ``offset``."""
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    z = rng.normal(0, lift, x.shape) + tilt * rng.normal(0, 1, x.shape) * x
    positions = np.column_stack([x.ravel(), z.ravel(), y.ravel()]) + offset
    v = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)
    a, b, c, d = v[:-1, :-1].ravel(), v[:-1, 1:].ravel(), v[1:, 1:].ravel(), v[1:, :-1].ravel()
    faces = np.concatenate([np.column_stack([a, c, b]), np.column_stack([a, d, c])])
    return positions, faces[rng.permutation(len(faces))]


@pytest.mark.parametrize("offset", [0.0, 1.0e6])
def test_random_grids_at_the_limits_give_the_former_regions(offset):
    rng = np.random.default_rng(11)
    counts = []
    for trial in range(60):
        tilt = float(rng.choice([0.0, 0.005, 0.01, 0.02]))
        lift = float(rng.choice([0.0, 2e-4, 5e-4, 1e-3]))
        positions, faces = _grid(rng, int(rng.integers(1, 9)), tilt, lift, offset)
        groups = rng.integers(0, 2, len(faces)) if trial % 3 == 0 else None
        counts.append(_same(positions, faces, groups))
    assert min(counts) == 1 and max(counts) > 10  # both merged and split grids were met


def test_degenerate_and_empty_faces():
    positions = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]])
    faces = np.array([[0, 1, 2], [0, 1, 3], [1, 0, 2], [2, 2, 2]])
    _same(positions, faces)
    assert len(planar_regions(positions, faces[:0])) == 0


def test_bad_vertex_ids_are_errors():
    positions = np.zeros((3, 3))
    with pytest.raises(ValueError, match="planar_regions"):
        planar_regions(positions, np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="planar_regions"):
        planar_regions(positions, np.array([[0, 1, 2]]), np.zeros(2, np.int64))
