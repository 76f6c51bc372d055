"""Quadric edge collapse (Garland & Heckbert 1997) through pymeshlab, with per-vertex locks and
texture coordinates carried by the collapse, checked for seams and foldovers.

Data form: a welded mesh, ``positions`` (k, 3) float64 metres (building-local East/Up/North),
``faces`` (m, 3) int64 wound outward; ``corner_uvs`` (m, 3, 2) float32 per face corner (glTF UV
convention) or None, ``face_chart`` (m,) int64 the UV chart (texture island) of every face.
``movable`` (m,) bool marks the faces simplification may change, ``locked`` (k,) bool the
vertices that must not move.

Why this shape:

- pymeshlab has no per-vertex lock, only "simplify the selected faces": a vertex may move only
  when all its faces are selected, and an edge collapses only when both ends may move. A locked
  vertex therefore gets an *anchor*: one tiny unselected triangle hung on it, removed afterwards.
  With ``selected`` MeshLab's face target counts the selected faces only (quadric_simp.cpp:
  ``target = fn - (selected - target)``).
- Face and vertex identity survive the filter in the per-face / per-vertex quality values (input
  face index + 1, negative when not movable, 0 for anchors; input vertex index, -1 for anchor
  corners).
- The geometric collapse runs without the texture quadric: measured on VWorld-like buildings,
  ``..._with_texture`` moves vertices off flat walls (2 % of the diagonal at 5 % reduction) where
  the plain filter removes half the faces with zero error. With texture, placement is restricted
  to the collapsed edge's end points (``optimalplacement=False``), so every output vertex is an
  input vertex and its UV in each chart is known exactly; without texture a vertex goes to the
  quadric's optimum.
- UVs of an output corner: the input face's own corner when the vertex did not change, otherwise
  the UV the new vertex has in the face's chart. A corner whose vertex is not in that chart at
  all is a collapse across a texture seam: with ``keep_seams`` the pass is redone with that
  vertex locked; without, it gets the UV of the closest point of the chart. A face whose UV
  triangle flipped against its input face is a foldover: with ``refuse_foldovers`` the pass is
  redone with its vertices locked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh._area import uv_signs as _uv_signs
from ..mesh.geometry import compact_vertices

# Offsets (metres) of an anchor's two extra corners; odd values so they never hit a real vertex.
PRESERVE_TOPOLOGY = True
_ANCHOR_OFFSETS = np.array([[7.31e-4, 0.0, 0.0], [0.0, 0.0, 6.17e-4]])


@dataclass
class Collapsed:
    """Result of :func:`collapse`: the same data form as its input plus the identity maps.

    ``vertex_ids`` (k',) int64: input vertex index of every output vertex (its position is that
    input vertex's position); ``face_ids`` (m',) int64: input face index of every output face.
    """

    positions: np.ndarray
    faces: np.ndarray
    corner_uvs: np.ndarray | None
    vertex_ids: np.ndarray
    face_ids: np.ndarray

    @classmethod
    def unchanged(
        cls, positions: np.ndarray, faces: np.ndarray, corner_uvs: np.ndarray | None
    ) -> Collapsed:
        """The mesh as a result that collapsed nothing (identity maps)."""
        return cls(positions, faces, corner_uvs, np.arange(len(positions)), np.arange(len(faces)))


# --------------------------------------------------------------------------- the pymeshlab pass


def _anchors(
    vertex_count: int, faces: np.ndarray, movable: np.ndarray, locked: np.ndarray
) -> np.ndarray:
    """Locked vertices not already held by an unmovable face: (a,) int64."""
    held = np.zeros(vertex_count, dtype=bool)
    held[faces[~movable].reshape(-1)] = True
    return np.flatnonzero(locked & ~held)


def quadric_pass(
    positions,
    faces,
    movable,
    locked,
    target: int,
    preserve_curvature: bool,
    optimal_placement: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pymeshlab collapse pass; returns ``(faces (m', 3) as input vertex indices, face_ids
    (m',), positions (k, 3))`` where ``positions`` is the input with the moved vertices' new
    positions (only with ``optimal_placement``)."""
    need = _anchors(len(positions), faces, movable, locked)
    k = len(positions)
    corners = (positions[need][:, None, :] + _ANCHOR_OFFSETS[None]).reshape(-1, 3)
    all_positions = np.concatenate([positions, corners])
    anchor_faces = np.column_stack(
        [need, k + 2 * np.arange(len(need)), k + 2 * np.arange(len(need)) + 1]
    )
    face_q = np.where(movable, 1.0, -1.0) * np.arange(1, len(faces) + 1)
    # Imported here: only `engine: pymeshlab` needs it, and loading it costs every process
    # ~47 MiB and ~0.1 s (the default engine's workers never load it).
    import pymeshlab

    mesh = pymeshlab.Mesh(
        all_positions,
        np.concatenate([faces, anchor_faces]).astype(np.int32),
        v_scalar_array=np.concatenate([np.arange(k), -np.ones(len(corners))]).astype(np.float64),
        f_scalar_array=np.concatenate([face_q, np.zeros(len(need))]),
    )
    ms = pymeshlab.MeshSet()
    ms.add_mesh(mesh)
    ms.compute_selection_by_condition_per_face(condselect="fq > 0")
    movable_target = max(0, int(target) - int((~movable).sum()))
    ms.meshing_decimation_quadric_edge_collapse(
        targetfacenum=movable_target,
        selected=True,
        preserveboundary=False,
        preservetopology=PRESERVE_TOPOLOGY,
        optimalplacement=bool(optimal_placement),
        planarquadric=True,
        preservenormal=bool(preserve_curvature),
        autoclean=False,
    )
    out = ms.current_mesh()
    out_q = out.face_scalar_array()
    keep = out_q != 0
    vertex_ids = np.rint(out.vertex_scalar_array()).astype(np.int64)
    moved = positions
    if optimal_placement:
        real = vertex_ids >= 0
        moved = positions.copy()
        new = out.vertex_matrix()[real]
        # pymeshlab stores float32: vertices that did not move keep their exact input position.
        shift = np.linalg.norm(new - positions[vertex_ids[real]], axis=1) > 1e-5
        moved[vertex_ids[real][shift]] = new[shift]
    return vertex_ids[out.face_matrix()[keep]], (np.abs(out_q[keep]) - 1).astype(np.int64), moved


