"""Attribute-aware edge collapse through meshoptimizer's ``meshopt_simplifyWithAttributes``, with
per-vertex locks, texture seams kept, and UV foldovers refused.

Data form: the welded mesh of :mod:`.quadric` — ``positions`` (k, 3) float64 metres
(building-local East/Up/North), ``faces`` (m, 3) int64 wound outward, ``corner_uvs`` (m, 3, 2)
float32 (glTF UV convention) or None, ``face_part`` (m,) int64, ``movable`` (m,) bool faces the
collapse may change, ``locked`` (k,) bool vertices that must not move. Result: a
:class:`~.quadric.Collapsed`.

Source: zeux/meshoptimizer ``src/simplifier.cpp`` (the version the PyPI wheel ``meshoptimizer``
0.2.30a0 ships: between tags v0.22 and v0.23, e.g. commit ccaebbcd^, whose exported symbols it
matches). What that version does, read from the source:

- collapses always move a vertex onto another *input* vertex (no optimal placement), so every
  output corner is an input vertex with its exact UV;
- vertices at the same position with different attributes are *wedges*; a position with exactly
  two wedges whose open edges pair up is a seam vertex and moves only along the seam, both sides
  together; any other multi-wedge position is locked (``classifyVertices``);
- ``vertex_lock[i] == 1`` locks a vertex and every wedge at its position (values other than 0/1
  are reserved);
- ``target_error`` with ``meshopt_SimplifyErrorAbsolute`` is in position units (metres here); the
  error is a quadric estimate, not a distance bound: callers check the result (the guard);
- it refuses collapses that flip a triangle's 3-D normal, not its UV orientation.

The PyPI binding declares no ``argtypes`` for ``meshopt_simplifyWithAttributes`` (ctypes then
rejects the float argument: ``ArgumentError``); this module loads the wheel's library in its own
``ctypes.CDLL`` handle and declares the C signature of ``meshoptimizer.h`` there, leaving the
package's handle untouched.

Mapping of the paper's Table II (the module's flat steps, in :func:`collapse`):

1. vertices: one per (welded position, part, UV) -- a part or UV change at one position is a
   wedge, so part borders and UV seams are seams to meshopt (``keep_seams``); without
   ``keep_seams`` the UV is dropped from the key and the corner UVs are re-assigned after the
   collapse by :func:`.quadric.assign_uvs` (the pymeshlab path's projection);
2. locks: ``locked`` (border, part borders, non-manifold) plus every corner of a face that is not
   ``movable`` (the paper's largest-30 % filter: a face whose corners are all locked is never
   touched by a collapse);
3. attributes: the UVs (weight ``UV_WEIGHT``) and, with ``preserve_curvature``, the area-weighted
   vertex normal (weight ``NORMAL_WEIGHT``: collapses that bend the surface cost more);
4. foldovers (``refuse_foldovers``): an output face whose UV triangle is oriented against its
   vertices' source faces is refused: its movable vertices are locked and the pass redone, at most
   ``max_iterations`` passes (the last clean one wins; the input when none is clean).
"""

from __future__ import annotations

import ctypes
import importlib.metadata

import meshoptimizer._loader as _binding
import numpy as np

from ..mesh._foldover import expected as wedge_orientation
from ..mesh._foldover import flipped as flipped_faces
from ..mesh.geometry import compact_vertices, unique_float_rows, vertex_normals
from .protect import face_areas
from .quadric import Collapsed, assign_uvs, uv_signs

# Square metres: faces below this are degenerate (as exporter.simplify.ZERO_AREA_M2).
ZERO_AREA_M2 = 1e-12
SIMPLIFY_LOCK_BORDER = 1 << 0
SIMPLIFY_ERROR_ABSOLUTE = 1 << 2

# Attribute weights relative to positions (meshopt rescales positions to a unit extent): a UV
# change of 0.01 costs like a 1 % move of the building's extent; a normal is unit length.
UV_WEIGHT = 1.0
NORMAL_WEIGHT = 0.5

