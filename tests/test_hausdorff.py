"""The certified Hausdorff distance (exporter/mesh/hausdorff.py): hand-built cases with known values,
random meshes against a dense sampling, degenerate input, and the guard never accepting a level
that a dense check finds above its budget."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exporter.mesh.hausdorff import Surface, directed_bounds, exceeds, hausdorff_bounds
from tests.hausdorff_check import count_rounds, dense_hausdorff, directed_dense


def notch():
    """A 2 m x 2 m square (z = 0) with a pyramid notch 1 m deep in its middle, and the level that
    keeps the four outer corners: two triangles bridging the notch. Every level vertex lies on
    the source; the level's centre (1, 1, 0) is 1/sqrt(2) m from the notch's faces, the notch's
    apex (1, 1, -1) is 1 m below the level."""
    positions = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, -1.0]])
    faces = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return (positions, faces), (positions[:4], np.array([[0, 1, 2], [0, 2, 3]]))


def wall(n: int = 10, width: float = 10.0, height: float = 5.0):
    """A flat wall (z = 0) cut into n x n squares of two triangles, and its two-triangle level."""
    xs, ys = np.meshgrid(np.linspace(0, width, n + 1), np.linspace(0, height, n + 1))
    positions = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    index = np.arange(xs.size).reshape(n + 1, n + 1)
    a, b = index[:-1, :-1].ravel(), index[:-1, 1:].ravel()
    c, d = index[1:, 1:].ravel(), index[1:, :-1].ravel()
    faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    corners = [index[0, 0], index[0, n], index[n, n], index[n, 0]]
    level = np.array([[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]])
    return (positions, faces), (positions, level)


def test_a_triangle_bridging_a_notch_is_bounded_from_above():
    source, level = notch()
    # The old guard's view: every level vertex is on the source.
    assert directed_dense(level, source, 1) == 0.0
    lower, upper = directed_bounds(Surface(*level).tri, Surface(*source))
    true = 1 / np.sqrt(2)
    assert lower <= true * (1 + 1e-12) and true <= upper <= true * 1.03
    lower, upper = hausdorff_bounds(source, level)
    assert lower <= 1.0 <= upper <= 1.03  # the apex, 1 m under the level
    assert exceeds(source, level, 0.99) and not exceeds(source, level, upper)


def test_a_wall_retriangulated_is_within_rounding_without_subdivision():
    source, level = wall()
    lower, upper = hausdorff_bounds(source, level)
    assert lower == 0.0 and upper < 1e-5  # exact up to the containment test's margin
    assert not exceeds(source, level, 1e-4)
    # Moved 3 cm off the wall: the bound follows (plane distance, no in-plane loss).
    moved = (level[0] + [0.0, 0.0, 0.03], level[1])
    lower, upper = hausdorff_bounds(source, moved)
    assert lower == pytest.approx(0.03) and upper <= 0.03 * 1.02 + 1e-5
    assert exceeds(source, moved, 0.029) and not exceeds(source, moved, 0.031)


def test_identical_meshes_and_a_single_triangle():
    source, _ = notch()
    assert hausdorff_bounds(source, source) == (0.0, 0.0)
    triangle = (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    assert hausdorff_bounds(triangle, triangle) == (0.0, 0.0)
    lifted = (triangle[0] + [0, 0, 0.5], triangle[1])
    lower, upper = hausdorff_bounds(triangle, lifted)
    assert lower == pytest.approx(0.5) and upper == pytest.approx(0.5, rel=0.02)


def test_empty_sides():
    source, _ = notch()
    empty = (np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    assert hausdorff_bounds(source, empty) == (np.inf, np.inf)
    assert hausdorff_bounds(empty, source) == (np.inf, np.inf)
    assert hausdorff_bounds(empty, empty) == (0.0, 0.0)
    assert exceeds(source, empty, 1e9) and not exceeds(empty, empty, 0.0)


def test_degenerate_duplicate_and_nonmanifold_faces():
    source, level = wall(4)
    positions, faces = source
    # Zero-area faces (a repeated index, three collinear points), duplicates, a fin sharing an
    # edge with two wall faces (non-manifold): all bounded, lower <= dense <= upper.
    extra = np.array([[0, 0, 1], [0, 1, 2], [5, 6, 7], [5, 6, 7]])
    fin_tip = len(positions)
    noisy = (
        np.vstack([positions, [[2.5, 0.0, 1.0]]]),
        np.vstack([faces, extra, [[0, 1, fin_tip]]]),
    )
    for a, b in ((noisy, level), (level, noisy), (noisy, source), (noisy, noisy)):
        lower, upper = hausdorff_bounds(a, b)
        dense = dense_hausdorff(a, b, 8)
        assert lower <= upper and dense <= upper + 1e-12
        assert upper <= max(lower, 1e-9) * 1.03 + 1e-4
    assert hausdorff_bounds(noisy, source)[0] == pytest.approx(1.0)  # the fin's tip


def test_one_flat_polygon_against_its_fan():
    # A convex polygon (regular 12-gon) as a fan from its centre and as a strip from one corner:
    # the same surface, different triangles, no triangle of one inside a triangle of the other.
    angle = np.linspace(0, 2 * np.pi, 13)[:-1]
    ring = np.column_stack([np.cos(angle), np.zeros(12), np.sin(angle)]) * 7.0
    fan = (np.vstack([ring, [[0, 0, 0]]]), np.array([[i, 12, (i + 1) % 12] for i in range(12)]))
    strip = (ring, np.array([[0, i + 1, i] for i in range(1, 11)]))
    lower, upper = hausdorff_bounds(fan, strip)
    assert lower < 1e-12 and upper < 1e-4
    assert not exceeds(fan, strip, 1e-3)


def _soup(draw_values, count):
    return np.array(draw_values, dtype=np.float64).reshape(count, 3, 3)


@settings(max_examples=25, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 6),
    st.integers(1, 6),
    st.sampled_from([0.0, 0.01, 0.3]),
)
def test_random_soups_are_bracketed_by_the_bounds(seed, m, n, offset):
    # Random triangle soups (a side, and a side near it): lower <= dense maximum <= upper, and
    # the gap closes to the requested tolerance (or the refinement was stopped by depth).
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, (m, 3, 3))
    b = np.concatenate(
        [
            a[: n // 2] + rng.normal(0, offset, (min(n // 2, m), 3, 3)),
            rng.uniform(-1, 1, (n - min(n // 2, m), 3, 3)),
        ]
    )
    mesh_a = (a.reshape(-1, 3), np.arange(3 * m).reshape(m, 3))
    mesh_b = (b.reshape(-1, 3), np.arange(3 * len(b)).reshape(len(b), 3))
    lower, upper = hausdorff_bounds(mesh_a, mesh_b, rtol=0.05)
    dense = dense_hausdorff(mesh_a, mesh_b, 10)
    assert lower <= upper and dense <= upper + 1e-12
    assert upper <= lower * 1.2 + 1e-3, (lower, upper)
    for tolerance in (0.5 * lower, upper, 1.5 * upper):
        decided = exceeds(mesh_a, mesh_b, tolerance)
        assert decided or dense <= tolerance + 1e-12  # never accepts above the true value
        if tolerance < lower:
            assert decided
        if tolerance >= upper:
            assert not decided


def test_no_exported_level_exceeds_its_budget_on_a_generated_tile(tmp_path):
    # The simplifier's guard on VWorld-like buildings (a seed no other test uses): every level's
    # dense distance to LOD0 stays within the level's budget.
    from exporter import samplegen
    from exporter.config import Config
    from exporter.readers import load_entry, scan_folder
    from exporter.simplify import _join, build_mesh_chain

    samplegen.generate_tile(tmp_path, count=8, seed=131, atlas_size=16)
    config = Config()
    checked = 0
    for entry in scan_folder(tmp_path, config.readers).entries:
        building = load_entry(entry, config.readers)
        chain = build_mesh_chain(building.parts, config.lods, config.simplify)
        lod0 = _join(chain[0].parts, 0.0)[:2]
        for k in range(1, len(chain)):
            budget = chain[k].tolerance  # the level's screen error budget, metres
            level = _join(chain[k].parts, 0.0)[:2]
            assert dense_hausdorff(lod0, level, 4) <= budget
            checked += 1
    assert checked == 16


def test_a_corner_beyond_give_up_returns_before_any_triangle_is_bounded(monkeypatch):
    """The guard's rejection: the notch's apex lies 1 m under the level, so with ``give_up``
    0.5 m the directed bound returns (1 m, inf) from the corners alone (a refused candidate
    used to pay a full round of triangle bounds first)."""
    import exporter.mesh.hausdorff as hausdorff_module

    source, level = notch()

    def no_triangles(*args):
        raise AssertionError("a triangle was bounded")

    monkeypatch.setattr(hausdorff_module, "_bound", no_triangles)
    lower, upper = directed_bounds(Surface(*source).tri, Surface(*level), give_up=0.5)
    assert lower == pytest.approx(1.0) and upper == float("inf")
    monkeypatch.undo()
    # Under the corners' distance the bound runs as before.
    lower, upper = directed_bounds(Surface(*source).tri, Surface(*level), give_up=1.5)
    assert lower == pytest.approx(1.0) and 1.0 <= upper <= 1.03


def cone(facets: int, height: float):
    """A faceted cone: apex ``height`` m over a ring of ``facets`` corners 5 m out (y up)."""
    angle = np.linspace(0, 2 * np.pi, facets, endpoint=False)
    ring = np.column_stack([5 * np.cos(angle), np.zeros(facets), 5 * np.sin(angle)])
    faces = np.array([[0, 1 + (i + 1) % facets, 1 + i] for i in range(facets)])
    return np.vstack([[0.0, height, 0.0], ring]), faces


def test_the_guard_refines_no_finer_than_a_share_of_the_budget(monkeypatch):
    """``certify`` of a 6-facet cone (apex 0.1 m lower) against a 24-facet one, budget 3 m: the
    bound (certified: never below the lower one) stops within 5 % of the budget, in fewer
    rounds than the manifest's 2 % alone would take."""
    from exporter.simplify import guard

    source = cone(24, 1.0)
    level = cone(6, 0.9)
    calls = count_rounds(monkeypatch)
    lower, upper = guard.certify(guard.Reference(*source), *level, 3.0)
    coarse = len(calls)
    assert lower <= upper <= lower * 1.02 + 0.05 * 3.0
    calls.clear()
    monkeypatch.setattr(guard, "BUDGET_SHARE", 0.0)
    tight = guard.certify(guard.Reference(*source), *level, 3.0)
    assert tight[0] == lower and tight[1] <= lower * 1.02 + 1e-3
    assert coarse < len(calls)


def test_refinement_goes_on_under_give_up_where_the_relative_gap_would_stop_above_it():
    """A 6-facet cone against a 24-facet one: refined to a 30 % gap the bound stops at ~0.159 m
    (true ~0.131 m); with ``give_up`` 0.14 m (the guard's budget) the refinement goes on until
    the bound is under it instead of refusing a level that is within."""
    source = Surface(*cone(24, 1.0))
    level = Surface(*cone(6, 0.9))
    lower, upper = directed_bounds(level.tri, source, rtol=0.3)
    assert upper > 0.14 > lower
    lower, upper = directed_bounds(level.tri, source, rtol=0.3, give_up=0.14)
    assert lower <= upper <= 0.14
