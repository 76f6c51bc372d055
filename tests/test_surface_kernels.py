"""The compiled point-to-surface queries (``exporter/mesh/c/surface.c``: ``SurfaceIndex._upper``
and ``hausdorff._nearest_face``) give exactly what their former numpy forms
(tests/surface_reference.py, tests/test_perf_hausdorff.py) give, on every call the mesh chain makes over generated buildings and
on random points near meshes with slivers, repeated faces (ties) and points on vertices, through
both the all-faces and the tree-candidate path; a bad index is an error, not a crash. Metres."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh import _surface, hausdorff
from exporter.mesh.distance import SurfaceIndex
from exporter.mesh.hausdorff import Surface
from tests.surface_reference import reference_pair_bound, reference_upper
from tests.test_perf_hausdorff import (
    reference_chain_bound,
    reference_nearest_face,
    reference_single_triangle_bound,
)


def test_every_call_of_the_chain_on_generated_buildings_gives_the_former_values(monkeypatch):
    import exporter.simplify as simplify
    from exporter import samplegen
    from exporter.config import Config

    compiled_upper, compiled_nearest = SurfaceIndex._upper, hausdorff._nearest_face
    compiled_single, compiled_chain = hausdorff._single_triangle_bound, hausdorff._chain_bound
    compiled_pair = hausdorff._pair_bound
    seen = {"upper": 0, "nearest": 0, "single": 0, "chain": 0, "pair": 0}

    def spy_upper(self, points, probe_distance, nearest):
        out = compiled_upper(self, points, probe_distance, nearest)
        assert np.array_equal(out, reference_upper(self, points, probe_distance, nearest))
        seen["upper"] += len(out)
        return out

    def spy_nearest(target, points):
        out = compiled_nearest(target, points)
        assert out.dtype == np.int64
        assert np.array_equal(out, reference_nearest_face(target.index, points))
        seen["nearest"] += len(out)
        return out

    def spy_single(tri, target, nearest):
        out = compiled_single(tri, target, nearest)
        assert np.array_equal(out, reference_single_triangle_bound(tri, target, nearest))
        seen["single"] += len(out)
        return out

    def spy_chain(tri, target, faces):
        out = compiled_chain(tri, target, faces)
        assert np.array_equal(out, reference_chain_bound(tri, target, faces))
        seen["chain"] += len(out)
        return out

    def spy_pair(tri, target, nearest):
        out = compiled_pair(tri, target, nearest)
        other = compiled_nearest(target, tri.reshape(-1, 3)).reshape(len(tri), 3)
        assert np.array_equal(out, reference_pair_bound(tri, target, nearest, other))
        seen["pair"] += int(np.isfinite(out).sum())
        return out

    monkeypatch.setattr(SurfaceIndex, "_upper", spy_upper)
    monkeypatch.setattr(hausdorff, "_pair_bound", spy_pair)
    monkeypatch.setattr(hausdorff, "_single_triangle_bound", spy_single)
    monkeypatch.setattr(hausdorff, "_chain_bound", spy_chain)
    monkeypatch.setattr(hausdorff, "_nearest_face", spy_nearest)
    config = Config()
    for building in samplegen.generate_buildings(30, seed=11):
        simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    assert seen["upper"] > 1000 and seen["nearest"] > 100  # asked often
    assert seen["single"] > 20 and seen["chain"] > 20 and seen["pair"] > 5


def _awkward_mesh(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A bumpy grid with a sliver, a zero-area face, a repeated face (equal distances) and a
    zero-length edge (a chain of no length)."""
    x, y = np.meshgrid(np.linspace(0, 10, 7), np.linspace(0, 6, 5))
    z = rng.normal(size=x.shape) * 0.3
    positions = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    faces = []
    for j in range(4):
        for i in range(6):
            a, b, c, d = j * 7 + i, j * 7 + i + 1, (j + 1) * 7 + i, (j + 1) * 7 + i + 1
            faces += [[a, b, d], [a, d, c]]
    k = len(positions)
    extra = np.array(
        [[0.0, 0.0, 0.0], [5.0, 0.0, 1e-9], [10.0, 0.0, 0.0], [3.0, 3.0, 2.0], [0.0, 0.0, 0.0]]
    )
    positions = np.concatenate([positions, extra])
    # a sliver, a zero-area face, a repeated face, a fin, a zero-length edge
    faces += [[k, k + 1, k + 2], [k, k + 2, k], faces[7], [k + 3, 8, 9], [k, k + 4, k + 3]]
    return positions, np.array(faces, np.int64)