# --------------------------------------------------------------------------- UVs of the result


def closest_barycentric(point: np.ndarray, tri: np.ndarray) -> tuple[int, np.ndarray]:
    """Index of the triangle (t, 3, 3) closest to ``point`` (3,) and the barycentric weights (3,)
    of the closest point on it (clamped to the triangle)."""
    best, best_d, best_w = 0, np.inf, np.array([1.0, 0.0, 0.0])
    for i, (a, b, c) in enumerate(tri):
        ab, ac = b - a, c - a
        gram = np.array([[ab @ ab, ab @ ac], [ab @ ac, ac @ ac]])
        rhs = np.array([ab @ (point - a), ac @ (point - a)])
        try:
            v, w = np.linalg.solve(gram, rhs)
        except np.linalg.LinAlgError:
            continue
        weights = np.clip(np.array([1.0 - v - w, v, w]), 0.0, None)
        weights /= max(weights.sum(), 1e-30)
        d = float(np.linalg.norm(weights @ np.stack([a, b, c]) - point))
        if d < best_d:
            best, best_d, best_w = i, d, weights
    return best, best_w


def assign_uvs(positions, faces, corner_uvs, face_chart, out_faces, face_ids, project: bool = True):
    """UVs (m', 3, 2) of the output corners and the input vertices found outside their face's
    chart ((s,) int64, seam crossings). See the module doc."""
    in_faces = faces[face_ids]
    in_uvs = corner_uvs[face_ids]
    out_uvs = in_uvs.copy()
    # Unchanged corners: the input face's corner holding the same vertex.
    match = out_faces[:, :, None] == in_faces[:, None, :]  # (m', 3 out, 3 in)
    found = match.any(axis=2)
    source_corner = match.argmax(axis=2)
    rows = np.arange(len(out_faces))[:, None]
    out_uvs[found] = in_uvs[np.broadcast_to(rows, found.shape)[found], source_corner[found]]
    crossings = []
    if (~found).any():
        # Changed corners: the vertex's UV in the face's chart (chart, vertex) -> candidate UVs.
        keys = face_chart[:, None] * (len(positions) + 1) + faces
        order = np.argsort(keys.reshape(-1), kind="stable")
        sorted_keys = keys.reshape(-1)[order]
        flat_uvs = corner_uvs.reshape(-1, 2)[order]
        changed_o, changed_j = np.nonzero(~found)
        wanted = (
            face_chart[face_ids[changed_o]] * (len(positions) + 1) + out_faces[changed_o, changed_j]
        )
        lo = np.searchsorted(sorted_keys, wanted, "left")
        # The usual case at once: the vertex has one UV in the chart (every corner of its
        # (chart, vertex) group equal to the group's first, which is taken).
        start = np.ones(len(sorted_keys), dtype=bool)
        start[1:] = sorted_keys[1:] != sorted_keys[:-1]
        group_first = np.maximum.accumulate(np.where(start, np.arange(len(start)), 0))
        same = (flat_uvs == flat_uvs[group_first]).all(axis=1)
        uniform = np.logical_and.reduceat(same, np.flatnonzero(start))[np.cumsum(start) - 1]
        present = sorted_keys[np.minimum(lo, len(sorted_keys) - 1)] == wanted
        easy = present & uniform[np.minimum(lo, len(sorted_keys) - 1)]
        out_uvs[changed_o[easy], changed_j[easy]] = flat_uvs[lo[easy]]
        for o, j in zip(changed_o[~easy], changed_j[~easy]):
            chart = face_chart[face_ids[o]]
            vertex = out_faces[o, j]
            key = chart * (len(positions) + 1) + vertex
            lo, hi = (
                np.searchsorted(sorted_keys, key, "left"),
                np.searchsorted(sorted_keys, key, "right"),
            )
            if hi > lo:
                block = flat_uvs[lo:hi]
                if (block == block[0]).all():  # the usual case: one UV per vertex in a chart
                    out_uvs[o, j] = block[0]
                    continue
                candidates = np.unique(block, axis=0)
                # Several UVs in one chart (a wrapped seam, e.g. a cylinder): nearest to the others.
                others = out_uvs[o, found[o]] if found[o].any() else in_uvs[o]
                out_uvs[o, j] = candidates[
                    np.argmin(np.linalg.norm(candidates - others.mean(axis=0), axis=1))
                ]
            else:
                crossings.append(vertex)
                if not project:
                    continue
                in_chart = np.flatnonzero(face_chart == chart)
                index, weights = closest_barycentric(positions[vertex], positions[faces[in_chart]])
                out_uvs[o, j] = weights @ corner_uvs[in_chart[index]]
    return out_uvs.astype(np.float32), np.unique(np.asarray(crossings, dtype=np.int64))


