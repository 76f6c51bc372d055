"""The pair step of the certified bound (``exporter.mesh.hausdorff._pair_bound``): a triangle bridging
two faces of the target (a chord across the facets of a dome, a piece of a facet across a ridge)
is bounded by splitting it where the two faces' planes are equally far.

Coordinates are metres in an arbitrary frame (y up for the hand-built roofs)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exporter.mesh import hausdorff
from exporter.mesh.hausdorff import Surface, _nearest_face, _pair_bound, directed_bounds
from tests.hausdorff_check import count_rounds, grid_points


def ridge(angle: float, convex: bool = True):
    """Two roof triangles meeting at a ridge along z (x = 0, y = 0, z from 0 to 8 m), each
    falling (convex) or rising (concave, a valley) by ``angle`` radians away from it to a corner
    4 m out at z = 4: wound up (+y normals)."""
    drop = (-1.0 if convex else 1.0) * 4.0 * np.tan(angle)
    positions = np.array([[0, 0, 0], [0, 0, 8], [4, drop, 4], [-4, drop, 4.0]])
    faces = np.array([[0, 1, 2], [1, 0, 3]])
    return positions, faces


def dense_max(tri: np.ndarray, target: Surface, steps: int = 40) -> np.ndarray:
    """(n,) metres: the largest exact distance to ``target`` over a barycentric grid of each
    triangle (n, 3, 3), a lower bound of the true maximum."""
    faces = np.arange(3)[None]
    return np.array(
        [
            target.index.refine(p, target.index.upper(p)).max()
            for p in (grid_points(t, faces, steps) for t in tri)
        ]
    )


def chord(offset: float) -> np.ndarray:
    """(1, 3, 3): a triangle across the ridge, ``offset`` metres above y = 0, 2 m each side."""
    return np.array([[[-2.0, offset, 3.5], [2.0, offset, 3.5], [0.0, offset, 5.0]]])


@pytest.mark.parametrize("convex", [True, False])
def test_a_triangle_across_a_ridge_is_bounded_tightly_in_one_step(convex):
    target = Surface(*ridge(0.1, convex))
    tri = chord(0.05)
    nearest = _nearest_face(target, hausdorff._centroid(tri))
    pair = _pair_bound(tri, target, nearest)[0]
    single = hausdorff._single_triangle_bound(tri, target, nearest)[0]
    true = dense_max(tri, target)[0]
    # No one face is near the far corner of the other side: the single-face bound is ~0.2 m.
    assert single > 2.5 * true
    assert true <= pair <= true * 1.01 + 1e-9


@pytest.mark.parametrize("convex", [True, False])
def test_the_pair_step_saves_refinement_rounds(convex, monkeypatch):
    target = Surface(*ridge(0.1, convex))
    tri = chord(0.05)
    calls = count_rounds(monkeypatch)
    with_pairs = directed_bounds(tri, target)
    rounds_with = len(calls)
    calls.clear()
    monkeypatch.setattr(
        hausdorff, "_pair_bound", lambda tri, target, nearest: np.full(len(tri), np.inf)
    )
    without = directed_bounds(tri, target)
    assert rounds_with == 1 and len(calls) > 1
    assert with_pairs[1] <= without[1] * (1 + 1e-9)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    facets=st.integers(5, 12),
    height=st.floats(-0.3, 0.3),
)
def test_pair_bounds_never_fall_below_a_dense_maximum(seed, facets, height):
    """A faceted dome cap (a ring of ``facets`` triangles to an apex, randomly jittered) and
    random triangles near it: every pair bound is at least the densely sampled maximum."""
    rng = np.random.default_rng(seed)
    angle = np.linspace(0, 2 * np.pi, facets, endpoint=False) + rng.uniform(0, 0.2)
    ring = np.column_stack([5 * np.cos(angle), np.full(facets, -1.0), 5 * np.sin(angle)])
    ring += rng.normal(0, 0.2, ring.shape)
    positions = np.vstack([[0.0, 0.0, 0.0], ring])
    faces = np.array([[0, 1 + (i + 1) % facets, 1 + i] for i in range(facets)])
    target = Surface(positions, faces)
    centre = rng.uniform(-3, 3, (20, 3)) * [1, 0, 1] + [0, height, 0]
    tri = centre[:, None] + rng.normal(0, 1.0, (20, 3, 3))
    nearest = _nearest_face(target, hausdorff._centroid(tri))
    bound = _pair_bound(tri, target, nearest)
    true = dense_max(tri, target, steps=24)
    assert np.all(bound >= true)
