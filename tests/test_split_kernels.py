"""The compiled fan split (:mod:`exporter.mesh.split_kernels`) gives exactly what the former numpy
``slits.split_sides`` gave (kept here as the reference): faces, float32 UVs, sources and the
moved points of the faces' other sides, on the slits of generated buildings (each round of
``close_slits``, with and without UVs) and on random faces with points on one, two or three
sides; unsorted or out-of-range sides are errors, not crashes."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh.slits import MAX_ROUNDS, slit_points, split_sides


def reference_split_sides(faces, corner_uvs, side, vertex, t):
    """The former numpy body of ``slits.split_sides``."""
    face = side // 3
    first_of_face = np.flatnonzero(np.concatenate([[True], face[1:] != face[:-1]]))
    lowest = np.repeat(side[first_of_face], np.diff(np.append(first_of_face, len(side))))
    chosen = side == lowest
    rest = side[~chosen], vertex[~chosen], t[~chosen]
    side, vertex, t = side[chosen], vertex[chosen], t[chosen]
    f, i = side // 3, side % 3
    a, b, c = faces[f, i], faces[f, (i + 1) % 3], faces[f, (i + 2) % 3]
    # The fan of a side with points v1..vn: (a, v1, c), (v1, v2, c), ..., (vn, b, c): one face
    # ending at each point, plus the last one ending at b.
    first = np.concatenate([[True], side[1:] != side[:-1]])
    last = np.concatenate([side[1:] != side[:-1], [True]])
    previous = np.concatenate([[0], vertex[:-1]])
    previous[first] = a[first]
    fan = np.concatenate(
        [np.column_stack([previous, vertex, c]), np.column_stack([vertex[last], b[last], c[last]])]
    )
    fan_source = np.concatenate([f, f[last]])
    keep = np.ones(len(faces), dtype=bool)
    keep[f] = False
    kept = int(keep.sum())
    out_faces = np.concatenate([faces[keep], fan])
    source = np.concatenate([np.flatnonzero(keep), fan_source])
    out_uvs = None
    if corner_uvs is not None:
        uv_a, uv_b, uv_c = (corner_uvs[f, (i + k) % 3].astype(np.float64) for k in range(3))
        at = uv_a + t[:, None] * (uv_b - uv_a)  # the UV of each point, along its side
        at_previous = np.concatenate([at[:1], at[:-1]])
        at_previous[first] = uv_a[first]
        fan_uvs = np.concatenate(
            [
                np.stack([at_previous, at, uv_c], axis=1),
                np.stack([at[last], uv_b[last], uv_c[last]], axis=1),
            ]
        ).astype(np.float32)
        out_uvs = np.concatenate([corner_uvs[keep], fan_uvs])
    if len(rest[0]):
        # The split faces ascend (sides sorted), so a face's fan is found by searchsorted.
        split_face = f[first]
        group = np.searchsorted(split_face, rest[0] // 3)
        first_fan = kept + np.flatnonzero(first)[group]
        last_fan = kept + len(side) + group
        on_last = rest[0] % 3 == (i[first][group] + 1) % 3  # the side b -> c
        moved = np.where(on_last, 3 * last_fan + 1, 3 * first_fan + 2)
        order = np.lexsort((rest[2], moved))
        rest = moved[order], rest[1][order], rest[2][order]
    return out_faces, out_uvs, source, rest


def _same(faces, corner_uvs, side, vertex, t):
    got = split_sides(faces, corner_uvs, side, vertex, t)
    expected = reference_split_sides(faces, corner_uvs, side, vertex, t)
    for g, e in zip(got[:3], expected[:3]):
        assert (g is None) == (e is None)
        if e is not None:
            assert g.dtype == e.dtype and np.array_equal(g, e)
    for g, e in zip(got[3], expected[3]):
        assert np.array_equal(g, e)
    return got


def test_generated_buildings_slits_split_as_before():
    from exporter import samplegen
    from exporter.simplify import _join

    rounds = moved = 0
    for building in samplegen.generate_buildings(20, seed=4):
        positions, faces, _, corner_uvs, _, _ = _join(building.parts, 0.0)
        for uvs in (corner_uvs, None):
            out_faces, out_uvs = faces, uvs
            side, vertex, t = slit_points(positions, faces)
            for _ in range(MAX_ROUNDS):
                if not len(side):
                    break
                out_faces, out_uvs, _, (side, vertex, t) = _same(
                    out_faces, out_uvs, side, vertex, t
                )
                rounds += 1
                moved += len(side)
    assert rounds > 0


def test_random_faces_with_points_on_several_sides():
    rng = np.random.default_rng(5)
    moved = 0
    for _ in range(200):
        m = int(rng.integers(1, 12))
        faces = rng.permutation(3 * m).reshape(m, 3) + 1000
        corner_uvs = rng.random((m, 3, 2)).astype(np.float32)
        entries = []
        next_vertex = 0
        for f in rng.choice(m, int(rng.integers(1, m + 1)), replace=False):
            for i in rng.choice(3, int(rng.integers(1, 4)), replace=False):
                count = int(rng.integers(1, 4))
                for value in np.sort(rng.random(count)):
                    entries.append((3 * int(f) + int(i), next_vertex, float(value)))
                    next_vertex += 1
        entries.sort(key=lambda e: (e[0], e[2]))
        side, vertex, t = (np.array(column) for column in zip(*entries))
        moved += len(_same(faces, corner_uvs, side, vertex, t)[3][0])
        _same(faces, None, side, vertex, t)
    assert moved > 0  # faces with points on two or three sides were met


def test_bad_sides_are_errors():
    faces = np.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="split_sides"):
        split_sides(faces, None, np.array([3]), np.array([5]), np.array([0.5]))
    with pytest.raises(ValueError, match="split_sides"):
        split_sides(faces, None, np.array([1, 0]), np.array([5, 6]), np.array([0.5, 0.5]))
