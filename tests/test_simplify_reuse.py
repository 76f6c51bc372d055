"""Work the simplify stage does once and reuses (issue 24, floor round): the twin's prepared
surface, the planar bound's packed regions, LOD0's joined mesh for a level built from LOD0's own
parts, the distinct corners of the lower bound. Each reuse gives what the work done again gives."""

from __future__ import annotations

import numpy as np

from exporter.config import Config
from exporter.mesh import hausdorff, planar_bound_kernels
from exporter.mesh.geometry import unique_float_rows
from exporter.mesh.hausdorff import LOOSE, PLANE_SLACK_MAX, SHRINK, Surface
from exporter.samplegen import generate_buildings
from exporter.simplify import _join, _simplify_level, build_mesh_chain, guard
from tests.test_guard_twin import planar_faces
from tests.test_hausdorff import wall


def test_the_twin_surface_prepared_for_the_open_faces_is_the_one_the_bounds_use(monkeypatch):
    (positions, faces), _ = wall(6)
    twin_faces = planar_faces(positions, faces)
    assert len(twin_faces) < len(faces)
    # Every face left open by the certificate: the twin's open faces are bounded against LOD0,
    # LOD0's against a prepared twin surface, which the reference then keeps.
    settle = guard.coverage.region_certificate

    def all_open(level, source, **kwargs):
        out = settle(level, source, **kwargs)
        return guard.coverage.Certificate(
            0.0, np.ones_like(out.open_level), np.ones_like(out.open_source)
        )

    monkeypatch.setattr(guard.coverage, "region_certificate", all_open)
    made: list = []
    prepared: list = []
    monkeypatch.setattr(
        guard.hausdorff,
        "Surface",
        lambda *args, **kwargs: prepared.append(Surface(*args, **kwargs)) or prepared[-1],
    )
    slack = guard.TWIN_SLACK * guard.diagonal(positions)
    found = guard.lossless_twin(positions, faces, twin_faces, slack, lambda: Surface(*wall(6)[0]))
    assert found is not None
    reference = guard.Reference(positions, faces)
    reference.offer_twin(twin_faces)
    prepared.clear()
    surface, delta = reference.twin
    twins = [s for s in prepared if len(s.faces) == len(twin_faces)]
    assert len(twins) == 1 and surface is twins[0]  # prepared once, not again for the bounds
    assert delta == found[2]
    assert np.array_equal(surface.positions, found[0]) and np.array_equal(surface.faces, found[1])
    assert made == []  # the caller's list only when it passes one


def test_the_planar_bound_packs_its_regions_once_and_again_when_they_change(monkeypatch):
    (positions, faces), (_, level) = wall(4)
    target = Surface(positions, faces)
    tri = positions[level]
    row, face = np.repeat([0, 1], len(faces)), np.tile(np.arange(len(faces)), 2)
    checks: list = []
    check = planar_bound_kernels._check_regions
    monkeypatch.setattr(
        planar_bound_kernels, "_check_regions", lambda *a: checks.append(1) or check(*a)
    )
    constants = (SHRINK, PLANE_SLACK_MAX, LOOSE)
    first = planar_bound_kernels.planar_bound(tri, row, face, target.regions, None, constants)
    again = planar_bound_kernels.planar_bound(tri, row, face, target.regions, None, constants)
    assert len(checks) == 1 and np.array_equal(first, again) and np.isfinite(first).all()
    fresh = Surface(positions, faces).regions
    assert np.array_equal(
        first, planar_bound_kernels.planar_bound(tri, row, face, fresh, None, constants)
    )
    assert len(checks) == 2
    target.regions.slack = target.regions.slack + 1.0  # another array: packed again
    moved = planar_bound_kernels.planar_bound(tri, row, face, target.regions, None, constants)
    assert len(checks) == 3 and not np.array_equal(moved, first)


def test_a_level_built_from_lod0s_own_parts_reuses_lod0s_joined_mesh(monkeypatch):
    config = Config()
    building = generate_buildings(1, seed=4, atlas_size=16)[0]
    chain = build_mesh_chain(building.parts, config.lods, config.simplify)
    assert chain[1].parts is chain[0].parts  # nothing collapsed at level 1
    joins: list = []
    monkeypatch.setattr(
        "exporter.simplify._join", lambda *a: joins.append(1) or _join(*a), raising=True
    )
    again = build_mesh_chain(building.parts, config.lods, config.simplify)
    assert joins == []  # level 2 took LOD0's joined mesh
    # The same level as joining the parts again.
    guard_reference = guard.Reference(*_join(chain[0].parts, 0.0)[:2])
    alone = _simplify_level(
        chain[1].parts,
        int(round(sum(p.triangle_count for p in building.parts) * config.lods[2].mesh)),
        config.simplify,
        guard_reference,
        None,
        chain[2].tolerance,
        True,
        False,
    )[0]
    assert [(p.positions.tobytes(), p.triangles.tobytes()) for p in again[2].parts] == [
        (p.positions.tobytes(), p.triangles.tobytes()) for p in alone
    ]


def test_the_lower_bounds_distinct_corners_are_np_uniques_rows():
    rng = np.random.default_rng(4)
    tri = np.round(rng.random((30, 3, 3)) * 4) / 4  # many repeated corners
    tri[3, 1] = -0.0
    corners = tri.reshape(-1, 3)
    assert np.array_equal(corners[unique_float_rows(corners)[0]], np.unique(corners, axis=0))
    (positions, faces), _ = wall(3)
    index = Surface(positions, faces).index
    assert index.max_distance(corners[unique_float_rows(corners)[0]]) == index.max_distance(
        np.unique(corners, axis=0)
    )
    assert hausdorff.directed_bounds(tri, Surface(positions, faces))[0] >= 0.0


def test_an_index_without_samples_draws_none_and_equals_the_sampled_form(monkeypatch):
    from exporter.mesh import distance

    (positions, faces), _ = wall(3)
    samples, owners = distance.sample_surface(
        positions, faces, 0, np.random.default_rng(distance.SEED), with_faces=True
    )
    monkeypatch.setattr(distance.np.random, "default_rng", lambda *a: 1 / 0)  # never drawn
    index = distance.SurfaceIndex(positions, faces, samples_per_face=0)
    m = len(faces)
    assert index.tree is not None and index.tree.n == 4 * m
    probes = np.concatenate([index.tri.reshape(-1, 3), index.centres, samples])
    assert np.array_equal(index.tree.data, probes)
    owner = np.concatenate([np.repeat(np.arange(m), 3), np.arange(m), owners])
    assert np.array_equal(index.owner, owner) and index.owner.dtype == owner.dtype
