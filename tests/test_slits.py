"""Slits (T-junction cracks) closed without changing the surface: exporter/mesh/slits.py.

Meshes are welded, positions building-local East/Up/North metres (y = Up); roofs lie at y = 5.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_quality import t_junction_roof

from exporter.mesh.hausdorff import hausdorff_bounds
from exporter.mesh.slits import close_slits, closed_surface, slit_points
from exporter.mesh.topology import boundary_loops, nonmanifold_vertices
from exporter.quality import joined
from exporter.samplegen import generate_samples
from exporter.simplify import _join
from exporter.simplify.planar import _retriangulate_keeping_boundary, retriangulate_planar_checked


def roof(points, faces):
    """Positions (n, 3) at y = 5 m from (x, z) points, faces wound so their normals point Up."""
    positions = np.array([[x, 5.0, z] for x, z in points], float)
    faces = np.array(faces, np.int64)
    a, b, c = (positions[faces[:, i]] for i in range(3))
    up = np.cross(b - a, c - a)[:, 1] > 0
    return positions, np.where(up[:, None], faces, faces[:, ::-1])


def open_length(positions, faces) -> float:
    border, _ = boundary_loops(faces, len(positions))
    return float(np.linalg.norm(positions[border[:, 0]] - positions[border[:, 1]], axis=1).sum())


def test_a_t_junction_closes_to_the_same_surface():
    positions, faces = joined(t_junction_roof()[0])
    closed, _, source = close_slits(positions, faces, None)
    # The 4 m of open edges inside the roof are shared now; the 8 m outline stays.
    assert open_length(positions, faces) == pytest.approx(12.0)
    assert open_length(positions, closed) == pytest.approx(8.0)
    assert boundary_loops(closed, len(positions))[1] == 1
    # Certified: the bound stops within its own tolerance (1e-7 of the diagonal) of the true 0.
    assert hausdorff_bounds((positions, faces), (positions, closed))[1] <= 1e-6
    assert len(closed) == len(faces) + 1 and set(source) == set(range(len(faces)))


def test_split_faces_keep_the_texture_mapping():
    # Every output face's corner UVs are its source face's UV map (affine) at the corners.
    checked = 0
    for sample in generate_samples(12, seed=4, atlas_size=16, kinds=["box_hip", "l_shape"]):
        positions, faces, _, corner_uvs, _, _ = _join(sample.building.parts, 0.0)
        closed, uvs, source = close_slits(positions, faces, corner_uvs)
        if len(closed) == len(faces):
            continue
        checked += 1
        tri = positions[faces[source]]  # (m', 3, 3) the source face of every output face
        # Barycentric coordinates of the output corners in their source face.
        v0, v1 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
        denominator = d00 * d11 - d01 * d01
        for corner in range(3):
            p = positions[closed[:, corner]] - tri[:, 0]
            d20, d21 = (p * v0).sum(1), (p * v1).sum(1)
            v = (d11 * d20 - d01 * d21) / denominator
            w = (d00 * d21 - d01 * d20) / denominator
            source_uvs = corner_uvs[source].astype(np.float64)
            expected = (
                (1 - v - w)[:, None] * source_uvs[:, 0]
                + v[:, None] * source_uvs[:, 1]
                + w[:, None] * source_uvs[:, 2]
            )
            assert np.abs(uvs[:, corner] - expected).max() < 1e-5
    assert checked >= 4


def test_a_slit_bridging_one_boundary_loop_stays_open():
    """A 4 x 4 m frame around a 2 x 2 m hole, cut from its outer to its inner edge at z = 2 m
    (the lower side is the edge A-B, the upper side goes through M): one boundary loop. Closing
    the cut would part it into the outer and the inner loop: a new hole to any loop count."""
    points = [(0, 0), (4, 0), (4, 4), (0, 4), (1, 1), (3, 1), (3, 3), (1, 3), (0, 2), (1, 2)]
    points.append((0.5, 2))
    o0, o1, o2, o3, i0, i1, i2, i3, a, b, m = range(11)
    positions, faces = roof(
        points,
        [
            [o0, o1, i1], [o0, i1, i0], [o1, o2, i2], [o1, i2, i1], [o2, o3, i3], [o2, i3, i2],
            [o0, i0, b], [o0, b, a], [m, b, i3], [m, i3, o3], [a, m, o3],
        ],
    )  # fmt: skip
    assert len(slit_points(positions, faces)[0]) == 1
    assert boundary_loops(faces, len(positions))[1] == 1
    closed, _, source = close_slits(positions, faces, None)
    assert closed is faces and np.array_equal(source, np.arange(len(faces)))


def test_walls_standing_back_to_back_are_not_joined():
    """Two parts' 4 x 3 m walls in the plane x = 0, facing away from each other, the first cut
    at z = 2 m, the second not: their bottom edges lie on each other, but that is a seam of two
    footprints, not a crack in one surface."""
    positions = np.array([[0, 0, 0], [0, 0, 4], [0, 3, 4], [0, 3, 0], [0, 0, 2], [0, 3, 2]], float)
    faces = np.array(
        [
            [0, 4, 5], [0, 5, 3], [4, 1, 2], [4, 2, 5],  # faces -x, cut at z = 2 m
            [0, 2, 1], [0, 3, 2],  # faces +x, whole
        ]
    )  # fmt: skip
    normals = np.cross(
        positions[faces[:, 1]] - positions[faces[:, 0]],
        positions[faces[:, 2]] - positions[faces[:, 0]],
    )
    assert (normals[:4, 0] < 0).all() and (normals[4:, 0] > 0).all()
    assert len(slit_points(positions, faces)[0]) == 0
    assert close_slits(positions, faces, None)[0] is faces


def test_a_vertex_off_the_side_is_no_slit():
    """The T-junction roof with its junction vertex moved 1 mm off the line: no slit (closing
    it would move the surface), while 1e-6 m off it still is one."""
    positions, faces = joined(t_junction_roof()[0])
    junction = np.flatnonzero((positions[:, 0] == 1.0) & (positions[:, 2] == 1.0))[0]
    for offset, slits in ((1e-3, 0), (1e-6, 1)):
        moved = positions.copy()
        moved[junction, 0] += offset
        assert len(slit_points(moved, faces)[0]) == slits


def test_the_planar_stage_gets_further_with_the_slits_closed():
    # Hip and gable roofs whose ends run past the wall tops' bay cuts: with the slits closed,
    # the planar stage drops those vertices from both sides; the surface and its open boundary
    # stay (certified within 1e-7 of the diagonal; the boundary compared as quality measures it).
    fewer = 0
    for sample in generate_samples(10, seed=2, atlas_size=16, kinds=["box_hip", "box_gable"]):
        positions, faces, _, corner_uvs, charts, _ = _join(sample.building.parts, 0.0)
        locked = nonmanifold_vertices(faces, len(positions))
        out, _, _, kept = retriangulate_planar_checked(positions, faces, corner_uvs, charts, locked)
        alone = _retriangulate_keeping_boundary(positions, faces, corner_uvs, charts, locked)[0]
        diagonal = float(np.linalg.norm(np.ptp(positions, axis=0)))
        assert kept and len(out) <= len(alone)
        assert hausdorff_bounds((positions, faces), (positions, out))[1] <= 1e-7 * diagonal
        fewer += len(out) < len(alone)
    assert fewer >= 5


def test_the_closed_surface_bounds_its_own_move():
    """The T-junction roof with its junction vertex 5e-6 m off the line (within SLIT_M): the
    closed roof moves by that much, and closed_surface says so."""
    positions, faces = joined(t_junction_roof()[0])
    junction = np.flatnonzero((positions[:, 0] == 1.0) & (positions[:, 2] == 1.0))[0]
    positions = positions.copy()
    positions[junction, 1] += 5e-6  # up, off the roof's plane
    closed, offset = closed_surface(positions, faces)
    assert len(closed) > len(faces) and offset == pytest.approx(5e-6, rel=1e-6)
    low, _ = hausdorff_bounds((positions, faces), (positions, closed), rtol=1e-3, atol=1e-9)
    assert low <= offset
    assert closed_surface(*joined(t_junction_roof()[1]))[1] == 0.0  # nothing to close
