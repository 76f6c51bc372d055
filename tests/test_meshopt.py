"""The local meshoptimizer wrapper (exporter.simplify.meshopt): the C signature declared, the
package's binding left alone, locks and the error target honoured. Meshes in metres (a flat
10 x 10 m grid in the x-z plane, local East/Up/North)."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from exporter.simplify import meshopt


def grid(n: int = 8):
    g = np.linspace(0.0, 10.0, n + 1)
    x, z = np.meshgrid(g, g)
    positions = np.column_stack([x.ravel(), np.zeros(x.size), z.ravel()]).astype(np.float32)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.concatenate(
        [np.column_stack([i, i + n + 1, i + 1]), np.column_stack([i + 1, i + n + 1, i + n + 2])]
    )
    return positions, faces.astype(np.uint32)


def test_the_package_binding_is_still_undeclared_and_ours_is_declared():
    # Why the wrapper exists: if the package ever declares the signature, this test says so.
    import meshoptimizer._loader as binding

    assert binding.lib.meshopt_simplifyWithAttributes.argtypes is None
    declared = meshopt._lib.meshopt_simplifyWithAttributes.argtypes
    assert len(declared) == 15 and declared[12] is ctypes.c_float


def test_flat_grid_collapses_to_the_target_with_locked_vertices_kept():
    positions, faces = grid()
    uvs = (positions[:, [0, 2]] / 10.0).astype(np.float32)
    lock = np.zeros(len(positions), np.uint8)
    lock[[0, 40, 80]] = 1  # a corner, the centre, the opposite corner
    kept, error = meshopt.simplify_with_attributes(
        faces, positions, uvs, np.ones(2, np.float32), lock, 3 * 20, 1e30
    )
    assert 0 < len(kept) <= 3 * 20 and len(kept) % 3 == 0
    assert np.isin([0, 40, 80], kept).all()  # locked vertices never collapse away
    assert error < 1e-4  # flat, affine UVs: nothing lost
    # The error target stops the collapse: at zero error on a bent grid, nothing goes.
    bent = positions.copy()
    bent[:, 1] = (bent[:, 0] - 5.0) ** 2 / 10.0
    kept_bent, _ = meshopt.simplify_with_attributes(
        faces, bent, uvs, np.ones(2, np.float32), np.zeros(len(bent), np.uint8), 0, 0.0
    )
    assert len(kept_bent) > len(kept)


def test_bad_arguments_are_refused_before_the_c_call():
    positions, faces = grid(2)
    with pytest.raises(ValueError, match="0/1"):
        meshopt.simplify_with_attributes(
            faces, positions, np.zeros((len(positions), 0)), np.zeros(0), np.full(9, 2), 0, 0.1
        )
    with pytest.raises(ValueError, match="attributes"):
        meshopt.simplify_with_attributes(
            faces, positions, np.zeros((len(positions), 2)), np.zeros(3), np.zeros(9), 0, 0.1
        )
