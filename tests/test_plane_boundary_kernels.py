"""The compiled boundary edges of planar regions (``exporter/mesh/c/plane_boundary.c``, called
by ``hausdorff._Regions``) give exactly what the former numpy form
(tests/plane_boundary_reference.py) gives, bit for bit and in the same order: on every call the
mesh chain makes over generated buildings, and on grids with T-junctions, flipped faces, repeated
faces and random soups; a bad index is an error, not a crash. Metres."""

from __future__ import annotations

import types

import numpy as np
import pytest

from exporter.mesh import _plane_boundary, hausdorff
from exporter.mesh.hausdorff import T_JUNCTION, Surface
from tests.plane_boundary_reference import reference_boundary


def _same(got, want) -> None:
    assert len(got) == len(want) == 5
    for g, w in zip(got, want, strict=True):
        # Regions merged on one plane are int32 labels in the numpy form: values compared.
        assert g.dtype == w.dtype or g.dtype.kind == w.dtype.kind == "i"
        assert g.shape == w.shape and np.array_equal(g, w)


def _checked(monkeypatch) -> list:
    """Swap in a boundary that asserts the C equals the reference on every call; the calls'
    edge counts and split counts are collected."""
    seen: list = []

    def boundary(faces, k, region, r, tri2, tjunction):
        got = _plane_boundary.boundary(faces, k, region, r, tri2, tjunction)
        _same(got, reference_boundary(faces, k, region, r, tri2))
        seen.append((len(got[0]), int((got[4] > 0).sum())))
        return got

    monkeypatch.setattr(hausdorff, "_plane_boundary", types.SimpleNamespace(boundary=boundary))
    return seen


def test_every_call_of_the_chain_on_generated_buildings_gives_the_former_edges(monkeypatch):
    import exporter.simplify as simplify
    from exporter import samplegen
    from exporter.config import Config

    seen = _checked(monkeypatch)
    config = Config()
    for building in samplegen.generate_buildings(30, seed=11):
        simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    assert len(seen) >= 5 and sum(s for s, _ in seen) > 500  # regions of several buildings


def _t_grid(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A flat grid whose left half is 2x finer (T-junctions on the seam), with a flipped face,
    a repeated face and a face on another plane."""
    left = [[x, y, 0.0] for y in np.linspace(0, 4, 5) for x in np.linspace(0, 2, 3)]
    right = [[x, y, 0.0] for y in np.linspace(0, 4, 3) for x in np.linspace(2, 6, 3)]
    positions = np.array(left + right) + rng.normal(size=(24, 3)) * [0, 0, 1e-12]
    faces = []
    for j in range(4):
        for i in range(2):
            a, b, c, d = j * 3 + i, j * 3 + i + 1, (j + 1) * 3 + i, (j + 1) * 3 + i + 1
            faces += [[a, b, d], [a, d, c]]
    for j in range(2):
        for i in range(2):
            a, b, c, d = (
                15 + j * 3 + i,
                15 + j * 3 + i + 1,
                15 + (j + 1) * 3 + i,
                15 + (j + 1) * 3 + i + 1,
            )
            faces += [[a, b, d], [a, d, c]]
    faces[3] = faces[3][::-1]  # flipped
    faces.append(faces[10])  # repeated
    positions = np.concatenate([positions, [[0.0, 0.0, 3.0]]])
    faces.append([0, 2, 24])  # another plane
    return positions, np.array(faces, np.int64)


def test_t_junction_grids_and_soups_give_the_former_edges(monkeypatch):
    seen = _checked(monkeypatch)
    rng = np.random.default_rng(3)
    for trial in range(12):
        if trial % 3 == 2:  # a random soup: open edges everywhere
            positions = rng.random((30, 3)) * [5, 5, 1e-7]
            faces = rng.integers(0, 30, size=(25, 3))
        else:
            positions, faces = _t_grid(rng)
        hausdorff._Regions(positions, faces, straighten=bool(trial % 2))
    assert any(split > 0 for _, split in seen)  # T-junctions were found and split


def test_no_faces_and_a_bad_index_are_handled():
    got = _plane_boundary.boundary(
        np.zeros((0, 3), np.int64), 0, np.zeros(0, np.int64), 0, np.zeros((0, 3, 2)), T_JUNCTION
    )
    assert [len(x) for x in got] == [0, 0, 0, 0, 0]
    faces = np.array([[0, 1, 2]])
    tri2 = np.array([[[0.0, 0], [1, 0], [0, 1]]])
    with pytest.raises(ValueError, match="faces"):
        _plane_boundary.boundary(faces, 2, np.zeros(1, np.int64), 1, tri2, T_JUNCTION)
    with pytest.raises(ValueError, match="region"):
        _plane_boundary.boundary(faces, 3, np.ones(1, np.int64), 1, tri2, T_JUNCTION)
    with pytest.raises(ValueError, match="tri2"):
        _plane_boundary.boundary(faces, 3, np.zeros(1, np.int64), 1, tri2[:, :2], T_JUNCTION)
    assert Surface(np.eye(3), faces).regions.seg_start.tolist() == [0, 3]
