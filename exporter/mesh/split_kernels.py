"""Faces split into fans at the points on one of their sides, compiled (the step of
:func:`exporter.mesh.slits.split_sides`): a face ``(a, b, c)`` with points ``v1..vn`` inside its
side ``a -> b`` becomes ``(a, v1, c), (v1, v2, c), ..., (vn, b, c)``, each point's UV interpolated
along the side in float64 and stored as float32. Kept faces first (in order), then every fan's
faces ending at a point, then the fans' last faces, as the former numpy form ordered them
(``tests/test_split_kernels.py`` keeps it as the reference and checks every array equal)."""

from __future__ import annotations

import numpy as np

from .jit import kernel
from .sorted_kernels import stable_order


@kernel
def split_fans(faces, corner_uvs, has_uvs, side, vertex, t):  # pragma: no cover - compiled
    """``(faces (m', 3), corner_uvs (m', 3, 2) float32, source (m',), rest side, rest vertex,
    rest t)`` for ``side``, ``vertex``, ``t`` sorted by side then t: each face split on its
    lowest side with points; ``rest`` the points on its other sides, on the fan faces now holding
    them (ascending by side, then t)."""
    m, p = faces.shape[0], side.shape[0]
    chosen = np.zeros(p, np.bool_)
    split = np.zeros(m, np.bool_)
    n = 0  # chosen points
    groups = 0  # split faces
    for j in range(p):
        f = side[j] // 3
        if j == 0 or f != side[j - 1] // 3:
            lowest = side[j]
            groups += 1
            split[f] = True
        if side[j] == lowest:
            chosen[j] = True
            n += 1
    kept = m - groups
    # Fans of the sides: n faces ending at a point, then one last face per side.
    sides = 0
    for j in range(p):
        if chosen[j] and (j == p - 1 or not chosen[j + 1] or side[j + 1] != side[j]):
            sides += 1
    total = kept + n + sides
    out = np.empty((total, 3), np.int64)
    source = np.empty(total, np.int64)
    uv_rows = total if has_uvs else 0
    uvs = np.empty((uv_rows, 3, 2), np.float32)
    row = 0
    for f in range(m):
        if not split[f]:
            for corner in range(3):
                out[row, corner] = faces[f, corner]
                if has_uvs:
                    uvs[row, corner, 0] = corner_uvs[f, corner, 0]
                    uvs[row, corner, 1] = corner_uvs[f, corner, 1]
            source[row] = f
            row += 1
    # Per split face (ascending), its first fan face and its chosen side's corner i.
    first_fan = np.empty(groups, np.int64)
    side_corner = np.empty(groups, np.int64)
    face_of_group = np.empty(groups, np.int64)
    group = -1
    last_row = kept + n
    previous = 0
    at_previous = np.zeros(2)
    at = np.zeros(2)
    for j in range(p):
        if not chosen[j]:
            continue
        f, i = side[j] // 3, side[j] % 3
        a, b, c = faces[f, i], faces[f, (i + 1) % 3], faces[f, (i + 2) % 3]
        first = j == 0 or side[j - 1] != side[j] or not chosen[j - 1]
        if first:
            group += 1
            first_fan[group] = row
            side_corner[group] = i
            face_of_group[group] = f
            previous = a
        out[row, 0] = previous
        out[row, 1] = vertex[j]
        out[row, 2] = c
        source[row] = f
        last = j == p - 1 or side[j + 1] != side[j]
        if last:
            out[last_row, 0] = vertex[j]
            out[last_row, 1] = b
            out[last_row, 2] = c
            source[last_row] = f
        if has_uvs:
            for d in range(2):
                uv_a = np.float64(corner_uvs[f, i, d])
                uv_b = np.float64(corner_uvs[f, (i + 1) % 3, d])
                at[d] = uv_a + t[j] * (uv_b - uv_a)
                if first:
                    at_previous[d] = uv_a
                uvs[row, 0, d] = np.float32(at_previous[d])
                uvs[row, 1, d] = np.float32(at[d])
                uvs[row, 2, d] = corner_uvs[f, (i + 2) % 3, d]
                if last:
                    uvs[last_row, 0, d] = np.float32(at[d])
                    uvs[last_row, 1, d] = corner_uvs[f, (i + 1) % 3, d]
                    uvs[last_row, 2, d] = corner_uvs[f, (i + 2) % 3, d]
                at_previous[d] = at[d]
        if last:
            last_row += 1
        previous = vertex[j]
        row += 1
    # The points on other sides, moved to the fan faces holding those sides now: the first fan
    # face holds c -> a (its side 2), the last one b -> c (its side 1).
    r = p - n
    moved = np.empty(r, np.int64)
    rest_vertex = np.empty(r, np.int64)
    rest_t = np.empty(r)
    q = 0
    group = -1
    for j in range(p):
        if j == 0 or side[j] // 3 != side[j - 1] // 3:
            group += 1
        if chosen[j]:
            continue
        if side[j] % 3 == (side_corner[group] + 1) % 3:
            moved[q] = 3 * (kept + n + group) + 1
        else:
            moved[q] = 3 * first_fan[group] + 2
        rest_vertex[q], rest_t[q] = vertex[j], t[j]
        q += 1
    # Points of one side keep their order (by t): a stable sort by side is the (side, t) order.
    order = stable_order(moved)
    return out, uvs, source, moved[order], rest_vertex[order], rest_t[order]