@pytest.mark.parametrize("dense", [True, False])
def test_random_points_near_an_awkward_mesh_give_the_former_values(monkeypatch, dense):
    if not dense:  # the tree's candidate lists instead of every face
        monkeypatch.setattr(hausdorff, "NEAREST_DENSE", 0)
    rng = np.random.default_rng(5)
    for _ in range(10):
        positions, faces = _awkward_mesh(rng)
        target = Surface(positions, faces, reference=bool(rng.integers(2)))
        points = np.concatenate(
            [
                rng.random((60, 3)) * [12, 8, 4] - [1, 1, 2],
                positions[rng.integers(0, len(positions), 10)],  # on a vertex (a probe)
                target.tri[:, [0, 1]].mean(axis=1)[:10],  # on edges
            ]
        )
        index = target.index
        probe_distance, nearest = index.probes(points, index.CANDIDATES)
        assert np.array_equal(
            index._upper(points, probe_distance, nearest),
            reference_upper(index, points, probe_distance, nearest),
        )
        nearest = hausdorff._nearest_face(target, points)
        assert np.array_equal(nearest, reference_nearest_face(target.index, points))
        tri = points[rng.integers(0, len(points), size=(30, 3))]
        tri[:3, 1] = tri[:3, 0]  # degenerate pieces
        near = nearest[:30]
        assert np.array_equal(
            hausdorff._single_triangle_bound(tri, target, near),
            reference_single_triangle_bound(tri, target, near),
        )
        other = rng.integers(0, len(faces), size=(30, 3))
        other[::4, 1] = other[::4, 0]  # repeated other faces
        other[::5, 0] = near[::5]  # the nearest face itself
        assert np.array_equal(
            _surface.pair_bound(
                tri, near, other, target.trusted, *target.face_planes[:2], target.tri
            ),
            reference_pair_bound(tri, target, near, other),
        )
        faces_near = rng.integers(0, len(faces), size=(30, 4))
        assert np.array_equal(
            hausdorff._chain_bound(tri, target, faces_near),
            reference_chain_bound(tri, target, faces_near),
        )


def test_a_tie_goes_to_the_first_face_and_no_candidate_to_face_0():
    positions = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [6, 5, 5], [5, 6, 5]])
    faces = np.array([[3, 4, 5], [0, 1, 2], [0, 1, 2]])
    target = Surface(positions, faces)
    points = np.array([[0.2, 0.2, 1.0]])
    assert hausdorff._nearest_face(target, points).tolist() == [1]
    index = target.index
    zero = np.zeros(3)
    got = _surface.nearest_face(
        points, np.array([-1.0]), index.centres, index.radii, zero.reshape(1, 3).repeat(3, 0),
        zero, 0.0, index.tri, None, None,
    )  # fmt: skip
    assert got.tolist() == [0]


def test_a_bad_index_is_an_error_not_a_crash():
    positions, faces = _awkward_mesh(np.random.default_rng(1))
    index = SurfaceIndex(positions, faces)
    points = np.zeros((2, 3))
    probe_distance, nearest = index.probes(points, 3)
    with pytest.raises(ValueError, match="nearest"):
        _surface.upper(points, probe_distance, nearest + 10**6, index.owner, index.tri)
    with pytest.raises(ValueError, match="owner"):
        _surface.upper(points, probe_distance, nearest, index.owner + len(faces), index.tri)
    with pytest.raises(ValueError, match="probe_distance"):
        _surface.upper(points, probe_distance[:1], nearest, index.owner, index.tri)
    m = len(faces)
    args = (points, np.ones(2), index.centres, index.radii, np.zeros((m, 3)), np.zeros(m), 0.0)
    with pytest.raises(ValueError, match="cols"):
        _surface.nearest_face(*args, index.tri, np.array([0, 1, 2]), np.array([0, m]))
    with pytest.raises(ValueError, match="start"):
        _surface.nearest_face(*args, index.tri, np.array([0, 2, 1]), np.array([0, 1]))
    with pytest.raises(ValueError, match="start"):
        _surface.nearest_face(*args, index.tri, np.array([0, 1]), np.array([0, 1]))
    with pytest.raises(ValueError, match="radii"):
        _surface.nearest_face(*args[:3], index.radii[:-1], *args[4:], index.tri, None, None)


def test_bad_candidates_are_an_error_not_a_crash():
    positions, faces = _awkward_mesh(np.random.default_rng(1))
    target = Surface(positions, faces)
    tri = target.tri[:4]
    chains = target.chains
    with pytest.raises(ValueError, match="cand"):
        _surface.single_bound(tri, np.full((4, 2), len(faces)), target.trusted, target.tri)
    with pytest.raises(ValueError, match="cand"):
        _surface.single_bound(tri, np.zeros((4, 0), np.int64), target.trusted, target.tri)
    with pytest.raises(ValueError, match="trusted"):
        _surface.single_bound(tri, np.zeros((4, 2), np.int64), target.trusted[1:], target.tri)
    with pytest.raises(ValueError, match="cand"):
        _surface.chain_bound(tri, np.full((4, 1), -1), chains.start, chains.end, chains.slack)
    args = (target.trusted, *target.face_planes[:2], target.tri)
    with pytest.raises(ValueError, match="other"):
        _surface.pair_bound(tri, np.zeros(4, np.int64), np.full((4, 3), len(faces)), *args)
    with pytest.raises(ValueError, match="nearest"):
        _surface.pair_bound(tri, np.zeros(3, np.int64), np.zeros((4, 3), np.int64), *args)
    with pytest.raises(ValueError, match="end"):
        _surface.chain_bound(
            tri, np.zeros((4, 1), np.int64), chains.start, chains.end[1:], chains.slack
        )