# The signatures below are read from the header of the library this wheel ships: another wheel
# version may ship another library, so it is checked rather than trusted.
WHEEL_VERSION = "0.2.30a0"
if importlib.metadata.version("meshoptimizer") != WHEEL_VERSION:
    raise ImportError(
        f"meshoptimizer {importlib.metadata.version('meshoptimizer')} installed; "
        f"exporter/simplify/meshopt.py declares the C signatures of {WHEEL_VERSION} "
        f"(pip install meshoptimizer=={WHEEL_VERSION}, or check the new header and update it)"
    )
_lib = ctypes.CDLL(_binding.lib_path)
# Arrays go in as their data addresses: the wrappers below make every one C-contiguous of the
# declared type first (numpy.ctypeslib.ndpointer's check of each costs more than the call).
_F32 = _U32 = _U8 = ctypes.c_void_p
# size_t meshopt_simplifyWithAttributes(unsigned int* destination, const unsigned int* indices,
#   size_t index_count, const float* vertex_positions, size_t vertex_count,
#   size_t vertex_positions_stride, const float* vertex_attributes, size_t vertex_attributes_stride,
#   const float* attribute_weights, size_t attribute_count, const unsigned char* vertex_lock,
#   size_t target_index_count, float target_error, unsigned int options, float* result_error);
_lib.meshopt_simplifyWithAttributes.argtypes = [
    _U32,
    _U32,
    ctypes.c_size_t,
    _F32,
    ctypes.c_size_t,
    ctypes.c_size_t,
    _F32,
    ctypes.c_size_t,
    _F32,
    ctypes.c_size_t,
    _U8,
    ctypes.c_size_t,
    ctypes.c_float,
    ctypes.c_uint,
    ctypes.POINTER(ctypes.c_float),
]
_lib.meshopt_simplifyWithAttributes.restype = ctypes.c_size_t
# size_t meshopt_simplify(unsigned int* destination, const unsigned int* indices, size_t
#   index_count, const float* vertex_positions, size_t vertex_count, size_t vertex_positions_stride,
#   size_t target_index_count, float target_error, unsigned int options, float* result_error);
_lib.meshopt_simplify.argtypes = [
    _U32,
    _U32,
    ctypes.c_size_t,
    _F32,
    ctypes.c_size_t,
    ctypes.c_size_t,
    ctypes.c_size_t,
    ctypes.c_float,
    ctypes.c_uint,
    ctypes.POINTER(ctypes.c_float),
]
_lib.meshopt_simplify.restype = ctypes.c_size_t


def simplify_with_attributes(
    indices: np.ndarray,
    positions: np.ndarray,
    attributes: np.ndarray,
    weights: np.ndarray,
    lock: np.ndarray,
    target_index_count: int,
    target_error: float,
    options: int = SIMPLIFY_ERROR_ABSOLUTE,
) -> tuple[np.ndarray, float]:
    """``meshopt_simplifyWithAttributes``: the kept indices ((i',) uint32 into ``positions``) and
    the error meshopt reports (position units with ``SIMPLIFY_ERROR_ABSOLUTE``).

    ``indices`` (i,) uint32, ``positions`` (v, 3) float32, ``attributes`` (v, a) float32 with
    ``weights`` (a,) float32 (a <= 32; a = 0 allowed), ``lock`` (v,) uint8 of 0/1."""
    indices = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
    positions = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
    count = len(positions)
    attributes = np.ascontiguousarray(attributes, dtype=np.float32).reshape(count, -1)
    weights = np.ascontiguousarray(weights, dtype=np.float32).reshape(-1)
    if attributes.shape[1] != len(weights) or len(weights) > 32:
        raise ValueError(f"{attributes.shape[1]} attributes for {len(weights)} weights (max 32)")
    if len(weights) == 0:  # a valid pointer even with no attribute
        attributes, weights = np.zeros((count, 1), np.float32), np.zeros(1, np.float32)
    lock = np.ascontiguousarray(lock, dtype=np.uint8).reshape(-1)
    if len(lock) != count or (lock > 1).any():
        raise ValueError("vertex_lock needs one 0/1 value per vertex")
    destination = np.empty(len(indices), np.uint32)
    error = ctypes.c_float(0.0)
    kept = _lib.meshopt_simplifyWithAttributes(
        destination.ctypes.data,
        indices.ctypes.data,
        len(indices),
        positions.ctypes.data,
        count,
        12,
        attributes.ctypes.data,
        4 * attributes.shape[1],
        weights.ctypes.data,
        len(weights),
        lock.ctypes.data,
        int(target_index_count),
        float(target_error),
        int(options),
        ctypes.byref(error),
    )
    return destination[:kept].copy(), float(error.value)


