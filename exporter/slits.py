"""Slits of a mesh closed without changing its surface: the T-junction repair before the planar
stage (:mod:`exporter.simplify.planar`), and what the open boundary of a surface is for the
quality metrics (:func:`exporter.quality.open_boundary`: a slit is no outline).

Data form: a welded mesh, ``positions`` (k, 3) float64 metres (building-local East/Up/North),
``faces`` (m, 3) int64 wound outward, ``corner_uvs`` (m, 3, 2) float32 (glTF UV convention) or
None.

A slit is a crack of zero width: one face's border edge runs past vertices of its neighbours'
border edges (a hip roof's end over a wall top cut into bays; a roof eave cut into more columns
than the wall below it; CityJSON polygons whose edges carry their neighbours' corners). The
mesh is open along it although the surface is not, so every vertex on it is an outline vertex
the planar stage must keep, and renderers may show the crack.

Steps (a flat pipeline, each a small function below):

1. :func:`slit_points`: every (border side, vertex) pair where the vertex lies strictly inside
   the side, within ``SLIT_M`` of it.
2. :func:`split_sides`: each face is split at the points inside one of its border sides into a fan
   around its opposite corner, ``(a, v1, c), (v1, v2, c), ..., (vn, b, c)``: same plane, same
   area, same winding; each point's UV is interpolated along the side (the UV map is affine on
   the face, so the texture does not change). Repeated while a face has points on another side.
3. Both sides of a slit now run through the same vertices, so their edges are shared: the slit
   is closed. The result is kept only when the open boundary has no more loops than before (a
   slit bridging two stretches of one boundary loop splits it: zero width, but a new hole to
   any count of loops).

The surface moves by at most ``SLIT_M`` (a point is that close to the side it splits). The open
boundary only loses points: it gets shorter by both sides of every closed slit.

Source: T-junction removal as in mesh cleaning (e.g. Botsch et al., "Polygon Mesh Processing",
2010, ch. 3: cracks and T-junctions are snapped by splitting the long edge at the vertices on
it).
"""

from __future__ import annotations

import numpy as np

from .geometry import cross_rows, row_norms

SLIT_M = 1e-5  # metres: a vertex this close to a border side lies on it (float32 input rounding)
MAX_ROUNDS = 4  # a face is split on one side per round; three sides at most, plus slack


