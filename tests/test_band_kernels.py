"""The compiled bands of a chain difference (:mod:`exporter.mesh.band_kernels`) give exactly what
the former plain-Python walk and widths (tests/test_perf_hausdorff.py) give: the same regions
refused and the same widths, bit for bit, on random chain differences (bands, bands meeting at a
corner, long cycles, open walks, random edges). In-plane metres, frame-free."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.band_kernels import region_bands
from exporter.mesh.coverage import MAX_BAND_EDGES
from tests.test_perf_hausdorff import reference_band_width, reference_cycles


def reference_bands(diff, xy, good, width):
    """The former ``coverage._bands`` after its in-plane coordinates: the plain walk and widths of
    tests/test_perf_hausdorff.py per region."""
    starts = np.flatnonzero(np.r_[True, diff[1:, 0] != diff[:-1, 0]])
    ends = np.r_[starts[1:], len(diff)]
    for s, e in zip(starts.tolist(), ends.tolist()):
        g = int(diff[s, 0])
        if not good[g]:
            continue
        rows = diff[s:e].tolist()
        cycles = reference_cycles(rows)
        if cycles is None or any(row[3] == 0 for row in rows):
            good[g] = False
            continue
        for cycle in cycles:
            band = reference_band_width(
                [xy[s + i].tolist() for i in cycle], [rows[i][3] for i in cycle]
            )
            if band is None:
                good[g] = False
                break
            width[g] = max(width[g], band)


def _cycle(rng, start_id, scale):
    """Rows (a, b, side) and start points of one cycle: mostly a band (a run of +1 edges along a
    chord, a run of -1 edges back, small offsets across), sometimes anything."""
    n = int(rng.integers(2, 9))
    kind = rng.random()
    ids = start_id + np.arange(n)
    if kind < 0.6:  # a band
        split = int(rng.integers(1, n)) if n > 2 else 1
        t = np.concatenate([np.sort(rng.random(split)), np.sort(rng.random(n - split))[::-1]])
        t[0], t[split % n] = 0.0, 1.0 if split < n else t[split % n]
        h = rng.normal(size=n) * 1e-3
        sides = np.where(np.arange(n) < split, 1, -1)
        if rng.random() < 0.5:
            sides = -sides
        xy = np.column_stack([t, h]) * scale
    else:
        xy = rng.normal(size=(n, 2)) * scale
        sides = rng.choice([-1, 1, 1, 0] if kind > 0.95 else [-1, 1], size=n)
    rows = np.column_stack([ids, np.roll(ids, -1), sides])
    return rows, xy


@pytest.mark.parametrize("seed", range(6))
def test_compiled_bands_equal_the_reference(seed):
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.integers(-3, 6)
    checked = 0
    for _ in range(40):
        regions = int(rng.integers(1, 6))
        parts, points = [], []
        next_id = 0
        for g in range(regions):
            for _ in range(int(rng.integers(1, 4))):
                rows, xy = _cycle(rng, next_id, scale)
                if rng.random() < 0.2 and parts:  # two cycles meeting at a vertex
                    rows[0, 0] = rows[-1, 1] = parts[-1][0, 1]
                next_id += len(rows)
                parts.append(np.column_stack([np.full(len(rows), g), rows]))
                points.append(xy)
            if rng.random() < 0.1:  # a long chain: beyond the walk's limit
                ids = next_id + np.arange(MAX_BAND_EDGES + 2)
                rows = np.column_stack(
                    [np.full(len(ids), g), ids, np.roll(ids, -1), np.ones_like(ids)]
                )
                next_id += len(ids)
                parts.append(rows)
                points.append(rng.normal(size=(len(ids), 2)))
        diff = np.concatenate(parts).astype(np.int64)
        xy = np.concatenate(points)
        shuffle = rng.permutation(len(diff))
        diff, xy = diff[shuffle], xy[shuffle]
        order = np.argsort(diff[:, 0], kind="stable")
        diff, xy = diff[order], xy[order]
        good = rng.random(regions) < 0.9
        width = np.zeros(regions)
        good_ref, width_ref = good.copy(), width.copy()
        reference_bands(diff, xy, good_ref, width_ref)
        region_bands(diff, xy, good, width, MAX_BAND_EDGES)
        assert np.array_equal(good, good_ref)
        # A refused region's width is never read (the former walk stopped at its first non-band).
        assert np.array_equal(width[good], width_ref[good])
        checked += int(good.sum())
    assert checked > 20  # bands were accepted, not only refused


def test_a_region_index_out_of_range_is_an_error_not_a_crash():
    diff = np.array([[3, 0, 1, 1], [3, 1, 0, -1]])
    with pytest.raises(ValueError, match="out of range"):
        region_bands(diff, np.zeros((2, 2)), np.ones(2, bool), np.zeros(2), MAX_BAND_EDGES)