def simplify(
    indices: np.ndarray,
    positions: np.ndarray,
    target_index_count: int,
    target_error: float,
    options: int = SIMPLIFY_LOCK_BORDER | SIMPLIFY_ERROR_ABSOLUTE,
) -> tuple[np.ndarray, float]:
    """``meshopt_simplify`` (positions only): the kept indices and meshopt's error estimate."""
    indices = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
    positions = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
    destination = np.empty(len(indices), np.uint32)
    error = ctypes.c_float(0.0)
    kept = _lib.meshopt_simplify(
        destination.ctypes.data,
        indices.ctypes.data,
        len(indices),
        positions.ctypes.data,
        len(positions),
        12,
        int(target_index_count),
        float(target_error),
        int(options),
        ctypes.byref(error),
    )
    return destination[:kept].copy(), float(error.value)


# --------------------------------------------------------------------------- the engine


def _wedges(faces, corner_uvs, face_part, keep_seams: bool):
    """meshopt's vertices: (w,) welded vertex of every wedge, (w, 2) UVs or None, (m, 3) wedge
    indices of the faces. A wedge is one (welded vertex, part, UV) combination."""
    corners = faces.reshape(-1)
    columns = [corners.astype(np.float64)]
    # A constant column changes neither the groups nor their order: one part needs no column.
    if len(face_part) and face_part.min() != face_part.max():
        columns.append(np.repeat(face_part, 3).astype(np.float64))
    if corner_uvs is not None and keep_seams:
        columns.append(corner_uvs.reshape(-1, 2).astype(np.float64))
    first, inverse = unique_float_rows(np.column_stack(columns))
    uvs = corner_uvs.reshape(-1, 2)[first] if corner_uvs is not None else None
    return corners[first], uvs, inverse.reshape(-1, 3)


def _source_faces(wedge_faces: np.ndarray, out: np.ndarray, wedge_count: int) -> np.ndarray:
    """(m',) int64: for every output face, an input face using its first corner's wedge (the
    output face's part and chart are that face's)."""
    owner = np.empty(wedge_count, np.int64)
    owner[wedge_faces.reshape(-1)] = np.repeat(np.arange(len(wedge_faces)), 3)
    return owner[out[:, 0]]


def _best_sources(faces: np.ndarray, out_faces: np.ndarray) -> np.ndarray:
    """(m',) int64: for every output face (welded vertex indices), the input face sharing most of
    its corners (ties: lowest index) -- the face whose chart gives its UVs when seams may go."""
    if len(out_faces) == 0:  # everything collapsed away (nothing locked, no error limit)
        return np.zeros(0, np.int64)
    k = int(max(faces.max(), out_faces.max())) + 1
    order = np.argsort(faces.reshape(-1), kind="stable")
    face_of = np.repeat(np.arange(len(faces)), 3)[order]
    start = np.searchsorted(faces.reshape(-1)[order], np.arange(k + 1))
    best = np.zeros(len(out_faces), np.int64)
    for o, corner_list in enumerate(out_faces.tolist()):
        candidates = np.concatenate([face_of[start[v] : start[v + 1]] for v in corner_list])
        shared = np.isin(faces[candidates], corner_list).sum(axis=1)
        best[o] = candidates[np.argmax(shared)]
    return best


