"""Quadric edge collapse (Garland & Heckbert 1997) through pymeshlab, with per-vertex locks.

Data form: a welded mesh, ``positions`` (k, 3) float64 metres (building-local East/Up/North),
``faces`` (m, 3) int64 wound outward, ``corner_uvs`` (m, 3, 2) float32 per face corner (glTF
UV convention) or None. ``movable`` (m,) bool marks the faces simplification may change,
``locked`` (k,) bool the vertices that must not move.

pymeshlab (MeshLab's ``tri::TriEdgeCollapseQuadric[Tex]``, Hoppe's texture quadric when UVs are
given) has no per-vertex lock, only "simplify the selected faces": a vertex may move only when
all its faces are selected, and an edge collapses only when both ends may move. So a locked vertex
gets an *anchor*: one tiny unselected triangle hung on it, removed afterwards. Face and vertex
identity survive the filter in the per-face / per-vertex quality values (input face index + 1,
negative when not movable, 0 for anchors; welded vertex index, -1 for anchor vertices).

Wedge UVs cannot be handed to the texture filter directly (pymeshlab then marks them "no texture"),
so the mesh is built split per corner with per-vertex UVs, converted to wedges, then re-welded with
``meshing_remove_duplicate_vertices`` (positions are exact duplicates by construction).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import pymeshlab

# Offsets (metres) of an anchor's two extra corners; odd values so they never hit a real vertex.
_ANCHOR_OFFSETS = np.array([[7.31e-4, 0.0, 0.0], [0.0, 0.0, 6.17e-4]])


@dataclass
class Collapsed:
    """Result of :func:`collapse`: the same data form as its input plus the identity maps.

    ``vertex_ids`` (k',) int64: input vertex index of every output vertex; ``face_ids`` (m',)
    int64: input face index of every output face (surviving faces keep their identity).
    """

    positions: np.ndarray
    faces: np.ndarray
    corner_uvs: Optional[np.ndarray]
    vertex_ids: np.ndarray
    face_ids: np.ndarray


def _anchors(positions: np.ndarray, faces: np.ndarray, movable: np.ndarray, locked: np.ndarray):
    """Anchor triangles for locked vertices not already held by an unmovable face."""
    held = np.zeros(len(positions), dtype=bool)
    held[faces[~movable].reshape(-1)] = True
    need = np.flatnonzero(locked & ~held)
    corners = positions[need][:, None, :] + np.vstack([np.zeros(3), _ANCHOR_OFFSETS])[None]
    return need, corners  # (a,), (a, 3, 3) metres


def _meshset(positions, faces, corner_uvs, movable, locked) -> tuple[pymeshlab.MeshSet, int]:
    need, anchor_corners = _anchors(positions, faces, movable, locked)
    face_q = np.where(movable, np.arange(1, len(faces) + 1), -np.arange(1, len(faces) + 1)).astype(np.float64)
    # Every face split into its own three corners; anchors' first corner is the locked vertex.
    corner_pos = np.concatenate([positions[faces].reshape(-1, 3), anchor_corners.reshape(-1, 3)])
    corner_id = np.concatenate([faces.reshape(-1), np.stack([need, -np.ones_like(need), -np.ones_like(need)], axis=1).reshape(-1)])
    all_q = np.concatenate([face_q, np.zeros(len(need))])
    tri = np.arange(len(corner_pos), dtype=np.int32).reshape(-1, 3)
    kwargs = dict(v_scalar_array=corner_id.astype(np.float64), f_scalar_array=all_q)
    if corner_uvs is not None:
        uv = np.concatenate([corner_uvs.reshape(-1, 2), np.zeros((3 * len(need), 2))]).astype(np.float64)
        kwargs["v_tex_coords_matrix"] = uv
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(corner_pos, tri, **kwargs))
    if corner_uvs is not None:
        ms.compute_texcoord_transfer_vertex_to_wedge()
    ms.meshing_remove_duplicate_vertices()
    ms.compute_selection_by_condition_per_face(condselect="fq > 0")
    return ms, len(need)


def _run(positions, faces, corner_uvs, movable, locked, target, preserve_curvature) -> Collapsed:
    ms, anchor_count = _meshset(positions, faces, corner_uvs, movable, locked)
    # With ``selected`` MeshLab's target counts the selected faces only (quadric_simp.cpp:
    # ``target = fn - (selected - target)``): ask for what the movable faces may keep.
    movable_target = max(0, int(target) - int((~movable).sum()))
    common = dict(targetfacenum=movable_target, selected=True, preserveboundary=False,
                  optimalplacement=True, planarquadric=True, preservenormal=bool(preserve_curvature))
    if movable.any():
        if corner_uvs is not None:
            ms.meshing_decimation_quadric_edge_collapse_with_texture(**common)
        else:
            ms.meshing_decimation_quadric_edge_collapse(**common, preservetopology=True, autoclean=False)
    mesh = ms.current_mesh()
    face_q = mesh.face_scalar_array()
    keep = face_q != 0
    out_faces = mesh.face_matrix()[keep].astype(np.int64)
    vertex_q = mesh.vertex_scalar_array().astype(np.int64)
    used = np.unique(out_faces)
    remap = np.full(len(vertex_q), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    vertex_ids = vertex_q[used]
    out_pos = mesh.vertex_matrix()[used].astype(np.float64)
    # pymeshlab stores float32: put unmoved vertices back on their exact input coordinates.
    close = np.linalg.norm(out_pos - positions[vertex_ids], axis=1) < 1e-4
    out_pos[close] = positions[vertex_ids[close]]
    uvs = None
    if corner_uvs is not None:
        uvs = mesh.wedge_tex_coord_matrix().reshape(-1, 3, 2)[keep].astype(np.float32)
    face_ids = (np.abs(face_q[keep]) - 1).astype(np.int64)
    return Collapsed(out_pos, remap[out_faces], uvs, vertex_ids, face_ids)


def uv_signs(positions: np.ndarray, faces: np.ndarray, corner_uvs: np.ndarray) -> np.ndarray:
    """(m,) int8 sign of every face's signed area in UV space (0 when degenerate in UV)."""
    d1 = corner_uvs[:, 1] - corner_uvs[:, 0]
    d2 = corner_uvs[:, 2] - corner_uvs[:, 0]
    cross = d1[:, 0].astype(np.float64) * d2[:, 1] - d1[:, 1].astype(np.float64) * d2[:, 0]
    return np.sign(np.where(np.abs(cross) < 1e-12, 0.0, cross)).astype(np.int8)


