"""The compiled slit search (:mod:`exporter.mesh.slit_kernels`) finds exactly the (side, vertex,
t) triples of the former numpy blocks (kept here as the reference), float for float and in the
same order: on generated buildings' border sides (walls cut into bays under a roof edge: real
slits), on random points near random sides (on, just off, beyond the tolerance, at the ends) and
at global-frame coordinates; bad vertex ids are errors, not crashes. Metres."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.geometry import row_norms
from exporter.mesh.slit_kernels import inside_sides
from exporter.mesh.slits import SLIT_M, border_sides


def reference_inside_sides(positions, ids, start, end, tolerance):
    """The former block loop of ``slits.slit_points`` (sides as indices into start/end)."""
    a = positions[start]
    direction = positions[end] - a
    length = np.maximum(row_norms(direction), 1e-30)
    ax, ay, az = a.T
    unit_x, unit_y, unit_z = (direction / length[:, None]).T
    px, py, pz = positions[ids].T
    ox, oy, oz = px[:, None] - ax, py[:, None] - ay, pz[:, None] - az
    along = ox * unit_x + oy * unit_y + oz * unit_z
    off2 = ox * ox + oy * oy + oz * oz - along * along
    hit = (
        (off2 <= tolerance * tolerance)
        & (along > tolerance)
        & (along < length - tolerance)
        & (start != ids[:, None])
        & (end != ids[:, None])
    )
    row, column = np.nonzero(hit)
    return column, ids[row], along[row, column] / length[column]


def _same(positions, ids, start, end, tolerance=SLIT_M):
    got = inside_sides(positions, ids, start, end, tolerance)
    expected = reference_inside_sides(positions, ids, start, end, tolerance)
    for g, e in zip(got, expected):
        assert np.array_equal(g, e)
    return len(got[0])


def test_generated_buildings_border_sides_give_the_former_slits():
    from exporter import samplegen
    from exporter.quality import joined

    found = 0
    for building in samplegen.generate_buildings(20, seed=4):
        positions, faces = joined(building.parts)
        sides = border_sides(faces, len(positions))
        start = faces.reshape(-1)[sides]
        end = faces[sides // 3, (sides % 3 + 1) % 3]
        points = np.unique(np.concatenate([start, end]))
        found += _same(positions, points, start, end)
    assert found > 0  # slits were there to find


@pytest.mark.parametrize("offset", [0.0, 6.4e6])
def test_random_points_near_random_sides_give_the_former_hits(offset):
    rng = np.random.default_rng(8)
    hits = 0
    for _ in range(30):
        s = int(rng.integers(1, 12))
        ends = rng.normal(size=(2 * s, 3)) * 10 + offset
        t = rng.random((40, 1))
        pick = rng.integers(0, s, 40)
        on = ends[2 * pick] + t * (ends[2 * pick + 1] - ends[2 * pick])
        noise = rng.normal(size=on.shape) * rng.choice([0.0, 1e-7, 5e-6, 1e-4], size=(40, 1))
        positions = np.vstack([ends, on + noise])
        ids = np.arange(len(positions))
        hits += _same(positions, ids, np.arange(0, 2 * s, 2), np.arange(1, 2 * s, 2))
    assert hits > 50


def test_a_vertex_out_of_range_is_an_error_not_a_crash():
    positions = np.zeros((3, 3))
    with pytest.raises(ValueError, match="out of range"):
        inside_sides(positions, np.array([0, 7]), np.array([0]), np.array([1]), SLIT_M)
