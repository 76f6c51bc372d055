"""The compiled outline walk (:mod:`exporter.mesh.outline_kernels`, behind
``planar._region_loops``) gives the former numpy and Python form's loops (kept here as the
reference): on the planar regions of generated buildings (every region at once, with and without
droppable vertices) and on random regions (pinched, open, with holes, repeated faces); bad ids are
errors, not crashes."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.simplify.planar import _region_loops


def _member(values, ordered):
    return ordered[np.minimum(np.searchsorted(ordered, values), len(ordered) - 1)] == values


def reference_region_loops(
    half: np.ndarray, half_region: np.ndarray, region_count: int, k: int, droppable
) -> list:
    """The former body of ``planar._region_loops``."""
    key = (half_region * k + half[:, 0]) * k + half[:, 1]
    reverse = (half_region * k + half[:, 1]) * k + half[:, 0]
    outline = ~_member(reverse, np.sort(key))
    edges, owner = half[outline], half_region[outline]
    source, target = owner * k + edges[:, 0], owner * k + edges[:, 1]
    bad = np.bincount(owner, minlength=region_count) == 0
    if not len(source):
        return [None] * region_count
    by_source = np.argsort(source)
    sources, targets = source[by_source], np.sort(target)
    bad[sources[1:][sources[1:] == sources[:-1]] // k] = True
    bad[targets[1:][targets[1:] == targets[:-1]] // k] = True
    at = np.minimum(np.searchsorted(sources, target), len(source) - 1)
    bad[owner[sources[at] != target]] = True
    following = by_source[at]
    loops: list = [None if b else [] for b in bad.tolist()]
    # Each outline vertex, or -1 where it is dropped.
    kept = np.where(np.asarray(droppable, dtype=bool)[edges[:, 0]], -1, edges[:, 0]).tolist()
    following, owners = following.tolist(), owner.tolist()
    # Walks start at every half-edge not yet seen, in face order (bytearray.find skips the seen
    # ones at C speed); bad regions' half-edges are never walked (their successors may be wrong).
    seen = bytearray(bad[owner].tobytes())
    first = seen.find(0)
    while first >= 0:
        loop, e = [], first
        while not seen[e]:
            seen[e] = 1
            if kept[e] >= 0:
                loop.append(kept[e])
            e = following[e]
        # A good region's walk stays in it; one of its loops under 3 vertices voids the region.
        region = loops[owners[first]]
        if region is not None:
            if len(loop) < 3:
                loops[owners[first]] = None
            else:
                region.append(loop)
        first = seen.find(0, first + 1)
    return loops


def _same(half, half_region, count, k, droppable):
    got = _region_loops(half, half_region, count, k, droppable)
    assert got == reference_region_loops(half, half_region, count, k, droppable)
    return got


def test_generated_buildings_regions_give_the_former_loops():
    from exporter import samplegen
    from exporter.mesh.topology import planar_regions
    from exporter.simplify import _join

    rng = np.random.default_rng(3)
    found = 0
    for building in samplegen.generate_buildings(20, seed=7):
        positions, faces, _, _, charts, _ = _join(building.parts, 0.0)
        regions = planar_regions(positions, faces, charts)
        order = np.argsort(regions, kind="stable")
        half = faces[order][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        half_region = np.repeat(regions[order], 3)
        k, count = len(positions), int(regions.max()) + 1
        for droppable in (np.zeros(k, dtype=bool), rng.random(k) < 0.2):
            loops = _same(half, half_region, count, k, droppable)
            found += sum(rings is not None for rings in loops)
    assert found > 0


def test_random_regions_give_the_former_loops():
    rng = np.random.default_rng(8)
    for _ in range(200):
        count = int(rng.integers(1, 6))
        k = int(rng.integers(3, 30))
        faces = [rng.integers(0, k, size=(int(rng.integers(1, 12)), 3)) for _ in range(count)]
        half = np.concatenate([f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2) for f in faces])
        half_region = np.repeat(np.arange(count), [3 * len(f) for f in faces])
        _same(half, half_region, count, k, rng.random(k) < 0.2)


def test_bad_input_is_an_error():
    half = np.array([[0, 1], [1, 2], [2, 0]])
    with pytest.raises(ValueError, match="_region_loops"):
        _region_loops(half, np.zeros(3, np.int64), 1, 2, np.zeros(3, dtype=bool))
    with pytest.raises(ValueError, match="_region_loops"):
        _region_loops(half, np.array([1, 0, 0]), 2, 3, np.zeros(3, dtype=bool))
