"""The straight edge chains of the certified bound (``hausdorff._Chains``, compiled:
exporter/mesh/c/chains.c) give exactly what the former numpy form (kept here,
:func:`reference_chains`) gives, float for float: on every surface the mesh chain prepares over
generated buildings, on an awkward mesh (zero-length edge, sliver, repeated face, fin) and on
random soups; a bad index is an error, not a crash."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh import _chains, hausdorff
from exporter.mesh.hausdorff import STRAIGHT, _components, _ranges
from tests.test_surface_kernels import _awkward_mesh


def reference_chains(positions: np.ndarray, faces: np.ndarray):
    """``(face_chain (m, 3), start (c, 3), end (c, 3), slack (c,))``: ``_Chains.__init__`` as it
    was in numpy."""
    m = len(faces)
    half = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    k = max(len(positions), 1)
    edges, edge_of = np.unique(half[:, 0] * k + half[:, 1], return_inverse=True)
    a, b = edges // k, edges % k
    face_chain = edge_of.reshape(m, 3)
    e = len(edges)
    direction = positions[b] - positions[a]
    length = np.sqrt((direction**2).sum(1))
    direction = np.divide(
        direction, length[:, None], out=np.zeros_like(direction), where=length[:, None] > 0
    )
    vertex = np.concatenate([a, b])
    edge = np.concatenate([np.arange(e), np.arange(e)])
    away = np.concatenate([direction, -direction])
    order = np.argsort(vertex, kind="stable")
    vertex, edge, away = vertex[order], edge[order], away[order]
    last = np.searchsorted(vertex, vertex, side="right")
    counts = last - np.arange(len(vertex)) - 1
    owner, item = _ranges(np.arange(len(vertex)) + 1, counts)
    straight = (away[owner] * away[item]).sum(1) < -STRAIGHT
    count, chain = _components(e, edge[owner[straight]], edge[item[straight]])
    face_chain = chain[face_chain]
    lead = np.full(count, e)
    np.minimum.at(lead, chain, np.arange(e))
    origin, axis = positions[a[lead]], direction[lead]
    ends = np.concatenate([a, b])
    owner_chain = np.concatenate([chain, chain])
    offset = positions[ends] - origin[owner_chain]
    along = (offset * axis[owner_chain]).sum(1)
    across = np.sqrt(np.maximum((offset**2).sum(1) - along**2, 0.0))
    low = np.full(count, np.inf)
    high = np.full(count, -np.inf)
    np.minimum.at(low, owner_chain, along)
    np.maximum.at(high, owner_chain, along)
    slack = np.zeros(count)
    np.maximum.at(slack, owner_chain, across)
    slack += 1e-7 * np.maximum(high - low, 0.0) + 1e-12
    return face_chain, origin + low[:, None] * axis, origin + high[:, None] * axis, slack


def _same(positions: np.ndarray, faces: np.ndarray, got=None) -> None:
    got = got if got is not None else hausdorff._Chains(positions, faces)
    want = reference_chains(positions, faces)
    for name, value in zip(("face_chain", "start", "end", "slack"), want):
        mine = getattr(got, name)
        assert mine.dtype == value.dtype and mine.shape == value.shape, name
        assert np.array_equal(mine.view(np.uint8), value.view(np.uint8)), name  # bits, -0.0 too


def test_every_chain_the_mesh_chain_prepares_on_generated_buildings_is_the_former_one(monkeypatch):
    import exporter.simplify as simplify
    from exporter import samplegen
    from exporter.config import Config

    compiled = hausdorff._Chains.__init__
    seen = []

    def spy(self, positions, faces):
        compiled(self, positions, faces)
        _same(positions, faces, self)
        seen.append(len(self.slack))

    monkeypatch.setattr(hausdorff._Chains, "__init__", spy)
    config = Config()
    for building in samplegen.generate_buildings(30, seed=11):
        simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    assert len(seen) >= 3 and sum(seen) > 100


def test_an_awkward_mesh_and_random_soups_give_the_former_chains():
    rng = np.random.default_rng(2)
    _same(*_awkward_mesh(rng))
    for _ in range(30):
        k = int(rng.integers(1, 30))
        # Coordinates on a coarse grid (collinear runs, opposite directions, repeated points).
        positions = np.round(rng.normal(size=(k, 3)) * 2) / 2
        positions[rng.random(k) < 0.2] *= -0.0  # signed zeros
        faces = rng.integers(0, k, (int(rng.integers(0, 40)), 3))
        _same(positions, faces)
    # A straight run cut into many edges, a fan around it: one long chain.
    line = np.column_stack([np.arange(12.0), np.zeros(12), np.zeros(12)])
    apex = np.array([[5.0, 3.0, 0.0]])
    positions = np.concatenate([line, apex])
    faces = np.array([[i, i + 1, 12] for i in range(11)])
    _same(positions, faces)
    assert hausdorff._Chains(positions, faces).face_chain[:, 0].tolist() == [0] * 11


def test_a_bad_index_or_shape_is_an_error_not_a_crash():
    positions = np.eye(3)
    with pytest.raises(ValueError, match="outside"):
        _chains.chains(positions, np.array([[0, 1, 3]]), STRAIGHT)
    with pytest.raises(ValueError, match="outside"):
        _chains.chains(positions, np.array([[0, -1, 2]]), STRAIGHT)
    with pytest.raises(ValueError, match="axis 1"):
        _chains.chains(positions, np.array([[0, 1]]), STRAIGHT)
    with pytest.raises(ValueError, match="axis 1"):
        _chains.chains(positions[:, :2], np.array([[0, 1, 2]]), STRAIGHT)
    face_chain, start, end, slack = _chains.chains(
        np.zeros((0, 3)), np.zeros((0, 3), np.int64), STRAIGHT
    )
    assert face_chain.shape == (0, 3) and start.shape == end.shape == (0, 3) and len(slack) == 0