def border_sides(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(s,) int64 border sides ``3 f + i`` (from corner i of face f to corner i + 1): the sides
    whose undirected edge no other side uses."""
    sides = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keys = sides.min(axis=1) * vertex_count + sides.max(axis=1)
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    once = np.ones(len(keys), dtype=bool)
    if len(keys) > 1:
        repeated = ordered[1:] == ordered[:-1]
        once[1:] &= ~repeated
        once[:-1] &= ~repeated
    return np.sort(order[once])


def slit_points(
    positions: np.ndarray, faces: np.ndarray, tolerance: float = SLIT_M
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices strictly inside border sides: ``(side (p,) int64, vertex (p,) int64, t (p,)
    float64)``, ``t`` in (0, 1) the vertex's parameter along the side, within ``tolerance``
    metres of it and more than ``tolerance`` from both ends; sorted by side, then t."""
    empty = np.zeros(0, np.int64)
    sides = border_sides(faces, len(positions))
    if len(sides) < 3:
        return empty, empty, np.zeros(0)
    start = faces.reshape(-1)[sides]
    end = faces[sides // 3, (sides % 3 + 1) % 3]
    points = np.unique(np.concatenate([start, end]))
    a = positions[start]
    direction = positions[end] - a
    length = np.maximum(row_norms(direction), 1e-30)
    found_side, found_vertex, found_t = [], [], []
    # Border points x border sides in blocks, so a large open mesh stays within memory.
    block = max(1, 2_000_000 // len(sides))
    for first in range(0, len(points), block):
        ids = points[first : first + block]
        offset = positions[ids][:, None, :] - a
        along = (offset * direction).sum(2) / length  # metres from the side's start
        off2 = (offset * offset).sum(2) - along * along
        hit = (
            (off2 <= tolerance * tolerance)
            & (along > tolerance)
            & (along < length - tolerance)
            & (start != ids[:, None])
            & (end != ids[:, None])
        )
        row, column = np.nonzero(hit)
        found_side.append(sides[column])
        found_vertex.append(ids[row])
        found_t.append(along[row, column] / length[column])
    side, vertex, t = (np.concatenate(x) for x in (found_side, found_vertex, found_t))
    # Not between back-to-back faces (two parts' walls standing against each other): that seam
    # is part of each part's footprint outline, and joining it would fold the mesh by 180 deg.
    facing = _facing_partner(positions, faces, sides, start, end, side, vertex)
    side, vertex, t = side[~facing], vertex[~facing], t[~facing]
    order = np.lexsort((t, side))
    return side[order], vertex[order], t[order]


def _facing_partner(positions, faces, sides, start, end, side, vertex) -> np.ndarray:
    """(p,) bool: pairs whose vertex has a border side along the pair's side (the other side of
    the slit) on a face turned against the side's face (unit normals' dot product < -0.5)."""
    if not len(side):
        return np.zeros(0, dtype=bool)
    a, b, c = (positions[faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a)
    normal /= np.maximum(row_norms(normal), 1e-30)[:, None]
    # Border sides by vertex (each side listed under both its ends).
    ends = np.concatenate([start, end])
    owner = np.concatenate([sides, sides])
    order = np.argsort(ends, kind="stable")
    ends, owner = ends[order], owner[order]
    lo = np.searchsorted(ends, vertex, "left")
    hi = np.searchsorted(ends, vertex, "right")
    facing = np.zeros(len(side), dtype=bool)
    for i in np.flatnonzero(hi > lo).tolist():
        partners = owner[lo[i] : hi[i]] // 3
        facing[i] = bool((normal[partners] @ normal[side[i] // 3] < -0.5).any())
    return facing


def slit_vertices(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(k,) bool: vertices inside a border side (:func:`slit_points`); dropping one closes (part
    of) its slit: the surface stays, the open boundary gets shorter."""
    mask = np.zeros(len(positions), dtype=bool)
    mask[slit_points(positions, faces)[1]] = True
    return mask


def split_sides(
    faces: np.ndarray,
    corner_uvs: np.ndarray | None,
    side: np.ndarray,
    vertex: np.ndarray,
    t: np.ndarray,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Every face split at the points on one of its sides (the lowest side that has some; the
    others wait for the next round): ``(faces (m', 3), corner_uvs (m', 3, 2) or None, source
    (m',) int64)``, ``source`` the input face of every output face. ``side``, ``vertex``, ``t``:
    :func:`slit_points`, sorted by side then t."""
    face = side // 3
    chosen = np.zeros(len(side), dtype=bool)
    first_of_face = np.flatnonzero(np.concatenate([[True], face[1:] != face[:-1]]))
    lowest = np.repeat(side[first_of_face], np.diff(np.append(first_of_face, len(side))))
    chosen = side == lowest
    side, vertex, t = side[chosen], vertex[chosen], t[chosen]
    split = np.unique(side)
    keep = np.ones(len(faces), dtype=bool)
    keep[split // 3] = False
    new_faces, new_uvs, new_source = [], [], []
    bounds = np.searchsorted(side, split)
    for s, lo, hi in zip(split.tolist(), bounds.tolist(), np.append(bounds[1:], len(side))):
        f, i = divmod(s, 3)
        a, b, c = faces[f, i], faces[f, (i + 1) % 3], faces[f, (i + 2) % 3]
        chain = np.concatenate([[a], vertex[lo:hi], [b]])
        fan = np.column_stack([chain[:-1], chain[1:], np.full(len(chain) - 1, c)])
        new_faces.append(fan)
        new_source.append(np.full(len(fan), f))
        if corner_uvs is not None:
            uv_a, uv_b, uv_c = (corner_uvs[f, (i + k) % 3].astype(np.float64) for k in range(3))
            along = np.concatenate([[0.0], t[lo:hi], [1.0]])
            chain_uvs = uv_a + along[:, None] * (uv_b - uv_a)
            fan_uvs = np.stack(
                [chain_uvs[:-1], chain_uvs[1:], np.broadcast_to(uv_c, (len(fan), 2))], axis=1
            )
            new_uvs.append(fan_uvs.astype(np.float32))
    out_faces = np.concatenate([faces[keep]] + new_faces)
    source = np.concatenate([np.flatnonzero(keep)] + new_source)
    out_uvs = None
    if corner_uvs is not None:
        out_uvs = np.concatenate([corner_uvs[keep]] + new_uvs)
    return out_faces, out_uvs, source


def close_slits(
    positions: np.ndarray, faces: np.ndarray, corner_uvs: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """The mesh with its slits closed (see the module doc): ``(faces (m', 3), corner_uvs
    (m', 3, 2) or None, source (m',) int64)``, ``source`` the input face of every output face;
    the input itself (``source`` the identity) when it has no slit or closing would add a
    boundary loop."""
    identity = (faces, corner_uvs, np.arange(len(faces)))
    side, vertex, t = slit_points(positions, faces)
    if not len(side):
        return identity
    out_faces, out_uvs, source = faces, corner_uvs, np.arange(len(faces))
    for _ in range(MAX_ROUNDS):
        if not len(side):
            break
        out_faces, out_uvs, step = split_sides(out_faces, out_uvs, side, vertex, t)
        source = source[step]
        side, vertex, t = slit_points(positions, out_faces)
    # quality imports this package (through hausdorff and coverage): imported when needed.
    from .quality import boundary_loops

    k = len(positions)
    if boundary_loops(out_faces, k)[1] > boundary_loops(faces, k)[1]:
        return identity
    return out_faces, out_uvs, source
