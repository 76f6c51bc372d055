"""The compiled bands of a chain difference (:mod:`exporter.mesh.band_kernels`) give exactly what
the former plain-Python walk and numpy widths (kept here as the reference) give: the same regions
refused and the same widths, bit for bit, on random chain differences (bands, bands meeting at a
corner, long cycles, open walks, random edges). In-plane metres, frame-free."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.coverage import MAX_BAND_EDGES
from exporter.mesh.band_kernels import region_bands


def _cycles(rows: list) -> list | None:
    """The cycles of one region's chain difference (``(region, a, b, side)`` rows), walked so
    that at a vertex where several edges leave, the walk turns onto the other side's edge (two
    bands meeting at a corner); None when that is ambiguous or a walk does not close."""
    leaving: dict[int, list[int]] = {}
    for i, row in enumerate(rows):
        leaving.setdefault(row[1], []).append(i)
    used = [False] * len(rows)
    cycles = []
    for first in range(len(rows)):
        if used[first]:
            continue
        cycle, i = [], first
        while True:
            used[i] = True
            cycle.append(i)
            if len(cycle) > MAX_BAND_EDGES:
                return None
            row = rows[i]
            out = leaving.get(row[2], ())
            if len(out) == 1:
                # One edge leaves (most vertices): the general rule below, without its lists.
                j = out[0]
                if j == first:
                    break
                if used[j]:
                    return None
                i = j
                continue
            options = [j for j in out if not used[j] or j == first]
            if first in options:
                break
            if len(options) > 1:
                options = [j for j in options if rows[j][3] != row[3]]
            if len(options) != 1:
                return None
            i = options[0]
        cycles.append(cycle)
    return cycles


def _band_widths(xy: np.ndarray, sides: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Width (metres) across the chord of each cycle of the chain difference that is a band: a
    cycle (vertices ``xy`` (sum lengths, 2) in-plane metres, edge e from vertex e to e + 1, the
    cycles' ``lengths`` (c,) one after the other) splits at its two farthest-apart vertices into
    two runs, each monotone along the chord, one of the level's boundary edges and the other of
    the source's (``sides`` (sum lengths,) +1 / -1 per edge); (c,) metres, NaN otherwise.

    All cycles at once on (c, L, L) padded arrays (a loop per cycle cost ~60 us of Python); the
    same float operations in the same order as the former loop, so the same bits (checked
    against it in tests/test_coverage.py)."""
    c, most = len(lengths), int(lengths.max())
    first = np.cumsum(lengths) - lengths
    owner = np.repeat(np.arange(c), lengths)
    pos = np.arange(len(owner)) - first[owner]
    x = np.zeros((c, most))
    y = np.zeros((c, most))
    side = np.zeros((c, most), np.int64)
    x[owner, pos], y[owner, pos], side[owner, pos] = xy[:, 0], xy[:, 1], sides
    valid = np.arange(most)[None] < lengths[:, None]  # (c, L)
    # Farthest pair p < q, the first in (p, q) order among equals (as the loop's strict '>').
    dx = x[:, None, :] - x[:, :, None]  # [p, q] = x_q - x_p
    dy = y[:, None, :] - y[:, :, None]
    d = dx * dx + dy * dy
    pair = np.triu(np.ones((most, most), bool), 1)[None] & valid[:, None, :]
    d = np.where(pair, d, -1.0)
    flat = d.reshape(c, -1).argmax(axis=1)
    i, j = flat // most, flat % most
    best = d.reshape(c, -1)[np.arange(c), flat]
    rows = np.arange(c)
    # Python's '** 0.5' (the loop's) rather than np.sqrt: the same last bit.
    length = np.array([b**0.5 if b > 0.0 else 1.0 for b in best.tolist()])
    xi, yi = x[rows, i][:, None], y[rows, i][:, None]
    ax = ((x[rows, j] - x[rows, i]) / length)[:, None]
    ay = ((y[rows, j] - y[rows, i]) / length)[:, None]
    t = (x - xi) * ax + (y - yi) * ay
    h = (y - yi) * ax - (x - xi) * ay
    # Edge e runs from vertex e to e + 1 (cyclically); the first run is i <= e < j.
    nxt = np.where(np.arange(most)[None] + 1 < lengths[:, None], np.arange(most)[None] + 1, 0)
    step = t[rows[:, None], nxt] - t  # (c, L) t[e + 1] - t[e]
    e = np.arange(most)[None]
    in_first = (e >= i[:, None]) & (e < j[:, None]) & valid
    in_second = ~in_first & valid
    slack = (1e-12 * length)[:, None]
    ok = ~(in_first & (step < -slack)).any(axis=1) & ~(in_second & (-step < -slack)).any(axis=1)
    # One side's edges on each run: all +1 then all -1, or the reverse.
    first_pos = ((side == 1) | ~in_first).all(axis=1)
    first_neg = ((side == -1) | ~in_first).all(axis=1)
    second_pos = ((side == 1) | ~in_second).all(axis=1)
    second_neg = ((side == -1) | ~in_second).all(axis=1)
    ok &= (first_pos & second_neg) | (first_neg & second_pos)
    ok &= best > 0.0
    high = np.where(valid, h, -np.inf).max(axis=1)
    low = np.where(valid, h, np.inf).min(axis=1)
    return np.where(ok, high - low, np.nan)


def reference_bands(diff, xy, good, width):
    """The former ``coverage._bands`` after the in-plane coordinates: a walk per region in Python,
    then every cycle's width at once."""
    starts = np.flatnonzero(np.r_[True, diff[1:, 0] != diff[:-1, 0]])
    ends = np.r_[starts[1:], len(diff)]
    edges: list[int] = []
    lengths: list[int] = []
    owners: list[int] = []
    every = diff.tolist()
    for s, e in zip(starts.tolist(), ends.tolist()):
        g = every[s][0]
        if not good[g]:
            continue
        rows = every[s:e]
        cycles = _cycles(rows)
        if cycles is None or any(row[3] == 0 for row in rows):
            good[g] = False
            continue
        for cycle in cycles:
            edges.extend(s + i for i in cycle)
            lengths.append(len(cycle))
            owners.append(g)
    if not lengths:
        return
    band = _band_widths(xy[edges], diff[edges, 3], np.array(lengths))
    owner = np.array(owners)
    bad = np.isnan(band)
    good[owner[bad]] = False
    np.maximum.at(width, owner[~bad], band[~bad])


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
        assert np.array_equal(width, width_ref)
        checked += int(good.sum())
    assert checked > 20  # bands were accepted, not only refused


def test_a_region_index_out_of_range_is_an_error_not_a_crash():
    diff = np.array([[3, 0, 1, 1], [3, 1, 0, -1]])
    with pytest.raises(ValueError, match="out of range"):
        region_bands(diff, np.zeros((2, 2)), np.ones(2, bool), np.zeros(2), MAX_BAND_EDGES)
