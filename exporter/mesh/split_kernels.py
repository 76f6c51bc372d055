"""Faces split into fans at the points on one of their sides (the step of
:func:`exporter.mesh.slits.split_sides`): the compiled kernel ``exporter/mesh/c/split.c`` (a face
``(a, b, c)`` with points ``v1..vn`` inside its side ``a -> b`` becomes ``(a, v1, c), (v1, v2, c),
..., (vn, b, c)``, each point's UV interpolated along the side in float64 and stored as float32;
kept faces first, then the fans' faces in the former numpy form's order:
``tests/test_split_kernels.py`` keeps it as the reference and checks every array equal)."""

from __future__ import annotations

import numpy as np

from ._split import fans as _fans


def split_fans(
    faces: np.ndarray,
    corner_uvs: np.ndarray,
    has_uvs: bool,
    side: np.ndarray,
    vertex: np.ndarray,
    t: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(faces (m', 3), corner_uvs (m', 3, 2) float32, source (m',), rest side, rest vertex,
    rest t)`` of ``faces`` (m, 3) int64 and ``corner_uvs`` (m, 3, 2) float32 (read when
    ``has_uvs``; else the result's UVs are (0, 3, 2)) for the points ``side``, ``vertex``, ``t``
    (p,) sorted by side then t: each face split on its lowest side with points; ``rest`` the
    points on its other sides, on the fan faces now holding them (ascending by side, then t)."""
    return _fans(faces, corner_uvs, has_uvs, side, vertex, t)
