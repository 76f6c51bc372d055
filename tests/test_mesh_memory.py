"""Large meshes in bounded memory (issue 24): the certified bound on a whole merged tile (1,248
generated buildings, 61,601 triangles in 31,424 planar regions) once built (r, r) and (points,
triangles) float64 blocks of 7.4 and 4.3 GiB and the process died. Here the same steps on meshes
just large enough that such a block is tens of MiB, with numpy's allocations traced."""

from __future__ import annotations

import tracemalloc

import numpy as np

from exporter.mesh.distance import SurfaceIndex
from exporter.mesh.hausdorff import Surface


def peak_mib(call) -> tuple[object, float]:
    """``call()``'s result and the peak of the memory traced while it ran (MiB; numpy reports its
    array buffers to tracemalloc)."""
    tracemalloc.start()
    try:
        result = call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return result, peak / 2**20


def tilted_soup(count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``count`` small triangles (metres) with random normals on a 100 m grid: one planar region
    each. Positions (3 count, 3), faces (count, 3)."""
    rng = np.random.default_rng(seed)
    centres = np.column_stack(
        [rng.uniform(0, 100, count), rng.uniform(0, 100, count), rng.uniform(0, 10, count)]
    )
    corners = centres[:, None] + rng.normal(scale=0.3, size=(count, 3, 3))
    return corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3)


def test_planar_regions_of_many_faces_need_no_region_by_region_block():
    positions, faces = tilted_soup(4000)
    # Two more triangles on the plane of the first, apart from it: the three are one region.
    a, b, c = positions[:3]
    u, v = b - a, c - a  # same winding: the same normal
    extra = np.array([a + 2 * u, a + 3 * u, a + 2 * u + v, a - 3 * v, a - 3 * v + u, a - 2 * v])
    positions = np.concatenate([positions, extra])
    faces = np.concatenate([faces, len(faces) * 3 + np.arange(6).reshape(2, 3)])
    surface = Surface(positions, faces)
    assert Surface(*tilted_soup(20)).regions  # compiled kernels loaded before the tracing
    regions, peak = peak_mib(lambda: surface.regions)
    # A (4002, 4002) float64 block alone is 122 MiB.
    assert peak < 40, f"{peak:.0f} MiB traced"
    region = regions.region
    assert region[-1] == region[-2] == region[0]
    assert len(np.unique(region)) == len(faces) - 2


def test_sphere_pairs_hold_a_bounded_block_of_point_triangle_pairs():
    positions, faces = tilted_soup(6000, seed=1)
    # One 1 km triangle: every centre is within the tree's reach, so all pairs are tested.
    big = np.array([[-500.0, -500.0, -50.0], [1500.0, -500.0, -50.0], [-500.0, 1500.0, -50.0]])
    positions = np.concatenate([positions, big])
    faces = np.concatenate([faces, [[len(positions) - 3, len(positions) - 2, len(positions) - 1]]])
    index = SurfaceIndex(positions, faces)
    points = np.random.default_rng(2).uniform(0, 100, (2000, 3))
    limit = np.full(len(points), 0.5)
    (rows, cols), peak = peak_mib(lambda: index.sphere_pairs(points, limit))
    # 2,000 x 6,001 pairs: a (p, m) float64 block alone is 92 MiB.
    assert peak < 40, f"{peak:.0f} MiB traced"
    # The same pairs as the test of every pair, row by row.
    expected = [
        np.flatnonzero(np.sqrt(((index.centres - p) ** 2).sum(1)) - index.radii <= 0.5)
        for p in points
    ]
    assert np.array_equal(rows, np.repeat(np.arange(len(points)), [len(e) for e in expected]))
    assert np.array_equal(cols, np.concatenate(expected))
