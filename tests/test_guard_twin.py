"""The error guard's lossless twin (exporter/simplify/guard.py): LOD0's flat polygons
re-triangulated stand in for LOD0 only when certified to be the same surface, and the bounds taken
through it stay bounds (a dense check)."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.config import Config
from exporter.mesh.slits import close_slits
from exporter.mesh.topology import nonmanifold_vertices
from exporter.quality import joined
from exporter.samplegen import generate_buildings, generate_samples
from exporter.simplify import _join, build_mesh_chain, guard
from exporter.simplify.planar import retriangulate_planar_checked
from tests.hausdorff_check import dense_hausdorff
from tests.test_hausdorff import wall


def planar_faces(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The planar stage's output for ``(positions, faces)``, without charts or locks."""
    return retriangulate_planar_checked(
        positions, faces, None, np.zeros(len(faces), np.int64), np.zeros(len(positions), bool)
    )[0]


@pytest.fixture(scope="module")
def tower():
    """A generated tower (wall columns cut into floors): LOD0 welded, the twin the pipeline
    offers the guard (its planar stage on LOD0, UV charts kept), level 2 and its budget."""
    config = Config()
    building = generate_buildings(1, seed=5, atlas_size=64, kinds=["tower"])[0]
    chain = build_mesh_chain(building.parts, config.lods, config.simplify)
    positions, faces, _, corner_uvs, face_chart, _ = _join(chain[0].parts, 0.0)
    twin = retriangulate_planar_checked(
        positions, faces, corner_uvs, face_chart, nonmanifold_vertices(faces, len(positions))
    )[0]
    level = joined(chain[1].parts)
    assert len(level[1]) < len(twin)  # the collapse did work after the planar stage
    return (positions, faces), twin, level, chain[1].tolerance


def test_the_twin_is_smaller_and_certified_as_the_same_surface(tower):
    (positions, faces), twin_faces, _, _ = tower
    slack = guard.TWIN_SLACK * guard.diagonal(positions)
    twin = guard.lossless_twin(positions, faces, twin_faces, slack)
    assert twin is not None
    twin_positions, twin_faces, delta = twin
    assert len(twin_faces) <= 0.5 * len(faces)
    assert 0 <= delta <= slack
    assert dense_hausdorff((twin_positions, twin_faces), (positions, faces), 6) <= delta + 1e-12


def test_a_twin_that_is_not_the_same_surface_is_refused(tower):
    (positions, faces), twin, _, _ = tower
    slack = guard.TWIN_SLACK * guard.diagonal(positions)
    # One polygon's triangle missing: a hole the twin does not have in LOD0.
    assert guard.lossless_twin(positions, faces, twin[1:], slack) is None
    # One triangle reaching to a far vertex: a surface LOD0 does not have.
    far = int(np.argmax(np.linalg.norm(positions - positions[twin[0, 0]], axis=1)))
    wrong = twin.copy()
    wrong[0, 0] = far
    assert guard.lossless_twin(positions, faces, wrong, slack) is None


def test_a_wall_bent_within_the_planar_tolerance_is_no_twin():
    """A wall of 10 x 10 squares whose middle vertex is pushed 0.5 mm out: the planar stage
    still takes it as one polygon (1 mm plane tolerance), but the twin is 0.5 mm off LOD0,
    more than the slack, so the guard keeps LOD0."""
    (positions, faces), _ = wall(10, 10.0, 10.0)
    positions = positions.copy()
    positions[60, 2] = 5e-4  # the middle vertex
    twin = planar_faces(positions, faces)
    assert len(twin) < len(faces)  # the planar stage did take it
    slack = guard.TWIN_SLACK * guard.diagonal(positions)
    assert guard.lossless_twin(positions, faces, twin, slack) is None
    assert guard.lossless_twin(positions, faces, twin, 1e-3) is not None  # 0.5 mm < 1 mm
    reference = guard.Reference(positions, faces)
    reference.offer_twin(twin)
    assert reference.twin == (reference.surface, 0.0)


def test_bounds_through_the_twin_stay_bounds(tower):
    (positions, faces), twin, level, tolerance = tower
    dense = dense_hausdorff((positions, faces), level, 12)
    plain = guard.certify(guard.Reference(positions, faces), *level, tolerance)
    reference = guard.Reference(positions, faces)
    reference.offer_twin(twin)
    surface, delta = reference.twin
    assert len(surface.faces) == len(twin) and delta > 0
    twinned = guard.certify(reference, *level, tolerance)
    assert plain is not None and twinned is not None
    for lower, upper in (plain, twinned):
        assert 0 <= lower <= upper
        assert dense <= upper * (1 + 1e-12) <= tolerance * (1 + 1e-12)
    # The same level, the same error: both bounds bracket it within the guard's tightness.
    assert abs(twinned[1] - plain[1]) <= 0.05 * tolerance + 0.02 * plain[0]
    assert guard.deviation(reference, *level) >= dense
    assert not guard.exceeds(reference, *level, tolerance)
    # Without an offer (or with planar_retriangulation off) the guard measures LOD0 itself.
    bare = guard.Reference(positions, faces)
    assert bare.twin[0] is bare.surface and bare.twin[1] == 0.0


def test_a_twin_with_slits_closed_is_certified_through_the_closed_surface():
    # A T-shaped building with slits along its roofs: the planar stage closes them first, so its
    # output is not LOD0's re-triangulation. Against LOD0 itself the region certificate leaves
    # the faces along the former slits open; against LOD0 with its slits closed
    # (slits.closed_surface, plus its offset) it settles them all, so the twin stands without
    # LOD0's prepared surface. A dense check stays below its delta.
    building = generate_samples(16, seed=3, atlas_size=16)[15].building
    positions, faces, _, corner_uvs, face_chart, _ = _join(building.parts, 0.0)
    twin_faces = retriangulate_planar_checked(
        positions, faces, corner_uvs, face_chart, nonmanifold_vertices(faces, len(positions))
    )[0]
    assert len(close_slits(positions, faces, None)[0]) > len(faces)  # it had slits
    slack = guard.TWIN_SLACK * guard.diagonal(positions)
    twin = guard.lossless_twin(positions, faces, twin_faces, slack)
    assert twin is not None
    twin_positions, twin_faces, delta = twin
    assert 0 <= delta <= slack
    assert dense_hausdorff((twin_positions, twin_faces), (positions, faces), 6) <= delta + 1e-12
    settled = guard.coverage.region_certificate(
        (twin_positions, twin_faces), (positions, faces), max_bound=slack
    )
    assert settled.open_level.any() or settled.open_source.any()
