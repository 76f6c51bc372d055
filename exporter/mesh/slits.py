"""Slits of a mesh closed without changing its surface: the T-junction repair before the planar
stage (:mod:`exporter.simplify.planar`), and what the open boundary of a surface is for the
quality metrics (:func:`open_boundary`: a slit is no outline).

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

from ._facing import facing
from .boundary_kernels import once_sides
from .distance import row_lengths
from .geometry import row_norms
from .slit_kernels import inside_sides
from .split_kernels import split_fans
from .topology import boundary_loops

SLIT_M = 1e-5  # metres: a vertex this close to a border side lies on it (float32 input rounding)
MAX_ROUNDS = 4  # a face is split on one side per round; three sides at most, plus slack


def border_sides(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(s,) int64 border sides ``3 f + i`` (from corner i of face f to corner i + 1), ascending:
    the sides whose undirected edge no other side uses."""
    faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() >= vertex_count):
        raise ValueError("border_sides: a face's vertex index is out of range")
    return once_sides(faces, int(vertex_count))  # compiled


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
    # The vertices the border sides end at, ascending (np.unique of both ends, without its sort).
    ends = np.zeros(len(positions), dtype=bool)
    ends[start] = True
    ends[end] = True
    points = np.flatnonzero(ends)
    column, vertex, t = inside_sides(positions, points, start, end, tolerance)  # compiled
    side = sides[column]
    # Not between back-to-back faces (two parts' walls standing against each other): that seam
    # is part of each part's footprint outline, and joining it would fold the mesh by 180 deg.
    facing = _facing_partner(positions, faces, sides, start, end, side, vertex)
    side, vertex, t = side[~facing], vertex[~facing], t[~facing]
    order = np.lexsort((t, side))
    return side[order], vertex[order], t[order]


def _facing_partner(positions, faces, sides, start, end, side, vertex) -> np.ndarray:
    """(p,) bool: pairs whose vertex has a border side along the pair's side (the other side of
    the slit) on a face turned against the side's face (unit normals' dot product < -0.5),
    compiled (``exporter/mesh/c/facing.c``)."""
    return facing(
        np.ascontiguousarray(positions, np.float64),
        np.ascontiguousarray(faces, np.int64).reshape(-1, 3),
        sides,
        start,
        end,
        side,
        vertex,
    )


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
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, tuple]:
    """Every face split at the points on one of its sides (the lowest side that has some):
    ``(faces (m', 3), corner_uvs (m', 3, 2) or None, source (m',) int64, rest)``, ``source``
    the input face of every output face, ``rest`` the ``(side, vertex, t)`` of the points on the
    faces' other sides, on the output faces now holding those sides (the fan's first face holds
    the side ``c -> a``, its last face ``b -> c``). ``side``, ``vertex``, ``t``:
    :func:`slit_points`, sorted by side then t; ``corner_uvs`` float32."""
    faces = np.ascontiguousarray(faces, np.int64)
    side = np.ascontiguousarray(side, np.int64)
    if len(side) and (side.min() < 0 or side.max() >= 3 * len(faces)):
        raise ValueError("split_sides: a side is out of range")
    if len(side) > 1 and (np.diff(side) < 0).any():
        raise ValueError("split_sides: the sides are not sorted")
    has_uvs = corner_uvs is not None
    out_faces, out_uvs, source, *rest = split_fans(  # compiled
        faces,
        np.ascontiguousarray(corner_uvs if has_uvs else np.zeros((0, 3, 2)), np.float32),
        has_uvs,
        side,
        np.ascontiguousarray(vertex, np.int64),
        np.ascontiguousarray(t, np.float64),
    )
    return out_faces, out_uvs if has_uvs else None, source, tuple(rest)


def close_slits(
    positions: np.ndarray, faces: np.ndarray, corner_uvs: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """The mesh with its slits closed (see the module doc): ``(faces (m', 3), corner_uvs
    (m', 3, 2) or None, source (m',) int64)``, ``source`` the input face of every output face;
    the input itself (``source`` the identity) when it has no slit or closing would add a
    boundary loop."""
    return _close(positions, faces, corner_uvs)[:3]


def closed_surface(positions: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`close_slits`' faces (m', 3) and a bound (metres) of the symmetric Hausdorff
    distance between them and ``faces``: the largest distance of a point it split a side at
    from that side's line (every fan triangle lies within it of the face it replaces, and
    covers that face's projection; 0 when nothing was split)."""
    closed, _, _, offset = _close(positions, faces, None)
    return closed, offset


# The last mesh _close saw (its arrays, held, so their identities cannot pass to others) and its
# result: the planar stage closes LOD0's slits, then the guard's twin needs the same closed faces
# (without UVs). Callers never modify these arrays in place.
_last_close: tuple = (None, None, None, None)


def _close(positions, faces, corner_uvs):
    """:func:`close_slits` and its :func:`closed_surface` offset (metres)."""
    global _last_close
    seen_positions, seen_faces, seen_uvs, result = _last_close
    if (
        seen_positions is positions
        and seen_faces is faces
        and (seen_uvs is corner_uvs or corner_uvs is None)
    ):
        closed, closed_uvs, source, offset = result
        return closed, closed_uvs if corner_uvs is not None else None, source, offset
    result = _close_uncached(positions, faces, corner_uvs)
    _last_close = (positions, faces, corner_uvs, result)
    return result


def _close_uncached(positions, faces, corner_uvs):
    identity = (faces, corner_uvs, np.arange(len(faces)), 0.0)
    side, vertex, t = slit_points(positions, faces)
    if not len(side):
        return identity
    out_faces, out_uvs, source = faces, corner_uvs, np.arange(len(faces))
    offset = 0.0
    for _ in range(MAX_ROUNDS):
        if not len(side):
            break
        a = positions[out_faces.reshape(-1)[side]]
        b = positions[out_faces[side // 3, (side % 3 + 1) % 3]]
        off_line = positions[vertex] - a - t[:, None] * (b - a)
        offset = max(offset, float(row_norms(off_line).max()))
        # A face with points on two sides is split on one per round; the points on its other
        # sides come back on the fan faces that now hold those sides.
        out_faces, out_uvs, step, (side, vertex, t) = split_sides(
            out_faces, out_uvs, side, vertex, t
        )
        source = source[step]
    k = len(positions)
    if boundary_loops(out_faces, k)[1] > boundary_loops(faces, k)[1]:
        return identity
    return out_faces, out_uvs, source, offset


def open_boundary(positions: np.ndarray, faces: np.ndarray) -> tuple[float, int]:
    """Length of the open boundary (metres) of a welded mesh's surface and its number of loops:
    the border edges once its slits are closed (:func:`close_slits`), since a
    zero-width crack along which the surface goes on is no outline."""
    faces = close_slits(positions, faces, None)[0]
    border, loops = boundary_loops(faces, len(positions))
    # The same sum as np.linalg.norm(np.diff(positions[border], axis=1), axis=-1).sum().
    length = (
        float(row_lengths(positions[border[:, 1]] - positions[border[:, 0]]).sum())
        if len(border)
        else 0.0
    )
    return length, loops