def uv_signs(corner_uvs: np.ndarray) -> np.ndarray:
    """(m,) int8 sign of every face's signed area in UV space (0 when degenerate in UV):
    compiled (``exporter/mesh/c/area.c``) for float32 UVs, the arithmetic below."""
    if corner_uvs.dtype == np.float32 and corner_uvs.ndim == 3:
        return _uv_signs(corner_uvs)
    d1 = (corner_uvs[:, 1] - corner_uvs[:, 0]).astype(np.float64)
    d2 = (corner_uvs[:, 2] - corner_uvs[:, 0]).astype(np.float64)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    return np.sign(np.where(np.abs(cross) < 1e-12, 0.0, cross)).astype(np.int8)


# --------------------------------------------------------------------------- entry point


def collapse(
    positions: np.ndarray,
    faces: np.ndarray,
    corner_uvs: np.ndarray | None,
    face_chart: np.ndarray | None,
    movable: np.ndarray,
    locked: np.ndarray,
    target: int,
    *,
    preserve_curvature: bool = False,
    keep_seams: bool = True,
    refuse_foldovers: bool = True,
    max_iterations: int = 100,
) -> Collapsed:
    """Collapse edges of the movable faces towards ``target`` faces (see the module doc).

    Each iteration is one pymeshlab pass from the input. A pass that crossed a texture seam
    (``keep_seams``) or flipped a face in UV space (``refuse_foldovers``) is redone with the
    offending vertices locked. At most ``max_iterations`` passes run; the last clean pass is
    returned (the input when none was clean).
    """
    locked = np.asarray(locked, dtype=bool).copy()
    source_signs = uv_signs(corner_uvs) if corner_uvs is not None else None
    unchanged = Collapsed.unchanged(positions, faces, corner_uvs)
    if len(faces) <= target or not movable.any():
        return unchanged
    for _ in range(max_iterations):
        # Without texture, vertices may go to the quadric's optimum; with texture they stay input
        # vertices so their UVs are exact.
        out_faces, face_ids, moved = quadric_pass(
            positions,
            faces,
            movable,
            locked,
            target,
            preserve_curvature,
            optimal_placement=corner_uvs is None,
        )
        uvs = None
        if corner_uvs is not None:
            uvs, crossings = assign_uvs(
                positions,
                faces,
                corner_uvs,
                face_chart,
                out_faces,
                face_ids,
                project=not keep_seams,
            )
            offenders = crossings if keep_seams else np.zeros(0, np.int64)
            if refuse_foldovers and source_signs is not None:
                before = source_signs[face_ids]

                flipped = (before != 0) & (uv_signs(uvs) != before)
                offenders = np.union1d(offenders, out_faces[flipped].reshape(-1))
            offenders = offenders[~locked[offenders]]
            if len(offenders):
                locked[offenders] = True
                continue
        used, kept = compact_vertices(out_faces, len(positions))
        return Collapsed(moved[used], kept, uvs, used, face_ids)
    return unchanged
