"""The compiled region certificate (:mod:`exporter.mesh.region_kernels` through
``coverage.region_certificate``) gives exactly what the former numpy code gives
(tests/region_reference.py): the same bound and the same open faces, bit for bit, on
re-triangulated walls and roofs with dropped outline vertices, flipped and degenerate faces,
slivers, noise, random soups and generated buildings' levels; and bad indices are errors, not
crashes. Metres, frame-free."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.coverage import region_certificate
from exporter.mesh.region_kernels import settle_regions
from tests.region_reference import reference_region_certificate
from tests.test_perf_hausdorff import reference_bands, reference_slivers


def _same(level, source, **options):
    got = region_certificate(level, source, **options)
    expected = reference_region_certificate(
        level, source, reference_bands, reference_slivers, **options
    )
    assert got.bound == expected.bound
    assert np.array_equal(got.open_level, expected.open_level)
    assert np.array_equal(got.open_source, expected.open_source)
    return got


def _grid(rng, nx, ny, scale):
    """A flat grid (a wall) of nx x ny vertices, triangulated, in a random plane; its outline
    corners and the grid's faces."""
    x, y = np.meshgrid(np.linspace(0, 1, nx), np.linspace(0, 1, ny))
    flat = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]) * scale
    rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    points = flat @ rotation.T + rng.normal(size=3) * scale
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1
            faces += [[a, b, d], [a, d, c]] if rng.random() < 0.5 else [[a, b, c], [b, d, c]]
    return points, np.array(faces, np.int64)


def _variants(rng, points, faces):
    """Levels of one source: a re-triangulation from the outline (fan), faces dropped, a flipped
    face, noise on the vertices, a degenerate face, a sliver."""
    nx = int(round(np.sqrt(len(points))))
    corners = [0, nx - 1, len(points) - 1, len(points) - nx]
    yield (
        points,
        np.array([[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]]),
    )
    keep = rng.random(len(faces)) < 0.7
    yield points, faces[keep]
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    yield points, flipped
    yield points + rng.normal(size=points.shape) * 1e-7, faces
    yield points + rng.normal(size=points.shape) * 1e-3, faces
    degenerate = np.vstack([faces, [[0, 0, 1]]])
    yield points, degenerate
    sliver = np.vstack([faces[1:], [[corners[0], 1, corners[1]]]])
    yield points, sliver


@pytest.mark.parametrize("seed", range(4))
def test_walls_and_their_levels_give_the_former_certificate(seed):
    rng = np.random.default_rng(seed)
    settled = 0
    for _ in range(8):
        scale = 10.0 ** rng.integers(-2, 4)
        points, faces = _grid(rng, int(rng.integers(2, 6)), int(rng.integers(2, 6)), scale)
        for level in _variants(rng, points, faces):
            for max_bound in (np.inf, 1e-6 * scale):
                got = _same(level, (points, faces), max_bound=max_bound)
                settled += int((~got.open_level).sum())
            _same((points, faces), level)
    assert settled > 50


def test_random_soups_give_the_former_certificate():
    rng = np.random.default_rng(7)
    for _ in range(30):
        n = int(rng.integers(3, 40))
        points = rng.random((n, 3)) * 10.0 ** rng.integers(-3, 7)
        faces = rng.integers(0, n, size=(int(rng.integers(1, 60)), 3))
        other = faces[rng.random(len(faces)) < 0.6]
        _same((points, other), (points, faces))
        _same((points + rng.normal(size=points.shape) * 1e-7, faces), (points, faces))


def test_generated_buildings_levels_give_the_former_certificate():
    from exporter import samplegen
    from exporter.config import Config
    from exporter.quality import joined
    from exporter.simplify import build_mesh_chain

    config = Config()
    for building in samplegen.generate_buildings(6, seed=5):
        chain = build_mesh_chain(building.parts, config.lods, config.simplify)
        source = joined(chain[0].parts)
        for level in chain[1:]:
            mesh = joined(level.parts)
            _same((mesh.positions, mesh.faces), (source.positions, source.faces))


def test_out_of_range_indices_are_errors_not_crashes():
    points = np.zeros((3, 3))
    faces = np.array([[0, 1, 5]])
    empty = np.zeros(0, np.int64)
    done = np.zeros(1, bool)
    constants = (0.99, 1e-9, 64, 1e-6, 4)
    with pytest.raises(ValueError, match="out of range"):
        settle_regions(points, faces, faces, empty, empty, empty, done, done, 0.0, 1.0, constants)
    within = np.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="out of range"):  # a face list past the faces
        settle_regions(
            points, within, within, np.array([7]), empty, empty, done, done, 0.0, 1.0, constants
        )
    with pytest.raises(ValueError, match="out of range"):  # one done flag short
        settle_regions(
            points, within, within, empty, empty, empty, done[:0], done, 0.0, 1.0, constants
        )


@pytest.mark.parametrize("offset, scale", [(6.4e6, 20.0), (0.0, 1e-6), (1e-9, 1e-9)])
def test_far_and_tiny_coordinates_give_the_former_certificate(offset, scale):
    # Global-frame magnitudes (metres from the Earth's centre) and sub-micrometre parts.
    rng = np.random.default_rng(3)
    points, faces = _grid(rng, 4, 3, scale)
    points = points + offset
    for level in _variants(rng, points, faces):
        _same(level, (points, faces))
    single = faces[:1]
    _same((points, single), (points, faces))
    _same((points, faces), (points, single))
