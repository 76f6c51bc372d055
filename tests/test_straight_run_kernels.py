"""The compiled straight-run merge (:mod:`exporter.mesh.straight_run_kernels`) gives exactly what
the former Python walk (``reference_straight_runs`` of tests/test_perf_hausdorff.py) gives: the
same segments and gaps, bit for bit, on random region outlines (straight runs with noise inside
and outside the tolerance, branching vertices, flipped faces, several regions). In-plane metres."""

from __future__ import annotations

import types

import numpy as np
import pytest

from exporter.mesh.hausdorff import T_JUNCTION
from exporter.mesh.straight_run_kernels import straight_runs
from tests.test_perf_hausdorff import reference_straight_runs


def _outline(rng, regions):
    """Closed loops per region, polygon corners with extra vertices along the sides (on the line,
    off it by noise around T_JUNCTION, or inwards/outwards), in vertex ids of one mesh."""
    seg_region, seg, ends = [], [], []
    vertex = 0
    for g in range(regions):
        for _loop in range(int(rng.integers(1, 3))):
            corners = rng.normal(size=(int(rng.integers(3, 6)), 2)) * 10.0 ** rng.integers(-2, 3)
            points = []
            for c in range(len(corners)):
                a, b = corners[c], corners[(c + 1) % len(corners)]
                points.append(a)
                for t in np.sort(rng.random(int(rng.integers(0, 4)))):
                    normal = np.array([a[1] - b[1], b[0] - a[0]])
                    off = rng.choice([0.0, 1e-12, 1e-8, -1e-8, 1e-5, 1e-3]) * rng.random()
                    points.append(a + t * (b - a) + off * normal)
            ids = vertex + np.arange(len(points))
            vertex += len(points)
            for i in range(len(points)):
                seg_region.append(g)
                seg.append([points[i], points[(i + 1) % len(points)]])
                ends.append([ids[i], ids[(i + 1) % len(points)]])
    seg_region = np.array(seg_region, np.int64)
    seg = np.array(seg, np.float64)
    ends = np.array(ends, np.int64)
    if rng.random() < 0.3:  # a vertex with two segments leaving it: no run passes through it
        i, j = rng.integers(len(ends), size=2)
        ends[i, 0] = ends[j, 0]
        seg_region[i] = seg_region[j]
    oriented = rng.random(len(seg)) < 0.95
    shuffle = rng.permutation(len(seg))
    return seg_region[shuffle], seg[shuffle], ends[shuffle], oriented[shuffle]


@pytest.mark.parametrize("seed", range(4))
def test_compiled_straight_runs_equal_the_former_walk(seed):
    rng = np.random.default_rng(seed)
    merged = 0
    for _ in range(60):
        regions = int(rng.integers(1, 4))
        seg_region, seg, ends, oriented = _outline(rng, regions)
        holder = types.SimpleNamespace(gap=rng.random(regions) * 1e-9)
        gap = holder.gap.copy()
        expected = reference_straight_runs(holder, seg_region, seg, ends, oriented)
        got = straight_runs(seg_region, seg, ends, oriented, gap, T_JUNCTION)
        assert np.array_equal(got[0], expected[0])
        assert np.array_equal(got[1], expected[1])
        assert np.array_equal(gap, holder.gap)
        merged += len(seg) - len(got[1])
    assert merged > 100  # runs were merged, not only kept


def test_an_index_out_of_range_is_an_error_not_a_crash():
    seg = np.zeros((2, 2, 2))
    ends = np.array([[0, 1], [1, 0]])
    with pytest.raises(ValueError, match="out of range"):
        straight_runs(np.array([0, 5]), seg, ends, np.ones(2, bool), np.zeros(2), T_JUNCTION)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"order_out": np.array([2])}, "order_out holds 2"),
        ({"region": np.array([0, 1])}, "region holds 1"),
        ({"keys_in": np.zeros(2, np.int64)}, "keys_in"),
        ({"gap": np.zeros(1, np.float32)}, "gap must be"),
        ({"out_seg": np.zeros((1, 2, 2))}, "out_seg"),
    ],
)
def test_the_compiled_walk_checks_what_it_follows(change, message):
    """The C walk called directly (past the wrapper's checks) refuses indices out of range."""
    from exporter.mesh._straight_run import runs

    args = {
        "region": np.array([0, 0]),
        "seg": np.array([[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]]]),
        "start_key": np.array([0, 1]),
        "end_key": np.array([1, 2]),
        "order_out": np.array([0]),
        "keys_in": np.array([1]),
        "oriented": np.array([True, False]),
        "t_junction": T_JUNCTION,
        "half": 0.5,
        "gap": np.zeros(1),
        "out_region": np.empty(2, np.int64),
        "out_seg": np.empty((2, 2, 2)),
    }
    assert runs(*args.values()) == 2  # the unchanged arguments are accepted
    with pytest.raises(ValueError, match=message):
        runs(*{**args, **change}.values())