def foldover_faces(result: Collapsed, source_signs: np.ndarray) -> np.ndarray:
    """(m',) bool: output faces whose UV orientation is flipped (or lost) against their source face."""
    if result.corner_uvs is None or len(result.faces) == 0:
        return np.zeros(len(result.faces), dtype=bool)
    before = source_signs[result.face_ids]
    after = uv_signs(result.positions, result.faces, result.corner_uvs)
    return (before != 0) & (after != before)


def collapse(positions: np.ndarray, faces: np.ndarray, corner_uvs: Optional[np.ndarray],
             movable: np.ndarray, locked: np.ndarray, target: int, *,
             preserve_curvature: bool = False, refuse_foldovers: bool = True,
             max_iterations: int = 100) -> Collapsed:
    """Collapse edges of the movable faces until the mesh has ``target`` faces or no collapse is left.

    Each iteration is one pymeshlab pass. With ``refuse_foldovers`` a pass that flipped faces in UV
    space is redone from its input with the flipped faces' vertices locked; otherwise, a pass that
    stopped above ``target`` while still making progress is followed by another pass from its
    output (the heap is rebuilt, so collapses refused on stale quadrics are retried). At most
    ``max_iterations`` passes run; the last accepted result is returned (the input when none).
    """
    locked = np.asarray(locked, dtype=bool).copy()
    source_signs = uv_signs(positions, faces, corner_uvs) if corner_uvs is not None else None
    best = Collapsed(positions, faces, corner_uvs, np.arange(len(positions)), np.arange(len(faces)))
    cur = best
    cur_movable = movable
    for _ in range(max_iterations):
        if len(cur.faces) <= target or not cur_movable.any():
            break
        cur_locked = locked[cur.vertex_ids]
        trial = _run(cur.positions, cur.faces, cur.corner_uvs, cur_movable, cur_locked, target, preserve_curvature)
        # Map identities back to the level's input.
        trial.vertex_ids = cur.vertex_ids[trial.vertex_ids]
        trial.face_ids = cur.face_ids[trial.face_ids]
        if refuse_foldovers and source_signs is not None:
            flipped = foldover_faces(trial, source_signs)
            if flipped.any():
                locked[trial.vertex_ids[np.unique(trial.faces[flipped])]] = True
                continue
        if len(trial.faces) >= len(cur.faces):
            break
        cur = best = trial
        cur_movable = movable[cur.face_ids]
    return best
