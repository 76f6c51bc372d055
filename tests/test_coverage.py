"""The region certificate (exporter/mesh/coverage.py): re-triangulated flat polygons settled by
counting, and everything it cannot vouch for left open. Soundness is checked against the
independent dense sampling of tests/hausdorff_check.py."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.coverage import region_certificate
from tests.hausdorff_check import directed_dense
from tests.test_hausdorff import notch, wall


def _settled_distances(level, source, cert, steps=10):
    """Dense distances (metres) of the settled faces of each side to the whole other side."""
    lv = (level[0], level[1][~cert.open_level])
    sv = (source[0], source[1][~cert.open_source])
    return directed_dense(lv, source, steps), directed_dense(sv, level, steps)


def test_a_wall_retriangulated_from_its_corners_is_settled_exactly():
    source, level = wall()
    cert = region_certificate(level, source)
    # The 36 straight outline vertices the level dropped are bands of width 0.
    assert not cert.open_level.any() and not cert.open_source.any()
    assert cert.bound < 1e-9


def test_a_dropped_outline_vertex_off_the_chord_widens_the_bound():
    (positions, faces), level = wall(n=4, width=4.0, height=4.0)
    positions = positions.copy()
    # The middle vertex of the bottom edge (y = 0) pushed 5 cm down, in the wall's plane: the
    # level's chord misses a sliver of the source 5 cm high.
    middle = np.flatnonzero((positions[:, 1] == 0) & (positions[:, 0] == 2.0))[0]
    positions[middle, 1] = -0.05
    source = (positions, faces)
    level = (positions, level[1])
    cert = region_certificate(level, source)
    assert not cert.open_level.any() and not cert.open_source.any()
    dense = max(_settled_distances(level, source, cert))
    assert dense == pytest.approx(0.05, rel=1e-6)
    assert 0.05 <= cert.bound <= 0.05 * (1 + 1e-9) + 1e-12
    # Outward bulge and an inward dent alike.
    positions[middle, 1] = 0.05
    cert = region_certificate((positions, level[1]), (positions, faces))
    assert cert.bound >= 0.05 and not cert.open_source.any()


def test_a_triangle_bridging_a_notch_is_left_open():
    source, level = notch()
    cert = region_certificate(level, source)
    # The notch's faces are not on the level's plane: nothing is settled, no bound claimed.
    assert cert.open_level.all() and cert.open_source.all() and cert.bound == 0.0


def test_a_level_covering_a_concave_corner_is_left_open():
    # An L-shaped flat polygon (z = 0) fanned from its reflex corner, from the corner opposite
    # (it sees the whole polygon too: the same cover) and from a corner next to the notch (a
    # triangle bridges the notch, outside the polygon, and another is flipped to pay for it).
    outline = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    positions = np.column_stack([outline, np.zeros(6)])
    from_reflex = np.array([[3, 4, 5], [3, 5, 0], [3, 0, 1], [3, 1, 2]])
    from_opposite = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    bridging = np.array([[2, 3, 4], [2, 4, 5], [2, 5, 0], [2, 0, 1]])
    source = (positions, from_reflex)
    for level in (from_reflex[[2, 0, 3, 1]], from_opposite):
        cert = region_certificate((positions, level), source)
        assert not cert.open_level.any() and cert.bound < 1e-9
    cert = region_certificate((positions, bridging), source)
    assert cert.open_level[0]  # the flipped face
    assert cert.bound >= max(_settled_distances((positions, bridging), source, cert))
    cert = region_certificate((positions, bridging), source, max_bound=0.1)
    assert cert.open_level.all() and cert.open_source.all()


def test_a_flipped_level_face_is_left_open():
    source, (positions, level) = wall(n=3)
    flipped = level.copy()
    flipped[0] = flipped[0, ::-1]
    cert = region_certificate((positions, flipped), source)
    assert cert.open_level[0]
    # The other face alone covers half the wall: the rest of the wall is a band as wide as the
    # corner's distance to the diagonal, a true but loose bound ...
    assert cert.bound >= max(_settled_distances((positions, flipped), source, cert))
    # ... that a caller's max_bound refuses.
    cert = region_certificate((positions, flipped), source, max_bound=1e-3)
    assert cert.open_level.all() and cert.open_source.all()


def test_faces_on_both_sides_are_settled_and_other_planes_left_open():
    source, level = notch()
    # The same mesh: every face is on both sides.
    cert = region_certificate(source, source)
    assert not cert.open_level.any() and cert.bound == 0.0
    cert = region_certificate(source, level)
    assert cert.open_level.all()


def test_max_bound_leaves_regions_above_it_open():
    (positions, faces), level = wall(n=4, width=4.0, height=4.0)
    positions = positions.copy()
    positions[:, 2] = 0.0004 * np.sin(positions[:, 0] * 3.0)  # a 0.8 mm ripple: one region
    source = (positions, faces)
    cert = region_certificate((positions, level[1]), source)
    assert not cert.open_source.any()
    assert cert.bound >= max(_settled_distances((positions, level[1]), source, cert))
    tight = region_certificate((positions, level[1]), source, max_bound=0.5 * cert.bound)
    assert tight.open_source.all() and tight.open_level.all() and tight.bound == 0.0


def _star(rng, count):
    """A star-shaped flat polygon around the origin (metres) with a little height noise, fanned
    from an interior centre vertex (the last one)."""
    angles = np.sort(rng.uniform(0, 2 * np.pi, count))
    radii = rng.uniform(2.0, 10.0, count)
    if rng.random() < 0.5:
        radii[::3] = radii.max()  # some straight-ish runs
    xy = np.column_stack([radii * np.cos(angles), radii * np.sin(angles)])
    positions = np.column_stack([xy, rng.uniform(-2e-4, 2e-4, count)])
    positions = np.vstack([positions, [0.0, 0.0, 0.0]])
    faces = np.array([[count, i, (i + 1) % count] for i in range(count)])
    return positions, faces


@pytest.mark.parametrize("seed", range(60))
def test_random_re_triangulations_are_never_under_bounded(seed):
    """Random star polygons fanned from their centre, against levels fanned from an outline vertex
    with random outline vertices dropped: valid or not, every settled face is within the bound
    of the other side by a dense check."""
    rng = np.random.default_rng(seed)
    count = int(rng.integers(5, 14))
    positions, faces = _star(rng, count)
    keep = np.sort(rng.choice(count, size=int(rng.integers(3, count + 1)), replace=False))
    apex = int(rng.integers(len(keep)))
    ring = np.roll(keep, -apex)
    level = np.array([[ring[0], ring[i], ring[i + 1]] for i in range(1, len(ring) - 1)])
    cert = region_certificate((positions, level), (positions, faces))
    to_source, to_level = _settled_distances((positions, level), (positions, faces), cert, 12)
    assert max(to_source, to_level) <= cert.bound * (1 + 1e-9) + 1e-12


def _t_junction(lift: float = 0.0):
    """A 2 x 1 m flat quad (z = 0) with a vertex m = (1, 1) on its top edge: the source fans it
    from its centre; the level fans its lower part to m and keeps the collinear sliver (3, m, 2)
    that a collapse onto the top edge leaves. ``lift`` (metres) moves m up off the edge within the
    plane (the sliver then has that altitude and the quad a dent of it)."""
    positions = np.array(
        [[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [1, 1 + lift, 0], [1, 0.5, 0]], np.float64
    )
    source = np.array([[0, 1, 5], [1, 2, 5], [2, 4, 5], [4, 3, 5], [3, 0, 5]])
    level = np.array([[0, 1, 4], [1, 2, 4], [0, 4, 3], [3, 4, 2]])
    return positions, source, level


def test_a_collinear_sliver_along_settled_edges_is_settled():
    positions, source, level = _t_junction()
    cert = region_certificate((positions, level), (positions, source))
    assert not cert.open_level.any() and not cert.open_source.any()
    assert cert.bound < 1e-9


def test_a_slightly_bent_sliver_adds_its_width_and_stays_sound():
    positions, source, level = _t_junction(lift=1e-7)
    cert = region_certificate((positions, level), (positions, source))
    # The sliver (3, 4, 2) sticks 1e-7 m out of the source: settled with at least that.
    assert not cert.open_level.any()
    to_source, to_level = _settled_distances((positions, level), (positions, source), cert, 12)
    assert max(to_source, to_level) <= cert.bound * (1 + 1e-9) + 1e-12
    assert cert.bound >= 1e-7


def test_a_sliver_off_every_settled_edge_stays_open():
    positions, source, level = _t_junction()
    # A thin triangle floating 1 m above the quad, sharing no edge with it: nothing vouches for it.
    far = np.array([[0.0, 0.5, 1.0], [1.0, 0.5, 1.0], [2.0, 0.5 + 1e-9, 1.0]])
    positions = np.vstack([positions, far])
    level = np.vstack([level, [[6, 7, 8]]])
    cert = region_certificate((positions, level), (positions, source))
    assert cert.open_level[-1]