def collapse(
    positions: np.ndarray,
    faces: np.ndarray,
    corner_uvs: np.ndarray | None,
    face_chart: np.ndarray,
    face_part: np.ndarray,
    movable: np.ndarray,
    locked: np.ndarray,
    target: int,
    target_error: float,
    *,
    preserve_curvature: bool = False,
    keep_seams: bool = True,
    refuse_foldovers: bool = True,
    max_iterations: int = 100,
) -> Collapsed:
    """Collapse towards ``target`` faces or until meshopt's error estimate reaches
    ``target_error`` metres, whichever comes first (see the module doc for the steps)."""
    unchanged = Collapsed.unchanged(positions, faces, corner_uvs)
    if len(faces) <= target or not movable.any():
        return unchanged
    vertex_of, wedge_uvs, wedge_faces = _wedges(faces, corner_uvs, face_part, keep_seams)
    origin = positions.min(axis=0)
    wedge_positions = (positions[vertex_of] - origin).astype(np.float32)
    columns, weights = [], []
    if wedge_uvs is not None:
        columns.append(wedge_uvs.astype(np.float32))
        weights += [UV_WEIGHT, UV_WEIGHT]
    if preserve_curvature:
        columns.append(vertex_normals(positions, faces)[vertex_of].astype(np.float32))
        weights += [NORMAL_WEIGHT] * 3
    attributes = np.column_stack(columns) if columns else np.zeros((len(vertex_of), 0), np.float32)
    vertex_locked = np.asarray(locked, dtype=bool).copy()
    vertex_locked[faces[~movable].reshape(-1)] = True
    # The UV orientation each wedge's source faces agree on (0 where they disagree or are flat).
    expected = None
    if refuse_foldovers and corner_uvs is not None:
        expected = wedge_orientation(wedge_faces, uv_signs(corner_uvs), len(vertex_of))  # compiled
    for _ in range(max_iterations):
        kept, _error = simplify_with_attributes(
            wedge_faces.reshape(-1),
            wedge_positions,
            attributes,
            np.asarray(weights, np.float32),
            vertex_locked[vertex_of].astype(np.uint8),
            3 * target,
            target_error,
        )
        out = kept.reshape(-1, 3).astype(np.int64)
        # meshopt keeps triangles that collapsed onto a line (distinct, collinear corners): drop
        # them as level 0 drops its zero-area faces.
        out = out[face_areas(positions, vertex_of[out]) >= ZERO_AREA_M2]
        out_faces = vertex_of[out]
        if corner_uvs is None:
            uvs = None
        elif keep_seams:
            uvs = wedge_uvs[out].astype(np.float32)
        else:
            uvs, _ = assign_uvs(
                positions,
                faces,
                corner_uvs,
                face_chart,
                out_faces,
                _best_sources(faces, out_faces),
                project=True,
            )
        if expected is not None and uvs is not None:
            # Against the orientation the face's corners agree on (any one of them, when the
            # others are 0); compiled (exporter/mesh/c/foldover.c).
            flipped = flipped_faces(expected, out, uv_signs(uvs))
            if flipped.any():
                offenders = out_faces[flipped].reshape(-1)
                offenders = offenders[~vertex_locked[offenders]]
                if not len(offenders):
                    # Every corner was locked already: the vertex that collapsed onto them did it;
                    # lock their input neighbours.
                    corners = np.isin(faces, out_faces[flipped]).any(axis=1)
                    offenders = faces[corners].reshape(-1)
                    offenders = offenders[~vertex_locked[offenders]]
                if not len(offenders):
                    break
                vertex_locked[offenders] = True
                continue
        face_ids = _source_faces(wedge_faces, out, len(vertex_of))
        used, kept = compact_vertices(out_faces, len(positions))
        return Collapsed(positions[used], kept, uvs, used, face_ids)
    return unchanged
