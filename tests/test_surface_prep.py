"""A prepared surface's compiled pieces give their former numpy forms' bits (the forms are kept
here as references): the refinement's split4, the triangles' centres and radii (``SurfaceIndex``), the regions' planes
(``hausdorff._planes``) and projected triangles (``_Regions.tri2``), on generated buildings,
random and degenerate triangles (zero, -0.0, NaN, inf). The point memo (``c/point_memo.c``,
``distance.PointMemo``) gives each distinct point (bit for bit) one row, computes each answer
once, and the certified bounds are the same with it as without. Metres."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh import _point_memo, _surface, hausdorff
from exporter.mesh.distance import PointMemo, SurfaceIndex
from exporter.mesh.geometry import cross_rows
from exporter.mesh.topology import planar_regions


def reference_centres_radii(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    centres = tri.mean(axis=1)
    return centres, np.sqrt(((tri - centres[:, None]) ** 2).sum(-1).max(axis=1))


def reference_planes(tri: np.ndarray, cross: np.ndarray, region: np.ndarray):
    r = int(region.max()) + 1 if len(region) else 0
    normal = np.zeros((r, 3))
    np.add.at(normal, region, cross)
    length = np.linalg.norm(normal, axis=1)
    good = length > 0
    normal[good] /= length[good, None]
    normal[~good] = (0.0, 0.0, 1.0)
    heights = np.einsum("mkj,mj->mk", tri, normal[region])
    high = np.full(r, -np.inf)
    low = np.full(r, np.inf)
    with np.errstate(invalid="ignore"):
        np.maximum.at(high, region, heights.max(axis=1))
        np.minimum.at(low, region, heights.min(axis=1))
        return normal, 0.5 * (high + low), 0.5 * (high - low)


def reference_project(tri: np.ndarray, u: np.ndarray, v: np.ndarray, region: np.ndarray):
    uf, vf = u[region], v[region]
    return np.stack([np.einsum("mkj,mj->mk", tri, uf), np.einsum("mkj,mj->mk", tri, vf)], axis=-1)


def reference_split4(tri: np.ndarray) -> np.ndarray:
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
    return np.stack(
        [
            np.stack([a, ab, ca], 1),
            np.stack([ab, b, bc], 1),
            np.stack([ca, bc, c], 1),
            np.stack([ab, bc, ca], 1),
        ],
        1,
    ).reshape(-1, 3, 3)


def _same_bits(got: np.ndarray, expected: np.ndarray) -> bool:
    """The same bits, except that any NaN matches any NaN (their payloads are the hardware's)."""
    got, expected = np.asarray(got, np.float64), np.asarray(expected, np.float64)
    nan = np.isnan(got)
    if got.shape != expected.shape or not np.array_equal(nan, np.isnan(expected)):
        return False
    return np.array_equal(got[~nan].view(np.int64), expected[~nan].view(np.int64))


def _same(got, expected) -> bool:
    return all(_same_bits(g, e) for g, e in zip(got, expected, strict=True))


def _random_triangles(rng: np.random.Generator, m: int, awkward: bool) -> np.ndarray:
    tri = rng.normal(size=(m, 3, 3)) * 10.0 ** rng.integers(-3, 6)
    if awkward:
        tri[rng.random((m, 3, 3)) < 0.15] = 0.0
        tri[rng.random((m, 3, 3)) < 0.15] = -0.0
        tri[rng.random((m, 3, 3)) < 0.02] = np.nan
        tri[rng.random((m, 3, 3)) < 0.02] = np.inf
    return tri


def _generated_meshes():
    from exporter import samplegen
    from exporter.quality import joined

    for building in samplegen.generate_buildings(6, seed=11, atlas_size=16):
        positions, faces = joined(building.parts)[:2]
        yield np.asarray(positions, np.float64), np.asarray(faces, np.int64)


def test_prepared_pieces_give_the_numpy_bits_on_generated_buildings():
    count = 0
    for positions, faces in _generated_meshes():
        tri = positions[faces]
        assert _same(_surface.centres_radii(tri), reference_centres_radii(tri))
        cross = cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        region = planar_regions(positions, faces)
        assert _same(hausdorff._planes(tri, cross, region), reference_planes(tri, cross, region))
        regions = hausdorff._Regions(positions, faces)
        assert _same(
            [regions.tri2],
            [reference_project(tri, regions.u, regions.v, regions.region)],
        )
        count += 1
    assert count == 6


@pytest.mark.parametrize("awkward", [False, True])
def test_prepared_pieces_give_the_numpy_bits_on_random_triangles(awkward):
    rng = np.random.default_rng(3)
    with np.errstate(invalid="ignore", over="ignore"):
        for _ in range(200):
            m = int(rng.integers(1, 200))
            tri = _random_triangles(rng, m, awkward)
            assert _same(_surface.centres_radii(tri), reference_centres_radii(tri))
            assert _same([hausdorff.split4(tri)], [reference_split4(tri)])
            cross = cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            cross[rng.random(m) < 0.2] = 0.0  # regions of zero area: the (0, 0, 1) normal
            region = rng.integers(0, max(1, m // 4), size=m)
            assert _same(
                hausdorff._planes(tri, cross, region), reference_planes(tri, cross, region)
            )
            r = int(rng.integers(1, 12))
            u, v = rng.normal(size=(r, 3)), rng.normal(size=(r, 3))
            which = rng.integers(0, r, size=m)
            assert _same(
                [_surface.project(tri, u, v, which)], [reference_project(tri, u, v, which)]
            )


def test_prepared_pieces_reject_bad_input():
    tri = np.zeros((2, 3, 3))
    with pytest.raises(ValueError, match="region"):
        _surface.planes(tri, np.zeros((2, 3)), np.array([0, 5]), 2)
    with pytest.raises(ValueError, match="cross"):
        _surface.planes(tri, np.zeros((3, 3)), np.array([0, 1]), 2)
    with pytest.raises(ValueError, match="region"):
        _surface.project(tri, np.zeros((1, 3)), np.zeros((1, 3)), np.array([0, 1]))
    with pytest.raises(ValueError, match="tri"):
        _surface.centres_radii(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="tri"):
        _surface.split4(np.zeros((2, 3, 2)))
    assert hausdorff.split4(np.zeros((0, 3, 3))).shape == (0, 3, 3)


def test_the_memo_gives_each_distinct_point_one_row_bit_for_bit():
    memo = _point_memo.memo()
    done = np.zeros(16, bool)
    points = np.array([[1.0, 2, 3], [0.0, 0, 0], [1.0, 2, 3], [-0.0, 0, 0], [np.nan, 0, 0]])
    rows, first = _point_memo.lookup(memo, points, done)
    # -0.0 is not 0.0 (their answers may differ in sign), a NaN row is itself.
    assert rows.tolist() == [0, 1, 0, 2, 3] and first.tolist() == [0, 1, 3, 4]
    assert done[:4].all() and not done[4:].any()
    again, first = _point_memo.lookup(memo, points[::-1].copy(), done)
    assert again.tolist() == [3, 2, 0, 1, 0] and len(first) == 0
    assert _point_memo.count(memo) == 4
    with pytest.raises(ValueError, match="done"):
        _point_memo.lookup(memo, points, np.zeros(5, bool))  # 4 rows + 5 points may need 9
    with pytest.raises(ValueError, match="memo"):
        _point_memo.lookup(object(), points, done)


def test_the_memo_computes_each_answer_once_and_grows():
    rng = np.random.default_rng(5)
    memo = PointMemo()
    asked: list[int] = []

    def compute(x: np.ndarray):
        asked.append(len(x))
        return x.sum(1), np.stack([x[:, 0], -x[:, 1]], 1)

    pool = rng.normal(size=(3000, 3))
    for _ in range(30):
        points = pool[rng.integers(0, len(pool), size=int(rng.integers(0, 400)))]
        got = memo.get("sum", points, compute)
        assert all(np.array_equal(g, e) for g, e in zip(got, compute(points), strict=True))
        asked.pop()  # the direct call above
    seen = len(np.unique(np.concatenate([np.zeros((0, 3)), pool]), axis=0))
    assert sum(asked) <= seen
    # A failing computation leaves nothing half done: the next call computes those points.
    fresh = rng.normal(size=(5, 3))
    with pytest.raises(RuntimeError):
        memo.get("sum", fresh, lambda x: (_ for _ in ()).throw(RuntimeError("no")))
    assert np.array_equal(memo.get("sum", fresh, compute)[0], fresh.sum(1))


def test_certified_bounds_are_the_same_with_and_without_the_memo(monkeypatch):
    from exporter import samplegen
    from exporter.config import Config
    from exporter.quality import joined
    from exporter.simplify import build_mesh_chain

    config = Config()
    pairs = []
    for building in samplegen.generate_buildings(3, seed=7, atlas_size=16):
        chain = build_mesh_chain(building.parts, config.lods, config.simplify)
        source = joined(chain[0].parts)[:2]
        pairs += [(source, joined(level.parts)[:2]) for level in chain[1:]]
    assert pairs

    def bounds(memo_faces: int) -> list:
        monkeypatch.setattr(SurfaceIndex, "MEMO_FACES", memo_faces)
        out, kept = [], 0
        for source, level in pairs:
            surface = hausdorff.Surface(*source)
            out.append(hausdorff.hausdorff_bounds(surface, level, rtol=0.0, atol=0.0))
            out.append(hausdorff.bounds_within(surface, level, 0.05))
            kept += _point_memo.count(surface.index.memo._memo)
        assert (kept > 0) == (memo_faces == 0)
        return out

    assert bounds(0) == bounds(1 << 40)  # every surface keeps its answers / none does


def test_an_unbalanced_probe_tree_gives_upper_bounds_as_a_balanced_one():
    """The proxies' clustering takes the sliding-midpoint tree (built in ~0.4 of the time): its
    k nearest probes are as near (only the order of probes at equal distance may differ, as at
    a corner shared by several triangles), so each point's value is still an upper bound of its
    exact distance, and close to the balanced tree's."""
    from exporter.mesh.distance import distance_to_surface

    positions, faces = next(_generated_meshes())
    rng = np.random.default_rng(6)
    low, high = positions.min(axis=0), positions.max(axis=0)
    # points on the surface's corners (ties: shared corners) and around it
    points = np.concatenate([positions, rng.uniform(low - 2.0, high + 2.0, (2000, 3))])
    balanced = SurfaceIndex(positions, faces, samples_per_face=0)
    unbalanced = SurfaceIndex(positions, faces, samples_per_face=0, balanced=False)
    near_b, _ = balanced.probes(points, 6, memo=False)
    near_u, _ = unbalanced.probes(points, 6, memo=False)
    np.testing.assert_array_equal(near_b, near_u)  # the same distances, ties in any order
    exact = distance_to_surface(points, positions, faces)
    upper_b = balanced.upper(points, memo=False)
    upper_u = unbalanced.upper(points, memo=False)
    assert (upper_u >= exact - 1e-9).all() and (upper_b >= exact - 1e-9).all()
    assert np.abs(upper_u - upper_b).max() <= 0.5 * max(1.0, float(np.abs(upper_b).max()))
